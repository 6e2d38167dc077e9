#include "studies/class_map.h"

#include <algorithm>
#include <cmath>
#include <fstream>
#include <limits>
#include <map>

#include "analysis/classification.h"
#include "analysis/threshold_curves.h"
#include "base/errors.h"
#include "base/number_format.h"
#include "files/output_file.h"
#include "modeling/units.h"
#include "reports/plots.h"
#include "reports/sweep_tables.h"
#include "studies/study_support.h"

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

struct AxisRange {
  double low = 0.0, high = 0.0;
};

AxisRange RangeOf(const std::vector<double>& values) {
  const auto [low, high] = std::minmax_element(values.begin(), values.end());
  return {*low, *high};
}

// Throws UsageError unless `axis` has at least two distinct values.
void RequireTwoValues(const GridAxis& axis, const std::vector<double>& values) {
  if (*std::max_element(values.begin(), values.end()) ==
      *std::min_element(values.begin(), values.end())) {
    throw UsageError("--vary " + axis.name + ": a map needs at least two values of it");
  }
}

// The grid's points (in display units), by class name.
using ClassPoints = std::map<std::string, std::vector<std::pair<double, double>>>;

// The grid, classified: the class of each point (`stored_classes`, when given, else
// MapClassName with `point_options`), and the points of each class.
ClassPoints ClassifyGrid(const Model& model,
                         const GridAxis& x,
                         const GridAxis& y,
                         const std::vector<double>& x_values,
                         const std::vector<double>& y_values,
                         const ClassificationOptions& point_options,
                         const std::vector<std::string>* stored_classes) {
  if (stored_classes && stored_classes->size() != x_values.size() * y_values.size()) {
    throw Error("a map of " + std::to_string(x_values.size() * y_values.size()) + " points given " +
                std::to_string(stored_classes->size()) + " classes");
  }
  Workspace workspace(model);
  ClassPoints classes;
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
  return classes;
}

// The stability, oscillation and realization curves within the grid's ranges, by continuation
// of the threshold finder.
std::vector<ThresholdCurve> TraceMapCurves(const Model& model,
                                           const GridAxis& x,
                                           const AxisRange& x_range,
                                           const GridAxis& y,
                                           const AxisRange& y_range,
                                           const ClassificationOptions& options) {
  ThresholdCurveOptions curve_options;
  curve_options.thresholds.classification = options;
  curve_options.lines = kCurveLines;
  return TraceThresholdCurves(
      model, {x.parameter, x_range.low, x_range.high}, {y.parameter, y_range.low, y_range.high},
      {ThresholdEvent::kStability, ThresholdEvent::kOscillation, ThresholdEvent::kRealization},
      curve_options);
}

std::string AxisLabel(const GridAxis& axis) {
  return PlotSymbol(axis.name) + (axis.display_unit == DisplayUnit::kDegree ? " [deg]" : "");
}

std::string DisplayRange(const GridAxis& axis, const AxisRange& range) {
  return "[" + FormatExact(axis.DisplayValue(range.low)) + ":" +
         FormatExact(axis.DisplayValue(range.high)) + "]";
}

// The map's figure, titled and ranged, without series.
PlotSpec MapPlot(const std::string& stem,
                 const GridAxis& x,
                 const AxisRange& x_range,
                 const GridAxis& y,
                 const AxisRange& y_range) {
  return PlotSpec{stem,
                  "Classes over " + PlotSymbol(x.name) + " and " + PlotSymbol(y.name),
                  AxisLabel(x),
                  AxisLabel(y),
                  DisplayRange(x, x_range),
                  DisplayRange(y, y_range),
                  {},
                  {}};
}

// The point size of a grid square (see kPlotWidthInPoints).
double GridSquareSize(std::size_t x_count, std::size_t y_count) {
  return std::clamp(
      std::max(kPlotWidthInPoints / double(x_count), kPlotHeightInPoints / double(y_count)),
      kSmallestSquare, kLargestSquare);
}

// One series of squares per class, in the next class colour; returns the table of the classes,
// their colours and numbers of points.
Table PlotClasses(const ClassPoints& classes, double square, PlotSpec& plot) {
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
  return class_table;
}

// A curve's points in display units.
std::vector<std::pair<double, double>> DisplayPoints(const ThresholdCurve& curve,
                                                     const GridAxis& x,
                                                     const GridAxis& y) {
  std::vector<std::pair<double, double>> points;
  for (const CurvePoint& point : curve.points) {
    points.emplace_back(x.DisplayValue(point.x), y.DisplayValue(point.y));
  }
  return points;
}

// The axis along which `curve` was traced.
const GridAxis& TracedAxis(const ThresholdCurve& curve, const GridAxis& x, const GridAxis& y) {
  return curve.traced_axis == 0 ? x : y;
}

// The rows of the `number`-th curve in the curves' CSV file, one per traced point.
void WriteCurveRows(std::ostream& csv,
                    std::size_t number,
                    const ThresholdCurve& curve,
                    const GridAxis& traced,
                    const std::vector<std::pair<double, double>>& points) {
  for (std::size_t k = 0; k < curve.points.size(); ++k) {
    const CurvePoint& point = curve.points[k];
    csv << number << "," << ToString(curve.event) << "," << CsvQuote(curve.from) << ","
        << CsvQuote(curve.to) << "," << CsvQuote(curve.via) << "," << traced.name << ","
        << FormatExact(points[k].first) << "," << FormatExact(points[k].second) << ","
        << FormatExact(traced.display_unit == DisplayUnit::kDegree
                           ? RadiansToDegrees(point.bracket_width)
                           : point.bracket_width)
        << "\n";
  }
}

// map_<x>_<y>_curves.csv: one row per traced point of every curve.
void WriteCurvesCsv(const std::filesystem::path& path,
                    const std::vector<ThresholdCurve>& curves,
                    const GridAxis& x,
                    const GridAxis& y) {
  OutputFile csv_file(path.string());
  std::ostream& csv = csv_file.stream();
  csv << "curve,event,from,to,via,traced_along," << x.ColumnName() << "," << y.ColumnName()
      << ",bracket_width\n";
  for (std::size_t i = 0; i < curves.size(); ++i) {
    WriteCurveRows(csv, i + 1, curves[i], TracedAxis(curves[i], x, y),
                   DisplayPoints(curves[i], x, y));
  }
  csv_file.Commit();
}

// The key's name of a curve's change: from -> to is read in the traced parameter's ascent, so
// the direction is part of the label.
std::string ChangeLabel(const ThresholdCurve& curve, const GridAxis& x, const GridAxis& y) {
  return CurveLabel(curve) + " (along " + PlotSymbol(TracedAxis(curve, x, y).name) + ")";
}

// The gnuplot style of a curve of the `change`-th change: its colour and dash type; a curve of
// one point is a marker.
std::string CurveStyle(std::size_t point_count, std::size_t change) {
  return std::string(point_count == 1 ? "points pointtype 6 pointsize 1.5"
                                      : "lines linewidth 2.5") +
         " linecolor rgb '" + kCurveColours[change % std::size(kCurveColours)] + "' dashtype " +
         std::to_string(1 + int(change % kDashTypes));
}

// The curves' table row of the `number`-th curve: what changes, along which parameter, its
// number of points and the ranges it spans.
std::vector<std::string> CurveTableRow(std::size_t number,
                                       const std::string& label,
                                       const GridAxis& traced,
                                       const std::vector<std::pair<double, double>>& points) {
  constexpr double kInfinity = std::numeric_limits<double>::infinity();
  double low_x = kInfinity, high_x = -kInfinity, low_y = kInfinity, high_y = -kInfinity;
  for (const auto& [point_x, point_y] : points) {
    low_x = std::min(low_x, point_x);
    high_x = std::max(high_x, point_x);
    low_y = std::min(low_y, point_y);
    high_y = std::max(high_y, point_y);
  }
  return {std::to_string(number) + ". " + label, traced.name, std::to_string(points.size()),
          FormatShort(low_x) + " to " + FormatShort(high_x),
          FormatShort(low_y) + " to " + FormatShort(high_y)};
}

// One series per curve, with one colour and dash type per change (the key names each change
// once); returns the curves' table.
Table PlotCurves(const std::vector<ThresholdCurve>& curves,
                 const GridAxis& x,
                 const GridAxis& y,
                 PlotSpec& plot) {
  std::vector<std::string> changes;
  Table curve_table;
  curve_table.header = {"curve", "traced along", "points", PlotSymbol(x.name) + " range",
                        PlotSymbol(y.name) + " range"};
  for (std::size_t i = 0; i < curves.size(); ++i) {
    const ThresholdCurve& curve = curves[i];
    const std::string label = ChangeLabel(curve, x, y);
    const auto found = std::find(changes.begin(), changes.end(), label);
    const std::size_t change = std::size_t(found - changes.begin());
    const bool first_of_change = found == changes.end();
    if (first_of_change) changes.push_back(label);
    const std::vector<std::pair<double, double>> points = DisplayPoints(curve, x, y);
    plot.series.push_back(
        {first_of_change ? label : "", points, CurveStyle(curve.points.size(), change)});
    curve_table.rows.push_back(CurveTableRow(i + 1, label, TracedAxis(curve, x, y), points));
  }
  return curve_table;
}

// The map's section: heading, figure, the classes' table and the curves' (or that there are
// none).
void AddMapSection(Document& document,
                   const std::string& stem,
                   const GridAxis& x,
                   const GridAxis& y,
                   std::size_t grid_points,
                   const Table& class_table,
                   const Table& curve_table) {
  document.Add(Heading{2, "Map over " + x.name + " and " + y.name});
  document.Add(FigureOf(
      stem, "Class of each of the " + std::to_string(grid_points) +
                " grid points (realization, stability, oscillatory), with the threshold curves "
                "traced by the threshold finder on " +
                std::to_string(kCurveLines + 1) + " lines along each axis (" + stem +
                "_curves.csv)"));
  document.Add(class_table);
  if (curve_table.rows.empty()) {
    document.Add(Paragraph{"No stability, oscillation or realization threshold in this range."});
  } else {
    document.Add(curve_table);
  }
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
  const AxisRange x_range = RangeOf(x_values), y_range = RangeOf(y_values);
  RequireTwoValues(x, x_values);
  RequireTwoValues(y, y_values);
  ClassificationOptions point_options = options;
  point_options.cross_check = false;
  point_options.Validate(model);
  const ClassPoints classes =
      ClassifyGrid(model, x, y, x_values, y_values, point_options, stored_classes);
  const std::vector<ThresholdCurve> curves = TraceMapCurves(model, x, x_range, y, y_range, options);

  const std::string stem = "map_" + x.name + "_" + y.name;
  PlotSpec plot = MapPlot(stem, x, x_range, y, y_range);
  const Table class_table =
      PlotClasses(classes, GridSquareSize(x_values.size(), y_values.size()), plot);
  WriteCurvesCsv(directory / (stem + "_curves.csv"), curves, x, y);
  const Table curve_table = PlotCurves(curves, x, y, plot);
  DrawPlot(directory.string(), plot);
  AddMapSection(document, stem, x, y, x_values.size() * y_values.size(), class_table, curve_table);
}

}  // namespace servokit
