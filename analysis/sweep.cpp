#include "analysis/sweep.h"

#include <omp.h>

#include <algorithm>
#include <array>
#include <condition_variable>
#include <cstddef>
#include <cstdlib>
#include <exception>
#include <limits>
#include <memory>
#include <mutex>
#include <string>
#include <thread>
#include <vector>

#include "base/errors.h"
#include "base/number_format.h"
#include "base/option_check.h"

namespace servokit {
namespace {

// Points a thread takes from the block at a time (and formats together). Dynamic scheduling,
// because a point where Newton struggles (or fails after its 50 iterations) costs many times an
// easy one; 256 points (some 80 microseconds for the mass on car, whose points cost 0.3 us) make
// taking a chunk, two short locked sections, and handing its rows over cheap: with 64, once its
// points had become that cheap, two threads on the rotational arm spent 30 % more CPU than one
// and were 1.35 times as fast instead of 1.6 (with 16, the mass on car 1.3 instead of 1.6).
constexpr std::size_t kPointsPerChunk = 256;
// A point of a large linear model costs milliseconds, so one at a time.
constexpr std::size_t kLinearPointsPerChunk = 1;

void ValidateOptions(const LoadedModel& model, const SweepOptions& options) {
  if (const Model* multibody = model.multibody()) {
    options.classification.Validate(*multibody);
  } else {
    options.linear.Validate();
  }
  RequireOption(options.threads >= 0, "SweepOptions", "threads", options.threads,
                "must be >= 0 (0: all cores)");
  RequireOption(options.threads <= kMaxSweepThreads, "SweepOptions", "threads", options.threads,
                "must be <= " + std::to_string(kMaxSweepThreads));
  RequireOption(options.block_size >= 1, "SweepOptions", "block_size", options.block_size,
                "must be >= 1");
  RequireOption(options.block_size <= kMaxSweepBlockSize, "SweepOptions", "block_size",
                options.block_size, "must be <= " + std::to_string(kMaxSweepBlockSize));
}

// Keeps the first exception thrown in an OpenMP region, to rethrow after it: an exception must
// not leave the region (it would terminate the program).
class FirstException {
 public:
  void Capture() {
#pragma omp critical(servokit_first_exception)
    if (!exception_) exception_ = std::current_exception();
  }
  void RethrowIfAny() const {
    if (exception_) std::rethrow_exception(exception_);
  }

 private:
  std::exception_ptr exception_;
};

}  // namespace

// Each workspace is built by the thread that uses it: its buffers then come from that thread's
// heap arena. Built on one thread, the small buffers of different workspaces share cache lines,
// and threads writing them slow each other down (measured on the mass on car: two threads 1.2
// times as fast as one that way, 1.55 times this way).
SweepWorkspaces::SweepWorkspaces(const LoadedModel& model, int threads)
    : workspaces_(static_cast<std::size_t>(std::max(threads, 1))) {
  FirstException failure;
#pragma omp parallel num_threads(static_cast <int>(workspaces_.size()))
  {
    try {
      workspaces_[static_cast<std::size_t>(omp_get_thread_num())] =
          std::make_unique<PointWorkspace>(model);
    } catch (...) {
      failure.Capture();
    }
  }
  failure.RethrowIfAny();
  // OpenMP may give a team smaller than asked; later loops then use fewer workspaces too, but
  // every slot must hold one.
  for (auto& workspace : workspaces_) {
    if (!workspace) workspace = std::make_unique<PointWorkspace>(model);
  }
}

std::vector<int> SweepWorkspaces::pattern_analyses() const {
  std::vector<int> counts;
  for (const auto& workspace : workspaces_) counts.push_back(workspace->pattern_analyses());
  return counts;
}

int SweepThreads(const SweepOptions& options) {
  if (options.threads > 0) return std::min(options.threads, kMaxSweepThreads);
  const int threads = omp_get_max_threads();
  if (threads <= kMaxSweepThreads) return threads;
  // Above the limit only when asked for: a machine with more cores than that gets the limit.
  if (const char* variable = std::getenv("OMP_NUM_THREADS")) {
    throw UsageError("OMP_NUM_THREADS=" + std::string(variable) + ": " + std::to_string(threads) +
                     " threads: must be at most " + std::to_string(kMaxSweepThreads));
  }
  return kMaxSweepThreads;
}

int SweepThreads(const SweepOptions& options, std::size_t points) {
  const int threads = SweepThreads(options);
  return static_cast<int>(
      std::min<std::size_t>(static_cast<std::size_t>(threads), std::max<std::size_t>(points, 1)));
}

void ParallelFor(std::size_t count,
                 int threads,
                 std::size_t chunk,
                 const std::function<void(std::size_t i, int thread)>& body) {
  FirstException failure;
  const auto end = static_cast<std::ptrdiff_t>(count);
  const auto chunk_size = static_cast<int>(chunk);
#pragma omp parallel for num_threads(threads) schedule(dynamic, chunk_size)
  for (std::ptrdiff_t i = 0; i < end; ++i) {
    try {
      body(static_cast<std::size_t>(i), omp_get_thread_num());
    } catch (...) {
      failure.Capture();
    }
  }
  failure.RethrowIfAny();
}

std::size_t SweepChunkSize(const LoadedModel& model) {
  return model.linear() ? kLinearPointsPerChunk : kPointsPerChunk;
}

namespace {

// The state RunSweepPipeline's threads share. Blocks are numbered from the sweep's first point;
// block b lives in slot b % kSweepSlots, which it may take only once block b - kSweepSlots was
// consumed. Everything but the points themselves is guarded by `mutex`: a chunk is taken and
// finished under it (two short critical sections per chunk of 256 points, against tens of
// microseconds of analysis), and the points of a chunk are written by the one thread that took it.
class SweepPipeline {
 public:
  SweepPipeline(const LoadedModel& model,
                const ParameterGrid& grid,
                const SweepOptions& options,
                std::size_t first_point,
                SweepWorkspaces& workspaces,
                const SweepChunkPreparer& prepare)
      : model_(model),
        grid_(grid),
        options_(options),
        workspaces_(workspaces),
        prepare_(prepare),
        first_point_(first_point),
        total_(grid.num_points()),
        block_size_(options.block_size),
        chunk_size_(SweepChunkSize(model)),
        block_count_((total_ - first_point + block_size_ - 1) / block_size_) {
    for (Slot& slot : slots_) slot.points.resize(std::min(block_size_, total_ - first_point));
  }

  ~SweepPipeline() { StopAndJoin(); }

  void Start() {
    for (int thread = 0; thread < workspaces_.threads(); ++thread) {
      threads_.emplace_back([this, thread] { Work(thread); });
    }
  }

  std::size_t BlockCount() const { return block_count_; }
  std::size_t BlockFirst(std::size_t block) const { return first_point_ + block * block_size_; }
  std::size_t BlockPoints(std::size_t block) const {
    return std::min(block_size_, total_ - BlockFirst(block));
  }

  // Waits until block `block` is complete and returns its points; rethrows (after stopping the
  // workers) an exception of this block or an earlier one.
  std::span<const SweepPoint> WaitForBlock(std::size_t block) {
    Slot& slot = slots_[block % kSweepSlots];
    std::unique_lock lock(mutex_);
    block_done_.wait(lock, [&] {
      return failed_block_ <= block || (slot.block == block && slot.chunks_left == 0);
    });
    if (failed_block_ <= block) {
      const std::exception_ptr failure = failure_;
      lock.unlock();
      StopAndJoin();
      std::rethrow_exception(failure);
    }
    return {slot.points.data(), BlockPoints(block)};
  }

  // Frees the slot of `block`, consumed.
  void Release(std::size_t block) {
    {
      const std::lock_guard lock(mutex_);
      consumed_blocks_ = block + 1;
    }
    slot_free_.notify_all();
  }

  void StopAndJoin() {
    {
      const std::lock_guard lock(mutex_);
      stopped_ = true;
    }
    slot_free_.notify_all();
    for (std::thread& thread : threads_) {
      if (thread.joinable()) thread.join();
    }
    threads_.clear();
  }

 private:
  struct Slot {
    std::vector<SweepPoint> points;
    std::size_t block = std::numeric_limits<std::size_t>::max();  // the block it holds
    std::size_t chunks_left = 0;  // chunks of that block not yet finished
  };

  std::size_t ChunkCount(std::size_t block) const {
    return (BlockPoints(block) + chunk_size_ - 1) / chunk_size_;
  }

  void Work(int thread) {
    PointWorkspace& workspace = workspaces_[thread];
    for (;;) {
      std::size_t block = 0, chunk = 0;
      {
        std::unique_lock lock(mutex_);
        slot_free_.wait(lock, [&] {
          return stopped_ || next_block_ >= block_count_ ||
                 next_block_ < consumed_blocks_ + kSweepSlots;
        });
        if (stopped_ || next_block_ >= block_count_ || next_block_ >= failed_block_) return;
        block = next_block_;
        chunk = next_chunk_;
        if (chunk == 0) {
          Slot& slot = slots_[block % kSweepSlots];
          slot.block = block;
          slot.chunks_left = ChunkCount(block);
        }
        if (++next_chunk_ == ChunkCount(block)) {
          ++next_block_;
          next_chunk_ = 0;
        }
      }
      Slot& slot = slots_[block % kSweepSlots];
      const std::size_t begin = chunk * chunk_size_;
      const std::size_t count = std::min(chunk_size_, BlockPoints(block) - begin);
      const std::size_t first = BlockFirst(block) + begin;
      std::exception_ptr failure;
      try {
        // Each workspace's parameters start from the model's (with the --set overrides) and the
        // grid overwrites only the varied entries.
        for (std::size_t i = 0; i < count; ++i) {
          grid_.Apply(first + i, workspace.parameters());
          AnalyzeSweepPointInto(model_, workspace, options_, slot.points[begin + i]);
        }
        if (prepare_) {
          prepare_(static_cast<int>(block % kSweepSlots), chunk, first,
                   std::span<const SweepPoint>(slot.points.data() + begin, count));
        }
      } catch (...) {
        failure = std::current_exception();
      }
      bool block_finished = false;
      {
        const std::lock_guard lock(mutex_);
        if (failure && block < failed_block_) {
          failed_block_ = block;
          failure_ = failure;
        }
        block_finished = --slot.chunks_left == 0;
      }
      if (block_finished || failure) block_done_.notify_one();
    }
  }

  const LoadedModel& model_;
  const ParameterGrid& grid_;
  const SweepOptions& options_;
  SweepWorkspaces& workspaces_;
  const SweepChunkPreparer& prepare_;
  const std::size_t first_point_, total_, block_size_, chunk_size_, block_count_;
  std::array<Slot, kSweepSlots> slots_;
  std::vector<std::thread> threads_;

  std::mutex mutex_;
  std::condition_variable slot_free_;            // a slot was freed, or the sweep stops
  std::condition_variable block_done_;           // a block was finished, or a chunk failed
  std::size_t next_block_ = 0, next_chunk_ = 0;  // the next chunk to take
  std::size_t consumed_blocks_ = 0;
  bool stopped_ = false;
  std::size_t failed_block_ = std::numeric_limits<std::size_t>::max();  // earliest failure
  std::exception_ptr failure_;
};

}  // namespace

std::size_t RunSweepPipeline(const LoadedModel& model,
                             const ParameterGrid& grid,
                             const SweepOptions& options,
                             std::size_t first_point,
                             SweepWorkspaces& workspaces,
                             const SweepChunkPreparer& prepare,
                             const SweepSlotConsumer& consume) {
  ValidateOptions(model, options);
  const std::size_t total = grid.num_points();
  if (first_point >= total) return total;
  SweepPipeline pipeline(model, grid, options, first_point, workspaces, prepare);
  pipeline.Start();
  for (std::size_t block = 0; block < pipeline.BlockCount(); ++block) {
    const std::span<const SweepPoint> points = pipeline.WaitForBlock(block);
    const std::size_t first = pipeline.BlockFirst(block);
    // An exception of the consumer leaves through the pipeline's destructor, which stops and
    // joins the workers.
    if (!consume(static_cast<int>(block % kSweepSlots), first, points)) {
      return first + points.size();
    }
    pipeline.Release(block);
  }
  return total;
}

std::size_t RunSweep(const LoadedModel& model,
                     const ParameterGrid& grid,
                     const SweepOptions& options,
                     std::size_t first_point,
                     SweepWorkspaces& workspaces,
                     const SweepConsumer& consume) {
  return RunSweepPipeline(model, grid, options, first_point, workspaces, {},
                          [&](int, std::size_t first, std::span<const SweepPoint> block) {
                            return consume(first, block);
                          });
}

std::size_t RunSweep(const LoadedModel& model,
                     const ParameterGrid& grid,
                     const SweepOptions& options,
                     std::size_t first_point,
                     const SweepConsumer& consume) {
  ValidateOptions(model, options);
  const std::size_t points = grid.num_points() - std::min(first_point, grid.num_points());
  SweepWorkspaces workspaces(model, SweepThreads(options, points));
  return RunSweep(model, grid, options, first_point, workspaces, consume);
}

std::string DescribeLinearSweepOptions(const LinearAnalysisOptions& options) {
  const LinearZeroDynamicsOptions& zeros = options.zero_dynamics;
  return "rank_tolerance=" + FormatShortest(options.rank_tolerance) +
         ",axis_tolerance=" + FormatShortest(zeros.imaginary_axis_tolerance) +
         ",eigen_solver=" + std::string(ToString(zeros.solver)) +
         ",which=" + std::string(ToString(zeros.target)) + ",shift=" + FormatShortest(zeros.shift) +
         ",eigenvalues=" + std::to_string(zeros.arpack.eigenvalues) +
         ",dense_threshold=" + std::to_string(zeros.dense_threshold);
}

}  // namespace servokit
