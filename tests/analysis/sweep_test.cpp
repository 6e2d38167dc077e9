// RunSweep on the mass on car (paper Sect. 3) against closed forms derived by hand:
//  - zero dynamics: the roots of m2 sin^2(alpha) s^2 + d s + k (m2 = 2, k = 5), which drops to
//    d s + k at alpha = 0 (one root -k/d) and to the constant k with d = 0 too (none, flat);
//  - realization tangential (rank P = 0) exactly at alpha = 0, ideal orthogonal at 90 deg,
//    non-ideal orthogonal between (P = sin^2 a / (m1 + m2 sin^2 a), Eq. 30);
//  - relative degree 2 for alpha != 0, 3 at alpha = 0 with d != 0, 4 at alpha = 0 with d = 0
//    (the paper's cases 1-2, 3, 4), index one more.
// And on tests/data/no_equilibrium.yaml (f = a + z^2 on the unactuated z, y = x + z): for a < 0
// the equilibrium z0 = sqrt(-a) has zero dynamics z'' + 2 z0 z = 0, eigenvalues +-i sqrt(2 z0);
// for a > 0 there is none, and the sweep records that and goes on.
#include "analysis/sweep.h"

#include <array>
#include <catch2/catch.hpp>
#include <cmath>
#include <cstdint>
#include <mutex>
#include <numbers>
#include <stdexcept>
#include <vector>

#include "base/errors.h"
#include "tests/analysis/classify_helpers.h"
#include "tests/analysis/grid_helpers.h"

namespace servokit {
namespace {

using testing::ModelPath;
using testing::QuadraticRoots;
using testing::TestDataPath;

constexpr double kM2 = 2.0, kK = 5.0;
// Eigenvalues of a 2x2 normal form against the quadratic formula: round-off far below this.
constexpr double kEigenvalueTolerance = 1e-9;

struct Collected {
  std::vector<std::size_t> firsts;  // the `first` of each block, in call order
  std::vector<SweepPoint> points;
};

Collected Sweep(const Model& model,
                const ParameterGrid& grid,
                const SweepOptions& options = {},
                std::size_t first_point = 0) {
  Collected collected;
  const std::size_t end =
      RunSweep(LoadedModel(model), grid, options, first_point,
               [&](std::size_t first, std::span<const SweepPoint> block) {
                 collected.firsts.push_back(first);
                 collected.points.insert(collected.points.end(), block.begin(), block.end());
                 return true;
               });
  CHECK(end == grid.num_points());
  return collected;
}

bool SamePoint(const SweepPoint& a, const SweepPoint& b) {
  const bool same_max_real_part = (std::isnan(a.max_real_part) && std::isnan(b.max_real_part)) ||
                                  a.max_real_part == b.max_real_part;
  return a.ok == b.ok && a.error == b.error && a.realization == b.realization && a.rank == b.rank &&
         a.relative_degree == b.relative_degree &&
         a.differentiation_index == b.differentiation_index &&
         a.internal_dynamics_order == b.internal_dynamics_order && a.stability == b.stability &&
         same_max_real_part && a.eigenvalues == b.eigenvalues;
}

void CheckSamePoints(const std::vector<SweepPoint>& a, const std::vector<SweepPoint>& b) {
  REQUIRE(a.size() == b.size());
  for (std::size_t i = 0; i < a.size(); ++i) {
    INFO("point " << i);
    CHECK(SamePoint(a[i], b[i]));
  }
}

void CheckEigenvalues(const SweepPoint& point, const std::vector<std::complex<double>>& expected) {
  REQUIRE(point.eigenvalues.size() == expected.size());
  for (std::size_t i = 0; i < expected.size(); ++i) {
    const double scale = std::abs(expected[i]);
    CHECK(std::abs(point.eigenvalues[i] - expected[i]) <= kEigenvalueTolerance * scale);
  }
}

// Zero dynamics of the mass on car by the closed form of the header comment.
std::vector<std::complex<double>> MassOnCarZeros(double alpha, double d) {
  const double a2 = kM2 * std::sin(alpha) * std::sin(alpha);
  if (alpha != 0.0) return QuadraticRoots(a2, d, kK);
  if (d != 0.0) return {-kK / d};
  return {};
}

TEST_CASE("a sweep of the mass on car over alpha and d agrees with the closed forms",
          "[analysis][paper]") {
  const Model model = LoadModel(ModelPath("mass_on_car.yaml"));
  const ParameterGrid grid = ParameterGrid(std::vector<GridAxis>{
      testing::RangeAxis(model.parameter_names(), "alpha", 0.0, std::numbers::pi / 2, 7),
      testing::RangeAxis(model.parameter_names(), "d", 0.0, 2.0, 5)});
  const Collected sweep = Sweep(model, grid);
  REQUIRE(sweep.points.size() == 35);
  std::vector<double> values(2);
  for (std::size_t i = 0; i < sweep.points.size(); ++i) {
    grid.PointValues(i, values);
    const double alpha = values[0], d = values[1];
    const SweepPoint& point = sweep.points[i];
    INFO("alpha = " << alpha << ", d = " << d);
    REQUIRE(point.ok);
    const std::vector<std::complex<double>> zeros = MassOnCarZeros(alpha, d);
    CheckEigenvalues(point, zeros);
    CHECK(point.internal_dynamics_order == static_cast<int>(zeros.size()));
    if (alpha == 0.0) {
      CHECK(point.realization == Realization::kTangential);
      CHECK(point.rank == 0);
      CHECK(point.relative_degree == std::vector<int>{d != 0.0 ? 3 : 4});
    } else {
      CHECK(point.realization == (alpha == std::numbers::pi / 2
                                      ? Realization::kIdealOrthogonal
                                      : Realization::kNonIdealOrthogonal));
      CHECK(point.rank == 1);
      CHECK(point.relative_degree == std::vector<int>{2});
    }
    CHECK(point.differentiation_index == point.relative_degree[0] + 1);
    if (zeros.empty()) {
      CHECK(point.stability == Stability::kNone);
      CHECK(std::isnan(point.max_real_part));
    } else {
      CHECK(point.stability == (d > 0.0 ? Stability::kAsymptoticallyStable : Stability::kCritical));
      CHECK(point.max_real_part == point.eigenvalues.front().real());
    }
  }
}

TEST_CASE("the points do not depend on the number of threads or the block size", "[analysis]") {
  const Model model = LoadModel(ModelPath("mass_on_car.yaml"));
  const ParameterGrid grid = ParameterGrid(std::vector<GridAxis>{
      testing::RangeAxis(model.parameter_names(), "alpha", 0.0, std::numbers::pi / 2, 40),
      testing::RangeAxis(model.parameter_names(), "d", 0.0, 2.0, 30)});
  SweepOptions one_thread;
  one_thread.threads = 1;
  SweepOptions two_threads_small_blocks;
  two_threads_small_blocks.threads = 2;
  two_threads_small_blocks.block_size = 7;
  CheckSamePoints(Sweep(model, grid, one_thread).points,
                  Sweep(model, grid, two_threads_small_blocks).points);
}

TEST_CASE("blocks come in index order and a sweep started at point K is the tail of a full one",
          "[analysis]") {
  const Model model = LoadModel(ModelPath("mass_on_car.yaml"));
  const ParameterGrid grid = ParameterGrid(std::vector<GridAxis>{
      testing::RangeAxis(model.parameter_names(), "alpha", std::numbers::pi / 180,
                         89 * std::numbers::pi / 180, 10),
      testing::ListAxis(model.parameter_names(), "d", {0.5, 1, 2})});
  SweepOptions options;
  options.threads = 2;
  options.block_size = 4;
  const Collected full = Sweep(model, grid, options);
  CHECK(full.firsts == std::vector<std::size_t>{0, 4, 8, 12, 16, 20, 24, 28});
  const Collected tail = Sweep(model, grid, options, 13);
  CHECK(tail.firsts == std::vector<std::size_t>{13, 17, 21, 25, 29});
  CheckSamePoints(tail.points,
                  std::vector<SweepPoint>(full.points.begin() + 13, full.points.end()));
}

TEST_CASE("a consumer that returns false stops the sweep after its block", "[analysis]") {
  const Model model = LoadModel(ModelPath("mass_on_car.yaml"));
  const ParameterGrid grid = ParameterGrid(
      std::vector<GridAxis>{testing::RangeAxis(model.parameter_names(), "d", 0.0, 1.0, 100)});
  SweepOptions options;
  options.block_size = 8;
  int calls = 0;
  const std::size_t end =
      RunSweep(LoadedModel(model), grid, options, 0,
               [&](std::size_t, std::span<const SweepPoint>) { return ++calls < 2; });
  CHECK(calls == 2);
  CHECK(end == 16);
}

// RunSweepPipeline: prepare runs once per point, on the chunks of the slot the consumer then
// reads; an exception of a later point arrives only after every block before it was consumed.
TEST_CASE("the pipelined sweep prepares every point once and keeps blocks in order", "[analysis]") {
  const Model model = LoadModel(ModelPath("mass_on_car.yaml"));
  const LoadedModel loaded(model);
  const ParameterGrid grid = ParameterGrid(
      std::vector<GridAxis>{testing::RangeAxis(model.parameter_names(), "d", 0.0, 1.0, 203)});
  for (const int threads : {1, 2, 3}) {
    SweepOptions options;
    options.threads = threads;
    options.block_size = 37;  // not a multiple of the chunk: chunks end inside blocks
    SweepWorkspaces workspaces(loaded, threads);
    // Which block each slot's prepared chunks belong to: the consumer checks its slot was
    // prepared for exactly its points.
    std::array<std::vector<std::size_t>, kSweepSlots> prepared;
    for (auto& firsts : prepared) firsts.assign(options.block_size, SIZE_MAX);
    std::vector<int> times_prepared(grid.num_points(), 0);
    std::mutex mutex;
    std::vector<std::size_t> firsts;
    const std::size_t end = RunSweepPipeline(
        loaded, grid, options, 5, workspaces,
        [&](int slot, std::size_t chunk, std::size_t first, std::span<const SweepPoint> points) {
          const std::lock_guard lock(mutex);
          for (std::size_t i = 0; i < points.size(); ++i) {
            ++times_prepared[first + i];
            prepared[static_cast<std::size_t>(slot)][chunk * SweepChunkSize(loaded) + i] =
                first + i;
          }
        },
        [&](int slot, std::size_t first, std::span<const SweepPoint> block) {
          firsts.push_back(first);
          const std::lock_guard lock(mutex);
          for (std::size_t i = 0; i < block.size(); ++i) {
            CHECK(prepared[static_cast<std::size_t>(slot)][i] == first + i);
          }
          return true;
        });
    CHECK(end == grid.num_points());
    std::vector<std::size_t> expected_firsts;
    for (std::size_t first = 5; first < grid.num_points(); first += 37) {
      expected_firsts.push_back(first);
    }
    CHECK(firsts == expected_firsts);
    for (std::size_t i = 0; i < grid.num_points(); ++i) CHECK(times_prepared[i] == (i < 5 ? 0 : 1));
  }
}

TEST_CASE("a failure in a later block reaches the caller after the blocks before it",
          "[analysis]") {
  const Model model = LoadModel(ModelPath("mass_on_car.yaml"));
  const LoadedModel loaded(model);
  const ParameterGrid grid = ParameterGrid(
      std::vector<GridAxis>{testing::RangeAxis(model.parameter_names(), "d", 0.0, 1.0, 400)});
  SweepOptions options;
  options.threads = 2;
  options.block_size = 50;
  SweepWorkspaces workspaces(loaded, 2);
  std::vector<std::size_t> firsts;
  CHECK_THROWS_MATCHES(
      RunSweepPipeline(
          loaded, grid, options, 0, workspaces,
          [](int, std::size_t, std::size_t first, std::span<const SweepPoint> points) {
            if (first <= 260 && 260 < first + points.size()) {
              throw std::runtime_error("point 260");
            }
          },
          [&](int, std::size_t first, std::span<const SweepPoint>) {
            firsts.push_back(first);
            return true;
          }),
      std::runtime_error, Catch::Message("point 260"));
  CHECK(firsts == std::vector<std::size_t>{0, 50, 100, 150, 200});
}

TEST_CASE("a point without a solution is recorded with its message and the sweep goes on",
          "[analysis]") {
  const Model model = LoadModel(TestDataPath("no_equilibrium.yaml"));
  const ParameterGrid grid = ParameterGrid(
      std::vector<GridAxis>{testing::ListAxis(model.parameter_names(), "a", {-1, 1, -4})});
  SweepOptions options;
  // Newton's Jacobian is singular at z = 0 (d(z^2)/dz = 0): start beside it.
  options.classification.operating_point.q_guess = Eigen::Vector2d(0.0, 0.5);
  const Collected sweep = Sweep(model, grid, options);
  REQUIRE(sweep.points.size() == 3);
  CHECK_FALSE(sweep.points[1].ok);
  CHECK_THAT(sweep.points[1].error, Catch::StartsWith("no equilibrium found for y0 = [0]"));
  CHECK(sweep.points[1].error.find('\n') == std::string::npos);
  CHECK(sweep.points[1].eigenvalues.empty());
  for (const std::size_t i : {0, 2}) {
    const double z0 = std::sqrt(-grid.axes()[0].Value(i));
    const std::complex<double> root(0.0, std::sqrt(2 * z0));
    REQUIRE(sweep.points[i].ok);
    CheckEigenvalues(sweep.points[i], {root, std::conj(root)});
  }
}

TEST_CASE("bad sweep options are refused before any point is evaluated", "[analysis]") {
  const Model model = LoadModel(ModelPath("mass_on_car.yaml"));
  const ParameterGrid grid = ParameterGrid(
      std::vector<GridAxis>{testing::RangeAxis(model.parameter_names(), "d", 0.0, 1.0, 3)});
  const auto never = [](std::size_t, std::span<const SweepPoint>) -> bool {
    FAIL("no block expected");
    return false;
  };
  SweepOptions negative_threads;
  negative_threads.threads = -1;
  CHECK_THROWS_MATCHES(RunSweep(LoadedModel(model), grid, negative_threads, 0, never), UsageError,
                       Catch::Message("SweepOptions::threads = -1: must be >= 0 (0: all cores)"));
  SweepOptions empty_blocks;
  empty_blocks.block_size = 0;
  CHECK_THROWS_MATCHES(RunSweep(LoadedModel(model), grid, empty_blocks, 0, never), UsageError,
                       Catch::Message("SweepOptions::block_size = 0: must be >= 1"));
}

TEST_CASE("an exception from the consumer or a loop body reaches the caller", "[analysis]") {
  const Model model = LoadModel(ModelPath("mass_on_car.yaml"));
  const ParameterGrid grid = ParameterGrid(
      std::vector<GridAxis>{testing::RangeAxis(model.parameter_names(), "d", 0.0, 1.0, 3)});
  CHECK_THROWS_MATCHES(RunSweep(LoadedModel(model), grid, {}, 0,
                                [](std::size_t, std::span<const SweepPoint>) -> bool {
                                  throw std::runtime_error("disk full");
                                }),
                       std::runtime_error, Catch::Message("disk full"));
  CHECK_THROWS_MATCHES(ParallelFor(100, 2, 4,
                                   [](std::size_t i, int) {
                                     if (i == 42) throw std::runtime_error("point 42");
                                   }),
                       std::runtime_error, Catch::Message("point 42"));
}

}  // namespace
}  // namespace servokit
