#pragma once
// Two-point boundary value problems for first-order ODE systems y' = f(t, y) on [a, b] with n
// boundary conditions g(y(a), y(b)) = 0, by collocation at Gauss-Lobatto points: damped Newton
// on all node values at once with a sparse Jacobian, and mesh refinement driven by the residual
// of the collocation solution. With 3 points per interval this is MATLAB's bvp4c (Kierzenka &
// Shampine, ACM TOMS 27, 2001: Hermite-Simpson, residual of the C1 cubic interpolant); with
// s > 3 points it is Lobatto IIIA of order 2s - 2 (bvp5c's formula at s = 4), with the interior
// nodes eliminated interval by interval before the sparse solve. Written here for stable
// inversion of unstable internal dynamics (paper Sect. 5.3): the unstable modes get end
// conditions, the stable ones start conditions.
#include <Eigen/Dense>
#include <functional>
#include <limits>
#include <string>
#include <vector>

#include "integrators/solve_summary.h"

namespace servokit {

/// The smallest BoundaryValueOptions::tolerance: Newton stops at 1e-2 of the tolerance, which
/// must stay above round-off of y.
inline constexpr double kBoundaryValueMinTolerance = 1e-12;

struct BoundaryValueOptions {
  // With collocation_points = 3: the largest relative residual of the interpolant S allowed on
  // any mesh interval, as bvp4c's RelTol: |S'(t) - f(t, S(t))| <= max(tolerance |f|,
  // absolute_tolerance) per component (see collocation_points for s > 3). A residual, not an
  // error: the global error is this times the problem's conditioning. 1e-8
  // gives about 8 digits on well-conditioned problems; it must be >= 1e-12 because Newton
  // stops at 1e-2 of it, which must stay above round-off.
  double tolerance = 1e-8;
  // Residual level below which a component counts as converged whatever |f| is (bvp4c's
  // AbsTol); it also scales the Newton stopping test (|dy| against absolute_tolerance +
  // tolerance |y|). Small, so that components of size 1 are held to the relative tolerance.
  double absolute_tolerance = 1e-10;
  // Mesh points allowed before refinement stops with kTooManySteps (the sparse Jacobian has
  // about 2 n^2 entries per point, so 200000 points of a 2-state problem need ~40 MB).
  long max_mesh_points = 200000;
  // Newton iterations per mesh before giving up with kNoConvergence. Newton converges
  // quadratically from a usable guess; 25 leaves room for the damped start from a poor one.
  int max_newton_iterations = 25;
  // Gauss-Lobatto collocation points per mesh interval, ends included (3 .. 10). 3 is bvp4c's
  // Hermite-Simpson method (order 4), with `tolerance` bounding the residual as described
  // above. s > 3 is Lobatto IIIA collocation with a polynomial of degree s per interval
  // (values at the interval ends accurate to O(h^(2s-2)), everywhere to O(h^(s+1)); s = 4 is
  // bvp5c's formula); `tolerance` then bounds the estimated error h |residual| of each interval
  // against max(tolerance |y|, absolute_tolerance), per component. Higher orders need far fewer
  // points for smooth solutions and tight tolerances (stable inversion uses 7).
  int collocation_points = 3;
  // Throws UsageError naming the field, its value and the rule it breaks.
  void Validate() const;
};

/// Right-hand side y' = f(t, y): writes f (resized to size n, as y) and returns true, or
/// returns false with a one-line reason in `why` when f cannot be evaluated at (t, y).
using BvpRightHandSide =
    std::function<bool(double t, const Eigen::VectorXd& y, Eigen::VectorXd& f, std::string& why)>;

/// Optional df/dy at (t, y) (n x n); returns false with `why` when it cannot be evaluated.
/// When empty, the solver uses forward differences of f.
using BvpJacobian = std::function<bool(
    double t, const Eigen::VectorXd& y, Eigen::MatrixXd& jacobian, std::string& why)>;

/// The n boundary conditions g(y(a), y(b)) = 0 (ya, yb of size n, residual of size n).
struct BoundaryConditions {
  std::function<void(
      const Eigen::VectorXd& ya, const Eigen::VectorXd& yb, Eigen::VectorXd& residual)>
      residual;
  // dg/dya and dg/dyb (n x n each). May be empty: forward differences of `residual`.
  std::function<void(const Eigen::VectorXd& ya,
                     const Eigen::VectorXd& yb,
                     Eigen::MatrixXd& d_ya,
                     Eigen::MatrixXd& d_yb)>
      jacobians;
};

struct BoundaryValueSolution {
  // status, message; steps = mesh intervals of the final mesh; newton_iterations summed over
  // all meshes; function_evaluations counts calls of f (difference Jacobians included);
  // jacobian_evaluations counts calls of df/dy; rejected_steps counts damped Newton steps.
  SolveSummary summary;
  // The mesh and the solution and its derivative f(t, y) there. On failure: the last mesh and
  // iterate, for diagnosis (y_prime may then be empty).
  std::vector<double> mesh;
  std::vector<Eigen::VectorXd> y;
  std::vector<Eigen::VectorXd> y_prime;
  // Largest relative residual (see BoundaryValueOptions::tolerance) over the final mesh.
  double max_residual = std::numeric_limits<double>::quiet_NaN();
  // Nodes per mesh interval, ends included: the mesh holds every node, interval k spans nodes
  // k (p - 1) .. k (p - 1) + p - 1 with p = nodes_per_interval (2 for Hermite-Simpson,
  // BoundaryValueOptions::collocation_points otherwise).
  int nodes_per_interval = 2;
  /// The collocation solution at t, size n: the C1 cubic Hermite interpolant through (mesh, y,
  /// y_prime) for Hermite-Simpson, the interval's collocation polynomial otherwise. Throws
  /// UsageError if t is outside [mesh.front(), mesh.back()] or the solution has no derivative
  /// values.
  Eigen::VectorXd Evaluate(double t) const;
};

/// Solves y' = f(t, y) on [initial_mesh.front(), initial_mesh.back()] with g(y(a), y(b)) = 0.
/// initial_mesh: at least 2 strictly increasing finite times, where the refinement starts;
/// initial_guess: one vector of size n per mesh point (Newton's start). `jacobian` may be
/// empty (forward differences). Never throws for numerical failure: the summary says why
/// (kNoConvergence: f failed, singular Jacobian or Newton diverged; kTooManySteps: the mesh
/// would exceed max_mesh_points). Throws UsageError for invalid options or inconsistent sizes
/// (also when f or g return vectors of the wrong size).
BoundaryValueSolution SolveBoundaryValueProblem(const BvpRightHandSide& f,
                                                const BvpJacobian& jacobian,
                                                const BoundaryConditions& conditions,
                                                std::vector<double> initial_mesh,
                                                std::vector<Eigen::VectorXd> initial_guess,
                                                const BoundaryValueOptions& options = {});

}  // namespace servokit
