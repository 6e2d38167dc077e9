// Issue #4 benchmark: the inverse-model solves of the paper's mass on car (Sect. 5.1-5.2).
//   - normal form (Eqs. 24-25) with Dormand-Prince, case 2 (alpha = 5 deg, d = 1 and d = 0),
//     rtol 1e-10, atol 1e-12: compared with SciPy's solve_ivp(RK45) by bench/compare_solve.sh;
//   - Radau IIA on the projected DAE, case 4 (alpha = 0, d = 0): goal under 1 ms;
//   - with `case3`: case 3 (alpha = 0, d = 1, tangential) through auto (the input-output
//     normal form) at several rtol, with u at every row, for bench/compare_case3.sh to compare
//     with SciPy's solve_ivp on the hand-written Eq. (40) at equal accuracy.
// Trajectory of Fig. 9: y from 0.5 m to 2.5 m in 0-6 s (Eq. 65), 10 s in all.
// Times the solve alone (model loaded and classified once, as a user sweeping trajectories
// would), best of several runs. Prints one JSON object per line.
//
// Usage: bench_solve MODELS_DIR [repetitions] [case3]
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <string>

#include "analysis/classification.h"
#include "solvers/inverse_model.h"

namespace {

using Clock = std::chrono::steady_clock;
using namespace servokit;

// The best time of `repetitions` solves; `solution` is the last one's answer.
double BestTime(const Model& model,
                const OutputTrajectory& trajectory,
                const Classification& classification,
                const InverseModelOptions& options,
                int repetitions,
                FeedforwardSolution& solution) {
  double best = 1e300;
  for (int i = 0; i < repetitions; ++i) {
    const auto start = Clock::now();
    solution = SolveInverseModel(model, trajectory, classification, options);
    best = std::min(best, std::chrono::duration<double>(Clock::now() - start).count());
  }
  return best;
}

void Measure(const std::string& path,
             const char* alpha,
             const char* damping,
             SolverMethod method,
             int repetitions) {
  const Model model = LoadModel(path, {{"alpha", alpha}, {"d", damping}});
  Workspace workspace(model);
  const Classification classification = Classify(model, workspace);
  const RestToRestTrajectory trajectory(Eigen::VectorXd::Constant(1, 0.5),
                                        Eigen::VectorXd::Constant(1, 2.5), 0.0, 6.0);
  InverseModelOptions options;
  options.method = method;
  options.t_end = 10.0;
  // The rows at the steps, as SciPy's solve_ivp gives them without dense_output.
  options.continuous_extension = false;
  if (method == SolverMethod::kNormalForm) {
    options.rtol = 1e-10;
    options.atol = 1e-12;
  }
  FeedforwardSolution solution;
  const double best = BestTime(model, trajectory, classification, options, repetitions, solution);
  if (!solution.summary.IsUsable()) {
    std::fprintf(stderr, "bench_solve: %s failed: %s\n", std::string(ToString(method)).c_str(),
                 solution.summary.message.c_str());
    std::exit(1);
  }
  std::printf(
      "{\"method\": \"%s\", \"alpha\": \"%s\", \"d\": \"%s\", \"seconds\": %.6e, \"steps\": %ld, "
      "\"rhs_evaluations\": %ld, \"s_end\": %.12e, \"u_end\": %.12e}\n",
      std::string(ToString(method)).c_str(), alpha, damping, best, solution.summary.steps,
      solution.summary.function_evaluations, solution.q.back()(1), solution.u.back()(0));
}

// Case 3 through auto at `rtol`: the rows at the steps (no continuous extension, as SciPy's
// solve_ivp without dense_output), printed with their times for the accuracy check.
void MeasureCase3(const std::string& path, double rtol, int repetitions) {
  const Model model = LoadModel(path, {{"alpha", "0"}, {"d", "1"}});
  Workspace workspace(model);
  const Classification classification = Classify(model, workspace);
  const RestToRestTrajectory trajectory(Eigen::VectorXd::Constant(1, 0.5),
                                        Eigen::VectorXd::Constant(1, 2.5), 0.0, 6.0);
  InverseModelOptions options;
  options.t_end = 10.0;
  options.continuous_extension = false;
  options.rtol = rtol;
  options.atol = rtol * 1e-2;
  FeedforwardSolution solution;
  const double best = BestTime(model, trajectory, classification, options, repetitions, solution);
  if (!solution.summary.IsUsable()) {
    std::fprintf(stderr, "bench_solve: case 3 failed: %s\n", solution.summary.message.c_str());
    std::exit(1);
  }
  std::printf(
      "{\"method\": \"%s\", \"rtol\": %.1e, \"seconds\": %.6e, \"steps\": %ld, "
      "\"t\": [",
      std::string(ToString(solution.method)).c_str(), rtol, best, solution.summary.steps);
  for (std::size_t i = 0; i < solution.times.size(); ++i) {
    std::printf("%s%.17g", i ? ", " : "", solution.times[i]);
  }
  std::printf("], \"u\": [");
  for (std::size_t i = 0; i < solution.u.size(); ++i) {
    std::printf("%s%.17g", i ? ", " : "", solution.u[i](0));
  }
  std::printf("]}\n");
}

}  // namespace

int main(int argc, char** argv) {
  if (argc < 2) {
    std::fprintf(stderr, "usage: %s MODELS_DIR [repetitions]\n", argv[0]);
    return 2;
  }
  const std::string path = std::string(argv[1]) + "/mass_on_car.yaml";
  const int repetitions = argc > 2 ? std::atoi(argv[2]) : 20;
  if (argc > 3 && std::string(argv[3]) == "case3") {
    for (const double rtol : {1e-5, 1e-6, 1e-7, 1e-8, 1e-9, 1e-10}) {
      MeasureCase3(path, rtol, repetitions);
    }
    return 0;
  }
  Measure(path, "5 deg", "1", SolverMethod::kNormalForm, repetitions);
  Measure(path, "5 deg", "0", SolverMethod::kNormalForm, repetitions);
  Measure(path, "0", "0", SolverMethod::kRadau, repetitions);
  return 0;
}
