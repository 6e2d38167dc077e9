#include "reports/model_report.h"

#include <algorithm>
#include <filesystem>

#include "analysis/classification.h"
#include "models/errors.h"
#include "models/units.h"
#include "reports/classification_report.h"
#include "reports/number_format.h"
#include "reports/report_support.h"

namespace servokit {
namespace {

void AddStudy(Document& document,
              const std::filesystem::path& directory,
              const Model& model,
              const GridAxis& axis,
              const ClassificationOptions& options) {
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
  const std::vector<SweepPoint> points = SweepParameter(model, axis.parameter, values, options);
  const std::string stem = "study_" + axis.name;
  PlotSpec locus{stem + "_root_locus",
                 "Zero-dynamics eigenvalues over " + axis.name,
                 "Re(lambda) [1/s]",
                 "Im(lambda) [1/s]",
                 "",
                 "",
                 {{"zero dynamics", RootLocus(points)}},
                 {}};
  PlotSpec real_part{stem + "_real_part",
                     "Real parts over " + axis.name,
                     label,
                     "Re(lambda) [1/s]",
                     "",
                     "",
                     {{"Re(lambda)", EigenvalueCurve(points, shown, false)}},
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
  DrawPlot(directory.string(), locus);
  DrawPlot(directory.string(), real_part);
  document.Add(FigureOf(locus.name, "Zero-dynamics eigenvalues, " + span));
  document.Add(FigureOf(real_part.name, "Real parts of the eigenvalues over " + axis.name));
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
                      const ClassificationOptions& options) {
  const std::filesystem::path out(directory);
  std::filesystem::create_directories(out);
  Document document;
  document.title = "servokit report: " + model.name();
  if (!model.description().empty()) document.Add(Paragraph{model.description()});
  document.Add(Heading{2, "Classification at the nominal parameters"});
  Workspace workspace(model);
  const Classification classification = Classify(model, workspace, options);
  Table summary;
  summary.header = {"property", "value"};
  for (const auto& [label, value] : ClassificationSummary(model, classification)) {
    summary.rows.push_back({label, value});
  }
  document.Add(summary);
  for (const GridAxis& axis : axes) AddStudy(document, out, model, axis, options);
  WriteDocument(out, document);
}

}  // namespace servokit
