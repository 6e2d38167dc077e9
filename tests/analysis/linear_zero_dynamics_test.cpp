// Zero dynamics of large sparse linear models (analysis/linear_zero_dynamics.h), against
// independent derivations.
//
// Chain (modeling/model_generators.h, GenerateChain): N masses m, springs k and dampers d from the
// ground to a free end, force on mass 1, output the position of mass j. Holding y = q_j = 0
// leaves masses j+1..N as a chain fixed at mass j and free at N, n' = N - j masses with
// M = m I, K = k T', D = d T', T' the fixed-free Laplacian of size n', whose eigenvalues are
// mu_i = 4 sin^2((2i - 1) pi / (2 (2n' + 1))), i = 1..n'. So these are zeros: the roots of
// m lambda^2 + d mu_i lambda + k mu_i = 0. Undamped, masses 1..j-1 follow from y and its
// derivatives: relative degree 2j, 2N - 2j zeros, exactly those. With dampers (d > 0) each link
// between the input and the output transmits k + d s: the transfer function q_j / u has the
// numerator (k + d s)^(j-1) times the sub-chain's polynomial, so the relative degree is j + 1
// and there are j - 1 more zeros at -k/d (a (j-1)-fold eigenvalue, whose round-off grows as
// eps^(1/(j-1)); the damped cases below stop at j = 2). This corrects the sketch, which
// holds for d = 0 only.
//
// Beam (GenerateBeam): hub of inertia J with torque u, Euler-Bernoulli link (rho_a, EI, L)
// clamped to it, output the tip's inertial displacement y = L theta + w(L). In the inertial
// deflection W(x, t) = x theta + w(x, t) the link obeys rho_a W_tt + EI W_xxxx = 0 (undamped),
// with w(0) = w'(0) = 0, w''(L) = w'''(L) = 0. Holding y = W(L) = 0 with the torque free: the
// clamp only says W(0) = 0 and W'(0) = theta (theta is free; the hub equation
// J theta'' = u + EI w''(0) only fixes u, so J drops out), and the zero dynamics is the link
// pinned at the hub and pinned at the tip with zero moment and shear at the tip:
//     W(0) = 0,  W(L) = 0,  W''(L) = 0,  W'''(L) = 0.
// With W = e^(lambda t) phi(x): EI phi'''' = -rho_a lambda^2 phi. Imaginary zeros
// lambda = +-i omega: phi'''' = b^4 phi, b^4 = rho_a omega^2 / EI, basis e^(bx), e^(-bx), cos bx,
// sin bx. Real zeros lambda = +-s: phi'''' = -4 a^4 phi, 4 a^4 = rho_a s^2 / EI, basis
// e^(+-ax) cos ax, e^(+-ax) sin ax. Each gives a 4 x 4 determinant of the four conditions in b
// (or a), whose roots GSL's Brent finds. Result, unlike the sketch: the determinant in b
// has no root below b L = 12 (no undamped zero; the problem is not self-adjoint, the boundary
// term -u''v' + u'v'' at x = 0 survives), the one in a has roots a L = 2.3650, 5.4978, 8.6394,
// ... (near (4k - 1) pi / 4): the zero dynamics is a ladder of real pairs +-s_k, hyperbolic and
// non-minimum phase, s_1 = 35.375 1/s for the default beam. Dense QZ of the FE pencil (SciPy)
// shows the same: only real pairs.
//
// The FE beam's P = C M^-1 B is nonzero in exact arithmetic but decays exponentially with N
// (M^-1 of a banded matrix decays away from the diagonal: 7e-3 at N = 4, 5e-10 at N = 16,
// round-off at N = 64), so its relative degree is numerically undetermined: the beam tests pass
// an unknown zero count, and the infinite eigenvalues are told apart by infinite_tolerance.
#include "analysis/linear_zero_dynamics.h"

#include <Eigen/Dense>
#include <algorithm>
#include <catch2/catch.hpp>
#include <chrono>
#include <cmath>
#include <complex>
#include <cstdlib>
#include <filesystem>
#include <functional>
#include <limits>
#include <numbers>
#include <string>
#include <vector>

#include "analysis/linear_analysis.h"
#include "base/errors.h"
#include "modeling/linear_model.h"
#include "modeling/model_generators.h"
#include "numerics/gsl_support.h"
#include "tests/chain_closed_form.h"

namespace servokit {
namespace {

using Complex = std::complex<double>;

// Writes the generated files, loads them back and assembles them at the nominal parameters:
// the path a user's model takes (servokit generate, then analyze).
LinearSystem LoadGenerated(const LinearModelFiles& files) {
  const std::filesystem::path directory =
      std::filesystem::temp_directory_path() /
      ("servokit_lzd_" + files.name + "_" + std::to_string(std::rand()));
  std::filesystem::create_directories(directory);
  const std::string path = WriteLinearModel(files, directory.string());
  const LinearModel model = LoadLinearModel(path);
  LinearSystem system = AssembleLinearSystem(model, model.parameters());
  std::filesystem::remove_all(directory);
  return system;
}

constexpr double kChainMass = 2.0;
constexpr double kChainStiffness = 3.0;

LinearSystem Chain(long masses, long output_mass, double damping) {
  ChainOptions options;
  options.masses = masses;
  options.output_mass = output_mass;
  options.mass = kChainMass;
  options.stiffness = kChainStiffness;
  options.damping = damping;
  return LoadGenerated(GenerateChain(options));
}

// The closed form, sorted as the solver sorts.
std::vector<Complex> ChainZeros(long masses, long output_mass, double d) {
  std::vector<Complex> zeros =
      testing::ChainZeros(masses, output_mass, kChainMass, kChainStiffness, d);
  SortEigenvalues(zeros);
  return zeros;
}

// A chain whose output mixes every coordinate: y = sum_i (i / N) q_i (a dense row of C).
LinearSystem LinearOutputChain(long masses, double damping) {
  ChainOptions options;
  options.masses = masses;
  options.mass = kChainMass;
  options.stiffness = kChainStiffness;
  options.damping = damping;
  options.output_weights = ChainOutputWeights::kLinear;
  return LoadGenerated(GenerateChain(options));
}

// The independent reference: QZ (Eigen's GeneralizedEigenSolver) of the dense first-order
// Rosenbrock pencil (A, E) of size 2n + m (see the header), no shift, no Schur complement, no
// sparse factorisation; the `count` eigenvalues of smallest magnitude (the infinite ones have
// beta ~ 0 and come last).
std::vector<Complex> PencilZeros(const LinearSystem& system, Eigen::Index count) {
  const Eigen::Index n = system.dof(), m = system.num_inputs();
  Eigen::MatrixXd a = Eigen::MatrixXd::Zero(2 * n + m, 2 * n + m);
  Eigen::MatrixXd e = Eigen::MatrixXd::Zero(2 * n + m, 2 * n + m);
  a.block(0, n, n, n).setIdentity();
  a.block(n, 0, n, n) = -Eigen::MatrixXd(system.stiffness);
  a.block(n, n, n, n) = -Eigen::MatrixXd(system.damping);
  a.block(n, 2 * n, n, m) = Eigen::MatrixXd(system.input_matrix);
  a.block(2 * n, 0, m, n) = Eigen::MatrixXd(system.output_matrix);
  e.block(0, 0, n, n).setIdentity();
  e.block(n, n, n, n) = Eigen::MatrixXd(system.mass);
  const Eigen::GeneralizedEigenSolver<Eigen::MatrixXd> qz(a, e, false);
  REQUIRE(qz.info() == Eigen::Success);
  std::vector<Complex> zeros;
  for (Eigen::Index i = 0; i < 2 * n + m; ++i) {
    const double beta = qz.betas()(i);
    zeros.push_back(beta == 0.0 ? Complex(std::numeric_limits<double>::infinity())
                                : qz.alphas()(i) / beta);
  }
  std::sort(zeros.begin(), zeros.end(),
            [](const Complex& x, const Complex& y) { return std::abs(x) < std::abs(y); });
  zeros.resize(std::size_t(count));
  SortEigenvalues(zeros);
  return zeros;
}

Eigen::Index ZeroCount(const LinearSystem& system) {
  LinearRelativeDegrees degrees;
  try {
    degrees = ComputeLinearRelativeDegrees(system, 1e-10);
  } catch (const NoSolution&) {
    return kUnknownZeroCount;  // the beam: P at round-off level (see the file comment)
  }
  Eigen::Index total = 0;
  for (int degree : degrees.relative_degree) total += degree;
  return 2 * system.dof() - total;
}

LinearZeroDynamics Zeros(const LinearSystem& system, const LinearZeroDynamicsOptions& options) {
  LinearZeroDynamicsWorkspace workspace;
  return ComputeLinearZeroDynamics(system, workspace, ZeroCount(system), options);
}

LinearZeroDynamicsOptions WithSolver(LinearEigenSolver solver, int eigenvalues = 10) {
  LinearZeroDynamicsOptions options;
  options.solver = solver;
  options.arpack.eigenvalues = eigenvalues;
  return options;
}

// ---- the continuous hub-beam zeros ------------------------------------------------------------

// Rows phi(0), phi(L), phi''(L), phi'''(L) of the real basis Re/Im e^(mu x) for the exponents
// `exponents` (a real exponent contributes e^(mu x) alone, a complex one its real and imaginary
// parts). Each column is divided by max(1, |e^(mu L)|) so that the determinant stays O(1).
double ConditionDeterminant(const std::vector<Complex>& exponents, double length) {
  Eigen::Matrix4d conditions;
  int column = 0;
  for (const Complex& mu : exponents) {
    const Complex tip = std::exp(mu * length);
    const double scale = std::max(1.0, std::abs(tip));
    const Complex rows[4] = {1.0, tip, mu * mu * tip, mu * mu * mu * tip};
    for (int part = 0; part < (mu.imag() == 0.0 ? 1 : 2); ++part) {
      for (int r = 0; r < 4; ++r) {
        conditions(r, column) = (part == 0 ? rows[r].real() : rows[r].imag()) / scale;
      }
      ++column;
    }
  }
  return conditions.determinant();
}

double OscillatoryDeterminant(double b, double length) {
  return ConditionDeterminant({b, -b, Complex(0.0, b)}, length);
}

double RealDeterminant(double a, double length) {
  return ConditionDeterminant({Complex(a, a), Complex(-a, a)}, length);
}

// Roots of `function` on (0, upper] by a scan for sign changes and Brent.
std::vector<double> Roots(const std::function<double(double)>& function, double upper, int steps) {
  UseGslStatusCodes();
  std::vector<double> roots;
  double previous = 1e-6 * upper;
  for (int i = 1; i <= steps; ++i) {
    const double next = upper * i / steps;
    if (function(previous) * function(next) < 0.0) {
      const auto bracket = NarrowBracket(gsl_root_fsolver_brent, function, previous, next, 1e-15);
      REQUIRE(bracket);
      roots.push_back(bracket->root);
    }
    previous = next;
  }
  return roots;
}

struct ContinuousBeamZeros {
  std::vector<double> real;       // s > 0 of lambda = +-s, ascending
  std::vector<double> frequency;  // omega > 0 of lambda = +-i omega (none, as it turns out)
};

ContinuousBeamZeros BeamZeros(const BeamOptions& beam) {
  const double speed = std::sqrt(beam.bending_stiffness / beam.mass_per_length);
  ContinuousBeamZeros zeros;
  // Wave numbers up to 12/L: the lowest few zeros, the ones FE resolves best.
  for (double a :
       Roots([&](double x) { return RealDeterminant(x, beam.length); }, 12.0 / beam.length, 4000)) {
    zeros.real.push_back(2.0 * a * a * speed);  // s = 2 a^2 sqrt(EI / rho_a)
  }
  for (double b : Roots([&](double x) { return OscillatoryDeterminant(x, beam.length); },
                        12.0 / beam.length, 4000)) {
    zeros.frequency.push_back(b * b * speed);  // omega = b^2 sqrt(EI / rho_a)
  }
  return zeros;
}

BeamOptions UndampedBeam(long elements) {
  BeamOptions options;
  options.elements = elements;
  options.damping_factor = 0.0;
  return options;
}

}  // namespace

// s^2 + 4 s + 13 = 0 has the roots -2 +- 3i, |lambda| = sqrt(13): one mode of sqrt(13) / (2 pi)
// Hz and damping ratio 2 / sqrt(13); with a root at -1 (carrying an imaginary round-off part of
// 1e-14, far below the tolerance 1e-9 * sqrt(13)) all three are in the left half plane.
TEST_CASE("the finishing step cleans, sorts and classifies the zeros of either route",
          "[analysis]") {
  ZeroDynamicsSpectrum spectrum;
  spectrum.eigenvalues = {{-2.0, -3.0}, {-1.0, 1e-14}, {-2.0, 3.0}};
  FinishZeroDynamics(spectrum, 1e-9);
  REQUIRE(spectrum.eigenvalues.size() == 3);
  CHECK(spectrum.eigenvalues[0] == std::complex<double>(-1.0, 0.0));  // imaginary part cleaned
  CHECK(spectrum.eigenvalues[1] == std::complex<double>(-2.0, 3.0));  // upper member first
  CHECK(spectrum.eigenvalues[2] == std::complex<double>(-2.0, -3.0));
  CHECK(spectrum.stability == Stability::kAsymptoticallyStable);
  CHECK(spectrum.minimum_phase);
  REQUIRE(spectrum.modes.size() == 1);
  // Built from the exact roots; round-off of |lambda| only.
  CHECK(spectrum.modes[0].frequency_hz == Approx(std::sqrt(13.0) / (2 * std::numbers::pi)));
  CHECK(spectrum.modes[0].damping_ratio == Approx(2.0 / std::sqrt(13.0)));

  ZeroDynamicsSpectrum unstable;
  unstable.eigenvalues = {{-1.0, 0.0}, {0.5, 0.0}};
  FinishZeroDynamics(unstable, 1e-9);
  CHECK(unstable.eigenvalues.front() == std::complex<double>(0.5, 0.0));
  CHECK(unstable.stability == Stability::kUnstable);
  CHECK_FALSE(unstable.minimum_phase);
  CHECK(unstable.modes.empty());
}

TEST_CASE("default linear zero-dynamics and ARPACK options are valid", "[analysis]") {
  CHECK_NOTHROW(LinearZeroDynamicsOptions{}.Validate());
  CHECK_NOTHROW(ArpackOptions{}.Validate());
}

TEST_CASE("bad options name the field, its value and the rule", "[analysis]") {
  ArpackOptions arpack;
  arpack.eigenvalues = 0;
  CHECK_THROWS_WITH(arpack.Validate(), "ArpackOptions::eigenvalues = 0: must be >= 1");
  arpack = {};
  arpack.basis_size = 5;
  CHECK_THROWS_WITH(arpack.Validate(),
                    "ArpackOptions::basis_size = 5: must be 0 (automatic) or >= eigenvalues + 2 "
                    "= 12");
  LinearZeroDynamicsOptions options;
  options.infinite_tolerance = 0.0;
  CHECK_THROWS_AS(options.Validate(), UsageError);
  CHECK_THROWS_WITH(options.Validate(), Catch::Contains("infinite_tolerance"));
}

TEST_CASE("solver and target names go both ways", "[analysis]") {
  for (auto solver :
       {LinearEigenSolver::kAuto, LinearEigenSolver::kDense, LinearEigenSolver::kArpack}) {
    CHECK(LinearEigenSolverFromString(ToString(solver)) == solver);
  }
  for (auto target : {EigenvalueTarget::kNearest, EigenvalueTarget::kRightmost}) {
    CHECK(EigenvalueTargetFromString(ToString(target)) == target);
  }
  CHECK_FALSE(LinearEigenSolverFromString("qz"));
}

TEST_CASE("chain zeros are those of the fixed-free sub-chain beyond the output", "[analysis]") {
  for (long masses : {6L, 12L, 25L}) {
    // Beyond j ~ 12 the Markov rows span more than 1e10 (entries of T^j grow as 4^j) and the
    // relative degree test cannot tell them from round-off.
    for (long output : {1L, 2L, masses / 2, std::min(masses - 1, 12L)}) {
      for (double damping : {0.0, 0.3}) {
        if (damping > 0.0 && output > 2) continue;  // (j-1)-fold zero at -k/d: see above
        CAPTURE(masses, output, damping);
        const LinearSystem system = Chain(masses, output, damping);
        const LinearZeroDynamics dense = Zeros(system, WithSolver(LinearEigenSolver::kDense));
        CHECK(dense.complete);
        CHECK(dense.zero_count == 2 * masses - (damping == 0.0 ? 2 * output : output + 1));
        // Dense eigensolver round-off relative to |lambda| ~ 1.
        CHECK(EigenvalueDistance(dense.eigenvalues, ChainZeros(masses, output, damping)) < 1e-10);
        CHECK(dense.stability ==
              (damping == 0.0 ? Stability::kCritical : Stability::kAsymptoticallyStable));
      }
    }
  }
}

TEST_CASE("ARPACK finds the chain zeros nearest the shift", "[analysis]") {
  const long masses = 25, output = 2;
  const LinearSystem system = Chain(masses, output, 0.1);
  for (double shift : {0.0, -0.05}) {
    LinearZeroDynamicsOptions options = WithSolver(LinearEigenSolver::kArpack, 6);
    options.shift = shift;
    const LinearZeroDynamics arpack = Zeros(system, options);
    CHECK(arpack.solver_used == LinearEigenSolver::kArpack);
    CHECK_FALSE(arpack.complete);
    REQUIRE(arpack.eigenvalues.size() == 6);
    const auto expected = NearestEigenvalues(ChainZeros(masses, output, 0.1), shift, 6);
    CHECK(EigenvalueDistance(arpack.eigenvalues, expected) < 1e-10);
  }
}

// The dense eigensolver is O(N^3): 35 s at N = 1000 on one core, about 500 s under the
// sanitizers, which would make this one test a third of CI. The sanitizers check the same code
// at N = 300 (3 % of the work); the normal build checks the size.
#if defined(__SANITIZE_ADDRESS__)
constexpr long kLargeChain = 300;
#else
constexpr long kLargeChain = 1000;
#endif

TEST_CASE("a large chain (N = 1000): ARPACK and dense agree on the 16 zeros nearest 0",
          "[analysis][slow]") {
  const LinearSystem system = Chain(kLargeChain, 1, 0.01);
  const auto start = std::chrono::steady_clock::now();
  const LinearZeroDynamics dense = Zeros(system, WithSolver(LinearEigenSolver::kDense));
  const double dense_seconds =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  const LinearZeroDynamics arpack = Zeros(system, WithSolver(LinearEigenSolver::kArpack, 16));
  REQUIRE(dense.eigenvalues.size() == static_cast<std::size_t>(2 * kLargeChain - 2));
  const auto dense_nearest = NearestEigenvalues(dense.eigenvalues, 0.0, 16);
  WARN("dense " << dense_seconds << " s; ARPACK - dense "
                << EigenvalueDistance(arpack.eigenvalues, dense_nearest));
  // Both are limited by round-off in the shift-inverted operator.
  CHECK(EigenvalueDistance(arpack.eigenvalues, dense_nearest) < 1e-8);
  CHECK(EigenvalueDistance(arpack.eigenvalues,
                           NearestEigenvalues(ChainZeros(kLargeChain, 1, 0.01), 0.0, 16)) < 1e-8);
  // The time is printed, not asserted (35 s on one busy core, 139 s with the machine
  // overloaded): tests assert numbers, bench/ measures speed.
}

TEST_CASE("FE zeros of the hub-beam converge to the continuous real pairs", "[analysis]") {
  const ContinuousBeamZeros continuous = BeamZeros(UndampedBeam(1));
  CHECK(continuous.frequency.empty());  // no undamped zero: see the file comment
  REQUIRE(continuous.real.size() >= 2);
  CHECK(continuous.real[0] == Approx(35.375).epsilon(1e-4));
  std::vector<double> errors;
  for (long elements : {8L, 16L, 32L, 64L}) {
    const LinearSystem system = LoadGenerated(GenerateBeam(UndampedBeam(elements)));
    const LinearZeroDynamics zeros = Zeros(system, WithSolver(LinearEigenSolver::kArpack, 4));
    // The four nearest 0, sorted descending: +s_2, +s_1, -s_1, -s_2, all real.
    REQUIRE(zeros.eigenvalues.size() == 4);
    double error = 0.0;
    for (std::size_t k = 0; k < 2; ++k) {
      const double exact = continuous.real[k];
      CHECK(zeros.eigenvalues[1 - k].imag() == 0.0);
      CHECK(zeros.eigenvalues[2 + k].imag() == 0.0);
      const double positive = zeros.eigenvalues[1 - k].real();
      const double negative = -zeros.eigenvalues[2 + k].real();
      error =
          std::max({error, std::abs(positive - exact) / exact, std::abs(negative - exact) / exact});
    }
    errors.push_back(error);
    CAPTURE(elements, error);
    CHECK(zeros.stability == Stability::kUnstable);
  }
  INFO("relative errors at N = 8, 16, 32, 64: " << errors[0] << ", " << errors[1] << ", "
                                                << errors[2] << ", " << errors[3]);
  // Hermite cubics: eigenvalue errors fall as h^4 (x16 per halving) until round-off.
  CHECK(errors[1] < errors[0] / 10.0);
  CHECK(errors[2] < errors[1] / 10.0);
  CHECK(errors[3] < 1e-6);
}

TEST_CASE("a non-minimum-phase beam is classified unstable by the rightmost route", "[analysis]") {
  BeamOptions beam;
  beam.elements = 400;  // 801 coordinates: ARPACK under auto
  const LinearSystem system = LoadGenerated(GenerateBeam(beam));
  LinearZeroDynamicsOptions options = WithSolver(LinearEigenSolver::kAuto, 4);
  options.target = EigenvalueTarget::kRightmost;
  const LinearZeroDynamics zeros = Zeros(system, options);
  CHECK(zeros.solver_used == LinearEigenSolver::kArpack);
  CHECK(zeros.stability == Stability::kUnstable);
  CHECK_FALSE(zeros.minimum_phase);
  REQUIRE_FALSE(zeros.eigenvalues.empty());
  // Re 1/lambda is largest for the lowest real zero of the tip output, so it is among them. With
  // D = beta K the link obeys rho_a W_tt + EI (1 + beta d/dt) W_xxxx = 0, so an undamped zero
  // s_1 becomes the root of lambda^2 = s_1^2 (1 + beta lambda):
  // lambda = (beta s_1^2 + sqrt(beta^2 s_1^4 + 4 s_1^2)) / 2 (35.4379 for 35.3753).
  const double s1 = BeamZeros(beam).real[0];
  const double beta = beam.damping_factor;
  const double damped =
      (beta * s1 * s1 + std::sqrt(beta * beta * s1 * s1 * s1 * s1 + 4 * s1 * s1)) / 2;
  double lowest_positive = std::numeric_limits<double>::infinity();
  for (const Complex& zero : zeros.eigenvalues) {
    if (zero.real() > 0.0) lowest_positive = std::min(lowest_positive, zero.real());
  }
  // 400 elements: FE error ~1e-10 (h^4 from the convergence test above); what is left is
  // round-off in the LU of R(0) (condition ~ h^-4): measured 1.1e-8.
  CHECK(lowest_positive == Approx(damped).epsilon(1e-7));
}

TEST_CASE("a sweep over parameter values analyses the pattern once", "[analysis]") {
  LinearZeroDynamicsWorkspace workspace;
  for (double damping : {0.05, 0.1, 0.2}) {
    const LinearSystem system = Chain(30, 2, damping);
    const LinearZeroDynamics zeros = ComputeLinearZeroDynamics(
        system, workspace, ZeroCount(system), WithSolver(LinearEigenSolver::kArpack, 4));
    CHECK(EigenvalueDistance(zeros.eigenvalues,
                             NearestEigenvalues(ChainZeros(30, 2, damping), 0.0, 4)) < 1e-10);
  }
  CHECK(workspace.pattern_analyses() == 1);
}

TEST_CASE("a sweep of a dense-output chain analyses the pattern of Q once", "[analysis]") {
  LinearZeroDynamicsWorkspace workspace;
  for (double damping : {0.05, 0.1, 0.2}) {
    const LinearSystem system = LinearOutputChain(30, damping);
    const LinearZeroDynamics zeros = ComputeLinearZeroDynamics(
        system, workspace, ZeroCount(system), WithSolver(LinearEigenSolver::kArpack, 4));
    CHECK(workspace.factorization() == RosenbrockFactorization::kSymmetricSchur);
    CHECK(EigenvalueDistance(zeros.eigenvalues,
                             NearestEigenvalues(PencilZeros(system, 58), 0.0, 4)) < 1e-9);
  }
  CHECK(workspace.pattern_analyses() == 1);
}

TEST_CASE("a shift on a zero is reported as a singular Rosenbrock matrix", "[analysis]") {
  // Two masses, output at mass 1, mass 2 without spring or damper: holding mass 1 leaves mass 2
  // free, a double zero at lambda = 0, which is the default shift.
  LinearSystem system = Chain(2, 1, 0.0);
  system.stiffness = SparseMatrix(2, 2);
  system.stiffness.insert(0, 0) = 1.0;
  system.damping = SparseMatrix(2, 2);
  LinearZeroDynamicsWorkspace workspace;
  CHECK_THROWS_AS(ComputeLinearZeroDynamics(system, workspace, 2, {}), NoSolution);
  CHECK_THROWS_WITH(ComputeLinearZeroDynamics(system, workspace, 2, {}),
                    Catch::Contains("singular at the shift s = 0"));
}

TEST_CASE("ARPACK out of iterations is NoSolution with ARPACK's reason", "[analysis]") {
  const LinearSystem system = Chain(200, 1, 0.01);
  LinearZeroDynamicsOptions options = WithSolver(LinearEigenSolver::kArpack, 30);
  options.target = EigenvalueTarget::kRightmost;  // slow: the wanted nu crowd near 0
  options.arpack.max_iterations = 1;
  CHECK_THROWS_AS(Zeros(system, options), NoSolution);
  CHECK_THROWS_WITH(Zeros(system, options),
                    Catch::Contains("ARPACK dnaupd failed (info = 1): maximum number of "
                                    "iterations taken"));
}

// Issue #19: an output that mixes all N coordinates makes C a dense row; the workspace applies
// the border through the Schur complement (LDLT of Q = K + sigma D + sigma^2 M only). The chain
// with y = sum (i/N) q_i has c_1 = 1/N != 0 next to the force on mass 1, so C M^-1 B != 0:
// relative degree 2 (a position output) and 2N - 2 zeros; the reference is QZ of the dense
// pencil.
TEST_CASE("a dense output row: the Schur route agrees with QZ of the dense pencil", "[analysis]") {
  for (double damping : {0.0, 0.3}) {
    CAPTURE(damping);
    const long masses = 40;
    const LinearSystem system = LinearOutputChain(masses, damping);
    REQUIRE(system.output_matrix.nonZeros() == masses);
    REQUIRE(ZeroCount(system) == 2 * masses - 2);
    LinearZeroDynamicsWorkspace workspace;
    const LinearZeroDynamics dense = ComputeLinearZeroDynamics(
        system, workspace, ZeroCount(system), WithSolver(LinearEigenSolver::kDense));
    CHECK(workspace.factorization() == RosenbrockFactorization::kSymmetricSchur);
    CHECK(dense.complete);
    CHECK(EigenvalueDistance(dense.eigenvalues, PencilZeros(system, 2 * masses - 2)) < 1e-9);
  }
}

TEST_CASE("a dense output row: ARPACK on the Schur route finds the zeros nearest 0", "[analysis]") {
  const long masses = 300;
  const LinearSystem system = LinearOutputChain(masses, 0.01);
  LinearZeroDynamicsWorkspace workspace;
  const LinearZeroDynamics arpack = ComputeLinearZeroDynamics(
      system, workspace, ZeroCount(system), WithSolver(LinearEigenSolver::kArpack, 10));
  CHECK(workspace.factorization() == RosenbrockFactorization::kSymmetricSchur);
  REQUIRE(arpack.eigenvalues.size() == 10);
  const auto expected = NearestEigenvalues(PencilZeros(system, 2 * masses - 2), 0.0, 10);
  CHECK(EigenvalueDistance(arpack.eigenvalues, expected) < 1e-8);
}

TEST_CASE("the Schur route reproduces the closed-form chain zeros, single and mixed weights",
          "[analysis]") {
  for (double shift : {0.0, 0.7, -0.05}) {
    CAPTURE(shift);
    LinearZeroDynamicsOptions options = WithSolver(LinearEigenSolver::kDense);
    options.shift = shift;
    const LinearSystem system = Chain(25, 2, 0.3);
    LinearZeroDynamicsWorkspace workspace;
    const LinearZeroDynamics dense =
        ComputeLinearZeroDynamics(system, workspace, ZeroCount(system), options);
    CHECK(workspace.factorization() == RosenbrockFactorization::kSymmetricSchur);
    CHECK(EigenvalueDistance(dense.eigenvalues, ChainZeros(25, 2, 0.3)) < 1e-10);
  }
  // The same chain with the output weights 0 except 1 at mass 2, written as a weighted sum over
  // all N coordinates (explicit zeros in C): the same zeros.
  LinearSystem system = Chain(25, 2, 0.3);
  std::vector<Eigen::Triplet<double>> row;
  for (int i = 0; i < 25; ++i) row.emplace_back(0, i, i == 1 ? 1.0 : 0.0);
  system.output_matrix.setFromTriplets(row.begin(), row.end());
  CHECK(EigenvalueDistance(Zeros(system, WithSolver(LinearEigenSolver::kDense)).eigenvalues,
                           ChainZeros(25, 2, 0.3)) < 1e-10);
}

// A circulatory (non-symmetric) term in the stiffness: Q is not symmetric, so the Schur route
// factorises it by sparse LU. The reference is QZ again.
TEST_CASE("a non-symmetric Q takes the sparse LU of Q and agrees with QZ", "[analysis]") {
  const long masses = 20;
  LinearSystem system = LinearOutputChain(masses, 0.2);
  SparseMatrix skew(masses, masses);
  for (int i = 0; i + 1 < masses; ++i) {
    skew.insert(i, i + 1) = 0.05;
    skew.insert(i + 1, i) = -0.05;
  }
  system.stiffness = system.stiffness + skew;
  LinearZeroDynamicsWorkspace workspace;
  const LinearZeroDynamics dense = ComputeLinearZeroDynamics(system, workspace, ZeroCount(system),
                                                             WithSolver(LinearEigenSolver::kDense));
  CHECK(workspace.factorization() == RosenbrockFactorization::kSchur);
  CHECK(EigenvalueDistance(dense.eigenvalues, PencilZeros(system, 2 * masses - 2)) < 1e-9);
}

// The beam's hub turns freely: K has an empty row, so Q(0) = K is singular while R(0) is not.
// The workspace falls back to the sparse LU of R and still finds the zeros.
TEST_CASE("a singular Q (free hub at shift 0) falls back to the bordered LU", "[analysis]") {
  BeamOptions beam;
  beam.elements = 8;
  const LinearSystem system = LoadGenerated(GenerateBeam(beam));
  LinearZeroDynamicsWorkspace workspace;
  const LinearZeroDynamics dense = ComputeLinearZeroDynamics(system, workspace, kUnknownZeroCount,
                                                             WithSolver(LinearEigenSolver::kDense));
  CHECK(workspace.factorization() == RosenbrockFactorization::kBorderedLU);
  LinearZeroDynamicsOptions shifted = WithSolver(LinearEigenSolver::kDense);
  shifted.shift = 1.0;  // Q(1) = K + D + M is regular: the Schur route
  const LinearZeroDynamics schur =
      ComputeLinearZeroDynamics(system, workspace, kUnknownZeroCount, shifted);
  CHECK(workspace.factorization() == RosenbrockFactorization::kSymmetricSchur);
  // The slowest six (the fast FE zeros sit near nu = 0 and may be taken as infinite at one
  // shift and not at the other).
  CHECK(EigenvalueDistance(NearestEigenvalues(dense.eigenvalues, 0.0, 6),
                           NearestEigenvalues(schur.eigenvalues, 0.0, 6)) < 1e-7);
}

// Chain N = 3, m = 2, k = 3, d = 0.5, output at mass 2: a zero at -k/d = -6. There
// Q = 3 T - 6 (0.5 T) + 36 (2 I) = 72 I exactly, regular, and S = C Q^-1 B = e2' e1 / 72 = 0.
TEST_CASE("a shift on a zero with Q regular: the Schur complement is singular", "[analysis]") {
  const LinearSystem system = Chain(3, 2, 0.5);
  LinearZeroDynamicsOptions options = WithSolver(LinearEigenSolver::kDense);
  options.shift = -6.0;
  LinearZeroDynamicsWorkspace workspace;
  CHECK_THROWS_WITH(ComputeLinearZeroDynamics(system, workspace, ZeroCount(system), options),
                    Catch::Contains("singular at the shift s = -6") &&
                        Catch::Contains("Schur complement C Q^-1 B is singular"));
}

TEST_CASE("factorization names", "[analysis]") {
  CHECK(ToString(RosenbrockFactorization::kSymmetricSchur) == "symmetric-schur");
  CHECK(ToString(RosenbrockFactorization::kSchur) == "schur");
  CHECK(ToString(RosenbrockFactorization::kBorderedLU) == "bordered-lu");
  CHECK(ToString(RosenbrockFactorization::kNone) == "none");
}

TEST_CASE("ARPACK past its time limit is NoSolution saying so, never converged", "[analysis]") {
  const LinearSystem system = Chain(200, 1, 0.01);
  LinearZeroDynamicsOptions options = WithSolver(LinearEigenSolver::kArpack, 30);
  options.target = EigenvalueTarget::kRightmost;  // slow: many restarts
  options.arpack.time_limit = 1e-9;               // passed after the first operator application
  CHECK_THROWS_WITH(Zeros(system, options), Catch::Contains("stopped at its time limit") &&
                                                Catch::Contains("not converged"));
}

// ---- verdicts from each zero's own accuracy (issue #19) ---------------------------------------

// The closed-form zero nearest `zero` (tests/chain_closed_form.h).
Complex NearestChainZero(long masses, long output, double damping, Complex zero) {
  const std::vector<Complex> all =
      testing::ChainZeros(masses, output, kChainMass, kChainStiffness, damping);
  return *std::min_element(all.begin(), all.end(), [zero](const Complex& a, const Complex& b) {
    return std::abs(a - zero) < std::abs(b - zero);
  });
}

TEST_CASE("bounds decide each eigenvalue's side; within its bound it is undetermined",
          "[analysis]") {
  ZeroDynamicsSpectrum spectrum;
  spectrum.eigenvalues = {{-1e-6, 1.0}, {-1e-6, -1.0}};
  FinishZeroDynamicsWithBounds(spectrum, {1e-9, 1e-9}, 1e-9);
  // Damping ratio 1e-6 above its bound 1e-9: left, whatever a band relative to max |lambda| says.
  CHECK(spectrum.stability == Stability::kAsymptoticallyStable);
  CHECK(spectrum.stability_note.empty());
  FinishZeroDynamicsWithBounds(spectrum, {1e-5, 1e-5}, 1e-9);
  CHECK(spectrum.stability == Stability::kUndetermined);
  CHECK_FALSE(spectrum.minimum_phase);
  CHECK_THAT(spectrum.stability_note,
             Catch::Contains("undetermined at this precision") && Catch::Contains("1e-05"));
  // One zero surely right decides, whatever the others.
  spectrum.eigenvalues = {{-1e-6, 1.0}, {-1e-6, -1.0}, {2.0, 0.0}};
  FinishZeroDynamicsWithBounds(spectrum, {1e-5, 1e-5, 1e-3}, 1e-9);
  CHECK(spectrum.stability == Stability::kUnstable);
  REQUIRE(spectrum.error_bounds.size() == 3);
  CHECK(spectrum.error_bounds[0] == 1e-3);  // sorted with its eigenvalue (2 first)
  // On the axis within its bound and below the axis tolerance: critical, as before.
  spectrum.eigenvalues = {{1e-12, 1.0}, {1e-12, -1.0}};
  FinishZeroDynamicsWithBounds(spectrum, {1e-9, 1e-9}, 1e-9);
  CHECK(spectrum.stability == Stability::kCritical);
  CHECK(spectrum.eigenvalues[0] == Complex(0.0, 1.0));
  CHECK(StabilityFromString(ToString(Stability::kUndetermined)) == Stability::kUndetermined);
  CHECK(ToString(Stability::kUndetermined) == "undetermined");
}

// A damped chain observed at the mass the force acts on: M, D, K symmetric and diagonally
// dominant positive definite, the output collocated, so every zero solves m s^2 + d s + k = 0
// with m, d, k > 0 (a structural proof of asymptotic stability). Its slowest zero has
// Re = -d mu_1 / (2 m) ~ -6e-13 beside |lambda| ~ 2e-5 at N = 1e5 (damping ratio 3e-8): the
// case whose Re came out as exactly 0, or positive, at N = 1e6. The run at N = 1e6 is in
// docs/analyze.md, "Large linear models" (the test stays at 1e5 for time).
TEST_CASE("a damped chain of 1e5 masses is asymptotically stable, each zero as the closed form",
          "[analysis]") {
  const long masses = 100000;
  const double damping = 0.01;
  const LinearZeroDynamics zeros =
      Zeros(Chain(masses, 1, damping), WithSolver(LinearEigenSolver::kArpack, 10));
  CHECK(zeros.stability == Stability::kAsymptoticallyStable);
  CHECK(zeros.minimum_phase);
  CHECK_THAT(zeros.stability_note, Catch::Contains("certified by structure"));
  REQUIRE(zeros.eigenvalues.size() == 10);
  REQUIRE(zeros.error_bounds.size() == 10);
  for (std::size_t i = 0; i < zeros.eigenvalues.size(); ++i) {
    const Complex zero = zeros.eigenvalues[i];
    const Complex exact = NearestChainZero(masses, 1, damping, zero);
    CAPTURE(i, zero, exact, zeros.error_bounds[i]);
    CHECK(zero.real() < 0.0);
    // The quadratic Rayleigh quotient in long double: measured 1e-13 relative on Re; 1e-6
    // leaves room for other compilers' long double and summation order.
    CHECK(zero.real() == Approx(exact.real()).epsilon(1e-6));
    CHECK(std::abs(zero - exact) <= zeros.error_bounds[i]);  // the bound holds
  }
}

// The same chain observed at mass 2 is not collocated: no structural proof, and each zero is
// judged by its own error bound (measured errors 1e-12 against bounds 3e-10 at N = 1e5). At
// N = 1e4 |Re lambda_1| ~ 1e-10 exceeds its bound ~ 4e-11: stable. At N = 1e5 it is ~1e-12,
// below its bound: the answer is "undetermined at this precision", never a wrong word.
TEST_CASE("a non-collocated damped chain is stable at 1e4 masses, undetermined at 1e5",
          "[analysis]") {
  const double damping = 0.01;
  for (long masses : {10000L, 100000L}) {
    CAPTURE(masses);
    const LinearZeroDynamics zeros =
        Zeros(Chain(masses, 2, damping), WithSolver(LinearEigenSolver::kArpack, 10));
    REQUIRE(zeros.error_bounds.size() == zeros.eigenvalues.size());
    for (std::size_t i = 0; i < zeros.eigenvalues.size(); ++i) {
      const Complex exact = NearestChainZero(masses, 2, damping, zeros.eigenvalues[i]);
      CAPTURE(i, zeros.eigenvalues[i], exact, zeros.error_bounds[i]);
      CHECK(std::abs(zeros.eigenvalues[i] - exact) <= zeros.error_bounds[i]);
    }
    if (masses == 10000) {
      CHECK(zeros.stability == Stability::kAsymptoticallyStable);
    } else {
      CHECK(zeros.stability == Stability::kUndetermined);
      CHECK_THAT(zeros.stability_note, Catch::Contains("undetermined at this precision"));
    }
  }
}

// The FE beam's stiffness grows like N^4 against its mass: at N = 1e4 elements the mesh's
// highest frequency squared (~3e17) over the slowest zero's |lambda|^2 (~1e3) times eps is far
// above 1. Before this refusal ARPACK returned complex pairs where the converged zeros are real
// (file comment), and at N = 1e6 ran 900 s without converging.
TEST_CASE("the FE beam of 1e4 elements is refused: its zeros would carry no correct digit",
          "[analysis]") {
  const LinearSystem system = LoadGenerated(GenerateBeam(UndampedBeam(10000)));
  CHECK_THROWS_AS(Zeros(system, WithSolver(LinearEigenSolver::kArpack)), NoSolution);
  CHECK_THROWS_WITH(Zeros(system, WithSolver(LinearEigenSolver::kArpack)),
                    Catch::Contains("would carry no correct digit") && Catch::Contains("N^-4"));
}

}  // namespace servokit
