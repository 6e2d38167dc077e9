#include "studies/model_report.h"

#include <algorithm>
#include <filesystem>

#include "analysis/classification.h"
#include "base/errors.h"
#include "base/number_format.h"
#include "modeling/units.h"
#include "reports/classification_report.h"
#include "reports/escaping.h"
#include "studies/class_map.h"
#include "studies/study_support.h"

namespace servokit {
namespace {

// The caption's note on eigenvalues outside the axes (plots.h, RobustLimits: the rule).
std::string ClippedNote(std::size_t clipped, std::size_t total, const RobustRange& real) {
  if (clipped == 0) return "";
  return "; " + std::to_string(clipped) + " of " + std::to_string(total) +
         " eigenvalues lie off the axes, Re λ from " + FormatShort(real.min) + " to " +
         FormatShort(real.max) +
         " 1/s (the axes span the 10-90 % quantile range widened by its "
         "width on each side)";
}

void AddStudy(Document& document,
              const std::filesystem::path& directory,
              const Model& model,
              const GridAxis& axis,
              const ClassificationOptions& options,
              const std::vector<SweepPoint>* stored_points) {
  // Values are SI; a parameter given in degrees is shown in degrees (axis label "alpha [deg]").
  const bool degrees = axis.display_unit == DisplayUnit::kDegree;
  const std::string label = axis.name + (degrees ? " [deg]" : "");
  std::vector<double> values, shown;
  for (std::size_t i = 0; i < axis.size(); ++i) {
    values.push_back(axis.Value(i));
    shown.push_back(axis.DisplayValue(values.back()));
  }
  const auto [low_it, high_it] = std::minmax_element(values.begin(), values.end());
  const double low = *low_it, high = *high_it;
  const std::string span = label + " from " + FormatShort(axis.DisplayValue(low)) + " to " +
                           FormatShort(axis.DisplayValue(high));
  double (*const to_display)(double) = degrees ? RadiansToDegrees : AsIs;
  document.Add(Heading{2, "Study of " + span});
  const std::vector<SweepPoint> points =
      stored_points ? *stored_points : SweepParameter(model, axis.parameter, values, options);
  const std::string stem = "study_" + axis.name;
  // In figures the parameter is shown as its symbol (alpha -> α) with its unit.
  const std::string symbol = PlotSymbol(axis.name);
  const std::string plot_label = symbol + (degrees ? " [deg]" : "");
  std::vector<std::pair<double, double>> eigenvalues;
  std::vector<double> parameter_of_eigenvalue;
  for (std::size_t i = 0; i < points.size(); ++i) {
    for (const auto& eigenvalue : points[i].eigenvalues) {
      eigenvalues.emplace_back(eigenvalue.real(), eigenvalue.imag());
      parameter_of_eigenvalue.push_back(shown[i]);
    }
  }
  std::vector<double> real_parts, imaginary_parts;
  for (const auto& [real, imaginary] : eigenvalues) {
    real_parts.push_back(real);
    imaginary_parts.push_back(imaginary);
  }
  const RobustRange real_range = RobustLimits(real_parts);
  const RobustRange imaginary_range = RobustLimits(imaginary_parts);
  PlotSpec locus{stem + "_root_locus", "Zero-dynamics eigenvalues over " + symbol,
                 "Re λ [1/s]",         "Im λ [1/s]",
                 real_range.range,     imaginary_range.range,
                 {{"", eigenvalues}},  {}};
  const PlotColouring by_parameter{{parameter_of_eigenvalue}, plot_label};
  PlotSpec real_part{stem + "_real_part",
                     "Real parts over " + symbol,
                     plot_label,
                     "Re λ [1/s]",
                     "",
                     real_range.range,
                     {{"Re λ", EigenvalueCurve(points, shown, false)}},
                     {}};
  std::vector<ThresholdSearch> searches;
  if (high > low) {
    ThresholdOptions threshold_options;
    threshold_options.classification = options;
    for (const ThresholdEvent event : {ThresholdEvent::kStability, ThresholdEvent::kOscillation,
                                       ThresholdEvent::kRealization, ThresholdEvent::kStructure}) {
      searches.push_back(
          FindThresholds(model, axis.parameter, low, high, event, threshold_options));
      for (const ThresholdCrossing& crossing : searches.back().events) {
        real_part.markers.push_back({to_display(crossing.value), std::string(ToString(event))});
      }
    }
  }
  DrawPlot(directory.string(), locus, by_parameter);
  DrawPlot(directory.string(), real_part);
  std::size_t clipped = 0;
  for (const auto& [real, imaginary] : eigenvalues) {
    clipped += real < real_range.low || real > real_range.high || imaginary < imaginary_range.low ||
                       imaginary > imaginary_range.high
                   ? 1
                   : 0;
  }
  document.Add(FigureOf(locus.name, "Zero-dynamics eigenvalues, " + span + ", coloured by " +
                                        axis.name +
                                        ClippedNote(clipped, eigenvalues.size(), real_range)));
  document.Add(
      FigureOf(real_part.name, "Real parts of the eigenvalues over " + axis.name +
                                   ClippedNote(real_range.outside, real_parts.size(), real_range)));
  std::size_t failed = 0;
  for (const SweepPoint& point : points) failed += point.ok ? 0 : 1;
  if (failed > 0) {
    document.Add(Paragraph{std::to_string(failed) + " of " + std::to_string(points.size()) +
                           " points have no solution (see `servokit sweep` for each reason)."});
  }
  if (!searches.empty()) {
    document.Add(Heading{3, "Located thresholds"});
    document.Add(ThresholdTable(searches, degrees ? "deg" : "", to_display));
    const bool default_operating_point =
        !options.operating_point.y0 && !options.operating_point.q_guess;
    if (const auto closed_form = default_operating_point ? DeriveCharacteristicPolynomial(
                                                               model, axis.parameter, low, high)
                                                         : std::nullopt) {
      AddClosedForm(document, *closed_form, axis.name);
    }
  }
}

}  // namespace

void WriteModelReport(const std::string& directory,
                      const Model& model,
                      const std::vector<GridAxis>& axes,
                      const ClassificationOptions& options,
                      const StoredSweep* stored) {
  const std::filesystem::path out(directory);
  std::filesystem::create_directories(out);
  Document document;
  document.title = "servokit report: " + MarkdownText(model.name());
  if (!model.description().empty()) document.Add(Paragraph{MarkdownText(model.description())});
  document.Add(Heading{2, "Classification at the nominal parameters"});
  Workspace workspace(model);
  const Classification classification = Classify(model, workspace, options);
  Table summary;
  summary.header = {"property", "value"};
  for (const auto& [label, value] : ClassificationSummary(model, classification)) {
    summary.rows.push_back({label, value});
  }
  document.Add(summary);
  if (axes.size() == 2) {
    AddClassMap(document, out, model, axes[0], axes[1], options,
                stored ? &stored->classes : nullptr);
  }
  for (const GridAxis& axis : axes) {
    AddStudy(document, out, model, axis, options,
             stored && axes.size() == 1 ? &stored->points : nullptr);
  }
  WriteDocument(out, document);
}

}  // namespace servokit
