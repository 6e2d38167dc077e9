#include "integrators/radau.h"

#include <algorithm>
#include <cmath>
#include <complex>
#include <string>
#include <utility>

#include "base/errors.h"
#include "base/option_check.h"

// Radau IIA after Hairer & Wanner, Solving ODEs II (2nd ed.), Sect. IV.8 (the method, its
// simplified Newton iteration in the eigenbasis of the Butcher matrix, the error estimate and
// the step-size control of their code RADAU5) and Sect. VII.8 (index-2 and index-3 DAEs: the
// error of an index-k component is measured against tolerances divided by h^(k-1)).
//
// Notation: a step from (t, x) of size h has stage increments Z = (Z_1, Z_2, Z_3) (n x 3), stage
// values X_i = x + Z_i at t + c_i h and stage derivatives K = Z (A_b^-1)^T / h, where A_b is
// the Butcher matrix. The stage equations are A(t + c_i h, X_i) K_i = phi(t + c_i h, X_i).

namespace servokit {
namespace {

using Eigen::Index;
using Eigen::MatrixXd;
using Eigen::VectorXd;
using Complex = std::complex<double>;

constexpr double kRoundoff = std::numeric_limits<double>::epsilon();

// Step-size control of RADAU5: the new step is h / quotient with quotient = err^(1/4) / safety
// (the estimate is O(h^4), hence kErrorExponent), kept within [1 / kMaxStepGrowth,
// kMaxStepShrink]. Growth is capped so that one lucky error
// estimate cannot throw the step far beyond where the Newton matrix was good; the safety
// factor is lowered further when Newton needed many iterations (see StepQuotient).
constexpr double kErrorExponent = 0.25;
constexpr double kSafety = 0.9;
constexpr double kMaxStepGrowth = 8.0;
constexpr double kMaxStepShrink = 5.0;
// A first step that fails its error test was a blind guess: RADAU5 cuts it by 10 instead of
// trusting the (then unreliable) error estimate.
constexpr double kFirstStepRejectionFactor = 0.1;
// A failed Newton iteration, failed evaluation or singular Newton matrix halves the step.
constexpr double kFailureStepFactor = 0.5;
// The default first step as a fraction of the interval, when options.initial_step is 0; the
// error control corrects a bad guess within a few steps.
constexpr double kDefaultInitialStepFraction = 1e-3;
// The step may not fall below kMinStepRoundoffs * eps * max(|t|, t_end - t_start): smaller
// steps no longer change t reliably (RADAU5 stops at 10 eps |t|).
constexpr double kMinStepRoundoffs = 10.0;
// The error norm is floored at this (RADAU5's 1e-10) so that err^(1/4) stays finite and the
// step grows by the maximum factor on a problem that the method solves exactly.
constexpr double kMinErrorNorm = 1e-10;
// Gustafsson's predictive controller uses the previous accepted error, floored at this
// (RADAU5's value) so that one tiny error does not make the prediction too bold.
constexpr double kGustafssonMinPreviousError = 1e-2;
// A proposed growth of the step by less than this factor is not taken when the Jacobian is
// kept: the step and the factorized Newton matrices then stay as they are (RADAU5's QUOT1 = 1,
// QUOT2 = 1.2). Besides saving the factorization, a constant step keeps the error of index-3
// components smooth, which depends on the ratio of successive steps and would otherwise make
// the controller oscillate.
constexpr double kMaxUntakenGrowth = 1.2;

// Newton: the contraction rate theta is estimated from successive increments. At or above
// kMaxContraction the iteration is not converging. At or below kJacobianReuseContraction the
// Jacobian was good enough to keep for the next step (RADAU5's THET = 0.001).
constexpr double kMaxContraction = 0.99;
constexpr double kJacobianReuseContraction = 1e-3;
// The remaining-error factor eta = theta / (1 - theta) of the last step starts the next one as
// max(eta, eps)^0.8 (RADAU5's FACCON): a little more cautious than the last rate.
constexpr double kNewtonRateMemoryExponent = 0.8;
// When Newton would need more iterations than allowed, RADAU5 shrinks the step by
// 0.8 * excess^(-1 / (3 + iterations left)), with the predicted excess clamped to [1e-4, 20]
// so that the cut is neither negligible nor drastic.
constexpr double kSlowNewtonSafety = 0.8;
constexpr double kSlowNewtonMinExcess = 1e-4;
constexpr double kSlowNewtonMaxExcess = 20.0;

// Euler backward accepts a Newton iteration that has stalled (an increment at least this
// fraction of the previous one) with increments within this many Newton tolerances: at most
// a few percent of the scaled tolerance, far below the method's own first-order error.
constexpr double kEulerRoundoffAcceptance = 100.0;
constexpr double kEulerStallRatio = 0.5;
// Steps shorter than this fraction of fixed_step are merged into their neighbour (a breakpoint
// within it of a grid point replaces the grid point): a tiny step adds nothing, and the Newton
// matrix A / h - J of an index-3 problem has a condition number ~ h^-3.
constexpr double kEulerSliverFraction = 0.01;

// The tolerances the error estimate is held to (RADAU5's transformation): 0.1 rtol^(2/3), with
// atol scaled alike. The embedded estimate is of order 3, the method of order 5, so the true
// local error is far below the estimate; this calibration (Hairer & Wanner's, from their test
// set) makes the error of index-1 components come out near the requested tolerance instead
// of orders of magnitude below it, at a fraction of the steps.
struct Tolerances {
  double rtol;
  double atol;
};

Tolerances CalibratedTolerances(const RadauOptions& options) {
  const double rtol = 0.1 * std::pow(options.rtol, 2.0 / 3.0);
  return {rtol, options.atol * rtol / options.rtol};
}

// Newton stops when its estimated remaining error, measured in units of the error tolerance,
// is below this (RADAU5's FNEWT, SciPy's newton_tol): sqrt(rtol), at most 0.03, keeps it well
// below the local error; 10 eps / rtol is the level at which round-off in x takes over.
double NewtonTolerance(double rtol) {
  return std::max(10.0 * kRoundoff / rtol, std::min(0.03, std::sqrt(rtol)));
}

// sqrt(mean((values_ij / scale_i)^2)): the norm in which every test of this file is made.
template <typename Values>
double ScaledRms(const Values& values, const VectorXd& scale) {
  const double sum = (values.array().colwise() / scale.array()).matrix().squaredNorm();
  return std::sqrt(sum / double(values.size()));
}

template <typename Decomposition>
bool HasRegularPivots(const Decomposition& lu) {
  return (lu.matrixLU().diagonal().array() != 0.0).all() && lu.matrixLU().allFinite();
}

// The 3-stage Radau IIA method in the form the simplified Newton iteration uses.
struct RadauTableau {
  Eigen::Vector3d nodes;                 // c = ((4 - sqrt 6) / 10, (4 + sqrt 6) / 10, 1)
  Eigen::Matrix3d inverse_coefficients;  // A_b^-1
  // A_b^-1 = T Lambda T^-1 with Lambda = diag(gamma, [alpha -beta; beta alpha]): in these
  // coordinates the 3n x 3n Newton system splits into one real and one complex n x n system.
  Eigen::Matrix3d from_eigenbasis;  // T
  Eigen::Matrix3d to_eigenbasis;    // T^-1
  double real_eigenvalue = 0.0;     // gamma = 3 + 3^(2/3) - 3^(1/3) = 3.6378...
  Complex complex_eigenvalue;       // alpha + i beta
  // Weights of the embedded error estimate (Hairer & Wanner IV.8, RADAU5's DD1..DD3).
  Eigen::Vector3d error_weights;
};

RadauTableau BuildRadauTableau() {
  RadauTableau tableau;
  const double root6 = std::sqrt(6.0);
  tableau.nodes << (4.0 - root6) / 10.0, (4.0 + root6) / 10.0, 1.0;
  // A_b from the collocation conditions C(3): sum_j a_ij c_j^(k-1) = c_i^k / k, k = 1, 2, 3.
  Eigen::Matrix3d node_powers;
  Eigen::Matrix3d integrated_powers;
  for (Index i = 0; i < 3; ++i) {
    for (Index k = 0; k < 3; ++k) {
      node_powers(i, k) = std::pow(tableau.nodes(i), double(k));
      integrated_powers(i, k) = std::pow(tableau.nodes(i), double(k + 1)) / double(k + 1);
    }
  }
  const Eigen::Matrix3d coefficients = integrated_powers * node_powers.inverse();
  tableau.inverse_coefficients = coefficients.inverse();

  const Eigen::EigenSolver<Eigen::Matrix3d> eigen(tableau.inverse_coefficients);
  Index real_index = 0;
  for (Index i = 1; i < 3; ++i) {
    if (std::abs(eigen.eigenvalues()(i).imag()) <
        std::abs(eigen.eigenvalues()(real_index).imag())) {
      real_index = i;
    }
  }
  const Index complex_index = real_index == 0 ? 1 : 0;
  tableau.from_eigenbasis.col(0) = eigen.eigenvectors().col(real_index).real();
  tableau.from_eigenbasis.col(1) = eigen.eigenvectors().col(complex_index).real();
  tableau.from_eigenbasis.col(2) = eigen.eigenvectors().col(complex_index).imag();
  tableau.to_eigenbasis = tableau.from_eigenbasis.inverse();
  // Read Lambda off rather than assume a sign convention of the eigenvectors: its 2 x 2 block
  // [a -b; b a] acts on (w_2, w_3) as multiplication by a + i b acts on w_2 + i w_3.
  const Eigen::Matrix3d lambda =
      tableau.to_eigenbasis * tableau.inverse_coefficients * tableau.from_eigenbasis;
  tableau.real_eigenvalue = lambda(0, 0);
  tableau.complex_eigenvalue = Complex(lambda(1, 1), lambda(2, 1));

  tableau.error_weights << -(13.0 + 7.0 * root6) / 3.0, (-13.0 + 7.0 * root6) / 3.0, -1.0 / 3.0;
  return tableau;
}

const RadauTableau& Tableau() {
  static const RadauTableau tableau = BuildRadauTableau();
  return tableau;
}

// Hairer & Wanner's stopping rule for the simplified Newton iteration (IV.8): from the
// contraction rate theta of successive increments, the error left after an increment of norm
// |dZ| is about eta |dZ| with eta = theta / (1 - theta); stop when that is below the tolerance,
// give up when theta >= 1 or when the predicted error after the remaining iterations is still
// too large.
class NewtonMonitor {
 public:
  enum class Verdict { kContinue, kConverged, kFailed };

  NewtonMonitor(double tolerance, int max_iterations, double previous_rate)
      : tolerance_(tolerance),
        max_iterations_(max_iterations),
        rate_(std::pow(std::max(previous_rate, kRoundoff), kNewtonRateMemoryExponent)) {}

  // Judges the increment just computed (scaled norm `norm`); kFailed means: do not apply it.
  Verdict Judge(double norm) {
    ++iterations_;
    if (!std::isfinite(norm)) return Fail(kFailureStepFactor);
    if (iterations_ >= 2) {
      const double ratio = norm / previous_norm_;
      contraction_ = iterations_ == 2 ? ratio : std::sqrt(ratio * previous_ratio_);
      previous_ratio_ = ratio;
      if (contraction_ >= kMaxContraction) return Fail(kFailureStepFactor);
      rate_ = contraction_ / (1.0 - contraction_);
      const int iterations_left = max_iterations_ - iterations_;
      const double predicted_excess =
          rate_ * norm * std::pow(contraction_, double(iterations_left)) / tolerance_;
      if (predicted_excess >= 1.0) {
        const double excess =
            std::clamp(predicted_excess, kSlowNewtonMinExcess, kSlowNewtonMaxExcess);
        return Fail(kSlowNewtonSafety * std::pow(excess, -1.0 / (3.0 + iterations_left)));
      }
    }
    previous_norm_ = std::max(norm, kRoundoff);
    if (rate_ * norm <= tolerance_) return Verdict::kConverged;
    if (iterations_ >= max_iterations_) return Fail(kFailureStepFactor);
    return Verdict::kContinue;
  }

  int iterations() const { return iterations_; }
  // eta of the last iteration: what the next step starts from.
  double rate() const { return rate_; }
  // theta; 0 when the first increment already met the tolerance.
  double contraction() const { return contraction_; }
  // By how much to multiply the step after kFailed.
  double step_factor() const { return step_factor_; }

 private:
  Verdict Fail(double step_factor) {
    step_factor_ = step_factor;
    return Verdict::kFailed;
  }

  double tolerance_;
  int max_iterations_;
  double rate_;
  int iterations_ = 0;
  double contraction_ = 0.0;
  double previous_norm_ = 0.0;
  double previous_ratio_ = 0.0;
  double step_factor_ = kFailureStepFactor;
};

// Why the last step attempt failed; reported when the step cannot shrink any further.
enum class FailureKind { kEvaluation, kNewton, kErrorTest };

struct StepFailure {
  FailureKind kind = FailureKind::kErrorTest;
  double time = 0.0;
  double step = 0.0;
  std::string why;  // Evaluate()'s reason, for kEvaluation
};

// What a run is given, as IntegrateRadau received it: the same for both methods.
struct RunSetup {
  LinearlyImplicitDae& dae;
  double t_start;
  const VectorXd& x_start;
  double t_end;
  const std::vector<double>& breakpoints;
  const RadauOptions& options;
  const StepObserver& observer;
  DenseOutput* dense_output;
};

// What Radau IIA and Euler backward share: the current point, the breakpoints, the error
// scale, the bookkeeping of the summary and the observer.
class IntegrationRun {
 protected:
  // `tolerances`: those the error scale is made of (Radau IIA calibrates the asked ones).
  IntegrationRun(const RunSetup& setup, Tolerances tolerances)
      : dae_(setup.dae),
        options_(setup.options),
        tolerances_(tolerances),
        observer_(setup.observer),
        dense_output_(setup.dense_output),
        size_(setup.dae.size()),
        t_start_(setup.t_start),
        t_end_(setup.t_end),
        t_(setup.t_start),
        x_(setup.x_start),
        new_x_(setup.x_start),
        scale_(size_),
        mass_(size_, size_),
        rhs_(size_) {
    for (const double time : setup.breakpoints) {
      if (time > t_start_ && time < t_end_) breakpoints_.push_back(time);
    }
    std::sort(breakpoints_.begin(), breakpoints_.end());
    for (const int index : setup.dae.ComponentIndices()) index_exponents_.push_back(index - 1);
  }

  // A and phi at the start point, then the observer; false (summary_ filled) when either fails.
  bool Begin() {
    if (!EvaluateDae(t_, x_, mass_, rhs_)) {
      RecordEvaluationFailure(t_, 0.0);
      Finish(SolveStatus::kNoConvergence, FailureMessage());
      return false;
    }
    if (observer_ && !observer_(t_, x_)) {
      FinishInterrupted();
      return false;
    }
    return true;
  }

  // Evaluate() with counting and a check for non-finite values; false leaves the reason in why_.
  bool EvaluateDae(double t, const VectorXd& x, MatrixXd& mass, VectorXd& rhs) {
    ++summary_.function_evaluations;
    if (!dae_.Evaluate(t, x, mass, rhs, why_)) return false;
    if (!rhs.allFinite() || !mass.allFinite()) {
      why_ =
          "the equations are not finite (NaN or Inf) at this state: the model's forces, "
          "inputs or outputs overflow or divide by zero there";
      return false;
    }
    return true;
  }

  bool EvaluateJacobian(double t, const VectorXd& x, const VectorXd& rhs, MatrixXd& jacobian) {
    ++summary_.jacobian_evaluations;
    if (!dae_.RhsJacobian(t, x, rhs, jacobian, why_)) return false;
    if (!jacobian.allFinite()) {
      why_ =
          "the equations' Jacobian is not finite (NaN or Inf) at this state: the model's "
          "derivatives overflow or divide by zero there (a singular configuration?)";
      return false;
    }
    return true;
  }

  void RecordEvaluationFailure(double time, double step) {
    failure_ = {FailureKind::kEvaluation, time, step, why_};
  }
  void RecordFailure(FailureKind kind, double time, double step) {
    failure_.kind = kind;
    failure_.time = time;
    failure_.step = step;
  }

  // Where the step from t_ must end: the first breakpoint beyond t_ + min_gap, else t_end
  // (a breakpoint closer than min_gap is passed over: the step to it would be meaningless).
  double NextStop(double min_gap) const {
    const auto next = std::upper_bound(breakpoints_.begin(), breakpoints_.end(), t_ + min_gap);
    return next == breakpoints_.end() ? t_end_ : *next;
  }

  double MinStep() const {
    return kMinStepRoundoffs * kRoundoff * std::max(std::abs(t_), t_end_ - t_start_);
  }

  // scale_i = (atol + rtol max(|x_i|, |other_i|)) / h^(k_i - 1) for an index-k_i component
  // (Sect. VII.8): the local error of an index-k component is k - 1 orders lower, and measuring
  // it against the plain tolerance would force needlessly small steps.
  void ComputeScale(const VectorXd& other, double h, VectorXd& scale) const {
    const double index_factors[3] = {1.0, h, h * h};
    for (Index i = 0; i < size_; ++i) {
      const double magnitude = std::max(std::abs(x_(i)), std::abs(other(i)));
      scale(i) = (tolerances_.atol + tolerances_.rtol * magnitude) /
                 index_factors[index_exponents_[std::size_t(i)]];
    }
  }

  // The accepted step's polynomial (through x_ at t_ and its stage values) as a piece of the
  // dense output; callers check dense_output_ first, so that a run without one builds nothing.
  void RecordPiece(const std::vector<double>& times, const std::vector<VectorXd>& values) {
    dense_output_->AppendPiece(times, values);
  }

  // Moves to (t_new, new_x_) and shows it to the observer; false when the observer says stop.
  bool AcceptStep(double t_new) {
    t_ = t_new;
    x_.swap(new_x_);
    ++summary_.steps;
    return !observer_ || observer_(t_, x_);
  }

  SolveSummary& Finish(SolveStatus status, std::string message) {
    summary_.status = status;
    summary_.message = std::move(message);
    summary_.stop_time = t_;
    return summary_;
  }
  SolveSummary& FinishConverged() {
    return Finish(SolveStatus::kConverged, "reached t = " + FormatNumber(t_) + " s in " +
                                               std::to_string(summary_.steps) + " steps");
  }
  SolveSummary& FinishTooManySteps() {
    return Finish(SolveStatus::kTooManySteps,
                  "at t = " + FormatNumber(t_) +
                      " s: max_steps = " + std::to_string(options_.max_steps) +
                      " steps taken before t_end = " + FormatNumber(t_end_));
  }
  SolveSummary& FinishInterrupted() {
    return Finish(SolveStatus::kInterrupted,
                  "interrupted by the observer at t = " + FormatNumber(t_) + " s");
  }
  // The step has shrunk as far as it may and still fails: report the last reason.
  SolveSummary& FinishAfterFailure() {
    const SolveStatus status = failure_.kind == FailureKind::kErrorTest
                                   ? SolveStatus::kStepSizeTooSmall
                                   : SolveStatus::kNoConvergence;
    return Finish(status, FailureMessage());
  }

  std::string FailureMessage() const {
    const std::string where = "at t = " + FormatNumber(failure_.time) + " s: ";
    switch (failure_.kind) {
      case FailureKind::kEvaluation:
        return where + failure_.why;
      case FailureKind::kNewton:
        return where + "Newton's method did not converge " +
               (options_.stages == 1 ? "with the fixed step " + FormatNumber(failure_.step) +
                                           " (Euler backward keeps its step; the Newton matrix "
                                           "of an index-3 DAE has a condition number ~ h^-3: "
                                           "a larger step, or Radau IIA, gets past it)"
                                     : "even with step size " + FormatNumber(failure_.step));
      case FailureKind::kErrorTest:
        break;
    }
    return where + "the local error test failed with step size " + FormatNumber(failure_.step) +
           ", the smallest allowed (round-off of t)";
  }

  LinearlyImplicitDae& dae_;
  const RadauOptions& options_;
  const Tolerances tolerances_;  // what scale_ is made of
  const StepObserver& observer_;
  DenseOutput* dense_output_;
  const Index size_;
  const double t_start_;
  const double t_end_;
  std::vector<double> breakpoints_;   // sorted, inside (t_start, t_end)
  std::vector<int> index_exponents_;  // differentiation index - 1, per component
  double t_;
  VectorXd x_;      // the solution at t_
  VectorXd new_x_;  // the solution at the end of the step being tried
  VectorXd scale_;  // atol + rtol |x| over h^(index - 1), per component
  MatrixXd mass_;   // A(t_, x_)
  VectorXd rhs_;    // phi(t_, x_)
  SolveSummary summary_;
  StepFailure failure_;
  std::string why_;  // the reason of the last failed evaluation
};

// Radau IIA of order 5 with RADAU5's error estimate and step-size control.
class RadauIIARun : private IntegrationRun {
 public:
  explicit RadauIIARun(const RunSetup& setup)
      : IntegrationRun(setup, CalibratedTolerances(setup.options)),
        tableau_(Tableau()),
        newton_tolerance_(NewtonTolerance(tolerances_.rtol)),
        jacobian_(size_, size_),
        real_matrix_(size_, size_),
        complex_matrix_(size_, size_),
        real_lu_(size_),
        complex_lu_(size_),
        stages_(size_, 3),
        derivatives_(size_, 3),
        residuals_(size_, 3),
        transformed_(size_, 3),
        increments_(size_, 3),
        complex_rhs_(size_),
        complex_solution_(size_),
        stage_x_(size_),
        stage_mass_(size_, size_),
        stage_rhs_(size_),
        new_mass_(size_, size_),
        new_rhs_(size_),
        error_(size_),
        error_rhs_(size_),
        weighted_stages_(size_),
        mass_weighted_stages_(size_),
        divided_differences_(size_, 3) {}

  SolveSummary Run();

 private:
  enum class JacobianState { kMissing, kCurrent, kReused };

  double InitialStep() const {
    const double step = options_.initial_step > 0.0
                            ? options_.initial_step
                            : kDefaultInitialStepFraction * (t_end_ - t_start_);
    return std::min(step, options_.max_step);
  }
  bool FitStepTo(double stop);
  bool UpdateJacobian();
  bool FactorNewtonMatrices(double h);
  void PredictStages(double h);
  bool ComputeStageResiduals(double h);
  void SolveNewtonSystems();
  bool SolveStages(double h, NewtonMonitor& monitor);
  bool EstimateError(double h, bool refine, double& error);
  double StepQuotient(double error, int newton_iterations) const;
  void Reject(double step_factor);
  double ProposeNextStep(double error, double quotient);
  void PrepareNextStep(const NewtonMonitor& newton, bool at_breakpoint, double next_step);
  void RememberCollocationPolynomial(double h);

  const RadauTableau& tableau_;
  const double newton_tolerance_;
  // The step-size controller.
  double step_ = 0.0;  // the step being tried
  bool first_step_ = true;
  bool after_rejection_ = false;
  // Gustafsson's predictive controller needs the previous accepted step and its error.
  bool have_previous_step_ = false;
  double previous_step_ = 0.0;
  double previous_error_ = 0.0;
  // Newton.
  double newton_rate_ = 1.0;  // eta of the last Newton iteration (RADAU5's FACCON)
  JacobianState jacobian_state_ = JacobianState::kMissing;
  MatrixXd jacobian_;  // d phi / dx, at t_ or at an earlier point (kReused)
  // The step for which real_lu_ and complex_lu_ hold the Newton matrices; 0 when they must be
  // factorized anew (new Jacobian, new step, or after a failure).
  double factored_step_ = 0.0;
  MatrixXd real_matrix_;             // gamma / h A - J
  Eigen::MatrixXcd complex_matrix_;  // (alpha + i beta) / h A - J
  Eigen::PartialPivLU<MatrixXd> real_lu_;
  Eigen::PartialPivLU<Eigen::MatrixXcd> complex_lu_;
  MatrixXd stages_;       // Z
  MatrixXd derivatives_;  // K
  MatrixXd residuals_;    // phi_i - A_i K_i
  MatrixXd transformed_;  // residuals and then increments in the eigenbasis
  MatrixXd increments_;   // the Newton correction of Z
  Eigen::VectorXcd complex_rhs_;
  Eigen::VectorXcd complex_solution_;
  VectorXd stage_x_;
  MatrixXd stage_mass_;
  VectorXd stage_rhs_;
  MatrixXd new_mass_;  // A and phi at the end of the step being tried
  VectorXd new_rhs_;
  VectorXd error_;
  VectorXd error_rhs_;
  VectorXd weighted_stages_;
  VectorXd mass_weighted_stages_;
  // The last accepted step's collocation polynomial, for the next Newton starting values.
  MatrixXd divided_differences_;
  double polynomial_step_ = 0.0;
  bool have_polynomial_ = false;
};

bool RadauIIARun::FactorNewtonMatrices(double h) {
  real_matrix_ = (tableau_.real_eigenvalue / h) * mass_ - jacobian_;
  real_lu_.compute(real_matrix_);
  complex_matrix_ =
      (tableau_.complex_eigenvalue / h) * mass_.cast<Complex>() - jacobian_.cast<Complex>();
  complex_lu_.compute(complex_matrix_);
  factored_step_ = h;
  return HasRegularPivots(real_lu_) && HasRegularPivots(complex_lu_);
}

// Starting values from the last step's collocation polynomial (RADAU5), else zero: the first
// step, and after a breakpoint, where the solution is not smooth.
void RadauIIARun::PredictStages(double h) {
  if (!have_polynomial_) {
    stages_.setZero();
    return;
  }
  const double c1 = tableau_.nodes(0);
  const double c2 = tableau_.nodes(1);
  for (Index i = 0; i < 3; ++i) {
    const double s = tableau_.nodes(i) * h / polynomial_step_;
    stages_.col(i) = s * (divided_differences_.col(0) +
                          (s - (c2 - 1.0)) * (divided_differences_.col(1) +
                                              (s - (c1 - 1.0)) * divided_differences_.col(2)));
  }
}

// The polynomial through the step's points relative to the new point x_{n+1}, in units of the
// step s = (t - t_{n+1}) / h: value 0 at s = 0, Z_2 - Z_3 at c_2 - 1, Z_1 - Z_3 at c_1 - 1 and
// -Z_3 at -1, kept as Newton divided differences on these nodes in that order.
void RadauIIARun::RememberCollocationPolynomial(double h) {
  const double c1 = tableau_.nodes(0);
  const double c2 = tableau_.nodes(1);
  for (Index i = 0; i < size_; ++i) {
    const double z1 = stages_(i, 0);
    const double z2 = stages_(i, 1);
    const double z3 = stages_(i, 2);
    const double first_01 = (z2 - z3) / (c2 - 1.0);
    const double first_12 = (z1 - z2) / (c1 - c2);
    const double first_23 = z1 / c1;
    const double second_012 = (first_12 - first_01) / (c1 - 1.0);
    const double second_123 = (first_12 - first_23) / c2;
    divided_differences_(i, 0) = first_01;
    divided_differences_(i, 1) = second_012;
    divided_differences_(i, 2) = second_012 - second_123;
  }
  polynomial_step_ = h;
  have_polynomial_ = true;
}

// residuals_.col(i) = phi(t_i, X_i) - A(t_i, X_i) K_i: the true stage equations, with the mass
// matrix at each stage even though the Newton matrix freezes it at (t_, x_).
bool RadauIIARun::ComputeStageResiduals(double h) {
  derivatives_.noalias() = stages_ * tableau_.inverse_coefficients.transpose();
  derivatives_ /= h;
  for (Index i = 0; i < 3; ++i) {
    const double stage_time = t_ + tableau_.nodes(i) * h;
    stage_x_ = x_ + stages_.col(i);
    if (!EvaluateDae(stage_time, stage_x_, stage_mass_, stage_rhs_)) {
      RecordEvaluationFailure(stage_time, h);
      return false;
    }
    residuals_.col(i) = stage_rhs_;
    residuals_.col(i).noalias() -= stage_mass_ * derivatives_.col(i);
  }
  return true;
}

// Solves ((1/h) A_b^-1 (x) A - I (x) J) dZ = residuals in the eigenbasis of A_b^-1, where it is
// one real and one complex n x n system (Hairer & Wanner IV.8).
void RadauIIARun::SolveNewtonSystems() {
  transformed_.noalias() = residuals_ * tableau_.to_eigenbasis.transpose();
  increments_.col(0) = real_lu_.solve(transformed_.col(0));
  complex_rhs_.real() = transformed_.col(1);
  complex_rhs_.imag() = transformed_.col(2);
  complex_solution_ = complex_lu_.solve(complex_rhs_);
  increments_.col(1) = complex_solution_.real();
  increments_.col(2) = complex_solution_.imag();
  transformed_.noalias() = increments_ * tableau_.from_eigenbasis.transpose();
  increments_ = transformed_;
}

// Simplified Newton on the stage equations from the starting values in stages_; true when it
// converged (stages_ then holds Z), false with the reason recorded.
bool RadauIIARun::SolveStages(double h, NewtonMonitor& monitor) {
  for (;;) {
    if (!ComputeStageResiduals(h)) return false;
    SolveNewtonSystems();
    ++summary_.newton_iterations;
    const NewtonMonitor::Verdict verdict = monitor.Judge(ScaledRms(increments_, scale_));
    newton_rate_ = monitor.rate();
    if (verdict == NewtonMonitor::Verdict::kFailed) {
      RecordFailure(FailureKind::kNewton, t_, h);
      return false;
    }
    stages_ += increments_;
    if (verdict == NewtonMonitor::Verdict::kConverged) return true;
  }
}

// RADAU5's error estimate for A x' = phi (its ESTRAD): err = E1^-1 (phi(t_n, x_n) + A F) with
// F = (d_1 Z_1 + d_2 Z_2 + d_3 Z_3) / h and E1 = gamma / h A - J; the solve with E1 damps the
// estimate of stiff components, which would otherwise be grossly overestimated. On the first
// step and after a rejection a large estimate is refined once with phi at x_n + err in place
// of phi(t_n, x_n) (Hairer & Wanner IV.8). `error` is the scaled RMS norm.
bool RadauIIARun::EstimateError(double h, bool refine, double& error) {
  weighted_stages_.noalias() = stages_ * tableau_.error_weights;
  weighted_stages_ /= h;
  mass_weighted_stages_.noalias() = mass_ * weighted_stages_;
  error_rhs_ = rhs_ + mass_weighted_stages_;
  error_ = real_lu_.solve(error_rhs_);
  error = ScaledRms(error_, scale_);
  // A failed evaluation at the perturbed point keeps the first, larger, estimate.
  if (refine && error >= 1.0) {
    stage_x_ = x_ + error_;
    if (EvaluateDae(t_, stage_x_, stage_mass_, stage_rhs_)) {
      error_rhs_ = stage_rhs_ + mass_weighted_stages_;
      error_ = real_lu_.solve(error_rhs_);
      error = ScaledRms(error_, scale_);
    }
  }
  error = std::max(error, kMinErrorNorm);
  return std::isfinite(error);
}

// h_new = h / quotient (RADAU5): the safety factor drops from 0.9 as Newton needs more of its
// allowed iterations, since a step that barely converged is a poor base to grow from.
double RadauIIARun::StepQuotient(double error, int newton_iterations) const {
  const int max_iterations = options_.max_newton_iterations;
  const double safety = std::min(
      kSafety, kSafety * (2.0 * max_iterations + 1.0) / (2.0 * max_iterations + newton_iterations));
  return std::clamp(std::pow(error, kErrorExponent) / safety, 1.0 / kMaxStepGrowth, kMaxStepShrink);
}

// Shortens step_ to max_step and so that it ends exactly on `stop`; true when it does.
bool RadauIIARun::FitStepTo(double stop) {
  const double remaining = stop - t_;
  step_ = std::min(step_, options_.max_step);
  if (step_ >= remaining) {
    step_ = remaining;
    return true;
  }
  if (2.0 * step_ > remaining) step_ = remaining / 2.0;  // two equal steps, not one and a sliver
  return false;
}

bool RadauIIARun::UpdateJacobian() {
  if (!EvaluateJacobian(t_, x_, rhs_, jacobian_)) {
    RecordEvaluationFailure(t_, step_);
    return false;
  }
  jacobian_state_ = JacobianState::kCurrent;
  factored_step_ = 0.0;
  return true;
}

// A failed attempt: an old Jacobian may be the cause, so the next attempt computes it anew.
void RadauIIARun::Reject(double step_factor) {
  ++summary_.rejected_steps;
  factored_step_ = 0.0;
  if (jacobian_state_ == JacobianState::kReused) jacobian_state_ = JacobianState::kMissing;
  step_ *= step_factor;
  after_rejection_ = true;
}

// The step after an accepted one: h / quotient, with Gustafsson's predictive controller
// (Hairer & Wanner IV.8) shrinking it further when the error grows from step to step, and no
// growth right after a rejection.
double RadauIIARun::ProposeNextStep(double error, double quotient) {
  if (have_previous_step_) {
    const double predictive = previous_step_ / step_ *
                              std::pow(error * error / previous_error_, kErrorExponent) / kSafety;
    quotient = std::max(quotient, std::clamp(predictive, 1.0 / kMaxStepGrowth, kMaxStepShrink));
  }
  previous_step_ = step_;
  previous_error_ = std::max(kGustafssonMinPreviousError, error);
  const double next_step = step_ / quotient;
  return after_rejection_ ? std::min(next_step, step_) : next_step;
}

// Carries over what the accepted step leaves for the next: A and phi at the new point, the
// collocation polynomial, the Jacobian when Newton converged fast with it, and the step with
// its factorization when the controller proposes only a small growth.
void RadauIIARun::PrepareNextStep(const NewtonMonitor& newton,
                                  bool at_breakpoint,
                                  double next_step) {
  mass_.swap(new_mass_);
  rhs_.swap(new_rhs_);
  RememberCollocationPolynomial(step_);
  jacobian_state_ = newton.contraction() <= kJacobianReuseContraction ? JacobianState::kReused
                                                                      : JacobianState::kMissing;
  have_previous_step_ = true;
  if (at_breakpoint) {
    // Beyond a breakpoint phi is another function: nothing of this step predicts the next.
    have_polynomial_ = false;
    have_previous_step_ = false;
    jacobian_state_ = JacobianState::kMissing;
  }
  const bool keep_step = jacobian_state_ == JacobianState::kReused && next_step >= step_ &&
                         next_step <= kMaxUntakenGrowth * step_;
  if (keep_step) {
    next_step = step_;
  } else {
    factored_step_ = 0.0;
  }
  step_ = next_step;
  first_step_ = false;
  after_rejection_ = false;
}

SolveSummary RadauIIARun::Run() {
  if (!Begin()) return summary_;
  step_ = InitialStep();
  while (t_ < t_end_) {
    if (summary_.steps >= options_.max_steps) return FinishTooManySteps();
    const double stop = NextStop(MinStep());
    const bool lands = FitStepTo(stop);
    // A step that lands may be shorter than round-off of t (a t_end just beyond t_start); one
    // that must shrink that far has failed.
    if (!lands && step_ < MinStep()) return FinishAfterFailure();
    if (jacobian_state_ == JacobianState::kMissing && !UpdateJacobian()) {
      return FinishAfterFailure();
    }
    if (step_ != factored_step_ && !FactorNewtonMatrices(step_)) {
      RecordFailure(FailureKind::kNewton, t_, step_);
      Reject(kFailureStepFactor);
      continue;
    }

    ComputeScale(x_, step_, scale_);
    PredictStages(step_);
    NewtonMonitor newton(newton_tolerance_, options_.max_newton_iterations, newton_rate_);
    if (!SolveStages(step_, newton)) {
      Reject(newton.step_factor());
      continue;
    }
    new_x_ = x_ + stages_.col(2);
    ComputeScale(new_x_, step_, scale_);
    double error = 0.0;
    if (!EstimateError(step_, first_step_ || after_rejection_, error)) {
      RecordFailure(FailureKind::kNewton, t_, step_);
      Reject(kFailureStepFactor);
      continue;
    }
    const double quotient = StepQuotient(error, newton.iterations());
    if (error >= 1.0) {
      RecordFailure(FailureKind::kErrorTest, t_, step_);
      Reject(first_step_ ? kFirstStepRejectionFactor : 1.0 / quotient);
      continue;
    }
    const double t_new = lands ? stop : t_ + step_;
    if (!EvaluateDae(t_new, new_x_, new_mass_, new_rhs_)) {
      RecordEvaluationFailure(t_new, step_);
      Reject(kFailureStepFactor);
      continue;
    }

    // The collocation polynomial: x_ at t_, the stage values at t_ + c_i h (the last is new_x_).
    if (dense_output_) {
      RecordPiece({t_, t_ + tableau_.nodes(0) * step_, t_ + tableau_.nodes(1) * step_, t_new},
                  {x_, x_ + stages_.col(0), x_ + stages_.col(1), new_x_});
    }
    PrepareNextStep(newton, lands && stop < t_end_, ProposeNextStep(error, quotient));
    if (!AcceptStep(t_new)) return FinishInterrupted();
  }
  return FinishConverged();
}

// Euler backward on the grid t_start + k fixed_step (the paper's Eqs. 61-64 on the projected
// servo constraints): x_{n+1} = x_n + Z with A(t_{n+1}, x_{n+1}) Z / h = phi(t_{n+1}, x_{n+1}),
// solved by Newton with A and J evaluated anew at every iteration.
class EulerBackwardRun : private IntegrationRun {
 public:
  explicit EulerBackwardRun(const RunSetup& setup)
      : IntegrationRun(setup, {setup.options.rtol, setup.options.atol}),
        newton_tolerance_(NewtonTolerance(setup.options.rtol)),
        slope_(VectorXd::Zero(size_)),
        increment_(size_),
        correction_(size_),
        residual_(size_),
        jacobian_(size_, size_),
        newton_matrix_(size_, size_),
        lu_(size_) {}

  SolveSummary Run();

 private:
  double NextTarget() const;
  bool SolveStep(double t_new, double h);

  const double newton_tolerance_;
  double newton_rate_ = 1.0;
  VectorXd slope_;       // (x_n - x_{n-1}) / h of the last step: the predictor of the next
  VectorXd increment_;   // Z
  VectorXd correction_;  // the Newton correction of Z
  VectorXd residual_;    // phi - A Z / h
  MatrixXd jacobian_;
  MatrixXd newton_matrix_;  // A / h - J
  Eigen::PartialPivLU<MatrixXd> lu_;
};

// The next grid point, unless a breakpoint or t_end comes first (or within a sliver after it).
double EulerBackwardRun::NextTarget() const {
  const double grid_step = options_.fixed_step;
  const double grid_position = (t_ - t_start_) / grid_step;
  const double next_grid_point =
      t_start_ + (std::floor(grid_position + kEulerSliverFraction) + 1.0) * grid_step;
  const double stop = NextStop(kEulerSliverFraction * grid_step);
  return stop <= next_grid_point + kEulerSliverFraction * grid_step ? stop : next_grid_point;
}

bool EulerBackwardRun::SolveStep(double t_new, double h) {
  ComputeScale(x_, h, scale_);
  increment_ = h * slope_;
  NewtonMonitor monitor(newton_tolerance_, options_.max_newton_iterations, newton_rate_);
  double previous_norm = std::numeric_limits<double>::infinity();
  for (;;) {
    new_x_ = x_ + increment_;
    if (!EvaluateDae(t_new, new_x_, mass_, rhs_) ||
        !EvaluateJacobian(t_new, new_x_, rhs_, jacobian_)) {
      RecordEvaluationFailure(t_new, h);
      return false;
    }
    residual_ = rhs_;
    residual_.noalias() -= mass_ * increment_ / h;
    newton_matrix_ = mass_ / h - jacobian_;
    lu_.compute(newton_matrix_);
    correction_ = lu_.solve(residual_);
    ++summary_.newton_iterations;
    const double norm = HasRegularPivots(lu_) ? ScaledRms(correction_, scale_)
                                              : std::numeric_limits<double>::infinity();
    NewtonMonitor::Verdict verdict = monitor.Judge(norm);
    newton_rate_ = monitor.rate();
    // Stalled at round-off: increments that no longer shrink, yet are a small fraction of the
    // tolerance (near rest, where |x| ~ 0 leaves atol / h^(k-1) as the scale, the solve's own
    // round-off reaches the Newton tolerance). Euler backward has no error estimate that a
    // further digit would serve, and keeps its step, so it takes the iterate.
    if (verdict == NewtonMonitor::Verdict::kFailed && monitor.iterations() >= 2 &&
        norm <= kEulerRoundoffAcceptance * newton_tolerance_ &&
        norm >= kEulerStallRatio * previous_norm) {
      verdict = NewtonMonitor::Verdict::kConverged;
      newton_rate_ = 1.0;  // no rate to carry over from a stalled iteration
    }
    previous_norm = norm;
    if (verdict == NewtonMonitor::Verdict::kFailed) {
      RecordFailure(FailureKind::kNewton, t_new, h);
      return false;
    }
    increment_ += correction_;
    if (verdict == NewtonMonitor::Verdict::kConverged) {
      new_x_ = x_ + increment_;
      return true;
    }
  }
}

// The paper's method keeps its fixed step. A failed step is not retried with a shorter one:
// the input, the index-3 component, comes from second differences of the positions, and a
// step shorter than its predecessor leaves an error of the previous velocity error over the
// new step (a halving near t = 5.5 s in case 4 wrote F = -80 N, 67 times its largest value).
// The run stops there instead and says why.
SolveSummary EulerBackwardRun::Run() {
  if (!Begin()) return summary_;
  while (t_ < t_end_) {
    if (summary_.steps >= options_.max_steps) return FinishTooManySteps();
    const double t_new = NextTarget();
    const double h = t_new - t_;
    if (!SolveStep(t_new, h)) {
      ++summary_.rejected_steps;
      return FinishAfterFailure();
    }
    slope_ = increment_ / h;
    if (dense_output_) RecordPiece({t_, t_new}, {x_, new_x_});  // Euler's: the straight line
    if (!AcceptStep(t_new)) return FinishInterrupted();
  }
  return FinishConverged();
}

void ValidateProblem(const LinearlyImplicitDae& dae,
                     double t_start,
                     const VectorXd& x_start,
                     double t_end) {
  if (!(std::isfinite(t_start) && std::isfinite(t_end) && t_end >= t_start)) {
    throw UsageError("IntegrateRadau: t_start = " + FormatNumber(t_start) +
                     ", t_end = " + FormatNumber(t_end) + ": must be finite with t_end >= t_start");
  }
  if (x_start.size() != dae.size() || !x_start.allFinite()) {
    throw UsageError("IntegrateRadau: x_start has size " + std::to_string(x_start.size()) +
                     ": must be finite and of the DAE's size " + std::to_string(dae.size()));
  }
  const std::vector<int> indices = dae.ComponentIndices();
  const bool indices_valid = indices.size() == std::size_t(dae.size()) &&
                             std::all_of(indices.begin(), indices.end(),
                                         [](int index) { return index >= 1 && index <= 3; });
  if (!indices_valid) {
    throw UsageError("IntegrateRadau: ComponentIndices() must give 1, 2 or 3 for each of the " +
                     std::to_string(dae.size()) + " components");
  }
}

}  // namespace

void RadauOptions::Validate() const {
  RequireOption(stages == 1 || stages == 3, "RadauOptions", "stages", stages,
                "must be 1 (Euler backward) or 3 (Radau IIA)");
  RequireOption(rtol >= kRadauMinRelativeTolerance && rtol < 1.0, "RadauOptions", "rtol", rtol,
                "must be >= " + FormatNumber(kRadauMinRelativeTolerance) + " and < 1");
  RequireOption(atol >= 0.0 && std::isfinite(atol), "RadauOptions", "atol", atol,
                "must be finite and >= 0");
  RequireOption(initial_step >= 0.0 && std::isfinite(initial_step), "RadauOptions", "initial_step",
                initial_step, "must be finite and >= 0 (0: chosen by the integrator)");
  RequireOption(fixed_step >= 0.0 && std::isfinite(fixed_step), "RadauOptions", "fixed_step",
                fixed_step, "must be finite and >= 0");
  RequireOption(stages != 1 || fixed_step > 0.0, "RadauOptions", "fixed_step", fixed_step,
                "must be > 0 when stages = 1 (Euler backward has no step-size control)");
  RequireOption(max_step > 0.0, "RadauOptions", "max_step", max_step, "must be > 0");
  RequireOption(max_steps >= 1, "RadauOptions", "max_steps", max_steps, "must be >= 1");
  RequireOption(max_newton_iterations >= 1, "RadauOptions", "max_newton_iterations",
                max_newton_iterations, "must be >= 1");
}

SolveSummary IntegrateRadau(LinearlyImplicitDae& dae,
                            double t_start,
                            const Eigen::VectorXd& x_start,
                            double t_end,
                            const std::vector<double>& breakpoints,
                            const RadauOptions& options,
                            const StepObserver& observer,
                            DenseOutput* dense_output) {
  options.Validate();
  ValidateProblem(dae, t_start, x_start, t_end);
  if (dense_output && (!dense_output->empty() || dense_output->size() != dae.size())) {
    throw UsageError("IntegrateRadau: the dense output must be empty and of the DAE's size");
  }
  const RunSetup setup{dae, t_start, x_start, t_end, breakpoints, options, observer, dense_output};
  if (options.stages == 1) return EulerBackwardRun(setup).Run();
  return RadauIIARun(setup).Run();
}

}  // namespace servokit
