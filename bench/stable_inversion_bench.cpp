// Issue #5 benchmark: stable inversion of the paper's rotational arm (Sect. 5.3, output at
// s = l, non-minimum phase) from 0 to 270 deg between t0 = 1 s and tf = 3 s (Eq. 65): a two-point
// boundary value problem on the window chosen from the eigenvalues. Compared with SciPy's
// solve_bvp on the same problem, window and tolerance by bench/compare_stable_inversion.sh.
// One solve without widening (max_widenings = 0) for a fair comparison. Times the solve alone
// (model loaded once), best of several runs. Prints one JSON object.
//
// Usage: bench_stable_inversion MODELS_DIR [tolerance (1e-6)] [repetitions (5)]
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <string>

#include "solvers/stable_inversion.h"

namespace {

using Clock = std::chrono::steady_clock;
using namespace servokit;

// The input T at t, linear interpolation on the mesh.
double InputAt(const StableInversionSolution& solution, double t) {
  const auto& times = solution.times;
  const auto upper = std::upper_bound(times.begin(), times.end(), t);
  if (upper == times.begin()) return solution.u.front()(0);
  if (upper == times.end()) return solution.u.back()(0);
  const std::size_t i = static_cast<std::size_t>(upper - times.begin());
  const double weight = (t - times[i - 1]) / (times[i] - times[i - 1]);
  return (1.0 - weight) * solution.u[i - 1](0) + weight * solution.u[i](0);
}

}  // namespace

int main(int argc, char** argv) {
  if (argc < 2) {
    std::fprintf(stderr, "usage: %s MODELS_DIR [tolerance] [repetitions]\n", argv[0]);
    return 2;
  }
  const std::string path = std::string(argv[1]) + "/rotational_arm.yaml";
  const double tolerance = argc > 2 ? std::atof(argv[2]) : 1e-6;
  const int repetitions = argc > 3 ? std::atoi(argv[3]) : 5;
  const double angle = 1.5 * M_PI;  // 270 deg
  const Model model = LoadModel(path);
  const RestToRestTrajectory trajectory(Eigen::VectorXd::Zero(1),
                                        Eigen::VectorXd::Constant(1, angle), 1.0, 3.0);
  StableInversionOptions options;
  options.tolerance = tolerance;
  options.max_widenings = 0;
  double best = 1e300;
  StableInversionSolution solution;
  for (int i = 0; i < repetitions; ++i) {
    const auto start = Clock::now();
    solution = SolveStableInversion(model, trajectory, Eigen::Vector2d(0.0, 0.0),
                                    Eigen::Vector2d(angle, 0.0), options);
    best = std::min(best, std::chrono::duration<double>(Clock::now() - start).count());
  }
  if (!solution.summary.IsUsable()) {
    std::fprintf(stderr, "bench_stable_inversion: failed: %s\n", solution.summary.message.c_str());
    return 1;
  }
  double largest = 0.0;
  for (const auto& u : solution.u) largest = std::max(largest, std::abs(u(0)));
  std::printf(
      "{\"method\": \"servokit\", \"tolerance\": %.3e, \"seconds\": %.6e, \"mesh_points\": %zu, "
      "\"window_start\": %.15e, \"window_end\": %.15e, \"max_abs_T\": %.12e, \"T_0_9\": %.12e, "
      "\"T_2_0\": %.12e, \"max_residual\": %.6e}\n",
      tolerance, best, solution.times.size(), solution.window_start, solution.window_end, largest,
      InputAt(solution, 0.9), InputAt(solution, 2.0), solution.max_residual);
  return 0;
}
