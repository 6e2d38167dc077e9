#pragma once
// Which inverse-model method solves a problem of a given class, and what `auto` picks: every
// method's conditions in one place, so that a refusal always names the methods that accept the
// problem, or says that none of servokit's does and why, and so that auto never picks a method
// that then refuses.
#include <memory>
#include <string>
#include <utility>
#include <vector>

#include "analysis/classification.h"
#include "base/errors.h"
#include "base/vocabulary.h"
#include "modeling/model.h"
#include "solvers/algebraic_inversion.h"

namespace servokit {

/// Whether a method solves the problem, and why not.
struct MethodVerdict {
  SolverMethod method = SolverMethod::kAuto;
  bool accepts = false;
  // Refused only because the zero dynamics are unstable: forcing it integrates them forward
  // anyway (and diverges; for a study of how fast).
  bool forceable = false;
  std::string reason;  // why it refuses; empty when it accepts
};

/// A method that does not fit the problem. what() gives the reason and the methods that fit,
/// or says that none of servokit's methods does and why each refuses.
/// The methods in the order auto tries them after the class's recommended one (Euler
/// backward, the paper's low-order comparison, is never auto's choice).
const std::vector<SolverMethod>& MethodsInOrderOfPreference();

/// The exact inverse of a linear problem (the method `linearized` solves its linearization by
/// it): algebraic when it is flat; the normal form, forward, when its zero dynamics are
/// asymptotically stable (causal, no pre-actuation) or critical (no bounded inverse); else the
/// bounded one, stable inversion.
SolverMethod ExactLinearInverseMethod(const Classification& linear);

class MethodChooser {
 public:
  /// `classification` of `model` at its operating point; both must outlive the chooser.
  /// `force`: forward methods accept unstable zero dynamics.
  MethodChooser(const Model& model, const Classification& classification, bool force);

  /// Whether `method` (not kAuto) solves this problem. For algebraic inversion of a flat
  /// problem this derives the inverse (GiNaC), once.
  const MethodVerdict& Assess(SolverMethod method);

  /// `asked` if it accepts, with "asked for"; for kAuto the class's recommended method if it
  /// accepts, else the first in MethodsInOrderOfPreference() that does, with why. Throws
  /// MethodRefused when the asked method refuses, or when none does for kAuto.
  std::pair<SolverMethod, std::string> Choose(SolverMethod asked);

  /// The inverse Assess(kAlgebraic) derived; null before or when it refused.
  std::shared_ptr<const AlgebraicInverse> algebraic_inverse() const { return algebraic_inverse_; }
  /// The input-output normal form of any vector relative degree (internal coordinates allowed)
  /// that Assess(kNormalForm) or Assess(kStableInversion) derived for a problem with P
  /// singular; null before, when it refused, or when P is regular (the normal form of Eq. 25
  /// serves then).
  std::shared_ptr<const AlgebraicInverse> output_normal_form() const { return output_normal_form_; }

 private:
  MethodVerdict Judge(SolverMethod method);
  // Derives output_normal_form_ once; "" when it exists, else why not (kept).
  std::string DeriveOutputNormalForm();
  // "method: reason; ..." for every method that refuses; adds the forceable ones.
  std::string RefusalReasons(std::vector<SolverMethod>& forceable);
  std::string Alternatives(SolverMethod refused,
                           std::vector<SolverMethod>& accepting,
                           std::vector<SolverMethod>& forceable);

  const Model& model_;
  const Classification& classification_;
  bool force_;
  std::vector<std::pair<SolverMethod, MethodVerdict>> verdicts_;
  std::shared_ptr<const AlgebraicInverse> algebraic_inverse_;
  std::shared_ptr<const AlgebraicInverse> output_normal_form_;
  std::string output_normal_form_refusal_;
  // A derivation found the relative degree undefined at the operating point.
  bool relative_degree_undefined_ = false;
};

}  // namespace servokit
