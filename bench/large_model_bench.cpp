// The k zero-dynamics eigenvalues nearest 0 of one large linear model file (issue #6), timed in
// phases: load (YAML + Matrix Market), assemble (M, D, K at the nominal parameters),
// zero dynamics (solves with the Rosenbrock matrix R(0), ARPACK shift-invert). Peak memory is the
// process's max RSS (getrusage), so run one model per process.
//
// Usage: bench_large_model MODEL.yaml [K [NCV]]   (K default 10; NCV default: ArpackOptions)
// Prints one JSON line: {"model", "dof", "k", "load_seconds", "assemble_seconds",
// "zero_dynamics_seconds", "seconds" (assemble + zero dynamics, what SciPy's side times),
// "max_rss_mb", "operator_applications", "restarts", "factorization" (how R(0) was factorised:
// RosenbrockFactorization), "eigenvalues": [[re, im], ...]}.
#include <sys/resource.h>

#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <exception>
#include <string>

#include "analysis/linear_zero_dynamics.h"
#include "modeling/linear_model.h"

namespace {

using Clock = std::chrono::steady_clock;

double SecondsSince(Clock::time_point start) {
  return std::chrono::duration<double>(Clock::now() - start).count();
}

double MaxRssMegabytes() {
  rusage usage{};
  getrusage(RUSAGE_SELF, &usage);
  return static_cast<double>(usage.ru_maxrss) / 1024.0;  // Linux: kilobytes
}

}  // namespace

int main(int argc, char** argv) {
  if (argc < 2 || argc > 4) {
    std::fprintf(stderr, "usage: %s MODEL.yaml [K [NCV]]\n", argv[0]);
    return 2;
  }
  try {
    using namespace servokit;
    const int k = argc >= 3 ? std::atoi(argv[2]) : 10;
    const int basis_size = argc == 4 ? std::atoi(argv[3]) : ArpackOptions{}.basis_size;
    auto start = Clock::now();
    const LinearModel model = LoadLinearModel(argv[1]);
    const double load_seconds = SecondsSince(start);

    start = Clock::now();
    const LinearSystem system = AssembleLinearSystem(model, model.parameters());
    const double assemble_seconds = SecondsSince(start);

    start = Clock::now();
    LinearZeroDynamicsOptions options;
    options.solver = LinearEigenSolver::kArpack;
    options.target = EigenvalueTarget::kNearest;
    options.arpack.eigenvalues = k;
    options.arpack.basis_size = basis_size;
    LinearZeroDynamicsWorkspace workspace;
    const LinearZeroDynamics zeros =
        ComputeLinearZeroDynamics(system, workspace, kUnknownZeroCount, options);
    const double zero_dynamics_seconds = SecondsSince(start);

    std::string eigenvalues;
    for (const auto& eigenvalue : zeros.eigenvalues) {
      char buffer[96];
      std::snprintf(buffer, sizeof buffer, "%s[%.17g, %.17g]", eigenvalues.empty() ? "" : ", ",
                    eigenvalue.real(), eigenvalue.imag());
      eigenvalues += buffer;
    }
    std::printf(
        "{\"model\": \"%s\", \"dof\": %zu, \"k\": %d, \"load_seconds\": %.6g, "
        "\"assemble_seconds\": %.6g, \"zero_dynamics_seconds\": %.6g, \"seconds\": %.6g, "
        "\"max_rss_mb\": %.1f, \"operator_applications\": %d, \"restarts\": %d, "
        "\"factorization\": \"%s\", \"eigenvalues\": [%s]}\n",
        model.name().c_str(), model.dof(), k, load_seconds, assemble_seconds, zero_dynamics_seconds,
        assemble_seconds + zero_dynamics_seconds, MaxRssMegabytes(),
        zeros.arpack.operator_applications, zeros.arpack.restarts,
        std::string(ToString(workspace.factorization())).c_str(), eigenvalues.c_str());
    return 0;
  } catch (const std::exception& error) {
    std::fprintf(stderr, "bench_large_model: error: %s\n", error.what());
    return 1;
  }
}
