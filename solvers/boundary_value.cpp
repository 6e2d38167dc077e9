#include "solvers/boundary_value.h"

#include <Eigen/SparseCore>
#include <Eigen/SparseLU>
#include <algorithm>
#include <cmath>
#include <string>
#include <utility>

#include "models/errors.h"
#include "solvers/solver_messages.h"

// The method of bvp4c (Kierzenka & Shampine, ACM TOMS 27 (2001) 299-316). On a mesh
// t_0 < ... < t_{N-1} with h_i = t_{i+1} - t_i, the unknowns are the mesh values y_i (N n of
// them) and the equations are the Hermite-Simpson (3-point Lobatto IIIA) collocation conditions
//   Phi_i = y_{i+1} - y_i - h_i / 6 (f_i + 4 f_mid + f_{i+1}) = 0,
//   y_mid = (y_i + y_{i+1}) / 2 - h_i / 8 (f_{i+1} - f_i),  f_mid = f(t_i + h_i / 2, y_mid),
// (rows i n .. i n + n - 1) and the boundary conditions g(y_0, y_{N-1}) = 0 (the last n rows).
// Its solution is the C1 cubic S through (t_i, y_i, f_i) that satisfies the ODE at the mesh
// points and the midpoints; the residual S' - f(t, S) at the two other 5-point Lobatto points
// of each interval measures how well the mesh resolves the solution.

namespace servokit {
namespace {

using Eigen::Index;
using Eigen::MatrixXd;
using Eigen::VectorXd;
using SparseMatrix = Eigen::SparseMatrix<double>;

constexpr double kRoundoff = std::numeric_limits<double>::epsilon();

// Newton stops when its next (simplified) correction is below this fraction of the tolerance
// (|dy| <= fraction (atol + tol |y|)), so that its error is negligible against the residual
// test. With tolerance >= kMinTolerance this stays above round-off of y.
constexpr double kNewtonFraction = 1e-2;
constexpr double kMinTolerance = 1e-12;

// Damped Newton halves the step at most this often (factor 2^-10 ~ 1e-3) before giving up.
constexpr int kMaxDampingHalvings = 10;

// An interval whose residual exceeds this multiple of the tolerance is split into three
// instead of two (bvp4c's rule; the residual is O(h^3), so thirds gain a factor 27, halves 8).
constexpr double kSplitInThreeRatio = 100.0;
// Two neighbouring intervals whose residuals are both below tolerance / kMergeRatio become
// one: doubling h multiplies an O(h^3) residual by about 8, which keeps the merged interval
// well within the tolerance, so merging does not undo itself on the next mesh.
constexpr double kMergeRatio = 100.0;

// Forward differences use steps sqrt(eps) max(|y_j|, 1): the balance of truncation and
// round-off for values of order one and above.
const double kDifferenceStep = std::sqrt(kRoundoff);

// The interior points of the 5-point Lobatto rule other than the midpoint, as fractions of
// the interval: (1 -+ sqrt(3/7)) / 2. S' - f vanishes at the ends and at the midpoint.
const double kLobattoOffset = 0.5 * std::sqrt(3.0 / 7.0);

// The C1 cubic Hermite interpolant on [t0, t0 + h] with values y0, y1 and slopes f0, f1, at
// the fraction s of the interval: value and derivative.
template <typename Value, typename Slope>
void Hermite(double h,
             double s,
             const Value& y0,
             const Value& y1,
             const Slope& f0,
             const Slope& f1,
             VectorXd& value,
             VectorXd* derivative) {
  const double s2 = s * s;
  const double s3 = s2 * s;
  value = (2.0 * s3 - 3.0 * s2 + 1.0) * y0 + (h * (s3 - 2.0 * s2 + s)) * f0 +
          (3.0 * s2 - 2.0 * s3) * y1 + (h * (s3 - s2)) * f1;
  if (derivative != nullptr) {
    *derivative = ((6.0 * s2 - 6.0 * s) / h) * (y0 - y1) + (3.0 * s2 - 4.0 * s + 1.0) * f0 +
                  (3.0 * s2 - 2.0 * s) * f1;
  }
}

struct Failure {
  SolveStatus status = SolveStatus::kNoConvergence;
  std::string message;
  double time = std::numeric_limits<double>::quiet_NaN();
};

class BvpSolver {
 public:
  BvpSolver(const BvpRightHandSide& f,
            const BvpJacobian& jacobian,
            const BoundaryConditions& conditions,
            const BoundaryValueOptions& options,
            Index n)
      : f_(f),
        jacobian_(jacobian),
        conditions_(conditions),
        options_(options),
        n_(n),
        y_point_(n),
        f_point_(n),
        f_shifted_(n),
        block_a_(n, n),
        block_b_(n, n),
        product_(n, n),
        bc_residual_(n),
        bc_shifted_(n),
        d_ya_(n, n),
        d_yb_(n, n) {}

  BoundaryValueSolution Solve(std::vector<double> mesh, const std::vector<VectorXd>& guess) {
    SetMesh(std::move(mesh));
    for (Index i = 0; i < points_; ++i) y_.segment(i * n_, n_) = guess[std::size_t(i)];
    std::vector<double> residuals;
    while (true) {
      if (!Newton() || !EstimateResiduals(residuals)) return Finish(false);
      max_residual_ = *std::max_element(residuals.begin(), residuals.end());
      if (max_residual_ <= options_.tolerance) return Finish(true);
      if (!Refine(residuals)) return Finish(false);
    }
  }

 private:
  void SetMesh(std::vector<double> mesh) {
    mesh_ = std::move(mesh);
    points_ = Index(mesh_.size());
    y_.resize(points_ * n_);
    step_.resize(points_ * n_);
    correction_.resize(points_ * n_);
    phi_.resize(points_ * n_);
    trial_.resize(points_ * n_);
    slopes_.resize(n_, points_);
    y_mid_.resize(n_, points_ - 1);
    f_mid_.resize(n_, points_ - 1);
    jacobians_.assign(std::size_t(points_), MatrixXd(n_, n_));
    jacobians_mid_.assign(std::size_t(points_ - 1), MatrixXd(n_, n_));
    pattern_ready_ = false;
  }

  bool CallF(double t, const VectorXd& y, VectorXd& out) {
    std::string why;
    ++summary_.function_evaluations;
    if (!f_(t, y, out, why)) {
      failure_ = {SolveStatus::kNoConvergence,
                  "the right-hand side failed at t = " + FormatNumber(t) + ": " + why, t};
      return false;
    }
    if (out.size() != n_) {
      throw UsageError("SolveBoundaryValueProblem: the right-hand side returned size " +
                       std::to_string(out.size()) + " at t = " + FormatNumber(t) + ", expected " +
                       std::to_string(n_) + " (the size of the guess)");
    }
    if (!out.allFinite()) {
      failure_ = {SolveStatus::kNoConvergence,
                  "the right-hand side is not finite at t = " + FormatNumber(t), t};
      return false;
    }
    return true;
  }

  // df/dy at (t, y) given f(t, y) = f0, by the user's function or forward differences.
  bool CallJacobian(double t, const VectorXd& y, const VectorXd& f0, MatrixXd& out) {
    if (jacobian_) {
      std::string why;
      ++summary_.jacobian_evaluations;
      if (!jacobian_(t, y, out, why)) {
        failure_ = {SolveStatus::kNoConvergence,
                    "the Jacobian df/dy failed at t = " + FormatNumber(t) + ": " + why, t};
        return false;
      }
      if (out.rows() != n_ || out.cols() != n_) {
        throw UsageError("SolveBoundaryValueProblem: the Jacobian returned size " +
                         std::to_string(out.rows()) + " x " + std::to_string(out.cols()) +
                         ", expected " + std::to_string(n_) + " x " + std::to_string(n_));
      }
      return true;
    }
    y_shifted_ = y;
    for (Index j = 0; j < n_; ++j) {
      const double delta = kDifferenceStep * std::max(std::abs(y(j)), 1.0);
      y_shifted_(j) = y(j) + delta;
      if (!CallF(t, y_shifted_, f_shifted_)) return false;
      out.col(j) = (f_shifted_ - f0) / delta;
      y_shifted_(j) = y(j);
    }
    return true;
  }

  void CallConditions(const VectorXd& ya, const VectorXd& yb, VectorXd& out) {
    conditions_.residual(ya, yb, out);
    if (out.size() != n_) {
      throw UsageError("SolveBoundaryValueProblem: the boundary conditions returned " +
                       std::to_string(out.size()) + " residuals, expected " + std::to_string(n_) +
                       " (the size of the guess)");
    }
  }

  // f at the mesh points and midpoints of the mesh values `y`, and the collocation and
  // boundary residuals into phi_. False (with failure_) when f cannot be evaluated.
  bool EvaluateResidual(const VectorXd& y) {
    for (Index i = 0; i < points_; ++i) {
      y_point_ = y.segment(i * n_, n_);
      if (!CallF(mesh_[std::size_t(i)], y_point_, f_point_)) return false;
      slopes_.col(i) = f_point_;
    }
    for (Index i = 0; i + 1 < points_; ++i) {
      const double t = mesh_[std::size_t(i)];
      const double h = mesh_[std::size_t(i + 1)] - t;
      const auto y0 = y.segment(i * n_, n_);
      const auto y1 = y.segment((i + 1) * n_, n_);
      y_point_ = 0.5 * (y0 + y1) - (h / 8.0) * (slopes_.col(i + 1) - slopes_.col(i));
      y_mid_.col(i) = y_point_;
      if (!CallF(t + 0.5 * h, y_point_, f_point_)) return false;
      f_mid_.col(i) = f_point_;
      phi_.segment(i * n_, n_) =
          y1 - y0 - (h / 6.0) * (slopes_.col(i) + 4.0 * f_mid_.col(i) + slopes_.col(i + 1));
    }
    ya_ = y.head(n_);
    yb_ = y.tail(n_);
    CallConditions(ya_, yb_, bc_residual_);
    phi_.tail(n_) = bc_residual_;
    return true;
  }

  // The Jacobian of phi_ at y_ (whose f values EvaluateResidual left in slopes_, f_mid_), as
  // triplets: two n x n blocks per interval and the boundary rows.
  bool AssembleJacobian() {
    for (Index i = 0; i < points_; ++i) {
      y_point_ = y_.segment(i * n_, n_);
      f_point_ = slopes_.col(i);
      if (!CallJacobian(mesh_[std::size_t(i)], y_point_, f_point_, jacobians_[std::size_t(i)])) {
        return false;
      }
    }
    for (Index i = 0; i + 1 < points_; ++i) {
      const double t = mesh_[std::size_t(i)];
      y_point_ = y_mid_.col(i);
      f_point_ = f_mid_.col(i);
      if (!CallJacobian(t + 0.5 * (mesh_[std::size_t(i + 1)] - t), y_point_, f_point_,
                        jacobians_mid_[std::size_t(i)])) {
        return false;
      }
    }
    triplets_.clear();
    triplets_.reserve(std::size_t(2 * points_ * n_ * n_));
    for (Index i = 0; i + 1 < points_; ++i) {
      const double h = mesh_[std::size_t(i + 1)] - mesh_[std::size_t(i)];
      const MatrixXd& j0 = jacobians_[std::size_t(i)];
      const MatrixXd& j1 = jacobians_[std::size_t(i + 1)];
      const MatrixXd& jm = jacobians_mid_[std::size_t(i)];
      // dPhi_i/dy_i and dPhi_i/dy_{i+1}, by the chain rule through y_mid:
      // dy_mid/dy_i = I/2 + h/8 J_i, dy_mid/dy_{i+1} = I/2 - h/8 J_{i+1}.
      product_.noalias() = jm * j0;
      block_a_ = -(h / 6.0) * j0 - (h / 3.0) * jm - (h * h / 12.0) * product_;
      block_a_.diagonal().array() -= 1.0;
      product_.noalias() = jm * j1;
      block_b_ = -(h / 6.0) * j1 - (h / 3.0) * jm + (h * h / 12.0) * product_;
      block_b_.diagonal().array() += 1.0;
      AddBlock(i * n_, i * n_, block_a_);
      AddBlock(i * n_, (i + 1) * n_, block_b_);
    }
    BoundaryJacobians();
    const Index rows = (points_ - 1) * n_;
    AddBlock(rows, 0, d_ya_);
    AddBlock(rows, (points_ - 1) * n_, d_yb_);
    matrix_.resize(points_ * n_, points_ * n_);
    matrix_.setFromTriplets(triplets_.begin(), triplets_.end());
    return true;
  }

  void BoundaryJacobians() {
    ya_ = y_.head(n_);
    yb_ = y_.tail(n_);
    if (conditions_.jacobians) {
      conditions_.jacobians(ya_, yb_, d_ya_, d_yb_);
      if (d_ya_.rows() != n_ || d_ya_.cols() != n_ || d_yb_.rows() != n_ || d_yb_.cols() != n_) {
        throw UsageError("SolveBoundaryValueProblem: the boundary Jacobians must be " +
                         std::to_string(n_) + " x " + std::to_string(n_));
      }
      return;
    }
    CallConditions(ya_, yb_, bc_residual_);
    for (VectorXd* side : {&ya_, &yb_}) {
      MatrixXd& out = side == &ya_ ? d_ya_ : d_yb_;
      for (Index j = 0; j < n_; ++j) {
        const double saved = (*side)(j);
        const double delta = kDifferenceStep * std::max(std::abs(saved), 1.0);
        (*side)(j) = saved + delta;
        CallConditions(ya_, yb_, bc_shifted_);
        out.col(j) = (bc_shifted_ - bc_residual_) / delta;
        (*side)(j) = saved;
      }
    }
  }

  void AddBlock(Index row, Index col, const MatrixXd& block) {
    for (Index c = 0; c < n_; ++c) {
      for (Index r = 0; r < n_; ++r) {
        triplets_.emplace_back(int(row + r), int(col + c), block(r, c));
      }
    }
  }

  // max_k |d_k| / (atol + tol |y_k|), and its root mean square version.
  double MaxScaled(const VectorXd& d) const {
    return (d.array().abs() / (options_.absolute_tolerance + options_.tolerance * y_.array().abs()))
        .maxCoeff();
  }
  double RmsScaled(const VectorXd& d) const {
    const double sum =
        (d.array() / (options_.absolute_tolerance + options_.tolerance * y_.array().abs()))
            .square()
            .sum();
    return std::sqrt(sum / double(d.size()));
  }

  // -J^-1 phi_ with the current factorisation; false if it is not finite.
  bool SolveLinear(VectorXd& out) {
    out = lu_.solve(phi_);
    out = -out;
    return lu_.info() == Eigen::Success && out.allFinite();
  }

  void SingularFailure() {
    failure_ = {SolveStatus::kNoConvergence,
                "singular Jacobian of the collocation equations on a mesh of " +
                    std::to_string(points_) +
                    " points (do the boundary conditions determine the solution?): " +
                    lu_.lastErrorMessage(),
                std::numeric_limits<double>::quiet_NaN()};
  }

  // Damped Newton on all mesh values: affine-invariant natural monotonicity test (Deuflhard,
  // Newton Methods for Nonlinear Problems, Sect. 3.3): a step of length lambda is accepted when
  // the simplified correction J^-1 phi(y + lambda dy) is shorter than (1 - lambda/4) |dy|;
  // otherwise lambda is halved. The same correction ends the iteration when it is below
  // kNewtonFraction of the tolerance (linear problems: after one factorisation).
  bool Newton() {
    if (!EvaluateResidual(y_)) return false;
    for (int iteration = 0; iteration < options_.max_newton_iterations; ++iteration) {
      if (!AssembleJacobian()) return false;
      if (!pattern_ready_) {
        lu_.analyzePattern(matrix_);
        pattern_ready_ = true;
      }
      lu_.factorize(matrix_);
      ++summary_.newton_iterations;
      if (lu_.info() != Eigen::Success || !SolveLinear(step_)) {
        SingularFailure();
        return false;
      }
      if (MaxScaled(step_) <= kNewtonFraction) {
        y_ += step_;
        return EvaluateResidual(y_);
      }
      const double step_norm = RmsScaled(step_);
      double lambda = 1.0;
      bool accepted = false;
      for (int halving = 0; halving <= kMaxDampingHalvings; ++halving, lambda *= 0.5) {
        trial_ = y_ + lambda * step_;
        if (EvaluateResidual(trial_) && SolveLinear(correction_) &&
            RmsScaled(correction_) <= (1.0 - 0.25 * lambda) * step_norm) {
          accepted = true;
          break;
        }
        ++summary_.rejected_steps;
      }
      if (!accepted) {
        if (failure_.message.empty()) {
          failure_.message = "damped Newton could not reduce the correction (down to " +
                             FormatNumber(2.0 * lambda) + " of the step) on a mesh of " +
                             std::to_string(points_) + " points: a better guess or mesh is needed";
        } else {
          failure_.message = "damped Newton: " + failure_.message;
        }
        failure_.status = SolveStatus::kNoConvergence;
        return false;
      }
      y_.swap(trial_);
      if (lambda == 1.0 && MaxScaled(correction_) <= kNewtonFraction) {
        y_ += correction_;
        return EvaluateResidual(y_);
      }
      failure_ = {};
    }
    failure_ = {SolveStatus::kNoConvergence,
                "Newton did not converge in " + std::to_string(options_.max_newton_iterations) +
                    " iterations on a mesh of " + std::to_string(points_) + " points",
                std::numeric_limits<double>::quiet_NaN()};
    return false;
  }

  // The relative residual of the interpolant on each interval (see BoundaryValueOptions):
  // max over components and the two Lobatto points of |S' - f| / max(|f|, atol / tol).
  bool EstimateResiduals(std::vector<double>& residuals) {
    residuals.assign(std::size_t(points_ - 1), 0.0);
    const double floor = options_.absolute_tolerance / options_.tolerance;
    for (Index i = 0; i + 1 < points_; ++i) {
      const double t = mesh_[std::size_t(i)];
      const double h = mesh_[std::size_t(i + 1)] - t;
      for (const double s : {0.5 - kLobattoOffset, 0.5 + kLobattoOffset}) {
        Hermite(h, s, y_.segment(i * n_, n_), y_.segment((i + 1) * n_, n_), slopes_.col(i),
                slopes_.col(i + 1), y_point_, &derivative_);
        if (!CallF(t + s * h, y_point_, f_point_)) return false;
        const double ratio =
            ((derivative_ - f_point_).array().abs() / f_point_.array().abs().max(floor)).maxCoeff();
        residuals[std::size_t(i)] = std::max(residuals[std::size_t(i)], ratio);
      }
    }
    return true;
  }

  // Splits every interval whose residual exceeds the tolerance in two or three, merges pairs
  // of neighbouring intervals whose residuals are both far below it (points left over from
  // refining a poor early solution), and interpolates the solution at the new points as the
  // next guess.
  bool Refine(const std::vector<double>& residuals) {
    const double split_three = kSplitInThreeRatio * options_.tolerance;
    const double merge = options_.tolerance / kMergeRatio;
    std::vector<double> mesh;
    std::vector<VectorXd> guess;
    mesh.reserve(std::size_t(3 * points_));
    guess.reserve(std::size_t(3 * points_));
    bool dropped_previous = false;
    for (Index i = 0; i < points_; ++i) {
      const double t = mesh_[std::size_t(i)];
      // Drop the point between two quiet intervals, but never two points in a row.
      if (i > 0 && i + 1 < points_ && !dropped_previous && residuals[std::size_t(i - 1)] < merge &&
          residuals[std::size_t(i)] < merge) {
        dropped_previous = true;
        continue;
      }
      dropped_previous = false;
      mesh.push_back(t);
      guess.emplace_back(y_.segment(i * n_, n_));
      if (i + 1 == points_) break;
      const double residual = residuals[std::size_t(i)];
      if (residual <= options_.tolerance) continue;
      const int pieces = residual > split_three ? 3 : 2;
      const double h = mesh_[std::size_t(i + 1)] - t;
      for (int k = 1; k < pieces; ++k) {
        const double s = double(k) / double(pieces);
        Hermite(h, s, y_.segment(i * n_, n_), y_.segment((i + 1) * n_, n_), slopes_.col(i),
                slopes_.col(i + 1), y_point_, nullptr);
        mesh.push_back(t + s * h);
        guess.push_back(y_point_);
      }
    }
    if (long(mesh.size()) > options_.max_mesh_points) {
      const auto worst = std::max_element(residuals.begin(), residuals.end());
      const double t = mesh_[std::size_t(worst - residuals.begin())];
      failure_ = {SolveStatus::kTooManySteps,
                  "refining the mesh of " + std::to_string(points_) + " points would need " +
                      std::to_string(mesh.size()) + " > max_mesh_points = " +
                      std::to_string(options_.max_mesh_points) + "; largest residual " +
                      FormatNumber(*worst) + " > tolerance " + FormatNumber(options_.tolerance) +
                      " on the interval starting at t = " + FormatNumber(t),
                  t};
      return false;
    }
    SetMesh(std::move(mesh));
    for (Index i = 0; i < points_; ++i) y_.segment(i * n_, n_) = guess[std::size_t(i)];
    return true;
  }

  BoundaryValueSolution Finish(bool converged) {
    BoundaryValueSolution solution;
    solution.summary = summary_;
    solution.summary.steps = long(points_ - 1);
    if (converged) {
      solution.summary.status = SolveStatus::kConverged;
      solution.summary.stop_time = mesh_.back();
      solution.summary.message = "residual " + FormatNumber(max_residual_) + " <= tolerance " +
                                 FormatNumber(options_.tolerance) + " on a mesh of " +
                                 std::to_string(points_) + " points";
      solution.max_residual = max_residual_;
    } else {
      solution.summary.status = failure_.status;
      solution.summary.stop_time = failure_.time;
      solution.summary.message = failure_.message;
    }
    solution.mesh = mesh_;
    solution.y.reserve(std::size_t(points_));
    for (Index i = 0; i < points_; ++i) solution.y.emplace_back(y_.segment(i * n_, n_));
    if (converged) {
      solution.y_prime.reserve(std::size_t(points_));
      for (Index i = 0; i < points_; ++i) solution.y_prime.emplace_back(slopes_.col(i));
    }
    return solution;
  }

  const BvpRightHandSide& f_;
  const BvpJacobian& jacobian_;
  const BoundaryConditions& conditions_;
  const BoundaryValueOptions& options_;
  const Index n_;

  std::vector<double> mesh_;
  Index points_ = 0;
  VectorXd y_, step_, correction_, phi_, trial_;  // size points_ n_, point after point
  MatrixXd slopes_;                               // f at the mesh points, n_ x points_
  MatrixXd y_mid_, f_mid_;                        // at the midpoints, n_ x (points_ - 1)
  std::vector<MatrixXd> jacobians_, jacobians_mid_;

  // Buffers for one point, allocated once.
  VectorXd y_point_, f_point_, y_shifted_, f_shifted_, derivative_;
  MatrixXd block_a_, block_b_, product_;
  VectorXd ya_, yb_, bc_residual_, bc_shifted_;
  MatrixXd d_ya_, d_yb_;

  std::vector<Eigen::Triplet<double>> triplets_;
  SparseMatrix matrix_;
  Eigen::SparseLU<SparseMatrix, Eigen::COLAMDOrdering<int>> lu_;
  bool pattern_ready_ = false;

  SolveSummary summary_;
  Failure failure_;
  double max_residual_ = std::numeric_limits<double>::quiet_NaN();
};

}  // namespace

void BoundaryValueOptions::Validate() const {
  RequireOption(tolerance >= kMinTolerance && tolerance < 1.0, "BoundaryValueOptions", "tolerance", tolerance,
                "must be >= " + FormatNumber(kMinTolerance) + " and < 1");
  RequireOption(absolute_tolerance > 0.0 && std::isfinite(absolute_tolerance), "BoundaryValueOptions", "absolute_tolerance", absolute_tolerance, "must be finite and > 0");
  RequireOption(max_mesh_points >= 2, "BoundaryValueOptions", "max_mesh_points", double(max_mesh_points), "must be >= 2");
  RequireOption(max_newton_iterations >= 1, "BoundaryValueOptions", "max_newton_iterations", double(max_newton_iterations),
                "must be >= 1");
}

Eigen::VectorXd BoundaryValueSolution::Evaluate(double t) const {
  if (mesh.size() < 2 || y_prime.size() != mesh.size() || y.size() != mesh.size()) {
    throw UsageError(
        "BoundaryValueSolution::Evaluate: the solution has no usable mesh values "
        "(the solver did not converge)");
  }
  if (!(t >= mesh.front() && t <= mesh.back())) {
    throw UsageError("BoundaryValueSolution::Evaluate: t = " + FormatNumber(t) +
                     ": must be within [" + FormatNumber(mesh.front()) + ", " +
                     FormatNumber(mesh.back()) + "]");
  }
  const auto upper = std::upper_bound(mesh.begin(), mesh.end(), t);
  const std::size_t i =
      std::min(std::size_t(std::max(upper - mesh.begin() - 1, std::ptrdiff_t(0))), mesh.size() - 2);
  const double h = mesh[i + 1] - mesh[i];
  VectorXd value;
  Hermite(h, (t - mesh[i]) / h, y[i], y[i + 1], y_prime[i], y_prime[i + 1], value, nullptr);
  return value;
}

BoundaryValueSolution SolveBoundaryValueProblem(const BvpRightHandSide& f,
                                                const BvpJacobian& jacobian,
                                                const BoundaryConditions& conditions,
                                                std::vector<double> initial_mesh,
                                                std::vector<Eigen::VectorXd> initial_guess,
                                                const BoundaryValueOptions& options) {
  options.Validate();
  if (!f || !conditions.residual) {
    throw UsageError(
        "SolveBoundaryValueProblem: the right-hand side and the boundary "
        "residual must be given");
  }
  if (initial_mesh.size() < 2) {
    throw UsageError("SolveBoundaryValueProblem: initial_mesh has " +
                     std::to_string(initial_mesh.size()) + " points: must have >= 2");
  }
  for (std::size_t i = 0; i < initial_mesh.size(); ++i) {
    if (!std::isfinite(initial_mesh[i]) || (i > 0 && !(initial_mesh[i] > initial_mesh[i - 1]))) {
      throw UsageError("SolveBoundaryValueProblem: initial_mesh[" + std::to_string(i) +
                       "] = " + FormatNumber(initial_mesh[i]) +
                       ": the mesh must be finite and strictly increasing");
    }
  }
  if (initial_guess.size() != initial_mesh.size()) {
    throw UsageError("SolveBoundaryValueProblem: initial_guess has " +
                     std::to_string(initial_guess.size()) + " vectors for " +
                     std::to_string(initial_mesh.size()) + " mesh points: must be equal");
  }
  const Index n = initial_guess.front().size();
  for (std::size_t i = 0; i < initial_guess.size(); ++i) {
    if (n == 0 || initial_guess[i].size() != n || !initial_guess[i].allFinite()) {
      throw UsageError("SolveBoundaryValueProblem: initial_guess[" + std::to_string(i) +
                       "] has size " + std::to_string(initial_guess[i].size()) +
                       ": all must have the same size n >= 1 and be finite");
    }
  }
  if (long(initial_mesh.size()) > options.max_mesh_points) {
    throw UsageError(
        "SolveBoundaryValueProblem: initial_mesh has " + std::to_string(initial_mesh.size()) +
        " points: more than " +
        "BoundaryValueOptions::max_mesh_points = " + std::to_string(options.max_mesh_points));
  }
  BvpSolver solver(f, jacobian, conditions, options, n);
  return solver.Solve(std::move(initial_mesh), initial_guess);
}

}  // namespace servokit
