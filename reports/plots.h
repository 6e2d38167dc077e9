#pragma once
// Figures drawn with gnuplot, driven with a data file and a script: for a plot named N,
// DIR/N.dat holds the data, DIR/N.gp the script, and gnuplot writes DIR/N.png, DIR/N.svg and
// DIR/N.pdf (its messages go to DIR/N.log). All text is drawn as written (gnuplot's "enhanced"
// mode is off), so a name such as x_dot is never read as a subscript; PlotSymbol() turns names
// into symbols (alpha -> α, x_dot -> ẋ).
#include <cstddef>
#include <string>
#include <utility>
#include <vector>

namespace servokit {

struct PlotSeries {
  std::string title;
  std::vector<std::pair<double, double>> points;
  std::string style = "points pointtype 7 pointsize 0.5";
};

struct MarkerLine {
  double x = 0.0;  // a vertical line at x, labelled
  std::string label;
};

struct PlotSpec {
  std::string name;  // file stem
  std::string title, x_label, y_label;
  std::string x_range, y_range;  // gnuplot ranges like "[-30:2]", "" for automatic
  std::vector<PlotSeries> series;
  std::vector<MarkerLine> markers;
};

/// Axis limits chosen so that a few far-out values (eigenvalues near a singular parameter
/// value) do not squash the rest. The rule: take the 10 % and 90 % quantiles q10, q90 of the
/// values (linear interpolation between order statistics, as R's type 7), widen that interval
/// by its own width w = q90 - q10 on each side, and cut it to the data's extremes:
/// [max(min, q10 - w), min(max, q90 + w)]. The axis spans these limits padded by 5 % of their
/// width on each side; values outside them are clipped (not drawn). Equal values (no width)
/// leave the axis to gnuplot's autoscaling (range "").
struct RobustRange {
  double low = 0.0, high = 0.0;  // the limits before padding
  std::size_t outside = 0;       // values outside [low, high], clipped
  double min = 0.0, max = 0.0;   // the data's extremes
  std::string range;             // gnuplot range ("[a:b]"), "" for autoscaling
};
RobustRange RobustLimits(std::vector<double> values);

/// A name as a symbol for figures: a Greek letter's name becomes the letter (alpha -> α,
/// Omega -> Ω), a trailing _dot / _ddot a dot / two dots above (x_dot -> ẋ), other text is
/// kept as written (u_d stays u_d).
std::string PlotSymbol(const std::string& name);

/// Points coloured by a value (a root locus by its parameter), kept apart from PlotSpec so that
/// code initialising PlotSpec and PlotSeries field by field stays complete (-Wextra).
struct PlotColouring {
  /// values[i][k] colours point k of series i on the palette; a series without values (or with
  /// an empty list) has one colour. Each non-empty list has one value per point.
  std::vector<std::vector<double>> values;
  std::string label;  // the colour bar's label
};

/// Writes the data and the script and runs gnuplot. Throws Error when gnuplot is missing
/// ("install gnuplot-nox") or fails (with the first line of its log).
void DrawPlot(const std::string& directory,
              const PlotSpec& spec,
              const PlotColouring& colouring = {});

}  // namespace servokit
