#pragma once
// Stable inversion of LINEAR internal dynamics (paper Sect. 5.3; Devasia, Chen & Paden 1996):
//   x' = A x + g(t),  A hyperbolic (no eigenvalue on the imaginary axis),
// has exactly one solution that stays bounded on the whole time axis when g vanishes outside
// a finite interval: its part in the stable invariant subspace of A is integrated forward
// from rest, its part in the unstable subspace backward from rest at the end. The solution is
// non-causal: the unstable part moves before g does (pre-actuation).
//
// Servokit uses it as the independent reference for the nonlinear boundary value problem
// (issue #5) and as the answer for linear models. The two parts are integrated in their own
// reduced coordinates, so round-off never feeds an unstable mode forward in time.
#include <Eigen/Dense>
#include <complex>
#include <functional>
#include <vector>

#include "integrators/solve_summary.h"
#include "integrators/sundials_integrators.h"

namespace servokit {

/// The invariant subspaces of a hyperbolic A: x = stable_basis w_s + unstable_basis w_u with
/// w_s = stable_left x, w_u = unstable_left x, and the reduced matrices
/// A_s = stable_left A stable_basis (all eigenvalues in the open left half plane) and A_u.
struct HyperbolicSplit {
  Eigen::MatrixXd stable_basis, unstable_basis;  // n x k_s, n x k_u, orthonormal columns
  Eigen::MatrixXd stable_left, unstable_left;    // k_s x n, k_u x n: rows of [Q_s Q_u]^-1
  Eigen::MatrixXd stable_matrix, unstable_matrix;
  std::vector<std::complex<double>> eigenvalues;  // of A, sorted by real part
};

/// SplitHyperbolic's default axis_tolerance: the default of
/// ClassificationOptions::imaginary_axis_tolerance (analysis/options.h), with the same test
/// (SideOfImaginaryAxis, analysis/zero_dynamics.h), so that stable inversion refuses exactly
/// what the classification calls critical.
inline constexpr double kHyperbolicAxisTolerance = 1e-9;

/// Splits A into its stable and unstable invariant subspaces. Throws NoSolution naming the
/// eigenvalues on the imaginary axis by SideOfImaginaryAxis (damping ratio at most
/// axis_tolerance, or |lambda| at the zero floor) ("not hyperbolic: eigenvalues on the
/// imaginary axis: 0 + 18.14i, 0 - 18.14i"), since stable inversion needs a dichotomy.
HyperbolicSplit SplitHyperbolic(const Eigen::MatrixXd& state_matrix,
                                double axis_tolerance = kHyperbolicAxisTolerance);

/// The bounded solution of x' = A x + g(t) on [t_start, t_end], with g = 0 outside [t_start,
/// t_end] assumed (the stable part starts at 0 at t_start, the unstable part ends at 0 at
/// t_end), sampled at `times` (increasing, within [t_start, t_end]). Each part is integrated
/// with Dormand-Prince at `options`, the unstable one backward in time; unless options.max_step
/// is set, steps are capped at 1/4000 of the window so that sampling between them is exact to
/// the integration tolerance. `breakpoints` are
/// where g is not smooth. Returns false with the reason in `summary` on failure.
struct LinearStableInversion {
  SolveSummary summary;
  std::vector<Eigen::VectorXd> states;  // x at each of `times`
};
LinearStableInversion SolveLinearStableInversion(
    const HyperbolicSplit& split,
    const std::function<Eigen::VectorXd(double)>& drive,
    double t_start,
    double t_end,
    const std::vector<double>& times,
    const std::vector<double>& breakpoints,
    const IntegratorOptions& options = {});

}  // namespace servokit
