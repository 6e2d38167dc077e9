#include "analysis/sweep.h"

#include <omp.h>

#include <algorithm>
#include <charconv>
#include <cstddef>
#include <exception>
#include <memory>
#include <string>
#include <vector>

#include "models/errors.h"
#include "models/option_check.h"

namespace servokit {
namespace {

// Points a thread takes from the block at a time. Dynamic scheduling, because a point where
// Newton struggles (or fails after its 50 iterations) costs many times an easy one; 16 points
// (microseconds even for the mass on car) make taking a chunk, one atomic increment, cheap.
constexpr std::size_t kPointsPerChunk = 16;
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
  RequireOption(options.block_size >= 1, "SweepOptions", "block_size", options.block_size,
                "must be >= 1");
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
  return options.threads > 0 ? options.threads : omp_get_max_threads();
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

std::size_t RunSweep(const LoadedModel& model,
                     const ParameterGrid& grid,
                     const SweepOptions& options,
                     std::size_t first_point,
                     SweepWorkspaces& workspaces,
                     const SweepConsumer& consume) {
  ValidateOptions(model, options);
  const std::size_t total = grid.num_points();
  if (first_point >= total) return total;
  const std::size_t chunk = model.linear() ? kLinearPointsPerChunk : kPointsPerChunk;
  std::vector<SweepPoint> block(std::min(options.block_size, total - first_point));
  for (std::size_t first = first_point; first < total;) {
    const std::size_t count = std::min(block.size(), total - first);
    const std::span<SweepPoint> points(block.data(), count);
    // Each workspace's parameters start from the model's (with the --set overrides) and the
    // grid overwrites only the varied entries.
    ParallelFor(count, workspaces.threads(), chunk, [&](std::size_t i, int thread) {
      PointWorkspace& workspace = workspaces[thread];
      grid.Apply(first + i, workspace.parameters());
      points[i] = AnalyzeSweepPoint(model, workspace, options);
    });
    first += count;
    if (!consume(first - count, points)) return first;
  }
  return total;
}

std::size_t RunSweep(const LoadedModel& model,
                     const ParameterGrid& grid,
                     const SweepOptions& options,
                     std::size_t first_point,
                     const SweepConsumer& consume) {
  ValidateOptions(model, options);
  SweepWorkspaces workspaces(model, SweepThreads(options));
  return RunSweep(model, grid, options, first_point, workspaces, consume);
}

std::string DescribeLinearSweepOptions(const LinearAnalysisOptions& options) {
  const LinearZeroDynamicsOptions& zeros = options.zero_dynamics;
  auto exact = [](double value) {
    char buffer[64];
    const auto result = std::to_chars(buffer, buffer + sizeof buffer, value);
    return std::string(buffer, result.ptr);
  };
  return "rank_tolerance=" + exact(options.rank_tolerance) +
         ",axis_tolerance=" + exact(zeros.imaginary_axis_tolerance) +
         ",eigen_solver=" + std::string(ToString(zeros.solver)) +
         ",which=" + std::string(ToString(zeros.target)) + ",shift=" + exact(zeros.shift) +
         ",eigenvalues=" + std::to_string(zeros.arpack.eigenvalues) +
         ",dense_threshold=" + std::to_string(zeros.dense_threshold);
}

}  // namespace servokit
