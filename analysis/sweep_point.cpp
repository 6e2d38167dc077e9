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
#include "analysis/linearization.h"
#include "analysis/zero_dynamics.h"
#include "base/errors.h"
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
    // GSL balances the companion matrix, whose last column is -a_k / a_n, by powers of 2 until
    // its row and column norms match; with a ratio beyond the double range that loop never ends
    // (measured: the three-mass chain at m = 9.7e-96, k = 1.3e87, c = -2.6e-72, a_0 / a_4 ~
    // 1e364, hung the sweep, deaf to SIGTERM). Such a polynomial goes to the general path.
    for (int k = 0; k < degree; ++k) {
      if (!std::isfinite(a[k] / a[degree])) return false;
    }
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

// What the polynomial path checks, one per thread: the matrices keep their memory from point to
// point, so that a sweep of millions of points does not allocate them each time.
struct PolynomialPathScratch {
  Linearization linearization;
  StateSpace state_space;
};

PolynomialPathScratch& ThreadScratch() {
  thread_local PolynomialPathScratch scratch;
  return scratch;
}

// The polynomial path answers only where the general path's numbers stay well inside the range
// of double: every nonzero entry of the time-scaled first-order form (ToStateSpace), which the
// general path works on, within [1 / kWellScaledEntry, kWellScaledEntry]. Its largest products
// are the Markov parameters C A^k B, k < 2 dof <= 6 (at most seven factors), whose squares it
// takes in norms: with entries up to 1e20 those stay within 1e+-280, where nothing overflows or
// underflows. Outside, the general path can fail (an overflow, a rank it cannot decide) where
// the polynomial still has roots, and a sweep must record what `analyze` says: there the
// general path decides. Measured on 50 000 random points per model (mass on car, rotational
// arm, rotational arm tip, three-mass chain), parameters up to 1e+-100 times their nominal
// values: 0 points where the two paths differ in success or failure with this bound, 50 to
// 500 without it.
constexpr double kWellScaledEntry = 1e20;

bool IsWellScaled(const Eigen::MatrixXd& matrix) {
  for (Eigen::Index i = 0; i < matrix.size(); ++i) {
    const double size = std::abs(matrix.data()[i]);
    if (size != 0.0 && !(size >= 1.0 / kWellScaledEntry && size <= kWellScaledEntry)) return false;
  }
  return true;
}

bool IsWellScaled(const StateSpace& state_space) {
  return IsWellScaled(state_space.state_matrix) && IsWellScaled(state_space.input_matrix) &&
         IsWellScaled(state_space.output_matrix);
}

// The fast path of a sweep point for single-output models whose zero-dynamics polynomial was
// derived at load (modeling/symbolic_model.h), at the default operating point q = 0. One compiled
// program gives the polynomial; its roots are the zero-dynamics eigenvalues (the invariant
// zeros, as in the QZ route of zero_dynamics.h), its degree the order of the internal dynamics,
// and 2 dof minus the degree the relative degree. P, its rank and the realization are decided
// exactly as in AnalyzeDecouplingMatrix. Returns false whenever the general path must decide:
// the equilibrium is not at rest at q = 0, B u0 varies with q, the equilibrium is not isolated
// (a_0 = 0), the linearization fails analyze's checks (FindLinearizationProblem: M singular or
// not finite, an overflow) or is not well scaled (IsWellScaled), or the two rank decisions
// disagree (inside the tolerance band of a singular point); `point` holds nothing of use then.
// So a point where `analyze` fails is recorded with analyze's own message. Writes into
// `point`'s own vectors, so that a sweep reusing its points allocates nothing here.
bool AnalyzeFromPolynomial(const Model& model,
                           Workspace& workspace,
                           const ClassificationOptions& options,
                           SweepPoint& point) {
  if (!SweepTriesPolynomial(model, options)) return false;
  const auto dof = static_cast<Eigen::Index>(model.dof());
  // A model with the polynomial has fewer than SymbolicModel::kMaxPolynomialSize = 4
  // coordinates (dof + inputs <= 4): its vectors fit on the stack, and a sweep that calls this
  // millions of times does not allocate them. (A larger model, were the limit raised, takes
  // the general path.)
  constexpr int kMost = 4;
  using SmallVector = Eigen::Matrix<double, Eigen::Dynamic, 1, 0, kMost, 1>;
  using SmallRow = Eigen::Matrix<double, 1, Eigen::Dynamic, Eigen::RowMajor, 1, kMost>;
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
  if (!AllFinite(coefficients)) return false;
  const double tolerance = options.rank_tolerance;
  auto nonzero = [&](Eigen::Index k) { return std::abs(coefficients(k)) > tolerance * scales(k); };
  if (!nonzero(0)) return false;  // not an isolated equilibrium: the general path says so

  // analyze's checks of the linearization at q = 0 (singular or non-finite M, overflow), by
  // the same function as Linearize: where one fails, the general path records its message.
  Evaluate(model, workspace, zero, zero, static_cast<unsigned>(Quantity::kForcesJacobians));
  PolynomialPathScratch& scratch = ThreadScratch();
  Linearization& linearization = scratch.linearization;
  linearization.mass_matrix = workspace.mass_matrix;
  linearization.damping = workspace.forces_velocity_jacobian;
  // K = df/dq - d(B u0)/dq, and d(B u0)/dq = 0 here (u0 = 0, or dB/dq = 0 checked above).
  linearization.stiffness = workspace.forces_position_jacobian;
  linearization.input_matrix = workspace.input_matrix;
  linearization.output_jacobian = workspace.output_jacobian;
  if (FindLinearizationProblem(linearization)) return false;
  ToStateSpace(linearization, scratch.state_space);
  if (!IsWellScaled(scratch.state_space)) return false;

  // P = H M^-1 B and its rank, as AnalyzeDecouplingMatrix decides it.
  const SmallVector input_acceleration = linearization.input_acceleration.col(0);
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

bool SweepTriesPolynomial(const Model& model, const ClassificationOptions& options) {
  return model.has_zero_dynamics_polynomial() && model.num_outputs() == 1 &&
         !options.operating_point.y0 && !options.operating_point.q_guess;
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
