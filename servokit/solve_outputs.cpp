// What a solve gives besides its numbers: the summary in a few lines, the figures, and the
// files around it (samples in, the feedforward's file name checked before any work).
#include <cmath>
#include <sstream>

#include "base/number_format.h"
#include "files/output_file.h"
#include "reports/solve_figures.h"
#include "reports/solve_files.h"
#include "servokit/servokit.h"
#include "trajectories/sampled_trajectory.h"

namespace servokit::api {
namespace {

// A number of the summary in a few digits, "none" where the JSON has null (not finite).
std::string ShortOrNone(double value) {
  if (!std::isfinite(value)) return "none";
  return FormatShort(WithoutNegativeZero(value));  // as the JSON: no negative zero
}

// A time of the window, none where the JSON has null.
std::optional<double> FiniteOrNone(double value) {
  if (!std::isfinite(value)) return std::nullopt;
  return WithoutNegativeZero(value);
}

SolveFigureRun FigureRunOf(const Feedforward& feedforward) {
  const SolveSummary& summary = feedforward.summary;
  SolveFigureRun run;
  run.method = std::string(ToString(summary.method));
  run.t = feedforward.t;
  run.q = feedforward.q;
  run.q_dot = feedforward.q_dot;
  run.u = feedforward.u;
  run.y_d = feedforward.y_d;
  if (summary.verification && !summary.verification->t.empty()) {
    run.output_times = summary.verification->t;
    run.output = summary.verification->y;
    run.output_source = "forward simulation";
  } else {
    run.output_times = feedforward.t;
    run.output = feedforward.y;
    run.output_source = "h(q_d)";
  }
  if (summary.window) {
    run.pre_actuation_start = FiniteOrNone(summary.window->pre_actuation_start);
    run.post_actuation_end = FiniteOrNone(summary.window->post_actuation_end);
  }
  return run;
}

}  // namespace

std::string SolveSummaryText(const SolveSummary& summary) {
  std::ostringstream text;
  text << "method: " << ToString(summary.method) << " (" << summary.method_reason << ")\n";
  text << "status: " << ToString(summary.status);
  if (!summary.message.empty()) text << ": " << summary.message;
  text << "\nsteps: " << summary.steps << " (" << summary.rejected_steps << " rejected, "
       << summary.newton_iterations << " Newton iterations), " << summary.samples
       << " samples from t = " << ShortOrNone(summary.t_start) << " s to "
       << ShortOrNone(summary.t_end) << " s\n";
  text << "max servo residual: " << ShortOrNone(summary.max_servo_residual) << "\n";
  if (const std::optional<Verification>& verification = summary.verification) {
    text << "verification: " << (verification->passed ? "passed" : "FAILED")
         << ", max output error " << ShortOrNone(verification->max_tracking_error)
         << " at t = " << ShortOrNone(verification->time_of_max_error) << " s, bound "
         << ShortOrNone(verification->bound) << "\n";
  } else {
    text << "verification: not run (--verify)\n";
  }
  if (summary.window) {
    text << "pre-actuation from t = " << ShortOrNone(summary.window->pre_actuation_start)
         << " s, post-actuation to t = " << ShortOrNone(summary.window->post_actuation_end)
         << " s\n";
  }
  for (const std::string& warning : summary.warnings) text << "warning: " << warning << "\n";
  text << "file: " << summary.out_file << "\n";
  return text.str();
}

void DrawSolveFigures(const std::string& directory,
                      const Model& model,
                      const std::vector<const Feedforward*>& solves) {
  if (solves.empty()) return;
  const SolveFigureFrame frame{model.name(), model.coordinate_names(), model.input_names(),
                               model.output_names(), solves.front()->breakpoints};
  std::vector<SolveFigureRun> runs;
  for (const Feedforward* feedforward : solves) runs.push_back(FigureRunOf(*feedforward));
  servokit::DrawSolveFigures(directory, frame, runs);
}

void ReadSamplesFile(const std::string& path, OutputTrajectory& trajectory) {
  TrajectorySamples samples = LoadTrajectorySamples(path);
  trajectory.sample_source = path;
  trajectory.sample_times = std::move(samples.times);
  trajectory.sample_values = std::move(samples.values);
}

void ReadSamplesFile(const std::string& path, const Model& model, OutputTrajectory& trajectory) {
  TrajectorySamples samples =
      SelectOutputColumns(LoadTrajectorySamples(path), model.output_names(), path);
  trajectory.sample_source = path;
  trajectory.sample_times = std::move(samples.times);
  trajectory.sample_values = std::move(samples.values);
}

SolveFileFormat SolveFileFormatOfName(const std::string& path) {
  return servokit::SolveFileFormatOfName(path);
}

std::optional<std::string> SolveFileNameProblem(const std::string& path, SolveFileFormat format) {
  return servokit::SolveFileNameProblem(path, format);
}

void CheckOutputPath(const std::string& path) { servokit::CheckOutputPath(path); }

}  // namespace servokit::api
