#pragma once
// A solution's continuous extension: q_d, q_d' and u_d at any time of its span, from the
// method's own continuous extension, never from a polynomial through its uneven step points:
//   - the projected DAE's state x = (q, v, u) from the solver's dense output (Radau IIA's
//     collocation polynomial, Euler backward's line, IDA's interpolant): InterpolatedMotion;
//   - the internal state of the normal form (ARKODE's interpolant) or of stable inversion (the
//     collocation solution) mapped through the servo constraint and Eq. (24): InternalMotion;
//   - the algebraic inverse evaluated at t itself: AlgebraicMotion.
// Output rows on a controller's grid and the forward check both read u_d from here.
#include <Eigen/Dense>
#include <functional>
#include <memory>
#include <string>
#include <vector>

#include "integrators/dense_output.h"
#include "modeling/model.h"
#include "solvers/algebraic_inversion.h"
#include "solvers/servo_constraint_problem.h"
#include "trajectories/trajectory.h"

namespace servokit {

class MotionExtension {
 public:
  virtual ~MotionExtension() = default;
  double start() const { return start_; }
  double end() const { return end_; }
  /// q (dof), q' (dof) and u (inputs) at t in [start(), end()] (clamped outside). False, with
  /// `why`, when the state cannot be recovered at t. Not thread-safe: extensions that map an
  /// internal state reuse one ServoConstraintProblem.
  virtual bool Evaluate(double t,
                        Eigen::VectorXd& q,
                        Eigen::VectorXd& q_dot,
                        Eigen::VectorXd& u,
                        std::string& why) const = 0;

 protected:
  MotionExtension(double start, double end) : start_(start), end_(end) {}

 private:
  double start_;
  double end_;
};

/// x = (q, v, u) of the projected DAE, from `states` (size 2 dof + inputs).
std::shared_ptr<const MotionExtension> InterpolatedMotion(DenseOutput states, Eigen::Index dof);

/// Maps the internal state at t to q, q' and u (false with `why` where it cannot).
using InternalStateMap = std::function<bool(double t,
                                            const Eigen::VectorXd& internal,
                                            Eigen::VectorXd& q,
                                            Eigen::VectorXd& q_dot,
                                            Eigen::VectorXd& u,
                                            std::string& why)>;

/// The internal state at t from `internal_state` on [start, end], mapped by `map`.
std::shared_ptr<const MotionExtension> MappedMotion(
    InternalStateMap map,
    std::function<Eigen::VectorXd(double)> internal_state,
    double start,
    double end);

/// MappedMotion with the map of the normal form for r = 2 (P regular): the internal state
/// (z, z') mapped to q and q' by the servo constraint (Eqs. 19-20) and to u by Eq. (24) through
/// `problem`, which keeps the model and trajectory it refers to (they must outlive the
/// extension). `q_guess` starts the first Newton iteration for q; later ones start from the
/// last q found.
std::shared_ptr<const MotionExtension> InternalMotion(
    std::shared_ptr<ServoConstraintProblem> problem,
    std::function<Eigen::VectorXd(double)> internal_state,
    const Eigen::VectorXd& q_guess,
    double start,
    double end);

/// The algebraic inverse at t: q, q', u from y_d and its derivatives, Newton started from the
/// sample at or before t (`times`, `q`, `q_dot`: the samples it was evaluated at). `model` and
/// `trajectory` must outlive the extension.
std::shared_ptr<const MotionExtension> AlgebraicMotion(
    std::shared_ptr<const AlgebraicInverse> inverse,
    const Model& model,
    const OutputTrajectory& trajectory,
    std::vector<double> times,
    std::vector<Eigen::VectorXd> q,
    std::vector<Eigen::VectorXd> q_dot);

/// The state of rest (q, 0, u) of an equilibrium.
struct RestState {
  Eigen::VectorXd q;
  Eigen::VectorXd u;
};

/// `inner` on its span, extended to [start, end] by the rest states before and after it (the
/// equilibria the motion leaves and reaches): stable inversion's window padded out to a span
/// wider than it needs.
std::shared_ptr<const MotionExtension> PaddedWithRest(std::shared_ptr<const MotionExtension> inner,
                                                      double start,
                                                      double end,
                                                      RestState before,
                                                      RestState after);

}  // namespace servokit
