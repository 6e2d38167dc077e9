#include "trajectories/trajectory.h"

#include <algorithm>
#include <cmath>
#include <string>

#include "base/errors.h"
#include "base/option_check.h"

namespace servokit {
namespace {

// The paper's Eq. (65) is p_4.
constexpr int kPaperContinuousDerivatives = 4;

// x^n for n >= 0 by repeated squaring: exact for the small powers here, and far cheaper than
// std::pow, which right-hand sides would call at every evaluation.
double IntegerPower(double x, int n) {
  double result = 1.0;
  for (; n > 0; n >>= 1, x *= x) {
    if (n & 1) result *= x;
  }
  return result;
}

double Binomial(int n, int k) {
  double value = 1.0;
  for (int i = 1; i <= k; ++i) value = value * double(n - k + i) / double(i);
  return value;
}

}  // namespace

std::vector<double> RestToRestCoefficients(int continuous_derivatives) {
  const int k = continuous_derivatives;
  std::vector<double> coefficients(std::size_t(2 * k + 2), 0.0);
  // tau^(k+1) C(k+j, j) (1 - tau)^j, with (1 - tau)^j = sum_i C(j, i) (-tau)^i.
  for (int j = 0; j <= k; ++j) {
    for (int i = 0; i <= j; ++i) {
      coefficients[std::size_t(k + 1 + i)] +=
          Binomial(k + j, j) * Binomial(j, i) * (i % 2 == 0 ? 1.0 : -1.0);
    }
  }
  return coefficients;
}

void RequireContinuousDerivatives(const std::string& what, int continuous_derivatives) {
  if (continuous_derivatives < 1 || continuous_derivatives > kMaxContinuousDerivatives) {
    throw UsageError(what + ": continuous derivatives = " + std::to_string(continuous_derivatives) +
                     ": must be from 1 to " + std::to_string(kMaxContinuousDerivatives));
  }
}

int RestToRestOrderFor(int needed_derivatives) {
  return std::max(kPaperContinuousDerivatives, needed_derivatives);
}

RestToRestTrajectory::RestToRestTrajectory(
    Eigen::VectorXd y0, Eigen::VectorXd yf, double t0, double tf, int continuous_derivatives)
    : y0_(std::move(y0)),
      yf_(std::move(yf)),
      t0_(t0),
      tf_(tf),
      continuous_derivatives_(continuous_derivatives) {
  if (y0_.size() != yf_.size() || y0_.size() == 0) {
    throw UsageError("rest-to-rest: y0 has " + std::to_string(y0_.size()) + " values, yf " +
                     std::to_string(yf_.size()) + ": one each per output");
  }
  if (!y0_.allFinite() || !yf_.allFinite() || !std::isfinite(t0) || !std::isfinite(tf)) {
    throw UsageError("rest-to-rest: y0, yf, t0 and tf must be finite");
  }
  if (!(t0 < tf)) {
    throw UsageError("rest-to-rest: t0 = " + FormatNumber(t0) + ", tf = " + FormatNumber(tf) +
                     ": needs t0 < tf");
  }
  if (!std::isfinite(tf - t0)) {  // tau = (t - t0) / (tf - t0) would be NaN at tf
    throw UsageError("rest-to-rest: t0 = " + FormatNumber(t0) + ", tf = " + FormatNumber(tf) +
                     ": tf - t0 overflows (too far apart for doubles)");
  }
  RequireContinuousDerivatives("rest-to-rest", continuous_derivatives);
  const int k = continuous_derivatives_;
  std::vector<double> falling(std::size_t(k + 1));  // k! / (k - j)!
  value_weights_.resize(std::size_t(k + 1));
  for (int j = 0; j <= k; ++j) {
    falling[std::size_t(j)] = j == 0 ? 1.0 : falling[std::size_t(j - 1)] * double(k - j + 1);
    value_weights_[std::size_t(j)] = Binomial(k + j, j);
  }
  // The Leibniz terms' factors for each order n = 1 .. 2k + 1 (beyond, p^(n) = 0), with
  // 1 / B(k + 1, k + 1) = (2k + 1) C(2k, k), the sign (-1)^m and the time scale folded in.
  const double slope_factor = double(2 * k + 1) * Binomial(2 * k, k);
  derivative_terms_.resize(std::size_t(2 * k + 2));
  for (int n = 1; n <= 2 * k + 1; ++n) {
    const double scale = slope_factor / std::pow(tf_ - t0_, n);
    for (int j = std::max(0, n - 1 - k); j <= std::min(n - 1, k); ++j) {
      const int m = n - 1 - j;
      const double sign = m % 2 == 0 ? 1.0 : -1.0;
      derivative_terms_[std::size_t(n)].push_back(
          {j, m,
           sign * scale * Binomial(n - 1, j) * falling[std::size_t(j)] * falling[std::size_t(m)]});
    }
  }
  RequireFiniteDerivatives();
}

// |p^(n)(tau)| <= sum |factor| on [0, 1], where tau and 1 - tau are at most 1: with that bound
// times |yf - y0| finite, every derivative the solvers read (orders up to k) is finite.
void RestToRestTrajectory::RequireFiniteDerivatives() const {
  const double distance = (yf_ - y0_).lpNorm<Eigen::Infinity>();
  for (int n = 1; n <= continuous_derivatives_; ++n) {
    double bound = 0.0;
    for (const LeibnizTerm& term : derivative_terms_[std::size_t(n)]) {
      bound += std::abs(term.factor);
    }
    if (!std::isfinite(distance * bound)) {
      throw UsageError("rest-to-rest: y0 to yf (|yf - y0| = " + FormatNumber(distance) +
                       ") from t0 = " + FormatNumber(t0_) + " to tf = " + FormatNumber(tf_) +
                       ": the derivative of order " + std::to_string(n) +
                       " of y_d overflows (the motion is too short for its distance)");
    }
  }
}

// p(tau) = tau^(k+1) sum_j C(k+j, j) (1 - tau)^j has positive terms only. Its derivatives come
// from p'(tau) = tau^k (1 - tau)^k / B(k+1, k+1) by Leibniz's rule:
//   p^(n) = 1/B sum_j C(n-1, j) (k!/(k-j)!) tau^(k-j) (-1)^m (k!/(k-m)!) (1 - tau)^(k-m),
// m = n - 1 - j: a few terms of moderate size. The monomial coefficients of p, which alternate
// in sign and reach 1e7 for k = 12, cancelled to 1e-5 of the result near tau = 1 (the six-mass
// chain's u_d was noisy there).
double RestToRestTrajectory::ScaledPolynomialDerivative(double tau, int order) const {
  const int k = continuous_derivatives_;
  const double rest = 1.0 - tau;
  if (order == 0) {
    double sum = 0.0, power = 1.0;  // (1 - tau)^j
    for (int j = 0; j <= k; ++j, power *= rest) sum += value_weights_[std::size_t(j)] * power;
    return IntegerPower(tau, k + 1) * sum;
  }
  if (order > 2 * k + 1) return 0.0;
  double sum = 0.0;
  for (const LeibnizTerm& term : derivative_terms_[std::size_t(order)]) {
    sum += term.factor * IntegerPower(tau, k - term.tau_order) *
           IntegerPower(rest, k - term.rest_order);
  }
  return sum;
}

Eigen::VectorXd RestToRestTrajectory::Derivative(double t, int order) const {
  Eigen::MatrixXd derivative(y0_.size(), 1);
  if (order == 0) {
    Derivatives(t, 0, derivative);
    return derivative.col(0);
  }
  // At rest outside the motion. At t0 and tf themselves the polynomial decides: its first k
  // derivatives vanish there, a higher one is the value from inside the motion.
  if (t < t0_ || t > tf_) return Eigen::VectorXd::Zero(y0_.size());
  const double tau = std::clamp((t - t0_) / (tf_ - t0_), 0.0, 1.0);
  return (yf_ - y0_) * ScaledPolynomialDerivative(tau, order);
}

void RestToRestTrajectory::Derivatives(double t, int highest, Eigen::MatrixXd& derivatives) const {
  if (derivatives.rows() != y0_.size() || derivatives.cols() != highest + 1) {
    derivatives.resize(y0_.size(), highest + 1);
  }
  const double tau = std::clamp((t - t0_) / (tf_ - t0_), 0.0, 1.0);
  const bool moving = t >= t0_ && t <= tf_;
  for (int order = 0; order <= highest; ++order) {
    if (order == 0) {
      // From the nearer end (p(tau) + p(1 - tau) = 1), so that y_d(tf) = yf exactly.
      if (tau > 0.5) {
        derivatives.col(0) = yf_ - (yf_ - y0_) * ScaledPolynomialDerivative(1.0 - tau, 0);
      } else {
        derivatives.col(0) = y0_ + (yf_ - y0_) * ScaledPolynomialDerivative(tau, 0);
      }
    } else if (moving) {
      derivatives.col(order) = (yf_ - y0_) * ScaledPolynomialDerivative(tau, order);
    } else {
      derivatives.col(order).setZero();
    }
  }
}

}  // namespace servokit
