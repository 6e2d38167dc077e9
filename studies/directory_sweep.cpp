#include "studies/directory_sweep.h"

#include <omp.h>

#include <algorithm>
#include <cstdlib>
#include <exception>
#include <span>
#include <thread>
#include <utility>

#include "base/errors.h"
#include "reports/sweep_records.h"
#include "studies/distributed_sweep.h"

namespace servokit {
namespace {

// Threads per process of an MPI sweep without a thread count: the cores this process may run on
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

// An MPI sweep's ranks must compute the same sweep: a rank that reads another model file (a
// different copy on its machine) or runs another servokit would mix two sweeps in one file.
void CheckSameSweepOnEveryProcess(const std::string& fingerprint) {
  if (Processes().size == 1) return;
  OnEveryProcess([&] {
    if (BroadcastFromRoot(fingerprint) != fingerprint) {
      throw UsageError("this rank computes another sweep than rank 0 (" + fingerprint +
                       "): its model file or servokit differs");
    }
  });
}

}  // namespace

DirectorySweep::DirectorySweep(const LoadedModel& model,
                               ParameterGrid grid,
                               SweepOptions options,
                               SweepFileFormat format,
                               SweepOutputOptions output_options,
                               std::vector<std::string> command_line)
    : model_(model),
      grid_(std::move(grid)),
      options_(std::move(options)),
      format_(format),
      output_options_(output_options),
      command_line_(std::move(command_line)) {
  OnEveryProcess([&] {
    if (Processes().size > 1 && !BuiltWithMpi()) {
      throw UsageError("started by an MPI launcher with " + std::to_string(Processes().size) +
                       " processes, but this servokit cannot run a distributed sweep: " +
                       MpiUnavailableReason());
    }
    CheckSweepFileColumns(format_, grid_, output_options_.format_label);
    if (options_.threads == 0 && Processes().size > 1) {
      options_.threads = DefaultThreadsPerProcess(Processes());
    }
    SweepThreads(options_);  // OMP_NUM_THREADS too, before the output directory is made
    // Before the output directory is touched: a bad option must not leave a half-made sweep.
    if (const Model* multibody = model_.multibody()) options_.classification.Validate(*multibody);
    info_ = DescribeSweepModel(model_, options_);
  });
  CheckSameSweepOnEveryProcess(SweepFingerprint(info_, grid_, options_.classification, format_));
}

DirectorySweep::~DirectorySweep() = default;

void DirectorySweep::Open(const std::filesystem::path& directory) {
  const bool root = Processes().IsRoot();
  OnEveryProcess([&] {
    if (root) {
      output_.emplace(directory, info_, grid_, options_.classification, command_line_,
                      output_options_, format_);
    }
  });
  already_complete_ = BroadcastFromRoot(root && output_->already_complete()) != 0;
  first_point_ = BroadcastFromRoot(root ? output_->points_done() : 0);
  points_done_ = first_point_;
}

std::size_t DirectorySweep::points_without_solution() const {
  return output_ ? output_->points_without_solution() : 0;
}

// Computes points first_point_.. and appends them to the output (rank 0 only); returns the index
// after the last point written: the grid's size, or less when stopped on request.
std::size_t DirectorySweep::Compute(const std::function<bool()>& stop_requested,
                                    const std::function<void(std::size_t)>& progress) {
  const auto report = [&](std::size_t done) {
    if (progress) progress(done);
  };
  // The per-thread workspaces are kept across blocks (and, under MPI, across the blocks of this
  // rank), so each thread of a linear sweep analyses the sparsity pattern once.
  SweepWorkspaces workspaces(model_, SweepThreads(options_, grid_.num_points() - first_point_));
  if (Processes().size == 1) {
    // The threads format their own chunks as they compute them, and this thread only writes
    // finished blocks while they go on with the next ones. Binary records (sweep.h5, sweep.mat)
    // are cheap to write, and the writing thread of a sweep with one computing thread has time
    // to spare: it encodes them itself there (and decodes sweep.h5's rows from them); with two
    // computing threads or more they do both.
    const bool records = TableEncodingOf(format_) != TableEncoding::kCsv;
    const bool format_here = records && workspaces.threads() < 2;
    const TableEncoding encoding = format_here ? TableEncoding::kRecords : TableEncodingOf(format_);
    const std::size_t chunk_size = SweepChunkSize(model_);
    PipelinedBlockFormatter formatter(grid_, encoding, options_.block_size, chunk_size);
    return RunSweepPipeline(
        model_, grid_, options_, first_point_, workspaces,
        [&](int slot, std::size_t chunk, std::size_t first, std::span<const SweepPoint> points) {
          if (!format_here) formatter.FormatChunk(slot, chunk, first, points);
        },
        [&](int slot, std::size_t first, std::span<const SweepPoint> block) {
          for (std::size_t begin = 0; format_here && begin < block.size(); begin += chunk_size) {
            formatter.FormatChunk(slot, begin / chunk_size, first + begin,
                                  block.subspan(begin, std::min(chunk_size, block.size() - begin)));
          }
          output_->Append(formatter.Block(slot, first, block));
          report(first + block.size());
          return !(stop_requested && stop_requested());
        });
  }
  const SweepRunner run = [&](std::size_t first, const SweepConsumer& consume) {
    return RunSweep(model_, grid_, options_, first, workspaces, consume);
  };
  return RunDistributedSweep(
             run, grid_, options_, first_point_, TableEncodingOf(format_),
             [&](const FormattedBlock& block) {
               output_->Append(block);
               report(block.first + block.points);
             },
             [&] { return stop_requested && stop_requested(); })
      .done;
}

DirectorySweepEnd DirectorySweep::Run(const std::function<bool()>& stop_requested,
                                      const std::function<void(std::size_t)>& progress) {
  if (already_complete_) {
    points_done_ = grid_.num_points();
    return DirectorySweepEnd::kFinished;
  }
  points_done_ = Compute(stop_requested, progress);
  if (!output_) {
    return points_done_ < grid_.num_points() ? DirectorySweepEnd::kStopped
                                             : DirectorySweepEnd::kFinished;
  }
  if (points_done_ < grid_.num_points()) {
    output_->Checkpoint();
    return DirectorySweepEnd::kStopped;
  }
  if (!output_->Finish([&] { return stop_requested && stop_requested(); })) {
    output_->Checkpoint();
    return DirectorySweepEnd::kStoppedInTables;
  }
  return DirectorySweepEnd::kFinished;
}

}  // namespace servokit
