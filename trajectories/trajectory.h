#pragma once
// Desired output trajectories y_d(t) with exact derivatives of any order (paper Eq. 65).
//
// Rest to rest: y_d = y0 + (yf - y0) p(tau), tau = (t - t0)/(tf - t0) clamped to [0, 1], where
// p is the polynomial of degree 2k + 1 with p(0) = 0, p(1) = 1 and its first k derivatives zero
// at both ends:  p_k(tau) = tau^(k+1) sum_{j=0..k} C(k+j, j) (1 - tau)^j.
// k = 4 is the paper's Eq. (65): 126 tau^5 - 420 tau^6 + 540 tau^7 - 315 tau^8 + 70 tau^9.
// y_d is then k times continuously differentiable; a problem whose inverse needs y_d^(r)
// continuous (r = the highest infinite-zero order, or more for the DAE solvers) needs k >= r,
// and RestToRestOrderFor() raises k when Eq. (65) is not enough.
#include <Eigen/Dense>
#include <cstddef>
#include <string>
#include <vector>

namespace servokit {

/// The most continuous derivatives k a trajectory may ask for (a waypoint file's
/// continuous_derivatives, a function's, the order a solve raises Eq. 65 to). The six-mass chain
/// needs 12; 32 serves chains of 16 bodies. A rest-to-rest segment then has degree 65 and a
/// table of (k + 1)^2 Leibniz terms, and its derivatives up to order 2k + 1 stay below 1e110 on
/// a motion of one second; above about 70 they overflow doubles, and a million (a typo) would
/// take hours to tabulate.
inline constexpr int kMaxContinuousDerivatives = 32;

/// The most samples (a CSV file, an array) or waypoints a trajectory may have: 10^6 is a
/// kilohertz for a quarter of an hour. A sampled trajectory takes 0.7 kB and 2 us per sample to
/// read and build (a million: 0.7 GB; with a Radau solve of the mass on car 2.4 s, measured),
/// and its derivatives carry the samples' rounding amplified by (c/h)^order, so that denser
/// data serves no solve better; far more is a mistake (a file of another kind, a unit off by
/// 1000) and is refused before memory is taken for it.
inline constexpr std::size_t kMaxTrajectoryPoints = 1'000'000;

/// Throws UsageError "<what>: continuous derivatives = k: must be from 1 to 32" unless
/// 1 <= k <= kMaxContinuousDerivatives.
void RequireContinuousDerivatives(const std::string& what, int continuous_derivatives);

/// A desired output trajectory y_d(t) with exact derivatives: what every inverse-model solver
/// reads. Implemented by RestToRestTrajectory and WaypointTrajectory.
class OutputTrajectory {
 public:
  virtual ~OutputTrajectory() = default;
  /// d^order y_d / dt^order at t (order 0 is y_d itself), size outputs().
  virtual Eigen::VectorXd Derivative(double t, int order) const = 0;
  /// Orders 0..highest at once into `derivatives` (outputs x (highest + 1), resized only when
  /// its size differs): for integrators' right-hand sides, without allocating.
  virtual void Derivatives(double t, int highest, Eigen::MatrixXd& derivatives) const {
    derivatives.resize(outputs(), highest + 1);
    for (int order = 0; order <= highest; ++order) derivatives.col(order) = Derivative(t, order);
  }
  virtual Eigen::Index outputs() const = 0;
  /// Derivatives of y_d that are continuous everywhere (4 for the paper's Eq. 65).
  virtual int continuous_derivatives() const = 0;
  /// Times at which a derivative above continuous_derivatives() jumps (segment ends), in
  /// increasing order: integrators step onto them exactly instead of across.
  virtual std::vector<double> breakpoints() const = 0;
};

/// Coefficients c_0 .. c_(2k+1) of p_k in powers of tau (exact integers held as doubles).
std::vector<double> RestToRestCoefficients(int continuous_derivatives);

/// The paper's Eq. (65) has 4 continuous derivatives; returns max(4, needed).
int RestToRestOrderFor(int needed_derivatives);

/// y_d(t) from y0 (at rest before t0) to yf (at rest after tf), for any number of outputs.
class RestToRestTrajectory final : public OutputTrajectory {
 public:
  /// Throws UsageError unless t0 < tf, the sizes of y0 and yf agree, everything is finite,
  /// 1 <= continuous_derivatives <= kMaxContinuousDerivatives, and the derivatives up to that
  /// order are finite too (a motion far too short for its distance would overflow them).
  RestToRestTrajectory(
      Eigen::VectorXd y0, Eigen::VectorXd yf, double t0, double tf, int continuous_derivatives = 4);

  /// d^order y_d / dt^order at t (order 0 is y_d itself), size outputs. Exact: the polynomial's
  /// derivative, scaled by (tf - t0)^-order; zero outside [t0, tf] for order >= 1; at t0 and
  /// tf, orders above continuous_derivatives() take the value from inside the motion.
  Eigen::VectorXd Derivative(double t, int order) const override;
  void Derivatives(double t, int highest, Eigen::MatrixXd& derivatives) const override;

  int continuous_derivatives() const override { return continuous_derivatives_; }
  Eigen::Index outputs() const override { return y0_.size(); }
  std::vector<double> breakpoints() const override { return {t0_, tf_}; }

 private:
  Eigen::VectorXd y0_, yf_;
  double t0_, tf_;
  int continuous_derivatives_;
  // C(k + j, j), j = 0..k: the weights of p's value.
  std::vector<double> value_weights_;
  // p^(n) = sum of factor tau^(k - tau_order) (1 - tau)^(k - rest_order), per order n (see the
  // .cpp), already scaled by (tf - t0)^-n.
  struct LeibnizTerm {
    int tau_order;
    int rest_order;
    double factor;
  };
  std::vector<std::vector<LeibnizTerm>> derivative_terms_;
  // d^order p / dtau^order at tau, scaled by (tf - t0)^-order; the one place this is evaluated.
  double ScaledPolynomialDerivative(double tau, int order) const;
  // Throws UsageError naming y0, yf, t0 and tf when a derivative up to order k could overflow.
  void RequireFiniteDerivatives() const;
};

}  // namespace servokit
