// servokit sweep MODEL --vary p=a:b:n | p=v1,v2,... [--vary ...] --out DIR [--threads N]
//                [--format csv|hdf5|mat]
//                [--set p=v]... [--y0 v]... [--q0 v]... [--rank-tolerance r] [--axis-tolerance a]
//                [--checkpoint-interval s] [--block-size n]
//                [--eigenvalues K] [--shift S] [--eigen-solver auto|dense|arpack]
//                [--which nearest|rightmost]            (linear models only)
// A model of either kind (modeling/loaded_model.h) is swept by analysis/sweep.h: one workspace per
// thread, kept across blocks (a linear model's sparsity pattern is analysed once per thread).
// Under mpirun (application/mpi_sweep.h) every rank runs this command: each sets the sweep up,
// rank 0 alone opens the output directory, and the blocks are shared out.
#include <omp.h>
#include <signal.h>

#include <algorithm>
#include <charconv>
#include <chrono>
#include <csignal>
#include <cstdlib>
#include <cstring>
#include <exception>
#include <memory>
#include <optional>
#include <ostream>
#include <string>
#include <thread>
#include <vector>

#include "analysis/parameter_grid.h"
#include "analysis/sweep.h"
#include "application/commands.h"
#include "application/exit_codes.h"
#include "application/grid_arguments.h"
#include "application/mpi_sweep.h"
#include "application/progress.h"
#include "application/sweep_store.h"
#include "base/errors.h"
#include "base/number_format.h"
#include "modeling/linear_model.h"
#include "modeling/loaded_model.h"

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
  std::size_t block_size = kSweepBlockSize;
  std::vector<std::string> overrides;  // "name=value"
  std::vector<std::string> y0, q0;     // each may hold several values separated by commas
  ClassificationOptions options;
  // Seconds between checkpoints.
  double checkpoint_interval = kSweepCheckpointInterval.count();
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

// Threads per process of an MPI sweep without --threads: the cores this process may run on
// (OpenMP's count follows mpirun's binding) shared among the ranks on this machine, unless it is
// bound to fewer cores than the machine has (then they are its own); OMP_NUM_THREADS wins.
int DefaultThreadsPerProcess(const ProcessGroup& processes) {
  // 0: OpenMP's default, which SweepThreads() checks against kMaxSweepThreads.
  if (std::getenv("OMP_NUM_THREADS") != nullptr) return 0;
  const int available = omp_get_num_procs();
  const auto machine = static_cast<int>(std::thread::hardware_concurrency());
  if (available < machine) return std::max(available, 1);
  return std::max(available / std::max(processes.ranks_on_node, 1), 1);
}

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
                              const LoadedModel& model) {
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
    if (arguments.threads > kMaxSweepThreads) {
      throw UsageError("--threads " + std::to_string(arguments.threads) + ": must be at most " +
                       std::to_string(kMaxSweepThreads));
    }
    options.threads = arguments.threads;
  } else if (Processes().size > 1) {
    options.threads = DefaultThreadsPerProcess(Processes());
  }
  SweepThreads(options);  // OMP_NUM_THREADS too, before the output directory is made
  if (arguments.block_size < 1) throw UsageError("--block-size 0: must be at least 1");
  if (arguments.block_size > kMaxSweepBlockSize) {
    throw UsageError("--block-size " + std::to_string(arguments.block_size) + ": must be at most " +
                     std::to_string(kMaxSweepBlockSize));
  }
  options.block_size = arguments.block_size;
  // Before the output directory is touched: a bad option must not leave a half-made sweep.
  if (const Model* multibody = model.multibody()) options.classification.Validate(*multibody);
  return options;
}

// Everything a sweep needs before it touches the output directory; the same on every process.
struct SweepSetup {
  LoadedModel model;
  SweepModelInfo info;  // what the files record of it
  ParameterGrid grid;
  SweepOptions options;
  SweepOutputOptions output_options;
  SweepFileFormat format = SweepFileFormat::kCsv;
  TestHooks test_hooks;
  std::vector<std::string> warnings;  // of the --vary texts, printed by rank 0
};

SweepFileFormat ParseSweepFileFormat(const std::string& text) {
  const std::optional<SweepFileFormat> format = SweepFileFormatFromString(text);
  if (!format) throw UsageError("--format " + text + ": must be csv, hdf5 or mat");
  return *format;
}

SweepSetup MakeSweepSetup(const SweepArguments& arguments, const CLI::App& sweep) {
  if (Processes().size > 1 && !BuiltWithMpi()) {
    throw UsageError(
        "started by an MPI launcher with " + std::to_string(Processes().size) +
        " processes, but this servokit cannot run a distributed sweep: " + MpiUnavailableReason());
  }
  const std::vector<ParameterOverride> overrides = ParseOverrides(arguments.overrides);
  LoadedModel model = LoadModelFile(arguments.model_path, overrides);
  LinearAnalysisOptions linear_options;
  if (model.linear()) {
    linear_options = MakeLinearAnalysisOptions(arguments.linear, arguments.options,
                                               !arguments.y0.empty(), !arguments.q0.empty());
  } else {
    RefuseLinearModelOptions(sweep);
  }
  std::vector<std::string> warnings;
  ParameterGrid grid = ParseParameterGrid(
      {model.parameter_names(), model.parameter_display_units()}, arguments.vary, &warnings);
  RejectSetAndVary(overrides, grid);
  const SweepFileFormat format = ParseSweepFileFormat(arguments.format);
  CheckSweepFileColumns(format, grid);
  SweepOptions options = MakeSweepOptions(arguments, sweep, model);
  options.linear = linear_options;
  if (!(arguments.checkpoint_interval > 0.0)) {
    throw UsageError("--checkpoint-interval " + FormatShort(arguments.checkpoint_interval) +
                     ": must be > 0 seconds");
  }
  const SweepOutputOptions output_options = {
      std::chrono::duration<double>(arguments.checkpoint_interval)};
  SweepModelInfo info = DescribeSweepModel(model, options);
  return {std::move(model),
          std::move(info),
          std::move(grid),
          options,
          output_options,
          format,
          TestHooksFromEnvironment(),
          std::move(warnings)};
}

// Runs `step` on every process; a failure on any ends all of them (AgreeOnSuccess).
template <typename Step>
void OnEveryProcess(Step step) {
  std::exception_ptr failure;
  try {
    step();
  } catch (...) {
    failure = std::current_exception();
  }
  AgreeOnSuccess(failure);
}

// An MPI sweep's ranks must compute the same sweep: a rank that reads another model file (a
// different copy on its machine) or runs another servokit would mix two sweeps in one file.
void CheckSameSweepOnEveryProcess(const SweepSetup& setup) {
  if (Processes().size == 1) return;
  const std::string fingerprint =
      SweepFingerprint(setup.info, setup.grid, setup.options.classification, setup.format);
  OnEveryProcess([&] {
    if (BroadcastFromRoot(fingerprint) != fingerprint) {
      throw UsageError("this rank computes another sweep than rank 0 (" + fingerprint +
                       "): its model file or servokit differs");
    }
  });
}

// Computes points first_point.. and appends them to `output` (rank 0 only); returns the index
// after the last point written: the grid's size, or less when stopped on request.
std::size_t ComputeSweep(const SweepSetup& setup,
                         std::size_t first_point,
                         SweepOutput* output,
                         StopRequest& stop_requested,
                         std::ostream& err) {
  ProgressBar progress(err, setup.grid.num_points(), first_point, IsTerminalStderr(err));
  // The per-thread workspaces are kept across blocks (and, under MPI, across the blocks of this
  // rank), so each thread of a linear sweep analyses the sparsity pattern once.
  SweepWorkspaces workspaces(setup.model,
                             SweepThreads(setup.options, setup.grid.num_points() - first_point));
  const SweepRunner run = [&](std::size_t first, const SweepConsumer& consume) {
    return RunSweep(setup.model, setup.grid, setup.options, first, workspaces, consume);
  };
  if (Processes().size == 1) {
    // The threads format their own chunks as they compute them, and this thread only writes
    // finished blocks while they go on with the next ones. Binary records (sweep.h5, sweep.mat)
    // are cheap to write, and the writing thread of a sweep with one computing thread has time
    // to spare: it encodes them itself there (and decodes sweep.h5's rows from them); with two
    // computing threads or more they do both.
    const bool records = TableEncodingOf(setup.format) != TableEncoding::kCsv;
    const bool format_here = records && workspaces.threads() < 2;
    const TableEncoding encoding =
        format_here ? TableEncoding::kRecords : TableEncodingOf(setup.format);
    const std::size_t chunk_size = SweepChunkSize(setup.model);
    PipelinedBlockFormatter formatter(setup.grid, encoding, setup.options.block_size, chunk_size);
    return RunSweepPipeline(
        setup.model, setup.grid, setup.options, first_point, workspaces,
        [&](int slot, std::size_t chunk, std::size_t first, std::span<const SweepPoint> points) {
          if (!format_here) formatter.FormatChunk(slot, chunk, first, points);
        },
        [&](int slot, std::size_t first, std::span<const SweepPoint> block) {
          for (std::size_t begin = 0; format_here && begin < block.size(); begin += chunk_size) {
            formatter.FormatChunk(slot, begin / chunk_size, first + begin,
                                  block.subspan(begin, std::min(chunk_size, block.size() - begin)));
          }
          output->Append(formatter.Block(slot, first, block));
          progress.Update(first + block.size());
          return !stop_requested();
        });
  }
  return RunDistributedSweep(
             run, setup.grid, setup.options, first_point, TableEncodingOf(setup.format),
             [&](const FormattedBlock& block) {
               output->Append(block);
               progress.Update(block.first + block.points);
             },
             stop_requested)
      .done;
}

int RunSweepCommand(const SweepArguments& arguments,
                    const CLI::App& sweep,
                    std::ostream& out,
                    std::ostream& err) {
  std::optional<SweepSetup> setup;
  OnEveryProcess([&] { setup.emplace(MakeSweepSetup(arguments, sweep)); });
  // `err` of a rank other than 0 is a null stream (mpi_sweep.h): rank 0 alone warns.
  for (const std::string& warning : setup->warnings)
    err << "servokit: warning: " << warning << "\n";
  CheckSameSweepOnEveryProcess(*setup);
  const bool root = Processes().IsRoot();
  std::optional<SweepOutput> output;
  OnEveryProcess([&] {
    if (root) {
      output.emplace(arguments.out, setup->info, setup->grid, setup->options.classification,
                     CommandLine(sweep), setup->output_options, setup->format);
    }
  });
  const std::size_t total = setup->grid.num_points();
  const bool already_complete = BroadcastFromRoot(root && output->already_complete()) != 0;
  const std::size_t first_point = BroadcastFromRoot(root ? output->points_done() : 0);
  if (already_complete) {
    err << "servokit: " << arguments.out << " already holds this sweep, complete (" << total
        << " points); nothing to do\n";
    return static_cast<int>(ExitCode::kSuccess);
  }
  if (first_point > 0) {
    err << "servokit: resuming at point " << first_point << " of " << total << "\n";
  }
  // Held until the tables are finished: Ctrl-C while sweep.mat is built is honoured too (and
  // the stop test hook counts the table file's chunks after the blocks).
  const InterruptGuard interrupt;
  StopRequest stop_requested(interrupt, setup->test_hooks);
  const std::size_t done =
      ComputeSweep(*setup, first_point, output ? &*output : nullptr, stop_requested, err);
  if (!root) {
    return done < total ? kInterruptedExitStatus : static_cast<int>(ExitCode::kSuccess);
  }
  if (done < total) {
    output->Checkpoint();
    err << "servokit: error: interrupted at point " << done << " of " << total
        << "; run the same command again to resume\n";
    return kInterruptedExitStatus;
  }
  if (!output->Finish([&] { return stop_requested(); })) {
    output->Checkpoint();
    err << "servokit: error: interrupted while writing the tables (every point is done); run "
        << "the same command again to finish them\n";
    return kInterruptedExitStatus;
  }
  out << "swept " << total << " points of " << setup->info.name << " into " << arguments.out << " ("
      << SweepTableFileNames(setup->format) << ", sweep.json); "
      << output->points_without_solution() << " without a solution\n";
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
                    "Threads, at most " + std::to_string(kMaxSweepThreads) +
                        " and never more than the points (default: all cores, or "
                        "OMP_NUM_THREADS, which must not ask for more; under mpirun, per rank: "
                        "the cores of its machine shared among its ranks)");
  sweep
      ->add_option("--block-size", arguments->block_size,
                   "Points per block, at most " + std::to_string(kMaxSweepBlockSize) +
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
      ->add_option("--rank-tolerance", arguments->options.rank_tolerance,
                   "Relative tolerance of rank decisions (P, Markov parameters)")
      ->capture_default_str();
  sweep
      ->add_option("--axis-tolerance", arguments->options.imaginary_axis_tolerance,
                   "Damping ratio |Re lambda|/|lambda| at or below which an eigenvalue is on the "
                   "imaginary axis")
      ->capture_default_str();
  AddLinearModelOptions(*sweep, arguments->linear, "zeros per point");
  return {sweep, [arguments, sweep](std::ostream& out, std::ostream& err) {
            return RunSweepCommand(*arguments, *sweep, out, err);
          }};
}

}  // namespace servokit
