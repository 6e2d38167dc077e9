// servokit sweep MODEL --vary p=a:b:n | p=v1,v2,... [--vary ...] --out DIR [--threads N]
//                [--set p=v]... [--y0 v]... [--q0 v]... [--rank-tolerance r] [--axis-tolerance a]
#include <signal.h>

#include <chrono>
#include <csignal>
#include <memory>
#include <ostream>
#include <string>
#include <vector>

#include "analysis/parameter_grid.h"
#include "analysis/sweep.h"
#include "models/errors.h"
#include "reports/commands.h"
#include "reports/exit_codes.h"
#include "reports/number_format.h"
#include "reports/progress.h"
#include "reports/sweep_files.h"

namespace servokit {
namespace {

// The shells' status for a job stopped by Ctrl-C (128 + SIGINT); also used for SIGTERM, since
// both mean "stopped on request, resumable".
constexpr int kInterruptedExitStatus = 128 + SIGINT;

struct SweepArguments {
  std::string model_path;
  std::vector<std::string> vary;       // "name=a:b:n" or "name=v1,v2,..."
  std::string out;                     // the output directory
  int threads = 0;                     // 0: not given, all cores
  std::vector<std::string> overrides;  // "name=value"
  std::vector<std::string> y0, q0;     // each may hold several values separated by commas
  ClassificationOptions options;
  // Seconds between checkpoints.
  double checkpoint_interval = kSweepCheckpointInterval.count();
};

// The signal that asked the sweep to stop, 0 if none. A signal handler may only touch a
// volatile sig_atomic_t (or a lock-free atomic).
volatile std::sig_atomic_t interrupt_signal = 0;

void OnInterrupt(int signal) {
  if (interrupt_signal != 0) {
    // A second Ctrl-C stops at once, as SIGKILL would: the last checkpoint still holds.
    ::signal(signal, SIG_DFL);
    ::raise(signal);
    return;
  }
  interrupt_signal = signal;
}

/// While alive, SIGINT and SIGTERM ask the sweep to stop after the running block instead of
/// killing it; the previous handlers come back afterwards (RunCommandLine may run in a test).
class InterruptGuard {
 public:
  InterruptGuard() {
    interrupt_signal = 0;
    struct sigaction action = {};
    action.sa_handler = OnInterrupt;
    sigemptyset(&action.sa_mask);
    action.sa_flags = SA_RESTART;  // file writes resume rather than fail with EINTR
    if (::sigaction(SIGINT, &action, &previous_interrupt_) != 0 ||
        ::sigaction(SIGTERM, &action, &previous_terminate_) != 0) {
      throw Error("cannot install the SIGINT/SIGTERM handlers");
    }
  }
  ~InterruptGuard() {
    ::sigaction(SIGINT, &previous_interrupt_, nullptr);
    ::sigaction(SIGTERM, &previous_terminate_, nullptr);
  }
  InterruptGuard(const InterruptGuard&) = delete;
  InterruptGuard& operator=(const InterruptGuard&) = delete;

  bool interrupted() const { return interrupt_signal != 0; }

 private:
  struct sigaction previous_interrupt_ = {}, previous_terminate_ = {};
};

// The command line as given, rebuilt from the parsed options (RunCommandLine does not pass argv
// on); options come in the order they are declared, each with every value it was given.
std::vector<std::string> CommandLine(const CLI::App& sweep) {
  std::vector<std::string> line = {"servokit", sweep.get_name()};
  for (const CLI::Option* option : sweep.get_options()) {
    for (const std::string& value : option->results()) {
      if (!option->get_positional()) line.push_back(option->get_name());
      line.push_back(value);
    }
  }
  return line;
}

void RejectSetAndVary(const std::vector<ParameterOverride>& overrides, const ParameterGrid& grid) {
  for (const GridAxis& axis : grid.axes()) {
    for (const ParameterOverride& override : overrides) {
      if (override.name == axis.name) {
        throw UsageError("--vary " + axis.name + ": the parameter is also given by --set; " +
                         "drop one of them");
      }
    }
  }
}

SweepOptions MakeSweepOptions(const SweepArguments& arguments,
                              const CLI::App& sweep,
                              const Model& model) {
  SweepOptions options;
  options.classification = arguments.options;
  if (!arguments.y0.empty()) {
    options.classification.operating_point.y0 = ParseValues("--y0", arguments.y0);
  }
  if (!arguments.q0.empty()) {
    options.classification.operating_point.q_guess = ParseValues("--q0", arguments.q0);
  }
  if (sweep.get_option("--threads")->count() > 0) {
    if (arguments.threads < 1) {
      throw UsageError("--threads " + std::to_string(arguments.threads) +
                       ": must be at least 1 (default: all cores)");
    }
    options.threads = arguments.threads;
  }
  // Before the output directory is touched: a bad option must not leave a half-made sweep.
  options.classification.Validate(model);
  return options;
}

int RunSweepCommand(const SweepArguments& arguments,
                    const CLI::App& sweep,
                    std::ostream& out,
                    std::ostream& err) {
  const std::vector<ParameterOverride> overrides = ParseOverrides(arguments.overrides);
  const Model model = LoadModel(arguments.model_path, overrides);
  const ParameterGrid grid = ParseParameterGrid(model, arguments.vary);
  RejectSetAndVary(overrides, grid);
  const SweepOptions options = MakeSweepOptions(arguments, sweep, model);
  if (!(arguments.checkpoint_interval > 0.0)) {
    throw UsageError("--checkpoint-interval " + FormatShort(arguments.checkpoint_interval) +
                     ": must be > 0 seconds");
  }
  const SweepOutputOptions output_options = {
      SweepThreads(options), std::chrono::duration<double>(arguments.checkpoint_interval)};
  SweepOutput output(arguments.out, model, grid, options.classification, CommandLine(sweep),
                     output_options);
  const std::size_t total = grid.num_points();
  if (output.already_complete()) {
    err << "servokit: " << arguments.out << " already holds this sweep, complete (" << total
        << " points); nothing to do\n";
    return static_cast<int>(ExitCode::kSuccess);
  }
  if (output.points_done() > 0) {
    err << "servokit: resuming at point " << output.points_done() << " of " << total << "\n";
  }
  std::size_t done = 0;
  {
    ProgressBar progress(err, total, output.points_done(), IsTerminalStderr(err));
    const InterruptGuard interrupt;
    done = RunSweep(model, grid, options, output.points_done(),
                    [&](std::size_t first, std::span<const SweepPoint> block) {
                      output.Append(first, block);
                      progress.Update(first + block.size());
                      return !interrupt.interrupted();
                    });
  }
  if (done < total) {
    output.Checkpoint();
    err << "servokit: error: interrupted at point " << done << " of " << total
        << "; run the same command again to resume\n";
    return kInterruptedExitStatus;
  }
  output.Finish();
  out << "swept " << total << " points of " << model.name() << " into " << arguments.out
      << " (points.csv, eigenvalues.csv, sweep.json); " << output.points_without_solution()
      << " without a solution\n";
  return static_cast<int>(ExitCode::kSuccess);
}

}  // namespace

Command AddSweepCommand(CLI::App& app) {
  auto arguments = std::make_shared<SweepArguments>();
  CLI::App* sweep = app.add_subcommand(
      "sweep", "Classify the problem at every point of a parameter grid (CSV tables)");
  sweep->footer(
      "Each --vary adds one axis of a full grid; the first varies slowest (row-major).\n"
      "A range a:b:n is n values from a to b inclusive; a list is v1,v2,...; values may end\n"
      "in deg. Interrupted (Ctrl-C), the sweep exits with status 130; the same command\n"
      "resumes it.\n"
      "Example:\n  servokit sweep models/mass_on_car.yaml --vary alpha=0deg:90deg:91 "
      "--vary d=0:2:21 --out sweep-out");
  sweep->add_option("MODEL", arguments->model_path, "Model file (YAML)")->required();
  sweep
      ->add_option("--vary", arguments->vary,
                   "A varied parameter: name=a:b:n (n values from a to b) or name=v1,v2,...")
      ->required();
  sweep->add_option("--out", arguments->out, "Output directory")->required();
  sweep->add_option("--threads", arguments->threads, "Threads (default: all cores)");
  sweep
      ->add_option("--checkpoint-interval", arguments->checkpoint_interval,
                   "Seconds between checkpoints (fsync): the most work a crash can lose")
      ->capture_default_str();
  sweep->add_option("--set", arguments->overrides,
                    "Override a fixed parameter: name=value (value may end in deg)");
  sweep->add_option("--y0", arguments->y0,
                    "Output value at the operating point, one per output (default: h(0))");
  sweep->add_option("--q0", arguments->q0, "Newton's starting point for q (default: 0)");
  sweep
      ->add_option("--rank-tolerance", arguments->options.rank_tolerance,
                   "Relative tolerance of rank decisions (P, Markov parameters)")
      ->capture_default_str();
  sweep
      ->add_option("--axis-tolerance", arguments->options.imaginary_axis_tolerance,
                   "Relative distance to the imaginary axis counted as on it")
      ->capture_default_str();
  return {sweep, [arguments, sweep](std::ostream& out, std::ostream& err) {
            return RunSweepCommand(*arguments, *sweep, out, err);
          }};
}

}  // namespace servokit
