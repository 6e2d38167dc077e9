#include "analysis/sweep_point.h"

#include <gsl/gsl_errno.h>
#include <gsl/gsl_poly.h>

#include <algorithm>
#include <cassert>
#include <cmath>
#include <limits>
#include <memory>
#include <mutex>
#include <optional>

#include "analysis/classification.h"
#include "analysis/zero_dynamics.h"
#include "models/errors.h"
#include "numerics/finite.h"
#include "numerics/gsl_support.h"

namespace servokit {
namespace {

// ARPACK (Fortran dnaupd/dneupd) keeps its state between calls in SAVE variables, so two threads
// in it at once corrupt each other (measured: wrong zeros and a segmentation fault on a
// 2000-mass chain with two threads). Points on the ARPACK route hold this lock for their
// analysis; assembling the matrices stays parallel. Separate processes (mpirun) do not share it.
std::mutex arpack_mutex;

bool UsesArpack(const LinearModel& model, const LinearAnalysisOptions& options) {
  const LinearZeroDynamicsOptions& zeros = options.zero_dynamics;
  return zeros.solver == LinearEigenSolver::kArpack ||
         (zeros.solver == LinearEigenSolver::kAuto &&
          static_cast<Eigen::Index>(model.dof()) > zeros.dense_threshold);
}

LinearAnalysis AnalyzeLinearPoint(const LinearModel& model,
                                  const Eigen::VectorXd& parameters,
                                  LinearZeroDynamicsWorkspace& workspace,
                                  const LinearAnalysisOptions& options) {
  const LinearSystem system = AssembleLinearSystem(model, parameters);
  std::unique_lock<std::mutex> arpack_lock(arpack_mutex, std::defer_lock);
  if (UsesArpack(model, options)) arpack_lock.lock();
  return AnalyzeLinearSystem(system, workspace, options);
}

// The largest real part of eigenvalues sorted by SortEigenvalues; NaN (an empty CSV field)
// when there are none.
double MaxRealPart(const std::vector<std::complex<double>>& eigenvalues) {
  return eigenvalues.empty() ? std::numeric_limits<double>::quiet_NaN()
                             : eigenvalues.front().real();
}

// Roots of a_0 + a_1 x + ... + a_n x^n (a_n != 0): closed forms up to degree 2 (the quadratic
// in its cancellation-free form), GSL's companion-matrix QR beyond.
// Writes them into `roots` (its memory reused); false when QR did not converge.
bool PolynomialRoots(const double* a, int degree, std::vector<std::complex<double>>& roots) {
  roots.clear();
  if (degree == 1) {
    roots.push_back(-a[0] / a[1]);
  } else if (degree == 2) {
    const double discriminant = a[1] * a[1] - 4 * a[2] * a[0];
    if (discriminant >= 0) {
      const double q = -0.5 * (a[1] + std::copysign(std::sqrt(discriminant), a[1]));
      roots.push_back(q / a[2]);
      roots.push_back(q != 0.0 ? a[0] / q : 0.0);
    } else {
      const double real = -a[1] / (2 * a[2]);
      const double imaginary = std::sqrt(-discriminant) / (2 * std::abs(a[2]));
      roots.push_back({real, imaginary});
      roots.push_back({real, -imaginary});
    }
  } else if (degree > 2) {
    UseGslStatusCodes();
    std::unique_ptr<gsl_poly_complex_workspace, void (*)(gsl_poly_complex_workspace*)> workspace(
        gsl_poly_complex_workspace_alloc(std::size_t(degree + 1)), gsl_poly_complex_workspace_free);
    std::vector<double> packed(2 * std::size_t(degree));
    if (!workspace || gsl_poly_complex_solve(a, std::size_t(degree + 1), workspace.get(),
                                             packed.data()) != GSL_SUCCESS) {
      return false;  // QR did not converge: let the general path decide
    }
    for (int k = 0; k < degree; ++k) roots.push_back({packed[2 * k], packed[2 * k + 1]});
  }
  return true;
}

// The fast path of a sweep point for single-output models whose zero-dynamics polynomial was
// derived at load (models/symbolic_model.h), at the default operating point q = 0. One compiled
// program gives the polynomial; its roots are the zero-dynamics eigenvalues (the invariant
// zeros, as in the QZ route of zero_dynamics.h), its degree the order of the internal dynamics,
// and 2 dof minus the degree the relative degree. P, its rank and the realization are decided
// exactly as in AnalyzeDecouplingMatrix. Returns nullopt whenever the general path must decide:
// the equilibrium is not at rest at q = 0, B u0 varies with q, the equilibrium is not isolated
// (a_0 = 0), or the two rank decisions disagree (inside the tolerance band of a singular point):
// it returns false then, and `point` holds nothing of use. Writes into `point`'s own vectors,
// so that a sweep reusing its points allocates nothing here.
bool AnalyzeFromPolynomial(const Model& model,
                           Workspace& workspace,
                           const ClassificationOptions& options,
                           SweepPoint& point) {
  if (!model.has_zero_dynamics_polynomial() || model.num_outputs() != 1 ||
      options.operating_point.y0 || options.operating_point.q_guess) {
    return false;
  }
  const auto dof = static_cast<Eigen::Index>(model.dof());
  // A model with the polynomial has fewer than SymbolicModel::kMaxPolynomialSize = 4
  // coordinates (dof + inputs <= 4): its vectors and the mass matrix's factor fit on the stack,
  // and a sweep that calls this millions of times does not allocate them. (A larger model, were
  // the limit raised, takes the general path.)
  constexpr int kMost = 4;
  using SmallVector = Eigen::Matrix<double, Eigen::Dynamic, 1, 0, kMost, 1>;
  using SmallRow = Eigen::Matrix<double, 1, Eigen::Dynamic, Eigen::RowMajor, 1, kMost>;
  using SmallMatrix = Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, 0, kMost, kMost>;
  if (dof > kMost) return false;
  const SmallVector zero = SmallVector::Zero(dof);
  Evaluate(model, workspace, zero, zero, kPolynomialPathQuantities);
  const Eigen::Ref<const Eigen::VectorXd> input = workspace.input_matrix.col(0);
  const double input_size = input.squaredNorm();
  if (!(input_size > 0.0)) return false;
  // Equilibrium at q = 0: f(0, 0) = B u0 exactly (to round-off of f's own size).
  const double held_input = input.dot(workspace.forces) / input_size;
  if (!std::isfinite(held_input) ||
      (workspace.forces - input * held_input).lpNorm<Eigen::Infinity>() >
          options.operating_point.residual_tolerance *
              std::max(1.0, workspace.forces.lpNorm<Eigen::Infinity>())) {
    return false;
  }
  if (held_input != 0.0) {
    Evaluate(model, workspace, zero, zero,
             static_cast<unsigned>(Quantity::kInputMatrixDerivatives));
    for (const Eigen::MatrixXd& derivative : workspace.input_matrix_derivatives) {
      if (!derivative.isZero(0.0)) return false;  // K would miss -d(B u0)/dq
    }
  }
  const Eigen::VectorXd& coefficients = workspace.zero_dynamics_polynomial;
  const Eigen::VectorXd& scales = workspace.zero_dynamics_polynomial_scale;
  if (!AllFinite(coefficients) || !AllFinite(workspace.mass_matrix) ||
      !AllFinite(workspace.output_jacobian)) {
    return false;
  }
  const double tolerance = options.rank_tolerance;
  auto nonzero = [&](Eigen::Index k) { return std::abs(coefficients(k)) > tolerance * scales(k); };
  if (!nonzero(0)) return false;  // not an isolated equilibrium: the general path says so

  // P = H M^-1 B and its rank, as AnalyzeDecouplingMatrix decides it.
  const Eigen::LLT<SmallMatrix> mass(SmallMatrix(workspace.mass_matrix));
  if (mass.info() != Eigen::Success) return false;
  const SmallVector input_acceleration = mass.solve(input);
  const SmallRow output_row = workspace.output_jacobian.row(0);
  const double decoupling = output_row.dot(input_acceleration);
  const bool full_rank =
      std::abs(decoupling) > tolerance * output_row.norm() * input_acceleration.norm();

  // The degree: 2 dof - 2 for rank P = 1 (relative degree 2); below that otherwise.
  int degree = full_rank ? int(2 * dof - 2) : int(2 * dof - 3);
  if (full_rank != nonzero(2 * dof - 2)) return false;
  while (degree > 0 && !nonzero(degree)) --degree;

  point.ok = true;
  point.error.clear();
  point.rank = full_rank ? 1 : 0;
  if (full_rank) {
    // |D^T B| / |B| with D the orthonormal complement of H: the part of B off H's direction.
    const double along = output_row.dot(input) / output_row.norm();
    const double share = std::sqrt(std::max(0.0, input_size - along * along) / input_size);
    point.realization =
        share <= tolerance ? Realization::kIdealOrthogonal : Realization::kNonIdealOrthogonal;
  } else {
    point.realization = Realization::kTangential;
  }
  const int relative_degree = int(2 * dof) - degree;
  point.relative_degree.assign(1, relative_degree);
  point.differentiation_index = relative_degree + 1;
  point.internal_dynamics_order = degree;
  ZeroDynamicsSpectrum spectrum;
  spectrum.eigenvalues.swap(point.eigenvalues);  // the point's memory, not a new vector's
  const bool solved = PolynomialRoots(coefficients.data(), degree, spectrum.eigenvalues);
  if (solved) FinishZeroDynamicsClass(spectrum, options.imaginary_axis_tolerance);  // no modes
  point.eigenvalues.swap(spectrum.eigenvalues);
  if (!solved) return false;
  point.stability = spectrum.stability;
  point.max_real_part = MaxRealPart(point.eigenvalues);
  return true;
}

// Classifies in full into `point`. A success sets every field, so the point's vectors keep
// their memory from point to point (a sweep reuses its points).
void AnalyzeGenerally(const Model& model,
                      Workspace& workspace,
                      const ClassificationOptions& options,
                      SweepPoint& point) {
  ClassificationOptions point_options = options;
  point_options.cross_check = false;
  try {
    const Classification c = Classify(model, workspace, point_options);
    point.ok = true;
    point.error.clear();
    point.realization = c.decoupling.realization;
    point.rank = static_cast<long>(c.decoupling.rank);
    point.relative_degree.assign(c.structure.relative_degree.begin(),
                                 c.structure.relative_degree.end());
    point.differentiation_index = c.structure.differentiation_index;
    point.internal_dynamics_order = c.structure.internal_dynamics_order;
    point.stability = c.zero_dynamics.stability;
    point.eigenvalues.assign(c.zero_dynamics.eigenvalues.begin(),
                             c.zero_dynamics.eigenvalues.end());
    point.max_real_part = MaxRealPart(point.eigenvalues);
  } catch (const NoSolution& error) {
    point = SweepPoint{};  // rare: its memory need not be kept
    point.error = error.what();
  }
}

SweepPoint SummarizeLinearPoint(const LinearAnalysis& analysis) {
  SweepPoint point;
  point.ok = true;
  point.realization = analysis.decoupling.realization;
  point.rank = static_cast<long>(analysis.decoupling.rank);
  point.relative_degree = analysis.relative_degrees.relative_degree;
  point.differentiation_index = analysis.differentiation_index;
  point.internal_dynamics_order = static_cast<int>(analysis.internal_dynamics_order);
  point.stability = analysis.zero_dynamics.stability;
  point.eigenvalues = analysis.zero_dynamics.eigenvalues;
  point.max_real_part = MaxRealPart(point.eigenvalues);
  return point;
}

SweepPoint FailedLinearPoint(const Error& failure) {
  SweepPoint point;
  point.error = failure.what();
  std::replace(point.error.begin(), point.error.end(), '\n', ' ');
  return point;
}

}  // namespace

PointWorkspace::PointWorkspace(const LoadedModel& model) {
  if (const Model* multibody = model.multibody()) {
    multibody_.emplace(*multibody);
  } else {
    linear_ = std::make_unique<LinearZeroDynamicsWorkspace>();
    linear_parameters_ = model.parameters();
  }
}

Eigen::VectorXd& PointWorkspace::parameters() {
  return multibody_ ? multibody_->parameters : linear_parameters_;
}

ModelAnalysis AnalyzePoint(const LoadedModel& model,
                           PointWorkspace& workspace,
                           const AnalysisOptions& options) {
  if (const LinearModel* linear = model.linear()) {
    assert(workspace.linear() != nullptr);
    return AnalyzeLinearPoint(*linear, workspace.parameters(), *workspace.linear(), options.linear);
  }
  assert(workspace.multibody() != nullptr);
  return Classify(*model.multibody(), *workspace.multibody(), options.classification);
}

SweepPoint AnalyzeSweepPoint(const LoadedModel& model,
                             PointWorkspace& workspace,
                             const AnalysisOptions& options) {
  SweepPoint point;
  AnalyzeSweepPointInto(model, workspace, options, point);
  return point;
}

void AnalyzeSweepPointInto(const LoadedModel& model,
                           PointWorkspace& workspace,
                           const AnalysisOptions& options,
                           SweepPoint& point) {
  if (const Model* multibody = model.multibody()) {
    AnalyzeSweepPointInto(*multibody, *workspace.multibody(), options.classification,
                          SweepPath::kFast, point);
    return;
  }
  try {
    point = SummarizeLinearPoint(std::get<LinearAnalysis>(AnalyzePoint(model, workspace, options)));
  } catch (const NoSolution& failure) {
    point = FailedLinearPoint(failure);
  } catch (const ModelError& failure) {
    // A factor that is not finite at this point (a division by a varied parameter at 0).
    point = FailedLinearPoint(failure);
  }
}

SweepPoint AnalyzeSweepPoint(const Model& model,
                             Workspace& workspace,
                             const ClassificationOptions& options,
                             SweepPath path) {
  SweepPoint point;
  AnalyzeSweepPointInto(model, workspace, options, path, point);
  return point;
}

void AnalyzeSweepPointInto(const Model& model,
                           Workspace& workspace,
                           const ClassificationOptions& options,
                           SweepPath path,
                           SweepPoint& point) {
  if (path == SweepPath::kFast && AnalyzeFromPolynomial(model, workspace, options, point)) return;
  AnalyzeGenerally(model, workspace, options, point);
}

}  // namespace servokit
