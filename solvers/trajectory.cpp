#include "solvers/trajectory.h"

#include <algorithm>
#include <cmath>
#include <string>

#include "models/errors.h"

namespace servokit {
namespace {

// The paper's Eq. (65) is p_4.
constexpr int kPaperContinuousDerivatives = 4;

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
    throw UsageError("rest-to-rest: t0 = " + std::to_string(t0) + ", tf = " + std::to_string(tf) +
                     ": needs t0 < tf");
  }
  if (continuous_derivatives < 1) {
    throw UsageError("rest-to-rest: continuous derivatives = " +
                     std::to_string(continuous_derivatives) + ": must be >= 1");
  }
  coefficients_ = RestToRestCoefficients(continuous_derivatives);
  for (int order = 0; order < kTabulatedOrders; ++order) {
    std::vector<double> scaled;
    const double scale = std::pow(tf_ - t0_, -order);
    for (std::size_t i = std::size_t(order); i < coefficients_.size(); ++i) {
      double falling = 1.0;  // i (i-1) ... (i-order+1)
      for (int j = 0; j < order; ++j) falling *= double(i) - double(j);
      scaled.push_back(coefficients_[i] * falling * scale);
    }
    scaled_derivative_coefficients_.push_back(std::move(scaled));
  }
}

double RestToRestTrajectory::ScaledPolynomialDerivative(double tau, int order) const {
  if (order < kTabulatedOrders) {
    const std::vector<double>& coefficients = scaled_derivative_coefficients_[std::size_t(order)];
    double value = 0.0;
    for (auto c = coefficients.rbegin(); c != coefficients.rend(); ++c) value = value * tau + *c;
    return value;
  }
  // d^order/dtau^order of sum c_i tau^i, by Horner on the differentiated coefficients.
  double value = 0.0;
  for (int i = int(coefficients_.size()) - 1; i >= order; --i) {
    double falling = 1.0;  // i (i-1) ... (i-order+1)
    for (int j = 0; j < order; ++j) falling *= double(i - j);
    value = value * tau + coefficients_[std::size_t(i)] * falling;
  }
  return value * std::pow(tf_ - t0_, -order);
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
      derivatives.col(0) = y0_ + (yf_ - y0_) * ScaledPolynomialDerivative(tau, 0);
    } else if (moving) {
      derivatives.col(order) = (yf_ - y0_) * ScaledPolynomialDerivative(tau, order);
    } else {
      derivatives.col(order).setZero();
    }
  }
}

}  // namespace servokit
