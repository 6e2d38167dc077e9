#include "analysis/linear_sweep.h"

#include <omp.h>

#include <algorithm>
#include <charconv>
#include <cstddef>
#include <limits>
#include <mutex>
#include <optional>
#include <string_view>

#include "analysis/linear_zero_dynamics.h"
#include "models/errors.h"
#include "models/units.h"

namespace servokit {
namespace {

// Points a thread takes at a time: a point of a large model costs milliseconds, so one at a time.
constexpr std::size_t kLinearPointsPerChunk = 1;

// ARPACK (Fortran dnaupd/dneupd) keeps its state between calls in SAVE variables, so two threads
// in it at once corrupt each other (measured: wrong zeros and a segmentation fault on a
// 2000-mass chain with two threads). Points on the ARPACK route hold this lock for their
// analysis; assembling the matrices stays parallel. Separate processes (mpirun) do not share it.
std::mutex arpack_mutex;

bool UsesArpack(const LinearModel& model, const LinearAnalysisOptions& options) {
  const LinearZeroDynamicsOptions& zeros = options.zero_dynamics;
  return zeros.solver == LinearEigenSolver::kArpack ||
         (zeros.solver == LinearEigenSolver::kAuto &&
          static_cast<Eigen::Index>(model.dof()) > zeros.dense_threshold);
}

double MaxRealPart(const std::vector<std::complex<double>>& eigenvalues) {
  if (eigenvalues.empty()) return std::numeric_limits<double>::quiet_NaN();
  double largest = -std::numeric_limits<double>::infinity();
  for (const auto& value : eigenvalues) largest = std::max(largest, value.real());
  return largest;
}

void ValidateOptions(const LinearSweepOptions& options) {
  options.analysis.Validate();
  if (options.threads < 0) {
    throw UsageError("LinearSweepOptions::threads = " + std::to_string(options.threads) +
                     ": must be >= 0 (0: all cores)");
  }
  if (options.block_size < 1) {
    throw UsageError("LinearSweepOptions::block_size = 0: must be >= 1");
  }
}

}  // namespace

SweepPoint AnalyzeLinearSweepPoint(const LinearModel& model,
                                   const Eigen::VectorXd& parameters,
                                   LinearZeroDynamicsWorkspace& workspace,
                                   const LinearAnalysisOptions& options) {
  SweepPoint point;
  try {
    const LinearSystem system = AssembleLinearSystem(model, parameters);
    std::unique_lock<std::mutex> arpack_lock(arpack_mutex, std::defer_lock);
    if (UsesArpack(model, options)) arpack_lock.lock();
    const LinearAnalysis analysis = AnalyzeLinearSystem(system, workspace, options);
    if (arpack_lock.owns_lock()) arpack_lock.unlock();
    point.ok = true;
    point.realization = analysis.decoupling.realization;
    point.rank = static_cast<long>(analysis.decoupling.rank);
    point.relative_degree = analysis.relative_degrees.relative_degree;
    point.differentiation_index = analysis.differentiation_index;
    point.internal_dynamics_order = static_cast<int>(analysis.internal_dynamics_order);
    point.stability = analysis.zero_dynamics.stability;
    point.eigenvalues = analysis.zero_dynamics.eigenvalues;
    point.max_real_part = MaxRealPart(point.eigenvalues);
  } catch (const NoSolution& failure) {
    point = SweepPoint{};
    point.error = failure.what();
    std::replace(point.error.begin(), point.error.end(), '\n', ' ');
  } catch (const ModelError& failure) {
    // A factor that is not finite at this point (a division by a varied parameter at 0).
    point = SweepPoint{};
    point.error = failure.what();
    std::replace(point.error.begin(), point.error.end(), '\n', ' ');
  }
  return point;
}

LinearSweepWorkspaces::LinearSweepWorkspaces(int threads) {
  workspaces_.resize(static_cast<std::size_t>(std::max(threads, 1)));
  for (auto& workspace : workspaces_) {
    workspace = std::make_unique<LinearZeroDynamicsWorkspace>();
  }
}

std::vector<int> LinearSweepWorkspaces::pattern_analyses() const {
  std::vector<int> counts;
  for (const auto& workspace : workspaces_) counts.push_back(workspace->pattern_analyses());
  return counts;
}

std::size_t RunLinearSweep(const LinearModel& model,
                           const ParameterGrid& grid,
                           const LinearSweepOptions& options,
                           std::size_t first_point,
                           LinearSweepWorkspaces& workspaces,
                           const SweepConsumer& consume) {
  ValidateOptions(options);
  const std::size_t total = grid.num_points();
  if (first_point >= total) return total;
  // Each thread's parameters start from the model's (with --set) and the grid overwrites the
  // varied entries.
  std::vector<Eigen::VectorXd> parameters(static_cast<std::size_t>(workspaces.threads()),
                                          model.parameters());
  std::vector<SweepPoint> block(std::min(options.block_size, total - first_point));
  for (std::size_t first = first_point; first < total;) {
    const std::size_t count = std::min(block.size(), total - first);
    const std::span<SweepPoint> points(block.data(), count);
    ParallelFor(count, workspaces.threads(), kLinearPointsPerChunk, [&](std::size_t i, int thread) {
      Eigen::VectorXd& values = parameters[static_cast<std::size_t>(thread)];
      grid.Apply(first + i, values);
      points[i] = AnalyzeLinearSweepPoint(model, values, workspaces[thread], options.analysis);
    });
    first += count;
    if (!consume(first - count, points)) return first;
  }
  return total;
}

std::size_t RunLinearSweep(const LinearModel& model,
                           const ParameterGrid& grid,
                           const LinearSweepOptions& options,
                           std::size_t first_point,
                           const SweepConsumer& consume) {
  ValidateOptions(options);
  SweepOptions threads;
  threads.threads = options.threads;
  LinearSweepWorkspaces workspaces(SweepThreads(threads));
  return RunLinearSweep(model, grid, options, first_point, workspaces, consume);
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
