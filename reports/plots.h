#pragma once
// Figures drawn with gnuplot (DESIGN.md: "driven with a data file and a script"): for a plot
// named N, DIR/N.dat holds the data, DIR/N.gp the script, and gnuplot writes DIR/N.png and
// DIR/N.svg (its messages go to DIR/N.log).
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

/// Writes the data and the script and runs gnuplot. Throws Error when gnuplot is missing
/// ("install gnuplot-nox") or fails (with the first line of its log).
void DrawPlot(const std::string& directory, const PlotSpec& spec);

}  // namespace servokit
