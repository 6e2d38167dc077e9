#pragma once
// The figures of a solve (`servokit solve --plot DIR`): u_d(t) for each input, q_d(t) and
// dq_d/dt for each coordinate, and y(t) against y_d(t) for each output, drawn with gnuplot
// (reports/plots.h). Several runs (one per method) are overlaid, as in the paper's Figs. 10, 12,
// 15 and 16. Dashed vertical lines mark the start and end of the desired motion and, for stable
// inversion, the start of the pre-actuation and the end of the post-actuation.
#include <Eigen/Dense>
#include <optional>
#include <string>
#include <vector>

namespace servokit {

/// One solve to draw: rows are times, columns the coordinates, inputs or outputs.
struct SolveFigureRun {
  std::string method;  // the method that ran, the key of its curves
  std::vector<double> t;
  Eigen::MatrixXd q, q_dot, u, y_d;  // size t.size() x (dof, dof, inputs, outputs)
  // The output drawn against y_d, at output_times: the forward simulation's when the solve was
  // verified, else h(q_d(t)) at t. output_source says which ("forward simulation" or "h(q_d)").
  std::vector<double> output_times;
  Eigen::MatrixXd output;
  std::string output_source;
  // Stable inversion's window (the JSON's pre_actuation_start and post_actuation_end) [s].
  std::optional<double> pre_actuation_start, post_actuation_end;
};

/// What every figure shares: the model's names and the desired motion's start and end.
struct SolveFigureFrame {
  std::string model_name;
  std::vector<std::string> coordinate_names, input_names, output_names;
  std::vector<double> breakpoints;  // of the desired output, increasing; the first and last
                                    // are marked as the motion's start and end
};

/// The file stems drawn, in order: "u_d-<input>" for each input, "q_d-<coordinate>" and
/// "q_d_dot-<coordinate>" for each coordinate, "y-<output>" for each output.
std::vector<std::string> SolveFigureNames(const SolveFigureFrame& frame);

/// Draws the figures of SolveFigureNames into `directory` (which must exist): for each stem N,
/// N.dat (one data set per curve, "# title" then "t value" rows, numbers in the CSV's exact
/// form), N.gp, N.png and N.svg. In each figure the runs come in order, one curve each; the y
/// figures start with y_d of the first run. Throws Error when gnuplot is missing or fails.
void DrawSolveFigures(const std::string& directory,
                      const SolveFigureFrame& frame,
                      const std::vector<SolveFigureRun>& runs);

}  // namespace servokit
