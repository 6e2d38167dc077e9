#pragma once
// How the classification decides: every tolerance of analysis/ lives here, with its reason.
#include "analysis/operating_point.h"

namespace servokit {

struct ClassificationOptions {
  // Where to linearize (docs/analyze.md "How it is computed", step 1: the operating point).
  OperatingPointOptions operating_point;
  // A singular value (or a row of a Markov parameter C A^k B) counts as zero when it is at most
  // rank_tolerance times the product of its factors' norms, e.g. sigma_i(P) <= 1e-10 |H| |M^-1 B|.
  // Relative to the factors, not to sigma_max(P), so that P = 0 (tangential) is recognised and
  // the verdict does not change with the model's units. 1e-10 is far above round-off (1e-16
  // times the condition of M) and far below any physically meant coupling.
  double rank_tolerance = 1e-10;
  // An eigenvalue whose own damping ratio |Re lambda| / |lambda| is at most this counts as on
  // the imaginary axis ("critical"); so does one below the zero floor, 1e-12 max |lambda|
  // (SideOfImaginaryAxis, analysis/zero_dynamics.h). Per eigenvalue, so that a slow mode beside
  // fast ones is not swallowed by a band the fast ones set; relative, so that the verdict does
  // not change with the model's time unit.
  double imaginary_axis_tolerance = 1e-9;
  // Also compute the invariant zeros of the linearization by QZ (a second, independent route)
  // and report how far they are from the zero-dynamics eigenvalues.
  bool cross_check = true;
  // The two routes agree when every eigenvalue matches within this, relative to max(1, |lambda|).
  double cross_check_tolerance = 1e-6;
  // Throws UsageError naming the field, its value and the rule it breaks.
  void Validate(const Model& model) const;
};

}  // namespace servokit
