// servokit sweep MODEL --vary p=a:b:n | p=v1,v2,... [--vary ...] --out DIR [--threads N]
//                [--format csv|hdf5|mat]
//                [--set p=v]... [--y0 v]... [--q0 v]... [--rank-tolerance r] [--axis-tolerance a]
//                [--checkpoint-interval s] [--block-size n]
//                [--eigenvalues K] [--shift S] [--eigen-solver auto|dense|arpack]
//                [--which nearest|rightmost]            (linear models only)
// The sweep itself is the library's api::DirectorySweep (servokit/servokit.h): durable,
// resumable, and shared out over the ranks of an MPI job, where every rank runs this command.
// Here: the flags, the signals that stop it, the test hooks and the progress bar.
#include <signal.h>

#include <charconv>
#include <csignal>
#include <cstdlib>
#include <cstring>
#include <memory>
#include <optional>
#include <ostream>
#include <string>
#include <vector>

#include "application/commands.h"
#include "application/exit_codes.h"
#include "application/progress.h"
#include "servokit/servokit.h"

namespace servokit {
namespace {

// The shells' status for a job stopped by Ctrl-C (128 + SIGINT); also used for SIGTERM, since
// both mean "stopped on request, resumable".
constexpr int kInterruptedExitStatus = 128 + SIGINT;

struct SweepArguments {
  std::string model_path;
  std::vector<std::string> vary;  // "name=a:b:n" or "name=v1,v2,..."
  std::string out;                // the output directory
  std::string format = "csv";     // SweepFileFormat's name
  int threads = 0;                // 0: not given, all cores
  std::size_t block_size = api::DefaultSweepSettings().block_size;
  std::vector<std::string> overrides;  // "name=value"
  std::vector<std::string> y0, q0;     // each may hold several values separated by commas
  double rank_tolerance = api::DefaultAnalyzeOptions().rank_tolerance;
  double imaginary_axis_tolerance = api::DefaultAnalyzeOptions().imaginary_axis_tolerance;
  // Seconds between checkpoints.
  double checkpoint_interval = api::DefaultSweepSettings().checkpoint_interval;
  LinearModelArguments linear;  // linear models only (as `servokit analyze`)
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

// Test hooks: SERVOKIT_TEST_STOP_AFTER_BLOCKS=B makes a process act as if interrupted, and
// SERVOKIT_TEST_FAIL_AFTER_BLOCKS=B throw an Error, once it has handled B blocks (written them,
// on rank 0 or alone; computed them, on the other ranks of an MPI sweep), so that tests stop or
// break a sweep at a known place, on a chosen rank.
constexpr const char* kTestStopVariable = "SERVOKIT_TEST_STOP_AFTER_BLOCKS";
constexpr const char* kTestFailVariable = "SERVOKIT_TEST_FAIL_AFTER_BLOCKS";

std::optional<std::size_t> BlocksFromEnvironment(const char* variable) {
  const char* text = std::getenv(variable);
  if (text == nullptr) return std::nullopt;
  std::size_t blocks = 0;
  const char* end = text + std::strlen(text);
  const auto [stop, error] = std::from_chars(text, end, blocks);
  if (error != std::errc() || stop != end || blocks < 1) {
    throw UsageError(std::string(variable) + "=" + text + ": must be a whole number >= 1");
  }
  return blocks;
}

struct TestHooks {
  std::optional<std::size_t> stop_after_blocks, fail_after_blocks;
};

TestHooks TestHooksFromEnvironment() {
  return {BlocksFromEnvironment(kTestStopVariable), BlocksFromEnvironment(kTestFailVariable)};
}

/// Asked after each block: should the sweep stop here (a signal, or a test hook)?
class StopRequest {
 public:
  StopRequest(const InterruptGuard& interrupt, const TestHooks& hooks)
      : interrupt_(interrupt), hooks_(hooks) {}
  bool operator()() {
    ++blocks_;
    if (hooks_.fail_after_blocks && blocks_ >= *hooks_.fail_after_blocks) {
      throw Error(std::string(kTestFailVariable) + "=" + std::to_string(blocks_) +
                  ": failing as asked");
    }
    return interrupt_.interrupted() ||
           (hooks_.stop_after_blocks && blocks_ >= *hooks_.stop_after_blocks);
  }

 private:
  const InterruptGuard& interrupt_;
  const TestHooks hooks_;
  std::size_t blocks_ = 0;
};

// The command line as given, rebuilt from the parsed options (RunCommandLine does not pass argv
// on); options come in the order they are declared, each with every value it was given. The
// thread count is left out: sweep.json, like the tables, is the same bytes for any count.
std::vector<std::string> CommandLine(const CLI::App& sweep) {
  std::vector<std::string> line = {"servokit", sweep.get_name()};
  for (const CLI::Option* option : sweep.get_options()) {
    if (option->get_name() == "--threads") continue;
    for (const std::string& value : option->results()) {
      if (!option->get_positional()) line.push_back(option->get_name());
      line.push_back(value);
    }
  }
  return line;
}

void RejectSetAndVary(const api::ParameterValues& overrides,
                      const std::vector<api::SweepAxis>& axes) {
  for (const api::SweepAxis& axis : axes) {
    for (const auto& [name, value] : overrides) {
      if (name == axis.parameter) {
        throw UsageError("--vary " + axis.parameter + ": the parameter is also given by --set; " +
                         "drop one of them");
      }
    }
  }
}

// The operating point and the thread count (the tolerances and a linear model's options are
// set before the grid is read).
void SetPointAndThreads(const SweepArguments& arguments,
                        const CLI::App& sweep,
                        api::SweepOptions& options) {
  if (!arguments.y0.empty()) options.analysis.y0 = ParseValues("--y0", arguments.y0);
  if (!arguments.q0.empty()) options.analysis.q_guess = ParseValues("--q0", arguments.q0);
  if (sweep.get_option("--threads")->count() > 0) {
    const int most = api::DefaultSweepSettings().max_threads;
    if (arguments.threads < 1) {
      throw UsageError("--threads " + std::to_string(arguments.threads) +
                       ": must be at least 1 (default: all cores)");
    }
    if (arguments.threads > most) {
      throw UsageError("--threads " + std::to_string(arguments.threads) + ": must be at most " +
                       std::to_string(most));
    }
    options.threads = arguments.threads;
  }
}

api::DirectorySweepOptions MakeDirectorySweepOptions(const SweepArguments& arguments,
                                                     const CLI::App& sweep) {
  api::DirectorySweepOptions options;
  const std::optional<SweepFileFormat> format = SweepFileFormatFromString(arguments.format);
  if (!format) throw UsageError("--format " + arguments.format + ": must be csv, hdf5 or mat");
  options.format = *format;
  if (arguments.block_size < 1) throw UsageError("--block-size 0: must be at least 1");
  const std::size_t most = api::DefaultSweepSettings().max_block_size;
  if (arguments.block_size > most) {
    throw UsageError("--block-size " + std::to_string(arguments.block_size) + ": must be at most " +
                     std::to_string(most));
  }
  options.block_size = arguments.block_size;
  if (!(arguments.checkpoint_interval > 0.0)) {
    throw UsageError("--checkpoint-interval " + api::FormatNumber(arguments.checkpoint_interval) +
                     ": must be > 0 seconds");
  }
  options.checkpoint_interval = arguments.checkpoint_interval;
  options.command_line = CommandLine(sweep);
  options.directory_label = "--out";
  options.format_label = "--format";
  return options;
}

// What the command line asks for, read on every process of an MPI sweep (before the output
// directory is touched: a bad option must not leave a half-made sweep).
struct SweepRequest {
  std::optional<api::Model> model;
  std::vector<api::SweepAxis> axes;
  api::SweepOptions options;
  api::DirectorySweepOptions directory_options;
  std::vector<std::string> warnings;  // of the --vary texts, printed once the sweep is set up
  TestHooks test_hooks;
};

SweepRequest ReadSweepRequest(const SweepArguments& arguments, const CLI::App& sweep) {
  SweepRequest request;
  api::OnEveryProcess([&] {
    const api::ParameterValues overrides = ParseParameterValues(arguments.overrides);
    request.model.emplace(api::Model::FromFile(arguments.model_path, overrides));
    api::AnalyzeOptions& analysis = request.options.analysis;
    analysis.rank_tolerance = arguments.rank_tolerance;
    analysis.imaginary_axis_tolerance = arguments.imaginary_axis_tolerance;
    if (request.model->kind() == ModelKind::kLinear) {
      ApplyLinearModelArguments(arguments.linear, !arguments.y0.empty(), !arguments.q0.empty(),
                                analysis);
    } else {
      RefuseLinearModelOptions(sweep);
    }
    request.axes = api::ParseSweepAxes(*request.model, arguments.vary, "--vary", &request.warnings);
    RejectSetAndVary(overrides, request.axes);
    request.directory_options = MakeDirectorySweepOptions(arguments, sweep);
    SetPointAndThreads(arguments, sweep, request.options);
    request.test_hooks = TestHooksFromEnvironment();
  });
  return request;
}

int RunSweepCommand(const SweepArguments& arguments,
                    const CLI::App& sweep,
                    std::ostream& out,
                    std::ostream& err) {
  // `err` of a rank other than 0 is a null stream (main.cpp): rank 0 alone prints.
  const SweepRequest request = ReadSweepRequest(arguments, sweep);
  const api::Model& model = *request.model;
  // Collective itself, as Open and Run are.
  api::DirectorySweep directory_sweep(model, request.axes, request.options,
                                      request.directory_options);
  for (const std::string& warning : request.warnings) {
    err << "servokit: warning: " << warning << "\n";
  }
  directory_sweep.Open(arguments.out);
  const std::size_t total = directory_sweep.num_points();
  if (directory_sweep.already_complete()) {
    err << "servokit: " << arguments.out << " already holds this sweep, complete (" << total
        << " points); nothing to do\n";
    return static_cast<int>(ExitCode::kSuccess);
  }
  const std::size_t first_point = directory_sweep.first_point();
  if (first_point > 0) {
    err << "servokit: resuming at point " << first_point << " of " << total << "\n";
  }
  // Held until the tables are finished: Ctrl-C while sweep.mat is built is honoured too (and
  // the stop test hook counts the table file's chunks after the blocks).
  const InterruptGuard interrupt;
  StopRequest stop_requested(interrupt, request.test_hooks);
  ProgressBar progress(err, total, first_point, IsTerminalStderr(err));
  const api::DirectorySweep::End end = directory_sweep.Run(
      [&] { return stop_requested(); }, [&](std::size_t done) { progress.Update(done); });
  progress.Clear();  // before the last line
  if (!api::Processes().IsRoot()) {
    return end == api::DirectorySweep::End::kFinished ? static_cast<int>(ExitCode::kSuccess)
                                                      : kInterruptedExitStatus;
  }
  switch (end) {
    case api::DirectorySweep::End::kStopped:
      err << "servokit: error: interrupted at point " << directory_sweep.points_done() << " of "
          << total << "; run the same command again to resume\n";
      return kInterruptedExitStatus;
    case api::DirectorySweep::End::kStoppedInTables:
      err << "servokit: error: interrupted while writing the tables (every point is done); run "
          << "the same command again to finish them\n";
      return kInterruptedExitStatus;
    case api::DirectorySweep::End::kFinished:
      break;
  }
  out << "swept " << total << " points of " << model.name() << " into " << arguments.out << " ("
      << directory_sweep.table_file_names() << ", sweep.json); "
      << directory_sweep.points_without_solution() << " without a solution\n";
  return static_cast<int>(ExitCode::kSuccess);
}

}  // namespace

Command AddSweepCommand(CLI::App& app) {
  auto arguments = std::make_shared<SweepArguments>();
  CLI::App* sweep = app.add_subcommand(
      "sweep",
      "Classify the problem at every point of a parameter grid (CSV tables, HDF5 or MAT file)");
  sweep->footer(
      "Each --vary adds one axis of a full grid; the first varies slowest (row-major).\n"
      "A range a:b:n (or a:b:n=N) is n values from a to b inclusive; a:b:step=h is a, a+h,\n"
      "... up to b; a list is v1,v2,...; values may end in deg, and a parameter given in deg\n"
      "is written in degrees (column <name>_deg). Interrupted (Ctrl-C), the sweep exits with "
      "status 130; the same command\n"
      "resumes it. `mpirun -np K servokit sweep ...` shares the blocks out over K ranks and\n"
      "writes the same files.\n"
      "Example:\n  servokit sweep models/mass_on_car.yaml --vary alpha=0deg:90deg:91 "
      "--vary d=0:2:21 --out sweep-out");
  sweep
      ->add_option("MODEL", arguments->model_path,
                   "Model file (YAML; `kind: linear` for a large sparse linear model)")
      ->required();
  sweep
      ->add_option("--vary", arguments->vary,
                   "A varied parameter: name=a:b:n (n values from a to b), name=a:b:n=N, "
                   "name=a:b:step=h or name=v1,v2,...")
      ->required();
  sweep->add_option("--out", arguments->out, "Output directory")->required();
  sweep
      ->add_option("--format", arguments->format,
                   "Files of the tables: csv (points.csv, eigenvalues.csv), hdf5 (sweep.h5) or "
                   "mat (sweep.mat, MAT 5)")
      ->capture_default_str();
  sweep->add_option("--threads", arguments->threads,
                    "Threads, at most " + std::to_string(api::DefaultSweepSettings().max_threads) +
                        " and never more than the points (default: all cores, or "
                        "OMP_NUM_THREADS, which must not ask for more; under mpirun, per rank: "
                        "the cores of its machine shared among its ranks)");
  sweep
      ->add_option("--block-size", arguments->block_size,
                   "Points per block, at most " +
                       std::to_string(api::DefaultSweepSettings().max_block_size) +
                       ": computed in parallel, then written; under mpirun block b goes to "
                       "rank b mod K. The files do not depend on it")
      ->capture_default_str();
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
      ->add_option("--rank-tolerance", arguments->rank_tolerance,
                   "Relative tolerance of rank decisions (P, Markov parameters)")
      ->capture_default_str();
  sweep
      ->add_option("--axis-tolerance", arguments->imaginary_axis_tolerance,
                   "Damping ratio |Re lambda|/|lambda| at or below which an eigenvalue is on the "
                   "imaginary axis")
      ->capture_default_str();
  AddLinearModelOptions(*sweep, arguments->linear, "zeros per point");
  return {sweep, [arguments, sweep](std::ostream& out, std::ostream& err) {
            return RunSweepCommand(*arguments, *sweep, out, err);
          }};
}

}  // namespace servokit
