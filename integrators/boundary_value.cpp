#include "integrators/boundary_value.h"

#include <Eigen/SparseCore>
#include <Eigen/SparseLU>
#include <algorithm>
#include <cmath>
#include <string>
#include <utility>

#include "base/errors.h"
#include "base/option_check.h"

// Two collocation methods share the Newton iteration and the refinement loop
// (CollocationSolver): bvp4c's Hermite-Simpson (HermiteSimpsonSolver, below) and Lobatto IIIA
// of any order (LobattoSolver, further down, with its own description).
//
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
// test. With tolerance >= kBoundaryValueMinTolerance this stays above round-off of y.
constexpr double kNewtonFraction = 1e-2;
// Beyond this many Lobatto points per interval the monomial-free Lagrange formulas here still
// work, but an interval that needs more accuracy is better split.
constexpr int kMaxCollocationPoints = 10;

// Newton keeps its Jacobian (chord steps) while each step shrinks the next by this factor.
constexpr double kReuseContraction = 0.25;
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

// The s-point Gauss-Lobatto rule on [0, 1] (s >= 2): nodes 0 = tau_0 < ... < tau_{s-1} = 1
// (the ends and the roots of P'_{s-1}, mapped from [-1, 1]) and weights summing to 1; exact
// for polynomials of degree 2s - 3.
struct LobattoQuadrature {
  std::vector<double> nodes, weights;
};

LobattoQuadrature LobattoRule(int s) {
  // Newton on (1 - x^2) P'_N(x) = N (P_{N-1} - x P_N) from the Chebyshev-Gauss-Lobatto points,
  // N = s - 1 (the iteration of Canuto et al., Spectral Methods, Sect. 2.3).
  const int degree = s - 1;
  std::vector<double> x(static_cast<std::size_t>(s)), legendre(static_cast<std::size_t>(s));
  for (int k = 0; k < s; ++k) x[std::size_t(k)] = -std::cos(M_PI * k / degree);
  for (int k = 0; k < s; ++k) {
    double& xk = x[std::size_t(k)];
    for (int iteration = 0; iteration < 100; ++iteration) {
      double previous = 1.0, current = xk;  // P_0, P_1
      for (int m = 2; m <= degree; ++m) {
        const double next = ((2.0 * m - 1.0) * xk * current - (m - 1.0) * previous) / m;
        previous = current;
        current = next;
      }
      legendre[std::size_t(k)] = current;
      const double update = (xk * current - previous) / (s * current);
      xk -= update;
      if (std::abs(update) <= kRoundoff) break;
    }
  }
  LobattoQuadrature rule;
  for (int k = 0; k < s; ++k) {
    const double p = legendre[std::size_t(k)];
    rule.nodes.push_back(0.5 * (x[std::size_t(k)] + 1.0));
    rule.weights.push_back(1.0 / (degree * (degree + 1.0) * p * p));  // 2 / (N(N+1) P_N^2) / 2
  }
  rule.nodes.front() = 0.0;
  rule.nodes.back() = 1.0;
  return rule;
}

// LobattoRule(s) for s = 3 .. kMaxCollocationPoints, computed once (thread-safe static).
const LobattoQuadrature& CachedLobattoRule(int s) {
  static const std::vector<LobattoQuadrature> rules = [] {
    std::vector<LobattoQuadrature> table(kMaxCollocationPoints + 1);
    for (int points = 3; points <= kMaxCollocationPoints; ++points) {
      table[std::size_t(points)] = LobattoRule(points);
    }
    return table;
  }();
  return rules[std::size_t(s)];
}

// The Lagrange basis polynomial l_j on `nodes` at x.
double LagrangeBasis(const std::vector<double>& nodes, int j, double x) {
  double value = 1.0;
  for (std::size_t m = 0; m < nodes.size(); ++m) {
    if (int(m) != j) value *= (x - nodes[m]) / (nodes[std::size_t(j)] - nodes[m]);
  }
  return value;
}

// integral_0^x l_j (Lagrange basis on `nodes`) for j = 0 .. nodes.size() - 1 into out, by the
// Lobatto rule `rule` mapped to [0, x]: exact when l_j's degree nodes.size() - 1 is at most
// 2 rule.nodes.size() - 3.
void LagrangeIntegrals(const std::vector<double>& nodes,
                       const LobattoQuadrature& rule,
                       double x,
                       double* out) {
  for (std::size_t j = 0; j < nodes.size(); ++j) {
    double sum = 0.0;
    for (std::size_t m = 0; m < rule.nodes.size(); ++m) {
      sum += rule.weights[m] * LagrangeBasis(nodes, int(j), x * rule.nodes[m]);
    }
    out[j] = x * sum;
  }
}

struct Failure {
  SolveStatus status = SolveStatus::kNoConvergence;
  std::string message;
  double time = std::numeric_limits<double>::quiet_NaN();
};

// What every collocation method here shares: the unknowns (values at the mesh's nodes), f and
// its Jacobian with their failure handling, the boundary conditions, damped Newton on the
// sparse system, and the refinement loop. A method supplies the collocation equations, their
// Jacobian, the error measure per mesh interval and the refinement of the mesh.
class CollocationSolver {
 public:
  virtual ~CollocationSolver() = default;
  CollocationSolver(const BvpRightHandSide& f,
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
        bc_residual_(n),
        bc_shifted_(n),
        d_ya_(n, n),
        d_yb_(n, n) {}

  // Solves from the caller's mesh (interval ends) and the guess at its points.
  BoundaryValueSolution Solve(std::vector<double> mesh, const std::vector<VectorXd>& guess) {
    Start(std::move(mesh), guess);
    std::vector<double> residuals;
    while (true) {
      if (!Newton() || !EstimateResiduals(residuals)) return Finish(false);
      max_residual_ = *std::max_element(residuals.begin(), residuals.end());
      if (max_residual_ <= options_.tolerance) return Finish(true);
      if (!Refine(residuals)) return Finish(false);
    }
  }

 protected:
  // The method's part. EvaluateResidual: f at the nodes (into slopes_) and wherever else the
  // method needs it, the collocation and boundary residuals into phi_; false (with failure_)
  // when f fails. AssembleJacobian: the Jacobian of phi_ at y_ into matrix_ (after
  // EvaluateResidual(y_)). EstimateResiduals: the error measure of each mesh interval (compared
  // with options_.tolerance). Refine: the next mesh and guess, through SetMesh; false (with
  // failure_) when it would exceed max_mesh_points. FillSolution: the method's fields of a
  // converged solution.
  virtual bool EvaluateResidual(const VectorXd& y) = 0;
  virtual bool AssembleJacobian() = 0;
  virtual bool EstimateResiduals(std::vector<double>& residuals) = 0;
  virtual bool Refine(const std::vector<double>& residuals) = 0;
  virtual void FillSolution(BoundaryValueSolution& solution) const = 0;

  // The first nodes and values from the caller's interval ends and guess there; by default the
  // nodes are the interval ends.
  virtual void Start(std::vector<double> mesh, const std::vector<VectorXd>& guess) {
    SetMesh(std::move(mesh));
    for (Index i = 0; i < points_; ++i) y_.segment(i * n_, n_) = guess[std::size_t(i)];
  }

  // Newton has converged with a last correction below kNewtonFraction of the tolerance. The
  // Hermite-Simpson residual measure divides nodal errors by h, so that method applies the
  // correction and evaluates f again; the Lobatto measure h |u' - f| does not, and y_ stays
  // as it is, consistent with the f values of its last evaluation (one f call per node less).
  bool Converged(const VectorXd& last_correction) {
    if (!apply_last_correction_) return true;
    y_ += last_correction;
    return EvaluateResidual(y_);
  }
  bool apply_last_correction_ = true;

  // f at every node of `y` into slopes_; false (with failure_) when f fails.
  bool EvaluateNodeSlopes(const VectorXd& y) {
    for (Index i = 0; i < points_; ++i) {
      y_point_ = y.segment(i * n_, n_);
      if (!CallF(mesh_[std::size_t(i)], y_point_, f_point_)) return false;
      slopes_.col(i) = f_point_;
    }
    return true;
  }

  // g(y(a), y(b)) into the last n rows of phi_.
  void EvaluateBoundaryResidual(const VectorXd& y) {
    ya_ = y.head(n_);
    yb_ = y.tail(n_);
    CallConditions(ya_, yb_, bc_residual_);
    phi_.tail(n_) = bc_residual_;
  }

  // df/dy at every node of y_ (whose f values are in slopes_) into jacobians_.
  bool NodeJacobians() {
    for (Index i = 0; i < points_; ++i) {
      y_point_ = y_.segment(i * n_, n_);
      f_point_ = slopes_.col(i);
      if (!CallJacobian(mesh_[std::size_t(i)], y_point_, f_point_, jacobians_[std::size_t(i)])) {
        return false;
      }
    }
    return true;
  }

  // A new set of nodes (the unknowns' times); the method keeps its own per-interval data.
  virtual void SetMesh(std::vector<double> mesh) {
    mesh_ = std::move(mesh);
    points_ = Index(mesh_.size());
    y_.resize(points_ * n_);
    step_.resize(points_ * n_);
    correction_.resize(points_ * n_);
    phi_.resize(points_ * n_);
    trial_.resize(points_ * n_);
    slopes_.resize(n_, points_);
    jacobians_.assign(std::size_t(points_), MatrixXd(n_, n_));
    pattern_ready_ = false;
  }

  // Failure when refining would exceed max_mesh_points: names the worst interval.
  bool TooManyPoints(std::size_t wanted,
                     const std::vector<double>& residuals,
                     Index first_node_stride) {
    const auto worst = std::max_element(residuals.begin(), residuals.end());
    const double t = mesh_[std::size_t((worst - residuals.begin()) * first_node_stride)];
    failure_ = {SolveStatus::kTooManySteps,
                "refining the mesh of " + std::to_string(points_) + " points would need " +
                    std::to_string(wanted) + " > max_mesh_points = " +
                    std::to_string(options_.max_mesh_points) + "; largest residual " +
                    FormatNumber(*worst) + " > tolerance " + FormatNumber(options_.tolerance) +
                    " on the interval starting at t = " + FormatNumber(t),
                t};
    return false;
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

  // -J^-1 phi_ with the current factorisation (of matrix_, as AssembleJacobian left it);
  // false if it is not finite.
  virtual bool SolveLinear(VectorXd& out) {
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
    // True while step_ holds the simplified correction -J^-1 phi(y_) of the current
    // factorisation and the last full step contracted well enough to keep using it.
    bool reuse = false;
    for (int iteration = 0; iteration < options_.max_newton_iterations; ++iteration) {
      if (!reuse) {
        if (!AssembleJacobian()) return false;
        if (!pattern_ready_) {
          lu_.analyzePattern(matrix_);
          pattern_ready_ = true;
        }
        lu_.factorize(matrix_);
        if (lu_.info() != Eigen::Success || !SolveLinear(step_)) {
          SingularFailure();
          return false;
        }
      }
      ++summary_.newton_iterations;
      if (MaxScaled(step_) <= kNewtonFraction) return Converged(step_);
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
        if (reuse) break;  // a stale Jacobian: take a fresh one rather than damp
      }
      if (!accepted && reuse) {
        reuse = false;
        failure_ = {};
        if (!EvaluateResidual(y_)) return false;
        continue;
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
      if (lambda == 1.0 && MaxScaled(correction_) <= kNewtonFraction) return Converged(correction_);
      // The simplified correction is the next step of the chord method with the same
      // factorisation; when it contracted the step well (theta = |correction| / |step| small),
      // it converges nearly as fast as Newton at a third of the cost (no Jacobian, no LU).
      reuse = lambda == 1.0 && RmsScaled(correction_) <= kReuseContraction * step_norm;
      if (reuse) step_ = correction_;
      failure_ = {};
    }
    failure_ = {SolveStatus::kNoConvergence,
                "Newton did not converge in " + std::to_string(options_.max_newton_iterations) +
                    " iterations on a mesh of " + std::to_string(points_) + " points",
                std::numeric_limits<double>::quiet_NaN()};
    return false;
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
      FillSolution(solution);
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
  MatrixXd slopes_;                               // f at the nodes, n_ x points_
  std::vector<MatrixXd> jacobians_;               // df/dy at the nodes

  // Buffers for one point, allocated once.
  VectorXd y_point_, f_point_, y_shifted_, f_shifted_, derivative_;
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

// bvp4c's method (see the top of this file): the unknowns are the values at the mesh points;
// the midpoint values are explicit in them, so each interval gives one n x 2n block row.
class HermiteSimpsonSolver final : public CollocationSolver {
 public:
  HermiteSimpsonSolver(const BvpRightHandSide& f,
                       const BvpJacobian& jacobian,
                       const BoundaryConditions& conditions,
                       const BoundaryValueOptions& options,
                       Index n)
      : CollocationSolver(f, jacobian, conditions, options, n),
        block_a_(n, n),
        block_b_(n, n),
        product_(n, n) {}

 private:
  void SetMesh(std::vector<double> mesh) override {
    CollocationSolver::SetMesh(std::move(mesh));
    y_mid_.resize(n_, points_ - 1);
    f_mid_.resize(n_, points_ - 1);
    jacobians_mid_.assign(std::size_t(points_ - 1), MatrixXd(n_, n_));
  }

  void FillSolution(BoundaryValueSolution& solution) const override {
    solution.nodes_per_interval = 2;
  }

  // f at the mesh points and midpoints of the mesh values `y`, and the collocation and
  // boundary residuals into phi_. False (with failure_) when f cannot be evaluated.
  bool EvaluateResidual(const VectorXd& y) override {
    if (!EvaluateNodeSlopes(y)) return false;
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
    EvaluateBoundaryResidual(y);
    return true;
  }

  // The Jacobian of phi_ at y_ (whose f values EvaluateResidual left in slopes_, f_mid_), as
  // triplets: two n x n blocks per interval and the boundary rows.
  bool AssembleJacobian() override {
    if (!NodeJacobians()) return false;
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

  // The relative residual of the interpolant on each interval (see BoundaryValueOptions):
  // max over components and the two Lobatto points of |S' - f| / max(|f|, atol / tol).
  bool EstimateResiduals(std::vector<double>& residuals) override {
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
  bool Refine(const std::vector<double>& residuals) override {
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
      return TooManyPoints(mesh.size(), residuals, 1);
    }
    SetMesh(std::move(mesh));
    for (Index i = 0; i < points_; ++i) y_.segment(i * n_, n_) = guess[std::size_t(i)];
    return true;
  }

  MatrixXd y_mid_, f_mid_;  // at the midpoints, n_ x (points_ - 1)
  std::vector<MatrixXd> jacobians_mid_;
  MatrixXd block_a_, block_b_, product_;
};

// Collocation at s Gauss-Lobatto points per interval (Lobatto IIIA, as bvp5c does with s = 4;
// Ascher, Mattheij & Russell, Numerical Solution of BVPs for ODEs, Sect. 5.6). On an interval
// [t_0, t_0 + h] the solution is the polynomial u of degree s with
//   u(t_0) = y_0,  u'(t_0 + tau_j h) = f_j = f(t_0 + tau_j h, y_j),  j = 0 .. s - 1,
// so u(t_0 + tau h) = y_0 + h sum_j f_j integral_0^tau l_j, with l_j the Lagrange basis on the
// nodes tau_j. The unknowns are the values y_j at all nodes (interval ends shared); the
// equations are y_k = u(t_0 + tau_k h), k = 1 .. s - 1, and the boundary conditions. The values
// at the interval ends are accurate to O(h^(2s-2)), u everywhere to O(h^(s+1)).
//
// Error measure of an interval: h max |u' - f(t, u)| at the s - 1 points halfway between
// consecutive nodes, against max(tolerance |u|, absolute_tolerance) per component. The
// residual u' - f is O(h^s), so this measure is O(h^(s+1)), the order of u's own error: a
// solution error e obeys e' = (df/dy) e + residual, and over an interval the residual adds at
// most about h |residual| to it.
class LobattoSolver final : public CollocationSolver {
 public:
  LobattoSolver(const BvpRightHandSide& f,
                const BvpJacobian& jacobian,
                const BoundaryConditions& conditions,
                const BoundaryValueOptions& options,
                Index n)
      : CollocationSolver(f, jacobian, conditions, options, n),
        stages_(options.collocation_points),
        rule_(CachedLobattoRule(stages_)),
        block_(n, n) {
    apply_last_correction_ = false;
    const int s = stages_;
    node_integrals_.resize(s, s);
    check_integrals_.resize(s - 1, s);
    check_basis_.resize(s - 1, s);
    for (int m = 0; m + 1 < s; ++m) {
      const double sigma = 0.5 * (rule_.nodes[std::size_t(m)] + rule_.nodes[std::size_t(m + 1)]);
      check_points_.push_back(sigma);
      for (int j = 0; j < s; ++j) {
        check_basis_(m, j) = LagrangeBasis(rule_.nodes, j, sigma);
      }
    }
    for (int m = 0; m + 1 < s; ++m) {
      Eigen::RowVectorXd row(s);
      LagrangeIntegrals(rule_.nodes, rule_, check_points_[std::size_t(m)], row.data());
      check_integrals_.row(m) = row;
    }
    for (int k = 0; k < s; ++k) {
      Eigen::RowVectorXd row(s);
      LagrangeIntegrals(rule_.nodes, rule_, rule_.nodes[std::size_t(k)], row.data());
      node_integrals_.row(k) = row;
    }
    split_integrals_.resize(kMaxPieces + 1);
    for (int pieces = 2; pieces <= kMaxPieces; ++pieces) {
      MatrixXd& integrals = split_integrals_[std::size_t(pieces)];
      integrals.resize(pieces * (s - 1), s);
      for (int piece = 0; piece < pieces; ++piece) {
        for (int k = 0; k + 1 < s; ++k) {
          Eigen::RowVectorXd row(s);
          LagrangeIntegrals(rule_.nodes, rule_, SplitNode(pieces, piece, k), row.data());
          integrals.row(piece * (s - 1) + k) = row;
        }
      }
    }
  }

 private:
  Index Intervals() const { return (points_ - 1) / (stages_ - 1); }
  Index FirstNode(Index interval) const { return interval * (stages_ - 1); }
  double Width(Index interval) const {
    return mesh_[std::size_t(FirstNode(interval + 1))] - mesh_[std::size_t(FirstNode(interval))];
  }

  // Nodes of the intervals with ends `ends`, and the guess there (linear between the ends).
  void Start(std::vector<double> ends, const std::vector<VectorXd>& guess) override {
    std::vector<double> nodes;
    std::vector<VectorXd> values;
    for (std::size_t i = 0; i + 1 < ends.size(); ++i) {
      const double h = ends[i + 1] - ends[i];
      for (int k = 0; k + 1 < stages_; ++k) {
        const double tau = rule_.nodes[std::size_t(k)];
        nodes.push_back(ends[i] + tau * h);
        values.push_back((1.0 - tau) * guess[i] + tau * guess[i + 1]);
      }
    }
    nodes.push_back(ends.back());
    values.push_back(guess.back());
    SetMesh(std::move(nodes));
    for (Index i = 0; i < points_; ++i) y_.segment(i * n_, n_) = values[std::size_t(i)];
  }

  void FillSolution(BoundaryValueSolution& solution) const override {
    solution.nodes_per_interval = stages_;
    solution.summary.steps = long(Intervals());
  }

  bool EvaluateResidual(const VectorXd& y) override {
    if (!EvaluateNodeSlopes(y)) return false;
    for (Index interval = 0; interval < Intervals(); ++interval) {
      const Index first = FirstNode(interval);
      const double h = Width(interval);
      const auto slopes = slopes_.middleCols(first, stages_);
      for (int k = 1; k < stages_; ++k) {
        auto equation = phi_.segment((first + k - 1) * n_, n_);
        equation = y.segment((first + k) * n_, n_) - y.segment(first * n_, n_);
        equation.noalias() -= h * (slopes * node_integrals_.row(k).transpose());
      }
    }
    EvaluateBoundaryResidual(y);
    return true;
  }

  // The Newton matrix with the interior nodes of each interval eliminated (static
  // condensation): with a = the interval's first node, b = its last, I = the s - 2 interior
  // ones, and G_kj = dPhi_k/dy_j = delta_kj I - delta_j0 I - h A_kj J_j for the equations
  // k = 1 .. s - 1 (interior rows I, last row e), the interior rows give
  //   dy_I = -G_II^-1 (phi_I + G_Ia dy_a + G_Ib dy_b),
  // and the last row becomes S dy_a + T dy_b = -phi_e + G_eI G_II^-1 phi_I with
  //   S = G_ea - G_eI G_II^-1 G_Ia,  T = G_eb - G_eI G_II^-1 G_Ib.
  // matrix_ is the block-bidiagonal system in the interval ends plus the boundary rows, a
  // (s - 1)-th of the full size; the dense G_II solves are local to each interval.
  bool AssembleJacobian() override {
    if (!NodeJacobians()) return false;
    const Index inner = (stages_ - 2) * n_;
    const Index intervals = Intervals();
    interior_lu_.resize(std::size_t(intervals));
    to_first_.resize(std::size_t(intervals));
    to_last_.resize(std::size_t(intervals));
    last_row_interior_.resize(std::size_t(intervals));
    triplets_.clear();
    triplets_.reserve(std::size_t((2 * intervals + 2) * n_ * n_));
    for (Index interval = 0; interval < intervals; ++interval) {
      const Index first = FirstNode(interval);
      const double h = Width(interval);
      // The blocks G_kj of this interval, rows k = 1 .. s - 1, columns j = 0 .. s - 1.
      local_.resize((stages_ - 1) * n_, stages_ * n_);
      for (int k = 1; k < stages_; ++k) {
        for (int j = 0; j < stages_; ++j) {
          auto block = local_.block((k - 1) * n_, j * n_, n_, n_);
          block = (-h * node_integrals_(k, j)) * jacobians_[std::size_t(first + j)];
          if (j == k) block.diagonal().array() += 1.0;
          if (j == 0) block.diagonal().array() -= 1.0;
        }
      }
      const std::size_t e = std::size_t(interval);
      interior_lu_[e].compute(local_.block(0, n_, inner, inner));
      to_first_[e] = interior_lu_[e].solve(local_.block(0, 0, inner, n_));
      to_last_[e] = interior_lu_[e].solve(local_.block(0, n_ + inner, inner, n_));
      last_row_interior_[e] = local_.block(inner, n_, n_, inner);
      block_ = local_.block(inner, 0, n_, n_);
      block_.noalias() -= last_row_interior_[e] * to_first_[e];
      AddBlock(interval * n_, interval * n_, block_);
      block_ = local_.block(inner, n_ + inner, n_, n_);
      block_.noalias() -= last_row_interior_[e] * to_last_[e];
      AddBlock(interval * n_, (interval + 1) * n_, block_);
    }
    BoundaryJacobians();
    AddBlock(intervals * n_, 0, d_ya_);
    AddBlock(intervals * n_, intervals * n_, d_yb_);
    matrix_.resize((intervals + 1) * n_, (intervals + 1) * n_);
    matrix_.setFromTriplets(triplets_.begin(), triplets_.end());
    return true;
  }

  // -J^-1 phi_ through the condensed system (see AssembleJacobian).
  bool SolveLinear(VectorXd& out) override {
    const Index inner = (stages_ - 2) * n_;
    const Index intervals = Intervals();
    interior_rhs_.resize(inner, intervals);
    ends_rhs_.resize((intervals + 1) * n_);
    for (Index interval = 0; interval < intervals; ++interval) {
      const std::size_t e = std::size_t(interval);
      const Index row = FirstNode(interval) * n_;
      interior_rhs_.col(interval) = interior_lu_[e].solve(phi_.segment(row, inner));
      ends_rhs_.segment(interval * n_, n_) = phi_.segment(row + inner, n_);
      ends_rhs_.segment(interval * n_, n_).noalias() -=
          last_row_interior_[e] * interior_rhs_.col(interval);
    }
    ends_rhs_.tail(n_) = phi_.tail(n_);
    ends_ = lu_.solve(ends_rhs_);
    if (lu_.info() != Eigen::Success) return false;
    out.resize(points_ * n_);
    for (Index interval = 0; interval < intervals; ++interval) {
      const std::size_t e = std::size_t(interval);
      const Index first = FirstNode(interval);
      const auto end_a = ends_.segment(interval * n_, n_);
      const auto end_b = ends_.segment((interval + 1) * n_, n_);
      out.segment(first * n_, n_) = -end_a;
      auto interior = out.segment((first + 1) * n_, inner);
      interior = -interior_rhs_.col(interval);
      interior.noalias() += to_first_[e] * end_a;
      interior.noalias() += to_last_[e] * end_b;
    }
    out.tail(n_) = -ends_.tail(n_);
    return out.allFinite();
  }

  bool EstimateResiduals(std::vector<double>& residuals) override {
    residuals.assign(std::size_t(Intervals()), 0.0);
    for (Index interval = 0; interval < Intervals(); ++interval) {
      const Index first = FirstNode(interval);
      const double t = mesh_[std::size_t(first)];
      const double h = Width(interval);
      const auto slopes = slopes_.middleCols(first, stages_);
      for (std::size_t m = 0; m < check_points_.size(); ++m) {
        y_point_ = y_.segment(first * n_, n_);
        y_point_.noalias() += h * (slopes * check_integrals_.row(Index(m)).transpose());
        derivative_.noalias() = slopes * check_basis_.row(Index(m)).transpose();
        if (!CallF(t + check_points_[m] * h, y_point_, f_point_)) return false;
        const double ratio =
            (h * (derivative_ - f_point_).array().abs() /
             (options_.tolerance * y_point_.array().abs()).max(options_.absolute_tolerance))
                .maxCoeff() *
            options_.tolerance;
        residuals[std::size_t(interval)] = std::max(residuals[std::size_t(interval)], ratio);
      }
    }
    return true;
  }

  // Splits each interval whose measure exceeds the tolerance into as many equal parts as the
  // measure's order s + 1 says bring it below tolerance / kRefinementMargin (2 to kMaxPieces),
  // with u as the guess at the new nodes. The margin pays for itself: a prediction that falls
  // short by a little on one interval costs another Newton solve on the whole mesh.
  bool Refine(const std::vector<double>& residuals) override {
    std::vector<double> ends;
    std::vector<VectorXd> values;
    for (Index interval = 0; interval < Intervals(); ++interval) {
      const Index first = FirstNode(interval);
      const double t = mesh_[std::size_t(first)];
      const double h = Width(interval);
      const double residual = residuals[std::size_t(interval)];
      int pieces = 1;
      if (residual > options_.tolerance) {
        pieces = int(std::ceil(
            std::pow(kRefinementMargin * residual / options_.tolerance, 1.0 / (stages_ + 1))));
        pieces = std::clamp(pieces, 2, kMaxPieces);
      }
      if (pieces == 1) {  // kept as it is
        for (int k = 0; k + 1 < stages_; ++k) {
          ends.push_back(mesh_[std::size_t(first + k)]);
          values.emplace_back(y_.segment((first + k) * n_, n_));
        }
        continue;
      }
      const MatrixXd& integrals = split_integrals_[std::size_t(pieces)];
      for (int piece = 0; piece < pieces; ++piece) {
        for (int k = 0; k + 1 < stages_; ++k) {
          const Index row = piece * (stages_ - 1) + k;
          ends.push_back(t + SplitNode(pieces, piece, k) * h);
          VectorXd value = y_.segment(first * n_, n_);
          value.noalias() +=
              h * (slopes_.middleCols(first, stages_) * integrals.row(row).transpose());
          values.push_back(std::move(value));
        }
      }
    }
    ends.push_back(mesh_.back());
    values.emplace_back(y_.tail(n_));
    if (long(ends.size()) > options_.max_mesh_points) {
      return TooManyPoints(ends.size(), residuals, stages_ - 1);
    }
    SetMesh(std::move(ends));
    for (Index i = 0; i < points_; ++i) y_.segment(i * n_, n_) = values[std::size_t(i)];
    return true;
  }

  // The fraction of an interval at which node k of piece `piece` of `pieces` equal parts lies.
  double SplitNode(int pieces, int piece, int k) const {
    return (piece + rule_.nodes[std::size_t(k)]) / pieces;
  }

  // Refine's limits: at most kMaxPieces parts per interval, and parts meant to bring the
  // measure to tolerance / kRefinementMargin.
  static constexpr int kMaxPieces = 8;
  static constexpr double kRefinementMargin = 16.0;

  const int stages_;
  const LobattoQuadrature rule_;
  // split_integrals_[p] (row piece (s - 1) + k, column j): integral_0^tau l_j at the new
  // node k of part `piece` when an interval is split into p parts (Refine's guess).
  std::vector<MatrixXd> split_integrals_;
  MatrixXd node_integrals_;  // (k, j): integral_0^tau_k l_j
  // The condensation of each interval (AssembleJacobian): LU of G_II, G_II^-1 G_Ia,
  // G_II^-1 G_Ib and G_eI; and buffers.
  std::vector<Eigen::PartialPivLU<MatrixXd>> interior_lu_;
  std::vector<MatrixXd> to_first_, to_last_, last_row_interior_;
  MatrixXd local_, interior_rhs_;
  VectorXd ends_rhs_, ends_;
  std::vector<double> check_points_;        // halfway between consecutive nodes
  MatrixXd check_integrals_, check_basis_;  // integral_0^sigma_m l_j and l_j(sigma_m)
  MatrixXd block_;
};
}  // namespace

void BoundaryValueOptions::Validate() const {
  RequireOption(tolerance >= kBoundaryValueMinTolerance && tolerance < 1.0, "BoundaryValueOptions",
                "tolerance", tolerance,
                "must be >= " + FormatNumber(kBoundaryValueMinTolerance) + " and < 1");
  RequireOption(absolute_tolerance > 0.0 && std::isfinite(absolute_tolerance),
                "BoundaryValueOptions", "absolute_tolerance", absolute_tolerance,
                "must be finite and > 0");
  RequireOption(max_mesh_points >= 2, "BoundaryValueOptions", "max_mesh_points", max_mesh_points,
                "must be >= 2");
  RequireOption(collocation_points >= 3 && collocation_points <= kMaxCollocationPoints,
                "BoundaryValueOptions", "collocation_points", collocation_points,
                "must be in 3 .. " + std::to_string(kMaxCollocationPoints));
  RequireOption(max_newton_iterations >= 1, "BoundaryValueOptions", "max_newton_iterations",
                max_newton_iterations, "must be >= 1");
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
  // The interval holding t: nodes first .. first + nodes_per_interval - 1.
  const std::size_t stride = std::size_t(nodes_per_interval - 1);
  const std::size_t intervals = (mesh.size() - 1) / stride;
  const auto upper = std::upper_bound(mesh.begin(), mesh.end(), t);
  const std::size_t node = std::size_t(std::max(upper - mesh.begin() - 1, std::ptrdiff_t(0)));
  const std::size_t first = std::min(node / stride, intervals - 1) * stride;
  const double h = mesh[first + stride] - mesh[first];
  VectorXd value;
  if (nodes_per_interval == 2) {
    Hermite(h, (t - mesh[first]) / h, y[first], y[first + 1], y_prime[first], y_prime[first + 1],
            value, nullptr);
    return value;
  }
  // The collocation polynomial u (see LobattoSolver) on this interval's nodes.
  std::vector<double> nodes;
  for (std::size_t k = 0; k <= stride; ++k) nodes.push_back((mesh[first + k] - mesh[first]) / h);
  std::vector<double> integrals(nodes.size());
  LagrangeIntegrals(nodes, CachedLobattoRule(nodes_per_interval), (t - mesh[first]) / h,
                    integrals.data());
  value = y[first];
  for (std::size_t k = 0; k <= stride; ++k) value += (h * integrals[k]) * y_prime[first + k];
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
  if (options.collocation_points == 3) {
    HermiteSimpsonSolver solver(f, jacobian, conditions, options, n);
    return solver.Solve(std::move(initial_mesh), initial_guess);
  }
  LobattoSolver solver(f, jacobian, conditions, options, n);
  return solver.Solve(std::move(initial_mesh), std::move(initial_guess));
}

}  // namespace servokit
