#include "solvers/linear_stable_inversion.h"

#include <algorithm>
#include <cmath>
#include <string>

#include "analysis/subspaces.h"
#include "analysis/zero_dynamics.h"
#include "base/errors.h"
#include "base/number_format.h"
#include "base/option_check.h"

namespace servokit {
namespace {

// Newton's iteration for the matrix sign function converges quadratically once the scaled
// iterate is near its limit; 100 iterations only stop a non-hyperbolic matrix from looping.
constexpr int kMaxSignIterations = 100;
// It has converged when a step changes the iterate by at most this relative to its norm: a
// hundred times the machine epsilon, the round-off floor of an inversion of a well-conditioned
// iterate (quadratic convergence makes the next step smaller still).
constexpr double kSignTolerance = 1e-14;
// Singular values of a spectral projector are 0 or >= 1: 0.5 separates them with room.
constexpr double kProjectorRankThreshold = 0.5;
// The largest |lambda| is floored at this in the imaginary-axis test, so that a spectrum of
// vanishing size (where its zero floor, analysis/zero_dynamics.h, would underflow to 0) counts
// as on the axis: rates that small are no dichotomy. Any number far below a physical rate will do.
constexpr double kMinEigenvalueScale = 1e-300;
// Samples come from cubic Hermite interpolation between steps (error ~ h^4): unless the caller
// bounds the step, steps of at most 1/kMinStepsPerWindow of the window keep it below the
// integration error.
constexpr double kMinStepsPerWindow = 4000.0;

// sign(A) by the scaled Newton iteration X <- (c X + (c X)^-1) / 2, c = |det X|^(-1/n)
// (Higham, Functions of Matrices, Sect. 5.5): its eigenvalues are the signs of A's real parts,
// and (I -+ sign A)/2 project on the stable / unstable invariant subspaces, Jordan blocks or
// not (eigenvectors of a defective A would not span them).
Eigen::MatrixXd MatrixSign(const Eigen::MatrixXd& matrix) {
  const auto n = double(matrix.rows());
  Eigen::MatrixXd sign = matrix;
  for (int iteration = 0; iteration < kMaxSignIterations; ++iteration) {
    const Eigen::PartialPivLU<Eigen::MatrixXd> factor(sign);
    const double scale = std::pow(std::abs(factor.determinant()), -1.0 / n);
    const Eigen::MatrixXd next =
        0.5 * (scale * sign + factor.inverse() / (std::isfinite(scale) ? scale : 1.0));
    const double change = (next - sign).norm();
    sign = next;
    if (change <= kSignTolerance * sign.norm()) break;
  }
  return sign;
}

// Samples (t, y, y') of one integration, and cubic Hermite interpolation between them.
struct Samples {
  std::vector<double> times;
  std::vector<Eigen::VectorXd> values, slopes;

  Eigen::VectorXd At(double t) const {
    const auto after = std::upper_bound(times.begin(), times.end(), t) - times.begin();
    const auto i = std::size_t(std::clamp<long>(long(after) - 1, 0, long(times.size()) - 2));
    const double h = times[i + 1] - times[i];
    const double s = (t - times[i]) / h;
    const double h00 = (1 + 2 * s) * (1 - s) * (1 - s), h10 = s * (1 - s) * (1 - s);
    const double h01 = s * s * (3 - 2 * s), h11 = s * s * (s - 1);
    return h00 * values[i] + h10 * h * slopes[i] + h01 * values[i + 1] + h11 * h * slopes[i + 1];
  }
};

}  // namespace

HyperbolicSplit SplitHyperbolic(const Eigen::MatrixXd& state_matrix, double axis_tolerance) {
  const Eigen::Index n = state_matrix.rows();
  HyperbolicSplit split;
  const Eigen::EigenSolver<Eigen::MatrixXd> eigen(state_matrix, /*computeEigenvectors=*/false);
  for (Eigen::Index i = 0; i < n; ++i) split.eigenvalues.push_back(eigen.eigenvalues()(i));
  std::sort(split.eigenvalues.begin(), split.eigenvalues.end(),
            [](auto a, auto b) { return a.real() < b.real(); });
  double largest = 0.0;
  for (const auto& value : split.eigenvalues) largest = std::max(largest, std::abs(value));
  std::string on_axis;
  for (const auto& value : split.eigenvalues) {
    if (SideOfImaginaryAxis(value, std::max(largest, kMinEigenvalueScale), axis_tolerance) ==
        AxisSide::kOn) {
      on_axis += (on_axis.empty() ? "" : ", ") + FormatComplexWith(value, FormatNumber);
    }
  }
  if (!on_axis.empty()) {
    throw NoSolution("the zero dynamics are not hyperbolic: eigenvalues on the imaginary axis: " +
                     on_axis + "; stable inversion needs every mode to decay forward or backward");
  }
  const Eigen::MatrixXd sign = MatrixSign(state_matrix);
  const Eigen::MatrixXd identity = Eigen::MatrixXd::Identity(n, n);
  split.stable_basis = ColumnSpaceBasis(0.5 * (identity - sign), kProjectorRankThreshold);
  split.unstable_basis = ColumnSpaceBasis(0.5 * (identity + sign), kProjectorRankThreshold);
  const Eigen::Index stable = split.stable_basis.cols();
  Eigen::MatrixXd bases(n, n);
  bases << split.stable_basis, split.unstable_basis;
  const Eigen::MatrixXd left = bases.inverse();
  split.stable_left = left.topRows(stable);
  split.unstable_left = left.bottomRows(n - stable);
  split.stable_matrix = split.stable_left * state_matrix * split.stable_basis;
  split.unstable_matrix = split.unstable_left * state_matrix * split.unstable_basis;
  return split;
}

LinearStableInversion SolveLinearStableInversion(
    const HyperbolicSplit& split,
    const std::function<Eigen::VectorXd(double)>& drive,
    double t_start,
    double t_end,
    const std::vector<double>& times,
    const std::vector<double>& breakpoints,
    const IntegratorOptions& options) {
  LinearStableInversion result;
  result.summary.status = SolveStatus::kConverged;
  IntegratorOptions capped = options;
  if (!std::isfinite(options.max_step)) capped.max_step = (t_end - t_start) / kMinStepsPerWindow;
  // One part, integrated in direction `sign` (+1 forward from t_start, -1 backward from
  // t_end, as forward in s = -t) in its reduced coordinates w, starting at rest.
  auto integrate = [&](const Eigen::MatrixXd& reduced, const Eigen::MatrixXd& left, double sign,
                       Samples& samples) {
    const Eigen::Index size = reduced.rows();
    if (size == 0) return true;
    std::vector<double> stops;
    for (double breakpoint : breakpoints) stops.push_back(sign * breakpoint);
    std::sort(stops.begin(), stops.end());
    const double from = sign > 0 ? t_start : -t_end, to = sign > 0 ? t_end : -t_start;
    const SolveSummary summary = IntegrateDormandPrince(
        [&](double s, const Eigen::VectorXd& w, Eigen::VectorXd& w_dot, std::string&) {
          w_dot = sign * (reduced * w + left * drive(sign * s));
          return true;
        },
        from, Eigen::VectorXd::Zero(size), to, stops, capped,
        [&](double s, const Eigen::VectorXd& w, const Eigen::VectorXd& w_dot) {
          if (!samples.times.empty() && s <= samples.times.back()) return true;
          samples.times.push_back(s);
          samples.values.push_back(w);
          samples.slopes.push_back(w_dot);
          return true;
        });
    result.summary.steps += summary.steps;
    result.summary.function_evaluations += summary.function_evaluations;
    if (!summary.IsUsable()) {
      result.summary.status = summary.status;
      result.summary.message =
          (sign > 0 ? "stable part: " : "unstable part (backward): ") + summary.message;
      return false;
    }
    return true;
  };
  Samples stable, unstable;
  if (!integrate(split.stable_matrix, split.stable_left, +1.0, stable) ||
      !integrate(split.unstable_matrix, split.unstable_left, -1.0, unstable)) {
    return result;
  }
  for (double t : times) {
    Eigen::VectorXd state = Eigen::VectorXd::Zero(split.stable_basis.rows());
    if (!stable.times.empty()) state += split.stable_basis * stable.At(t);
    if (!unstable.times.empty()) state += split.unstable_basis * unstable.At(-t);
    result.states.push_back(state);
  }
  result.summary.stop_time = t_end;
  result.summary.message =
      "stable part forward, unstable part backward: " + std::to_string(result.summary.steps) +
      " steps";
  return result;
}

}  // namespace servokit
