#pragma once
// The toolkit's named classes, each with one table of the words the docs, the files and the
// command line use for it (docs/analyze.md, docs/solve.md, docs/sweep.md). Every layer speaks
// them, and the public API (servokit/servokit.h) exports them, so they sit at the bottom with
// the errors: a value crosses every layer as the enum and becomes a word only where it is
// written or read. The header needs only the standard library (it is installed with the API).
#include <cstddef>
#include <optional>
#include <string_view>

namespace servokit {

/// A model file's kind: a multibody model (M(q) q'' + f = B u, y = h(q), with expressions) or a
/// large linear one (`kind: linear`, sparse matrices from Matrix Market files).
enum class ModelKind { kMultibody, kLinear };

/// How the inputs act on the servo constraint (paper Sect. 2.2, Fig. 3).
enum class Realization {
  kIdealOrthogonal,     // rank P = m and D^T B = 0: B u is orthogonal to the constraint manifold
  kNonIdealOrthogonal,  // rank P = m, B u also has a tangential part
  kTangential,          // P = 0: the inputs act only through the internal coupling
  kMixed,               // 0 < rank P < m
};

/// Stability of the linearized zero dynamics (paper Sect. 4, Lyapunov's indirect method).
enum class Stability {
  kAsymptoticallyStable,  // every eigenvalue in the open left half plane
  kUnstable,              // some eigenvalue in the open right half plane
  kCritical,              // none to the right, some on the imaginary axis: inconclusive
  kNone,                  // no zero dynamics (flat)
  // Some eigenvalue's real part is within its own error bound of 0 (and its damping ratio above
  // the axis tolerance), and none lies surely to the right: the precision of the computation
  // does not decide the side ("undetermined at this precision"; the note gives the numbers).
  // Last, so that the stored sweep records' codes of the others stay.
  kUndetermined,
};

/// Inverse-model solvers (paper Sect. 5).
enum class SolverMethod {
  kAuto,
  kAlgebraic,        // flat: u_d and q_d from y_d and its derivatives only
  kEuler,            // Euler backward on the projected DAE (Eqs. 61-64)
  kRadau,            // Radau IIA on the projected DAE (index up to 3)
  kBdf,              // BDF (SUNDIALS IDA) on the projected DAE, index 1
  kNormalForm,       // internal dynamics (Eq. 25) with Dormand-Prince
  kStableInversion,  // two-sided boundary value problem (Sect. 5.3)
  kLinearized,       // the exact inverse of the linearization, applied to the model
};

/// How a solve ended (style: Ceres' Solver::Summary). Solvers do not throw when they fail
/// numerically; the caller decides (`servokit solve` turns any status but kConverged into exit
/// status 3).
enum class SolveStatus {
  kConverged,           // reached the end time
  kNoConvergence,       // Newton failed even at the smallest step
  kSingularDecoupling,  // P = H M^-1 B became singular along the motion
  kSingularMass,        // M(q) became singular or ill-conditioned
  kStepSizeTooSmall,    // the step size fell below round-off of t
  kTooManySteps,        // the step limit was reached before the end time
  kIntegratorFailure,   // a SUNDIALS integrator failed (its flag is in the message)
  kNotApplicable,       // the method does not fit the problem's class (message says which does)
  kInterrupted,         // the observer asked to stop (e.g. Ctrl-C)
  // The solver reached the end, but its u_d, driving the model, leaves y_d by more than the
  // bound its tolerances allow (solvers/verification.h): the answer is not within them.
  kVerificationFailed,
};

/// The settings of a solve, as the toolkit names them in its messages (SettingError says which
/// one a message is about).
enum class SolveSetting {
  kMethod,
  kForce,              // integrate unstable internal dynamics forward anyway
  kStartTime,          // t_start
  kEndTime,            // t_end
  kStep,               // Euler backward's fixed step; the algebraic inverse's sample spacing
  kRelativeTolerance,  // rtol
  kAbsoluteTolerance,  // atol
  kSampleTime,         // the output grid t_start + k sample_time
  kPreActuation,       // stable inversion: time covered before the motion
  kPostActuation,      // stable inversion: time covered after it
};

/// What a threshold search looks for along a parameter.
enum class ThresholdEvent {
  kStability,    // the stability class or the number of eigenvalues in the right half plane
  kOscillation,  // the number of complex eigenvalue pairs (over-damping)
  kRealization,  // the realization class, the rank of P, or the sign of det P (P through zero)
  kStructure,    // the relative degrees or the differentiation index (the structure at infinity)
};

/// Which eigensolver computes a linear model's zeros.
enum class LinearEigenSolver {
  kAuto,    // dense up to LinearZeroDynamicsOptions::dense_threshold coordinates, ARPACK above
  kDense,   // every finite zero (cost ~ (2n)^3: 0.2 s at n = 200, ~35 s at n = 1000)
  kArpack,  // k zeros by ARPACK shift-invert (cost ~ n per iteration)
};

/// Which k zeros the ARPACK route computes (the dense route always computes all); the choice is
/// explained at LinearZeroDynamicsOptions (analysis/linear_zero_dynamics.h).
enum class EigenvalueTarget {
  kNearest,    // the k zeros nearest the real shift sigma (the slowest ones for sigma = 0)
  kRightmost,  // the k zeros of largest Re 1/(lambda - sigma): any right of sigma first
};

/// The formats of `analyze`'s report.
enum class ReportFormat { kText, kJson, kMarkdown };

/// The formats of a solve's file.
enum class SolveFileFormat {
  kCsv,       // "csv": every column, one row per sample (the default)
  kMat,       // "mat": MAT v5, one double column vector per CSV column and a struct `solve`
  kModelica,  // "modelica": CombiTimeTable text of t and the inputs, the table `u_d`
};

/// The files a sweep writes its tables to.
enum class SweepFileFormat {
  kCsv,   // points.csv, eigenvalues.csv
  kHdf5,  // sweep.h5
  kMat,   // sweep.mat (MAT 5)
};

/// A generated chain's output y = C q, one row C.
enum class ChainOutputWeights {
  kMass,     // y = q_j, the position of one mass (C has one entry)
  kLinear,   // y = sum_i (i / N) q_i: every mass, weighted by its place (a dense row of C)
  kUniform,  // y = sum_i q_i / N: the mean position, the centre of mass (a dense row of C)
};

// Each enum's word, and the enum of a word (nullopt for a word that names none).
std::string_view ToString(ModelKind kind);              // "multibody", "linear"
std::string_view ToString(Realization realization);     // "ideal-orthogonal", ...
std::string_view ToString(Stability stability);         // "asymptotically-stable", ...
std::string_view ToString(SolverMethod method);         // "auto", "algebraic", ...
std::string_view ToString(SolveStatus status);          // "converged", ...
std::string_view ToString(SolveSetting setting);        // "relative tolerance", ...
std::string_view ToString(ThresholdEvent event);        // "stability", ...
std::string_view ToString(LinearEigenSolver solver);    // "auto", "dense", "arpack"
std::string_view ToString(EigenvalueTarget target);     // "nearest", "rightmost"
std::string_view ToString(ReportFormat format);         // "text", "json", "md"
std::string_view ToString(SolveFileFormat format);      // "csv", "mat", "modelica"
std::string_view ToString(SweepFileFormat format);      // "csv", "hdf5", "mat"
std::string_view ToString(ChainOutputWeights weights);  // "mass", "linear", "uniform"

std::optional<ModelKind> ModelKindFromString(std::string_view text);
std::optional<Realization> RealizationFromString(std::string_view text);
std::optional<Stability> StabilityFromString(std::string_view text);
std::optional<SolverMethod> SolverMethodFromString(std::string_view text);
std::optional<SolveStatus> SolveStatusFromString(std::string_view text);
std::optional<ThresholdEvent> ThresholdEventFromString(std::string_view text);
std::optional<LinearEigenSolver> LinearEigenSolverFromString(std::string_view text);
std::optional<EigenvalueTarget> EigenvalueTargetFromString(std::string_view text);
std::optional<ReportFormat> ReportFormatFromString(std::string_view text);
std::optional<SolveFileFormat> SolveFileFormatFromString(std::string_view text);
std::optional<SweepFileFormat> SweepFileFormatFromString(std::string_view text);
std::optional<ChainOutputWeights> ChainOutputWeightsFromString(std::string_view text);

/// The length of the longest word of any Realization or Stability: the width of a fixed-width
/// text column that holds them (sweep.h5).
std::size_t LongestRealizationName();
std::size_t LongestStabilityName();

}  // namespace servokit
