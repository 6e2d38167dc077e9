#pragma once
// The named classes of servokit's analysis and their strings. Each enum has one table that maps
// it to the string the docs use (docs/analyze.md; JSON, CSV, Markdown and the command line all go
// through it).
#include <cstddef>
#include <optional>
#include <string_view>

namespace servokit {

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

/// What a threshold search (FindThresholds) looks for along a parameter.
enum class ThresholdEvent {
  kStability,    // the stability class or the number of eigenvalues in the right half plane
  kOscillation,  // the number of complex eigenvalue pairs (over-damping)
  kRealization,  // the realization class, the rank of P, or the sign of det P (P through zero)
  kStructure,    // the relative degrees or the differentiation index (the structure at infinity)
};

std::string_view ToString(Realization realization);
std::string_view ToString(Stability stability);
std::string_view ToString(SolverMethod method);
std::string_view ToString(ThresholdEvent event);

/// The length of the longest name ToString gives any Realization or Stability: the width of a
/// fixed-width text column that holds them (sweep.h5).
std::size_t LongestRealizationName();
std::size_t LongestStabilityName();

std::optional<Realization> RealizationFromString(std::string_view text);
std::optional<Stability> StabilityFromString(std::string_view text);
std::optional<SolverMethod> SolverMethodFromString(std::string_view text);
std::optional<ThresholdEvent> ThresholdEventFromString(std::string_view text);

}  // namespace servokit
