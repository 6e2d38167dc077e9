#pragma once
// The Taylor series of a motion of a model, computed on its compiled programs (Taylor mode,
// ExpressionProgram::EvaluateTaylor) and never by differentiating a formula: the derivatives of
// the outputs along a motion, y^(k)(0), which the structure algorithm needs, cost a few
// evaluations of M, f, B and h, however large their expanded derivatives would be (issue #31).
//
// The motion solves M(q) q'' + f(q, q') = B(q) u (paper Eq. 1) from q(0), q'(0) with the input
// held constant. With q(t) = sum_k q_k t^k and q''(t) = sum_k a_k t^k, the coefficient of t^k of
// the equations of motion reads
//   sum_(l=0..k) M_l a_(k-l) + f_k = B_k u,
// where M_l, f_k, B_k are the Taylor coefficients of M(q(t)), f(q(t), q'(t)), B(q(t)); they read
// q_0..q_(k+1) only, so a_k follows from the orders before it with the one factorisation of
// M_0 = M(q(0)), and q_(k+2) = a_k / ((k + 1)(k + 2)). This is the Taylor series method for
// ODEs (Griewank and Walther, "Evaluating Derivatives", 2nd ed., 2008, Sect. 13.5).
//
// Every coefficient is a dual number (modeling/dual_number.h): it carries its derivative along a
// direction of the start and the input, so that the derivative of y^(k) with respect to u or to
// the state is exact, never a difference of two motions (whose rounding grows with a drift that
// may dwarf the input's part).
//
// A tracking motion (Tracking) is the motion along which some outputs follow a desired second
// derivative: some inputs are Taylor series solved an order at a time. u_k enters a_k through
// M_0^-1 B_0 u_k and y_R's coefficient k + 2 through H_R q_(k+2) alone (y = h(q): a term with
// q_(k+2) twice is of order 2 k + 4), so each order is one linear solve with P_RC = H_R M_0^-1 B_C
// at the start, exactly. Along it, a dynamic extension's combined rows
// g_d = y_d^(r_d) - kappa(q, q') (y_R'' - y_R_d'') are y_d^(r_d) (analysis/numeric_structure.cpp).
#include <Eigen/Dense>
#include <cstddef>
#include <memory>
#include <vector>

#include "modeling/dual_number.h"
#include "modeling/model.h"

namespace servokit {

/// Where a motion starts and what drives it, or a direction in those.
struct MotionStart {
  Eigen::VectorXd q, q_dot, u;
};

/// One motion's Taylor series, extended an order at a time. Not thread-safe (it writes its
/// scratch); the model is only read, so threads may each hold motions for the same model.
class MotionSeries {
 public:
  /// The programs' dual-number inputs, registers and outputs: as large as the largest program,
  /// so that many motions of one thread share one (a chain of 100 pendulums' motions would
  /// take a gigabyte with one each).
  struct Scratch {
    std::vector<Dual> inputs, registers, outputs;
    /// The work of every evaluation made with it: instructions times (degree + 1)^2, what a
    /// product costs in Taylor mode. Callers bound it (analysis/numeric_structure.cpp).
    double work = 0.0;
  };

  /// A value and its derivative along the direction.
  struct Derivative {
    Eigen::VectorXd value, tangent;
  };

  /// Outputs whose second derivative follows a desired one, by as many inputs: y_R''(t) =
  /// y_R_d''(t), the input series u_C(t) solved for (every output in `outputs` has relative
  /// degree 2 and P_RC is regular at the start).
  struct Tracking {
    std::vector<std::size_t> outputs, inputs;
    /// desired[r][k]: the k-th derivative of output outputs[r] desired at t = 0 (0 beyond).
    std::vector<std::vector<double>> desired;
  };

  /// The motion from `start` at the parameter values `parameters` (SI units;
  /// Model::parameters() for the nominal ones); the tangents are derivatives along `direction`
  /// (all zero: none); `scratch` outlives it. Where M(q) is singular or not finite, every value and
  /// tangent is NaN (nothing can be decided there).
  MotionSeries(const Model& model,
               const Eigen::VectorXd& parameters,
               const MotionStart& start,
               const MotionStart& direction,
               Scratch& scratch);
  /// The motion from the same start, parameters and input as `same_start`, with the tangents
  /// along `direction`: it shares the factorisation of M(q(0)), which depends on the start
  /// alone (a gradient takes 2 dof motions from one start: for 400 coordinates, 800 LU
  /// factorisations of 400 x 400 and 2.6 MB each, issue #31).
  MotionSeries(const MotionSeries& same_start, const MotionStart& direction);
  /// As above, a tracking motion: `tracking` (kept by the motion) says which outputs follow.
  /// Where P_RC is singular at the start, every value and tangent is NaN.
  MotionSeries(const MotionSeries& same_start,
               const MotionStart& direction,
               std::shared_ptr<const Tracking> tracking);

  /// y^(k)(0), the k-th time derivative of the outputs h(q(t)) at t = 0; extends the series as
  /// far as that needs (order k of q). Not finite where the model is not (a pole on the way).
  Derivative OutputDerivative(int k);
  /// q''(0) = M^-1 (B u - f) at the start.
  Derivative Acceleration();

 private:
  // Computes a_k for the next k, hence q_(k+2), from the orders before it.
  void AddOrder();
  // The Taylor coefficients 0..degree of the program inputs [parameters, q, q'] (degree + 1
  // per input, input-major, as EvaluateTaylor reads them).
  void FillInputs(int degree);
  // EvaluateTaylor of `quantity`'s program to `degree` into outputs_.
  void EvaluateSeries(Quantity quantity, int degree);
  // M_0^-1 rhs, its tangent from the product rule: M_0 (a)' = rhs' - M_0' a, with M_0' the
  // tangents of the coefficients 0 of `mass_series` (M's Taylor coefficients, 0..width - 1 per
  // entry, as EvaluateSeries leaves them).
  std::vector<Dual> SolveMassMatrix(const std::vector<Dual>& rhs,
                                    const Dual* mass_series,
                                    std::size_t width) const;
  // A Derivative of a vector of duals, each multiplied by `scale`.
  static Derivative Split(const std::vector<Dual>& duals, double scale);
  // Tracking: B_0's tracking columns, copied from the series of B before M's overwrites them.
  void KeepTrackingColumns(std::size_t width);
  // Tracking: M_0^-1 B_C (M's series in the scratch) and P_RC = H_R M_0^-1 B_C, the coefficient
  // 1 of h_R(q_0 + t M_0^-1 B_C). False where M_0 or P_RC is singular.
  bool PrepareTracking(std::size_t width);
  // Tracking: u_C's coefficient k, from the provisional acceleration (u_C,k = 0); corrects it.
  void SolveTrackingInputs(std::size_t k, std::vector<Dual>& acceleration);

  const Model& model_;
  Scratch* scratch_;
  std::vector<Dual> parameters_, u_;
  // The factorisation of M_0's values, shared by the motions from one start; null where M(q(0))
  // is not finite or singular.
  std::shared_ptr<const Eigen::PartialPivLU<Eigen::MatrixXd>> mass_matrix_;
  std::vector<std::vector<Dual>> q_;              // q_0 .. q_(orders + 1)
  std::vector<std::vector<Dual>> accelerations_;  // a_0 .. a_(orders - 1)
  // Tracking: the rule, B_0's and M_0^-1 B_0's columns C, P_RC, and u_C's coefficients
  // u_C,0 .. u_C,(orders - 1).
  std::shared_ptr<const Tracking> tracking_;
  std::vector<std::vector<Dual>> tracking_columns_, tracking_directions_;
  std::vector<Dual> tracking_matrix_;  // P_RC, column-major
  std::vector<std::vector<Dual>> tracking_inputs_;
};

}  // namespace servokit
