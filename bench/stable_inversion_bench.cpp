// Issue #5 benchmark: stable inversion of the paper's rotational arm (Sect. 5.3, output at
// s = l, non-minimum phase) from 0 to 270 deg between t0 = 1 s and tf = 3 s (Eq. 65): a two-point
// boundary value problem on the window chosen from the eigenvalues. Compared with SciPy's
// solve_bvp on the same problem, window and tolerance by bench/compare_stable_inversion.sh.
// One solve without widening (max_widenings = 0) for a fair comparison. Times the solve alone
// (model loaded once), best of several runs. Prints one JSON object.
//
// Usage: bench_stable_inversion MODELS_DIR [tolerance (1e-6)] [repetitions (5)]
//                               [window_start window_end]
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

// T on a uniform grid of `count` times over [t0 - 1, tf + 1] (clamped to the window), from the
// solution's own interpolant, as a JSON array.
std::string InputGrid(const StableInversionSolution& solution, int count) {
  std::string text = "[";
  for (int i = 0; i < count; ++i) {
    const double t = 0.0 + 4.0 * i / (count - 1);
    Eigen::VectorXd q, q_dot, u;
    std::string why;
    if (!solution.extension->Evaluate(t, q, q_dot, u, why)) u.setConstant(1, NAN);
    char number[32];
    std::snprintf(number, sizeof number, "%s%.15e", i ? ", " : "", u(0));
    text += number;
  }
  return text + "]";
}

}  // namespace

int main(int argc, char** argv) {
  constexpr int kGridPoints = 401;
  if (argc < 2) {
    std::fprintf(stderr,
                 "usage: %s MODELS_DIR [tolerance] [repetitions] [window_start window_end]\n",
                 argv[0]);
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
  if (argc > 5) {  // a given window (for a reference solution on the same problem)
    options.pre_actuation = 1.0 - std::atof(argv[4]);
    options.post_actuation = std::atof(argv[5]) - 3.0;
  }
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
      "\"window_start\": %.15e, \"window_end\": %.15e, \"max_abs_T\": %.12e, "
      "\"max_residual\": %.6e, \"function_evaluations\": %ld, \"newton_iterations\": %ld, "
      "\"T_grid\": %s}\n",
      tolerance, best, solution.times.size(), solution.window.start, solution.window.end, largest,
      solution.window.boundary_value_residual, solution.summary.function_evaluations,
      solution.summary.newton_iterations, InputGrid(solution, kGridPoints).c_str());
  return 0;
}
