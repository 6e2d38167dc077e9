// Sweeps of a linear model (analysis/sweep.h) against the chain's closed form, and the
// reuse of the sparsity pattern: one pattern analysis per thread, not per point.
//
// Chain (GenerateChain): N masses, force and output at mass 1, M = m I, K = k T, D = d T. The
// zero dynamics are the chain beyond mass 1 held at rest (N' = N - 1 masses, fixed-free), so
// the zeros are the roots of m λ² + d μ_i λ + k μ_i = 0, μ_i = 4 sin²((2i − 1)π / (2(2N' + 1))),
// i = 1..N': 2N' zeros (docs/generate.md "Synopsis").
#include <catch2/catch.hpp>
#include <cmath>
#include <complex>
#include <cstdlib>
#include <filesystem>
#include <numbers>
#include <string>
#include <variant>
#include <vector>

#include "analysis/sweep.h"
#include "modeling/linear_model.h"
#include "modeling/model_generators.h"
#include "tests/analysis/grid_helpers.h"
#include "tests/chain_closed_form.h"

namespace servokit {
namespace {

constexpr double kMass = 2.0, kStiffness = 3.0;

LinearModel Chain(long masses) {
  ChainOptions options;
  options.masses = masses;
  options.mass = kMass;
  options.stiffness = kStiffness;
  const LinearModelFiles files = GenerateChain(options);
  const std::filesystem::path directory =
      std::filesystem::temp_directory_path() /
      ("servokit_lsweep_" + files.name + "_" + std::to_string(std::rand()));
  std::filesystem::create_directories(directory);
  LinearModel model = LoadLinearModel(WriteLinearModel(files, directory.string()));
  std::filesystem::remove_all(directory);
  return model;
}

double DistanceToNearest(std::complex<double> value, const std::vector<std::complex<double>>& set) {
  double best = INFINITY;
  for (const auto& other : set) best = std::min(best, std::abs(value - other));
  return best;
}

struct Collected {
  std::vector<SweepPoint> points;
  std::vector<std::size_t> firsts;
};

Collected Sweep(const LoadedModel& model,
                const ParameterGrid& grid,
                const SweepOptions& options,
                SweepWorkspaces& workspaces) {
  Collected collected;
  const std::size_t done =
      RunSweep(model, grid, options, 0, workspaces,
               [&](std::size_t first, std::span<const SweepPoint> block) {
                 collected.firsts.push_back(first);
                 collected.points.insert(collected.points.end(), block.begin(), block.end());
                 return true;
               });
  REQUIRE(done == grid.num_points());
  return collected;
}

}  // namespace

TEST_CASE("linear sweep: every zero of a 30-mass chain at each damping (dense route)",
          "[linear_sweep]") {
  const long masses = 30;
  const LinearModel model = Chain(masses);
  const ParameterGrid grid = ParameterGrid(
      std::vector<GridAxis>{testing::RangeAxis(model.parameter_names(), "d", 0.01, 0.1, 5)});
  REQUIRE(grid.num_points() == 5);
  SweepOptions options;
  options.threads = 1;
  options.block_size = 2;  // several blocks, one workspace across them
  const LoadedModel loaded(model);
  SweepWorkspaces workspaces(loaded, 1);
  const Collected result = Sweep(loaded, grid, options, workspaces);
  REQUIRE(result.points.size() == 5);
  CHECK(result.firsts == std::vector<std::size_t>{0, 2, 4});
  for (std::size_t p = 0; p < 5; ++p) {
    const double d = 0.01 + static_cast<double>(p) * (0.1 - 0.01) / 4.0;
    const SweepPoint& point = result.points[p];
    INFO("d = " << d);
    REQUIRE(point.ok);
    CHECK(point.realization == Realization::kIdealOrthogonal);
    CHECK(point.rank == 1);
    CHECK(point.relative_degree == std::vector<int>{2});
    CHECK(point.internal_dynamics_order == 2 * (masses - 1));
    CHECK(point.stability == Stability::kAsymptoticallyStable);
    const auto expected = testing::ChainZeros(masses, 1, kMass, kStiffness, d);
    REQUIRE(point.eigenvalues.size() == expected.size());
    double worst = 0.0;
    for (const auto& zero : expected) {
      worst = std::max(worst, DistanceToNearest(zero, point.eigenvalues) / std::abs(zero));
    }
    CHECK(worst < 1e-9);
    double max_real = -INFINITY;
    for (const auto& zero : expected) max_real = std::max(max_real, zero.real());
    CHECK(point.max_real_part == Approx(max_real).epsilon(1e-8));
  }
  // The sparsity pattern of the Rosenbrock matrix is analysed once for the five points.
  CHECK(workspaces.pattern_analyses() == std::vector<int>{1});
}

TEST_CASE(
    "linear sweep: ARPACK's zeros nearest 0 of a 2000-mass chain, one pattern analysis "
    "per thread",
    "[linear_sweep]") {
  const long masses = 2000;
  const LinearModel model = Chain(masses);
  const ParameterGrid grid = ParameterGrid(
      std::vector<GridAxis>{testing::RangeAxis(model.parameter_names(), "d", 0.01, 0.1, 6)});
  SweepOptions options;
  options.threads = 2;
  options.block_size = 3;
  options.linear.zero_dynamics.arpack.eigenvalues = 6;
  const LoadedModel loaded(model);
  SweepWorkspaces workspaces(loaded, 2);
  const Collected result = Sweep(loaded, grid, options, workspaces);
  REQUIRE(result.points.size() == 6);
  for (std::size_t p = 0; p < 6; ++p) {
    const double d = p == 5 ? 0.1 : 0.01 + static_cast<double>(p) * (0.1 - 0.01) / 5.0;
    INFO("d = " << d);
    const SweepPoint& point = result.points[p];
    INFO(point.error);
    REQUIRE(point.ok);
    REQUIRE(point.eigenvalues.size() == 6);
    // The six zeros nearest 0 are the three slowest pairs (i = 1, 2, 3).
    auto expected = testing::ChainZeros(masses, 1, kMass, kStiffness, d);
    expected.resize(6);
    for (const auto& zero : point.eigenvalues) {
      CHECK(DistanceToNearest(zero, expected) / std::abs(zero) < 1e-8);
    }
  }
  const std::vector<int> analyses = workspaces.pattern_analyses();
  int total = 0;
  for (const int count : analyses) {
    CHECK(count <= 1);  // never once per point
    total += count;
  }
  CHECK(total >= 1);
  CHECK(total <= 2);
}

TEST_CASE("AnalyzePoint analyses a linear model; a factor not finite is a recorded failure",
          "[linear_sweep]") {
  const long masses = 12;
  const LoadedModel model(Chain(masses));
  PointWorkspace workspace(model);
  const auto d = static_cast<Eigen::Index>(ParameterIndex(model.parameter_names(), "d"));
  const ModelAnalysis analysis = AnalyzePoint(model, workspace, {});
  const auto* linear = std::get_if<LinearAnalysis>(&analysis);
  REQUIRE(linear != nullptr);
  const auto expected = testing::ChainZeros(masses, 1, kMass, kStiffness, model.parameters()[d]);
  REQUIRE(linear->zero_dynamics.eigenvalues.size() == expected.size());
  for (const auto& zero : linear->zero_dynamics.eigenvalues) {
    CHECK(DistanceToNearest(zero, expected) / std::abs(zero) < 1e-9);  // dense QZ round-off
  }
  workspace.parameters()[d] = INFINITY;  // the damping factor d is then not finite
  const SweepPoint point = AnalyzeSweepPoint(model, workspace, {});
  CHECK_FALSE(point.ok);
  CHECK_THAT(point.error, Catch::Contains("= inf at these parameter values"));
}

TEST_CASE("linear sweep: an unknown parameter is a usage error naming the known ones",
          "[linear_sweep]") {
  const LinearModel model = Chain(3);
  CHECK_THROWS_WITH(ParameterIndex(model.parameter_names(), "q"),
                    Catch::Contains("unknown parameter 'q'") && Catch::Contains("d"));
}

}  // namespace servokit
