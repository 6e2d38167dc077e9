#pragma once
// The sweep engine (`servokit sweep`, docs/sweep.md): AnalyzeSweepPoint at every point of a
// ParameterGrid, for a model of either kind, on all cores, handed to a consumer block by block
// in index order.
//
// Points are evaluated in blocks by worker threads, and each finished block goes to the consumer
// on the calling thread, in index order, while the workers compute the next blocks (at most
// kSweepSlots blocks in flight). So the consumer sees the same points in the same order
// whatever the number of threads, and memory holds a few blocks, never the grid or all results.
// What the consumer does with a block (files, checkpoints) is not this layer's business.
#include <cstddef>
#include <functional>
#include <memory>
#include <span>
#include <string>
#include <vector>

#include "analysis/options.h"
#include "analysis/parameter_grid.h"
#include "analysis/sweep_point.h"
#include "modeling/loaded_model.h"

namespace servokit {

/// Points per block. Large enough that the threads stay busy between the consumer's calls
/// (4096 points take 4 ms for the mass on car, 0.15 s for the six-mass chain, on two cores),
/// small enough that a block in memory is a few MB and an interrupted sweep stops within a
/// fraction of a second.
inline constexpr std::size_t kSweepBlockSize = 4096;

/// The largest block_size: 16 times the default. Blocks beyond the default gain nothing (the
/// threads are busy already), while memory grows with them: kSweepSlots blocks of points and
/// their formatted rows, 0.55 kB a point for the mass on car (0.3 GB at this size, measured;
/// 4e9 took 7.8 GB for 3 points).
inline constexpr std::size_t kMaxSweepBlockSize = 65536;

/// The most threads a sweep runs (threads, or OpenMP's default from OMP_NUM_THREADS): more than
/// the hardware threads of any one machine servokit runs on, so that it never limits a real
/// run, while each thread's stack and workspace stay affordable; libgomp crashed at 100000.
inline constexpr int kMaxSweepThreads = 1024;

/// How each point is analysed (AnalysisOptions: the options of the model's kind; the QZ
/// cross-check of a multibody model is never run in a sweep, SweepPoint), and how the sweep runs.
struct SweepOptions : AnalysisOptions {
  // Threads to use, at most kMaxSweepThreads; 0 means OpenMP's default (all cores, or
  // OMP_NUM_THREADS).
  int threads = 0;
  // Points per block handed to the consumer (1 .. kMaxSweepBlockSize); the results do not
  // depend on it.
  std::size_t block_size = kSweepBlockSize;
};

/// Receives the results of points first, first + 1, ..., first + block.size() - 1, in order.
/// Returns false to stop the sweep after this block (an interrupt).
using SweepConsumer = std::function<bool(std::size_t first, std::span<const SweepPoint> block)>;

/// The number of threads RunSweep uses for `options`: threads, or for threads = 0 OpenMP's
/// default, at most kMaxSweepThreads. Throws UsageError naming OMP_NUM_THREADS when that asks
/// for more.
int SweepThreads(const SweepOptions& options);

/// The same for a sweep of `points` points: no more threads than points (at least one).
int SweepThreads(const SweepOptions& options, std::size_t points);

/// Runs body(i, thread) for every i in [0, count) on `threads` threads (OpenMP, dynamic
/// schedule, `chunk` consecutive indices at a time); `thread` is in [0, threads) and no two
/// bodies run with the same one at once, so it can index per-thread buffers. An exception must
/// not leave an OpenMP region: the first one a body throws is rethrown once all have run.
void ParallelFor(std::size_t count,
                 int threads,
                 std::size_t chunk,
                 const std::function<void(std::size_t i, int thread)>& body);

/// The workspaces of a sweep, one per thread (PointWorkspace), each built by the thread that
/// uses it. Kept across the calls of RunSweep that an MPI rank makes for its blocks, so that a
/// thread of a linear sweep analyses the sparsity pattern once.
class SweepWorkspaces {
 public:
  /// `threads` (at least one) workspaces for `model`.
  SweepWorkspaces(const LoadedModel& model, int threads);
  int threads() const { return static_cast<int>(workspaces_.size()); }
  PointWorkspace& operator[](int thread) { return *workspaces_[static_cast<std::size_t>(thread)]; }
  /// Pattern analyses (symbolic factorisations) done by each thread's workspace so far.
  std::vector<int> pattern_analyses() const;

 private:
  std::vector<std::unique_ptr<PointWorkspace>> workspaces_;
};

/// Analyses grid points first_point .. grid.num_points() - 1 of `model` (with the model's own
/// parameters where the grid does not vary them) with `workspaces` (built for `model`) and hands
/// them to `consume` block by block, on the calling thread. Returns the index after the last
/// point consumed: grid.num_points(), or less when the consumer stopped. A point without a
/// solution is recorded in its SweepPoint and the sweep goes on. Throws UsageError for bad
/// options (before any point is evaluated) and rethrows whatever the consumer or an evaluation
/// throws otherwise, after the running block.
std::size_t RunSweep(const LoadedModel& model,
                     const ParameterGrid& grid,
                     const SweepOptions& options,
                     std::size_t first_point,
                     SweepWorkspaces& workspaces,
                     const SweepConsumer& consume);

/// Points per chunk: a computing thread takes this many consecutive points at a time (and hands
/// them to a SweepChunkPreparer together). Depends only on the model's kind.
std::size_t SweepChunkSize(const LoadedModel& model);

/// Blocks a pipelined sweep keeps in flight (computed or being computed, not yet consumed): the
/// threads compute the next ones while the consumer handles block b. Eight, not two or three:
/// on a machine shared with other work the consumer's thread is sometimes not scheduled for a
/// while, and the workers must not stop for it (with three, two threads beside a busy process
/// were no faster than one on the mass on car; with eight, 1.3 times).
inline constexpr int kSweepSlots = 8;

/// Called on a computing thread for chunk `chunk` (its index within its block) of the block in
/// slot `slot` (< kSweepSlots), once its points first, first + 1, ... are analysed. Chunks of
/// one block run at the same time on different threads: it may write only what belongs to
/// (slot, chunk), e.g. format the rows of its points into the chunk's own buffer.
using SweepChunkPreparer = std::function<void(
    int slot, std::size_t chunk, std::size_t first, std::span<const SweepPoint> points)>;

/// Receives block first, first + 1, ... from slot `slot` once all its chunks were prepared, on
/// the calling thread and in index order. Returns false to stop the sweep after this block.
using SweepSlotConsumer =
    std::function<bool(int slot, std::size_t first, std::span<const SweepPoint> block)>;

/// RunSweep as a pipeline, for a consumer with work that threads can share. Worker threads
/// (one per workspace) take chunks in index order, analyse and `prepare` them, while the
/// calling thread consumes finished blocks in order: computing, preparing and consuming overlap,
/// with no barrier between blocks, and a thread with nothing to do sleeps (it never spins, so
/// threads do not slow down a machine shared with other work). The consumer sees exactly the
/// points and order RunSweep gives, whatever the number of threads. Exceptions as RunSweep: one
/// thrown by an evaluation or by `prepare` is rethrown after the blocks before its own were
/// consumed.
std::size_t RunSweepPipeline(const LoadedModel& model,
                             const ParameterGrid& grid,
                             const SweepOptions& options,
                             std::size_t first_point,
                             SweepWorkspaces& workspaces,
                             const SweepChunkPreparer& prepare,
                             const SweepSlotConsumer& consume);

/// The same with workspaces of its own (SweepThreads of the options).
std::size_t RunSweep(const LoadedModel& model,
                     const ParameterGrid& grid,
                     const SweepOptions& options,
                     std::size_t first_point,
                     const SweepConsumer& consume);

/// The options that decide a linear sweep's points, as one line, for fingerprints and sweep.json.
std::string DescribeLinearSweepOptions(const LinearAnalysisOptions& options);

}  // namespace servokit
