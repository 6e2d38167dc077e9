#include "reports/solve_figures.h"

#include <algorithm>
#include <cassert>
#include <limits>
#include <utility>

#include "reports/plots.h"

namespace servokit {
namespace {

constexpr const char* kLine = "lines linewidth 2";
constexpr const char* kDesiredLine = "lines linewidth 2 dashtype 2";

// The model file gives no units: values are SI, and the axis says so rather than guess one.
constexpr const char* kTimeLabel = "t [s]";

std::vector<std::pair<double, double>> Column(const std::vector<double>& t,
                                              const Eigen::MatrixXd& values,
                                              Eigen::Index column) {
  assert(values.rows() == Eigen::Index(t.size()));
  std::vector<std::pair<double, double>> points;
  points.reserve(t.size());
  for (std::size_t i = 0; i < t.size(); ++i) {
    points.emplace_back(t[i], values(Eigen::Index(i), column));
  }
  return points;
}

// The motion's start and end, then stable inversion's window (of the first run that has one);
// only those within the span of the runs' times (a post-actuation cut short by --t-end ends
// after it, and the solve warns).
std::vector<MarkerLine> Markers(const SolveFigureFrame& frame,
                                const std::vector<SolveFigureRun>& runs) {
  std::vector<MarkerLine> markers;
  if (!frame.breakpoints.empty()) {
    markers.push_back({frame.breakpoints.front(), "motion start"});
    if (frame.breakpoints.back() > frame.breakpoints.front()) {
      markers.push_back({frame.breakpoints.back(), "motion end"});
    }
  }
  for (const SolveFigureRun& run : runs) {
    if (!run.pre_actuation_start && !run.post_actuation_end) continue;
    if (run.pre_actuation_start) {
      markers.push_back({*run.pre_actuation_start, "pre-actuation start"});
    }
    if (run.post_actuation_end) markers.push_back({*run.post_actuation_end, "post-actuation end"});
    break;
  }
  double first = std::numeric_limits<double>::infinity();
  double last = -first;
  for (const SolveFigureRun& run : runs) {
    if (run.t.empty()) continue;
    first = std::min(first, run.t.front());
    last = std::max(last, run.t.back());
  }
  std::vector<MarkerLine> within;
  for (const MarkerLine& marker : markers) {
    if (marker.x >= first && marker.x <= last) within.push_back(marker);
  }
  return within;
}

// gnuplot's enhanced text reads "_" as a subscript: the model's name keeps its words apart
// with spaces instead.
std::string Readable(std::string name) {
  std::replace(name.begin(), name.end(), '_', ' ');
  return name;
}

// "q_d (radau)" when runs are overlaid, "q_d" for one.
std::string CurveTitle(const std::string& quantity,
                       const SolveFigureRun& run,
                       const std::vector<SolveFigureRun>& runs) {
  return runs.size() > 1 ? quantity + " (" + run.method + ")" : quantity;
}

// The line of run `index` of `count` overlaid: one run a solid line; several each their own
// dash pattern, the first the widest, so that curves that coincide stay told apart (issue #34).
std::string RunLine(std::size_t index, std::size_t count) {
  if (count == 1) return kLine;
  constexpr int kWidest = 4;
  const int width = std::max(1, kWidest - int(index));
  return "lines linewidth " + std::to_string(width) + " dashtype " + std::to_string(index + 1);
}

std::string Methods(const std::vector<SolveFigureRun>& runs) {
  std::string methods;
  for (const SolveFigureRun& run : runs) methods += (methods.empty() ? "" : ", ") + run.method;
  return methods;
}

}  // namespace

std::vector<std::string> SolveFigureNames(const SolveFigureFrame& frame) {
  std::vector<std::string> names;
  for (const std::string& input : frame.input_names) names.push_back("u_d-" + input);
  for (const std::string& coordinate : frame.coordinate_names) names.push_back("q_d-" + coordinate);
  for (const std::string& coordinate : frame.coordinate_names) {
    names.push_back("q_d_dot-" + coordinate);
  }
  for (const std::string& output : frame.output_names) names.push_back("y-" + output);
  return names;
}

void DrawSolveFigures(const std::string& directory,
                      const SolveFigureFrame& frame,
                      const std::vector<SolveFigureRun>& runs) {
  const std::vector<MarkerLine> markers = Markers(frame, runs);
  const std::string about = " - " + Readable(frame.model_name) + ", " + Methods(runs);
  // One figure per column of one quantity, one curve per run.
  const auto draw = [&](const std::string& stem, const std::string& title,
                        const std::string& quantity, const Eigen::MatrixXd SolveFigureRun::*values,
                        Eigen::Index column) {
    PlotSpec spec;
    spec.name = stem;
    spec.title = title + about;
    spec.x_label = kTimeLabel;
    spec.y_label = quantity + " [SI]";
    spec.markers = markers;
    for (std::size_t k = 0; k < runs.size(); ++k) {
      const SolveFigureRun& run = runs[k];
      spec.series.push_back({CurveTitle(quantity, run, runs), Column(run.t, run.*values, column),
                             RunLine(k, runs.size())});
    }
    DrawPlot(directory, spec);
  };
  for (std::size_t k = 0; k < frame.input_names.size(); ++k) {
    const std::string& name = frame.input_names[k];
    draw("u_d-" + name, "feedforward " + name, "u_d", &SolveFigureRun::u, Eigen::Index(k));
  }
  for (std::size_t k = 0; k < frame.coordinate_names.size(); ++k) {
    const std::string& name = frame.coordinate_names[k];
    draw("q_d-" + name, "motion " + name, "q_d", &SolveFigureRun::q, Eigen::Index(k));
  }
  for (std::size_t k = 0; k < frame.coordinate_names.size(); ++k) {
    const std::string& name = frame.coordinate_names[k];
    draw("q_d_dot-" + name, "velocity of " + name, "dq_d/dt", &SolveFigureRun::q_dot,
         Eigen::Index(k));
  }
  for (std::size_t k = 0; k < frame.output_names.size(); ++k) {
    const std::string& name = frame.output_names[k];
    PlotSpec spec;
    spec.name = "y-" + name;
    spec.title = "output " + name + " and its desired course" + about;
    spec.x_label = kTimeLabel;
    spec.y_label = name + " [SI]";
    spec.markers = markers;
    if (!runs.empty()) {
      spec.series.push_back(
          {"y_d", Column(runs.front().t, runs.front().y_d, Eigen::Index(k)), kDesiredLine});
    }
    for (const SolveFigureRun& run : runs) {
      spec.series.push_back({CurveTitle("y, " + run.output_source, run, runs),
                             Column(run.output_times, run.output, Eigen::Index(k)), kLine});
    }
    DrawPlot(directory, spec);
  }
}

}  // namespace servokit
