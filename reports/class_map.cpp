#include "reports/class_map.h"

#include <algorithm>
#include <cmath>
#include <fstream>
#include <limits>
#include <map>

#include "analysis/classification.h"
#include "analysis/threshold_curves.h"
#include "files/output_file.h"
#include "models/errors.h"
#include "models/units.h"
#include "reports/number_format.h"
#include "reports/plots.h"
#include "reports/report_support.h"
#include "reports/sweep_tables.h"

namespace servokit {
namespace {

// Class colours (Okabe-Ito, then Tableau): distinct for readers with a colour vision
// deficiency as far as eight classes; a class is given the next one in the order of the sorted
// names present, so the colours of one map do not depend on the order of the points.
constexpr const char* kClassColours[] = {"#56b4e9", "#e69f00", "#009e73", "#f0e442",
                                         "#0072b2", "#d55e00", "#cc79a7", "#999999",
                                         "#8c564b", "#bcbd22", "#17becf", "#9467bd"};
// Curve colours: dark, so that they stand out on any class colour; with a dash type per change.
constexpr const char* kCurveColours[] = {"#000000", "#7f0000", "#3f007d", "#00441b", "#4d4d4d"};
constexpr int kDashTypes = 5;
// Lines across each axis for the curves: threshold searches per event and direction.
constexpr int kCurveLines = 40;
// Point size of a grid square: the plot's width and height (in units of point size 1, about
// 5.5 pixels in the PNG) over the number of values on each axis; the larger, so that squares
// touch (and overlap along the finer axis), kept readable on coarse and fine grids.
constexpr double kPlotWidthInPoints = 160.0, kPlotHeightInPoints = 80.0;
constexpr double kSmallestSquare = 0.2, kLargestSquare = 6.0;

std::vector<double> AxisValues(const GridAxis& axis) {
  std::vector<double> values;
  for (std::size_t i = 0; i < axis.size(); ++i) values.push_back(axis.Value(i));
  return values;
}

}  // namespace

std::string MapClassName(const Model& model,
                         Workspace& workspace,
                         const ClassificationOptions& options) {
  try {
    const Classification c = Classify(model, workspace, options);
    return MapClassName(ToString(c.decoupling.realization), ToString(c.zero_dynamics.stability),
                        !c.zero_dynamics.modes.empty());
  } catch (const NoSolution&) {
    return "no solution";
  }
}

std::string MapClassName(std::string_view realization,
                         std::string_view stability,
                         bool oscillatory) {
  return std::string(realization) + ", " + std::string(stability) + ", " +
         (oscillatory ? "oscillatory" : "non-oscillatory");
}

void AddClassMap(Document& document,
                 const std::filesystem::path& directory,
                 const Model& model,
                 const GridAxis& x,
                 const GridAxis& y,
                 const ClassificationOptions& options,
                 const std::vector<std::string>* stored_classes) {
  const std::vector<double> x_values = AxisValues(x), y_values = AxisValues(y);
  const auto [x_low, x_high] = std::minmax_element(x_values.begin(), x_values.end());
  const auto [y_low, y_high] = std::minmax_element(y_values.begin(), y_values.end());
  for (const GridAxis* axis : {&x, &y}) {
    const std::vector<double>& values = axis == &x ? x_values : y_values;
    if (*std::max_element(values.begin(), values.end()) ==
        *std::min_element(values.begin(), values.end())) {
      throw UsageError("--vary " + axis->name + ": a map needs at least two values of it");
    }
  }
  ClassificationOptions point_options = options;
  point_options.cross_check = false;
  point_options.Validate(model);

  // The grid, classified: the class of each point, and the points of each class.
  if (stored_classes && stored_classes->size() != x_values.size() * y_values.size()) {
    throw Error("a map of " + std::to_string(x_values.size() * y_values.size()) + " points given " +
                std::to_string(stored_classes->size()) + " classes");
  }
  Workspace workspace(model);
  std::map<std::string, std::vector<std::pair<double, double>>> classes;
  std::size_t grid_point = 0;
  for (const double x_value : x_values) {
    for (const double y_value : y_values) {
      workspace.parameters = model.parameters();
      workspace.parameters(Eigen::Index(x.parameter)) = x_value;
      workspace.parameters(Eigen::Index(y.parameter)) = y_value;
      classes[stored_classes ? (*stored_classes)[grid_point]
                             : MapClassName(model, workspace, point_options)]
          .emplace_back(x.DisplayValue(x_value), y.DisplayValue(y_value));
      ++grid_point;
    }
  }

  // The curves, by continuation of the threshold finder.
  ThresholdCurveOptions curve_options;
  curve_options.thresholds.classification = options;
  curve_options.lines = kCurveLines;
  const std::vector<ThresholdCurve> curves = TraceThresholdCurves(
      model, {x.parameter, *x_low, *x_high}, {y.parameter, *y_low, *y_high},
      {ThresholdEvent::kStability, ThresholdEvent::kOscillation, ThresholdEvent::kRealization},
      curve_options);

  const std::string stem = "map_" + x.name + "_" + y.name;
  const auto label_of = [](const GridAxis& axis) {
    return PlotSymbol(axis.name) + (axis.display_unit == DisplayUnit::kDegree ? " [deg]" : "");
  };
  PlotSpec plot{
      stem,
      "Classes over " + PlotSymbol(x.name) + " and " + PlotSymbol(y.name),
      label_of(x),
      label_of(y),
      "[" + FormatExact(x.DisplayValue(*x_low)) + ":" + FormatExact(x.DisplayValue(*x_high)) + "]",
      "[" + FormatExact(y.DisplayValue(*y_low)) + ":" + FormatExact(y.DisplayValue(*y_high)) + "]",
      {},
      {}};
  const double square = std::clamp(std::max(kPlotWidthInPoints / double(x_values.size()),
                                            kPlotHeightInPoints / double(y_values.size())),
                                   kSmallestSquare, kLargestSquare);
  std::size_t colour = 0;
  Table class_table;
  class_table.header = {"class", "colour", "grid points"};
  for (const auto& [name, points] : classes) {
    const char* rgb = kClassColours[colour++ % std::size(kClassColours)];
    plot.series.push_back(
        {name, points,
         "points pointtype 5 pointsize " + FormatExact(square) + " linecolor rgb '" + rgb + "'"});
    class_table.rows.push_back({name, rgb, std::to_string(points.size())});
  }
  // One colour and dash type per change; the key names each change once.
  std::vector<std::string> changes;
  OutputFile csv_file((directory / (stem + "_curves.csv")).string());
  std::ostream& csv = csv_file.stream();
  csv << "curve,event,from,to,via,traced_along," << x.ColumnName() << "," << y.ColumnName()
      << ",bracket_width\n";
  Table curve_table;
  curve_table.header = {"curve", "traced along", "points", PlotSymbol(x.name) + " range",
                        PlotSymbol(y.name) + " range"};
  for (std::size_t i = 0; i < curves.size(); ++i) {
    const ThresholdCurve& curve = curves[i];
    // from -> to is read in the traced parameter's ascent: the direction is part of the label.
    const std::string label =
        CurveLabel(curve) + " (along " + PlotSymbol(curve.traced_axis == 0 ? x.name : y.name) + ")";
    const auto found = std::find(changes.begin(), changes.end(), label);
    const std::size_t change = std::size_t(found - changes.begin());
    const bool first_of_change = found == changes.end();
    if (first_of_change) changes.push_back(label);
    std::vector<std::pair<double, double>> points;
    constexpr double kInfinity = std::numeric_limits<double>::infinity();
    double low_x = kInfinity, high_x = -kInfinity, low_y = kInfinity, high_y = -kInfinity;
    const GridAxis& traced = curve.traced_axis == 0 ? x : y;
    for (const CurvePoint& point : curve.points) {
      points.emplace_back(x.DisplayValue(point.x), y.DisplayValue(point.y));
      low_x = std::min(low_x, points.back().first);
      high_x = std::max(high_x, points.back().first);
      low_y = std::min(low_y, points.back().second);
      high_y = std::max(high_y, points.back().second);
      csv << i + 1 << "," << ToString(curve.event) << "," << CsvQuote(curve.from) << ","
          << CsvQuote(curve.to) << "," << CsvQuote(curve.via) << "," << traced.name << ","
          << FormatExact(points.back().first) << "," << FormatExact(points.back().second) << ","
          << FormatExact(traced.display_unit == DisplayUnit::kDegree
                             ? RadiansToDegrees(point.bracket_width)
                             : point.bracket_width)
          << "\n";
    }
    plot.series.push_back({first_of_change ? label : "", points,
                           std::string(curve.points.size() == 1 ? "points pointtype 6 pointsize 1.5"
                                                                : "lines linewidth 2.5") +
                               " linecolor rgb '" +
                               kCurveColours[change % std::size(kCurveColours)] + "' dashtype " +
                               std::to_string(1 + int(change % kDashTypes))});
    curve_table.rows.push_back({std::to_string(i + 1) + ". " + label, traced.name,
                                std::to_string(curve.points.size()),
                                FormatShort(low_x) + " to " + FormatShort(high_x),
                                FormatShort(low_y) + " to " + FormatShort(high_y)});
  }
  csv_file.Commit();
  DrawPlot(directory.string(), plot);

  document.Add(Heading{2, "Map over " + x.name + " and " + y.name});
  document.Add(FigureOf(
      stem, "Class of each of the " + std::to_string(x_values.size() * y_values.size()) +
                " grid points (realization, stability, oscillatory), with the threshold curves "
                "traced by the threshold finder on " +
                std::to_string(kCurveLines + 1) + " lines along each axis (" + stem +
                "_curves.csv)"));
  document.Add(class_table);
  if (curves.empty()) {
    document.Add(Paragraph{"No stability, oscillation or realization threshold in this range."});
  } else {
    document.Add(curve_table);
  }
}

}  // namespace servokit
