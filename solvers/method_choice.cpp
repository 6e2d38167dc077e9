#include "solvers/method_choice.h"

#include <algorithm>

#include "base/number_format.h"
#include "solvers/solve_settings.h"

namespace servokit {
namespace {

// Radau IIA and Euler backward converge on DAEs of index up to 3 (Hairer & Wanner VII.8);
// beyond that the Newton iteration of the stages is too ill-conditioned.
constexpr int kMaxProjectedIndexForRadau = 3;

std::string Name(SolverMethod method) { return std::string(ToString(method)); }

std::string Join(const std::vector<SolverMethod>& methods, const std::string& separator) {
  std::string text;
  for (std::size_t i = 0; i < methods.size(); ++i) {
    text += (i > 0 ? separator : "") + Name(methods[i]);
  }
  return text;
}

// The zero-dynamics eigenvalues to 6 digits, as `analyze` prints them.
std::string Eigenvalues(const ZeroDynamics& zero_dynamics) {
  std::string text;
  for (const std::complex<double>& value : zero_dynamics.eigenvalues) {
    text += (text.empty() ? "" : ", ") +
            FormatComplexWith(value, [](double part) { return FormatSignificant(part, 6); });
  }
  return text;
}

}  // namespace

const std::vector<SolverMethod>& MethodsInOrderOfPreference() {
  // Exact first, then the methods accurate to their tolerance on the widest classes, then the
  // projected DAE; Euler backward last (first order, the paper's comparison).
  static const std::vector<SolverMethod> kOrder = {
      SolverMethod::kAlgebraic, SolverMethod::kStableInversion, SolverMethod::kNormalForm,
      SolverMethod::kBdf,       SolverMethod::kRadau,           SolverMethod::kEuler};
  return kOrder;
}

MethodChooser::MethodChooser(const Model& model, const Classification& classification, bool force)
    : model_(model), classification_(classification), force_(force) {}

const MethodVerdict& MethodChooser::Assess(SolverMethod method) {
  for (const auto& [judged, verdict] : verdicts_) {
    if (judged == method) return verdict;
  }
  verdicts_.emplace_back(method, Judge(method));
  return verdicts_.back().second;
}

MethodVerdict MethodChooser::Judge(SolverMethod method) {
  MethodVerdict verdict;
  verdict.method = method;
  const auto refuse = [&](std::string reason) {
    verdict.reason = std::move(reason);
    return verdict;
  };
  const DecouplingAnalysis& decoupling = classification_.decoupling;
  const OutputStructure& structure = classification_.structure;
  const ZeroDynamics& zero_dynamics = classification_.zero_dynamics;
  const bool decoupling_regular = decoupling.rank == decoupling.decoupling_matrix.rows();
  const std::string p_singular =
      Name(method) + " needs P = H M^-1 B regular (an orthogonal realization); this problem is " +
      std::string(ToString(decoupling.realization));
  const std::string no_internal_dynamics =
      "there are no internal dynamics for " + Name(method) + " to integrate (the problem is flat)";
  const bool unstable = zero_dynamics.stability == Stability::kUnstable;
  const std::string diverges = "the zero dynamics are unstable: " + Name(method) +
                               " integrates the internal dynamics forward, which diverges "
                               "(paper Sect. 5.3)";
  switch (method) {
    case SolverMethod::kAlgebraic:
      if (!classification_.flat) {
        return refuse("algebraic inversion needs a flat problem; internal dynamics of order " +
                      std::to_string(structure.internal_dynamics_order) + " remain");
      }
      try {
        AlgebraicInverseOptions options;
        options.reference_q = classification_.operating_point.q;
        options.rank_tolerance = classification_.rank_tolerance;
        algebraic_inverse_ = DeriveAlgebraicInverse(model_, options);
      } catch (const UndefinedRelativeDegree& error) {
        relative_degree_undefined_ = true;
        return refuse(error.what());
      } catch (const NoSolution& error) {
        return refuse(error.what());
      }
      break;
    case SolverMethod::kEuler:
    case SolverMethod::kRadau:
      if (structure.projected_index > kMaxProjectedIndexForRadau) {
        return refuse("the projected DAE has index " + std::to_string(structure.projected_index) +
                      ", more than the " + std::to_string(kMaxProjectedIndexForRadau) + " that " +
                      Name(method) + " handles");
      }
      if (unstable && !force_) {
        verdict.forceable = true;
        return refuse(diverges);
      }
      break;
    case SolverMethod::kBdf:
      if (!decoupling_regular) return refuse(p_singular);
      if (structure.internal_dynamics_order == 0) return refuse(no_internal_dynamics);
      if (unstable && !force_) {
        verdict.forceable = true;
        return refuse(diverges);
      }
      break;
    case SolverMethod::kNormalForm:
      if (decoupling_regular) {
        // Eq. (25): relative degree 2 in every output.
        if (structure.internal_dynamics_order == 0) return refuse(no_internal_dynamics);
      } else if (const std::string why = DeriveOutputNormalForm(); !why.empty()) {
        return refuse(why);
      }
      if (unstable && !force_) {
        verdict.forceable = true;
        return refuse(diverges);
      }
      break;
    case SolverMethod::kStableInversion:
      if (structure.internal_dynamics_order == 0) return refuse(no_internal_dynamics);
      // Stable inversion splits the internal dynamics into a part that decays forward in time
      // and one that decays backward (paper Sect. 5.3). With every eigenvalue to the left there
      // is no backward part: the boundary value problem is the forward one, which the causal
      // methods solve without pre-actuation (and its window search would widen without end).
      if (zero_dynamics.stability == Stability::kAsymptoticallyStable) {
        return refuse("the zero dynamics are asymptotically stable (" + Eigenvalues(zero_dynamics) +
                      "): the inverse is causal and needs no pre-actuation, which the forward "
                      "methods give");
      }
      if (!decoupling_regular) {
        if (const std::string why = DeriveOutputNormalForm(); !why.empty()) return refuse(why);
      }
      if (zero_dynamics.stability == Stability::kCritical) {
        return refuse("the zero dynamics are not hyperbolic: eigenvalues on the imaginary axis (" +
                      Eigenvalues(zero_dynamics) +
                      "), which stable inversion cannot split into decaying and growing parts");
      }
      break;
    case SolverMethod::kLinearized:
      break;  // the linearization's inverse always exists where the classification does
    case SolverMethod::kAuto:
      return refuse("auto is not a method");
  }
  verdict.accepts = true;
  return verdict;
}

std::string MethodChooser::DeriveOutputNormalForm() {
  if (output_normal_form_) return "";
  if (!output_normal_form_refusal_.empty()) return output_normal_form_refusal_;
  // Any vector relative degree: the outputs differentiated until the inputs appear (with a
  // dynamic extension where needed), internal coordinates completing the state (Isidori
  // Ch. 4-5).
  try {
    AlgebraicInverseOptions options;
    options.internal_dynamics = true;
    options.reference_q = classification_.operating_point.q;
    options.rank_tolerance = classification_.rank_tolerance;
    output_normal_form_ = DeriveAlgebraicInverse(model_, options);
    return "";
  } catch (const UndefinedRelativeDegree& error) {
    relative_degree_undefined_ = true;
    output_normal_form_refusal_ = "no input-output normal form: " + std::string(error.what());
    return output_normal_form_refusal_;
  } catch (const NoSolution& error) {
    output_normal_form_refusal_ = "no input-output normal form: " + std::string(error.what());
    return output_normal_form_refusal_;
  }
}

std::string MethodChooser::RefusalReasons(std::vector<SolverMethod>& forceable) {
  std::string why;
  for (const SolverMethod method : MethodsInOrderOfPreference()) {
    const MethodVerdict& verdict = Assess(method);
    if (verdict.accepts) continue;
    if (verdict.forceable) forceable.push_back(method);
    why += (why.empty() ? "" : "; ") + Name(method) + ": " + verdict.reason;
  }
  return why;
}

std::string MethodChooser::Alternatives(SolverMethod refused,
                                        std::vector<SolverMethod>& accepting,
                                        std::vector<SolverMethod>& forceable) {
  std::vector<SolverMethod> others;
  for (const SolverMethod method : MethodsInOrderOfPreference()) {
    if (method == refused) continue;
    const MethodVerdict& verdict = Assess(method);
    if (verdict.accepts) accepting.push_back(method);
    if (verdict.forceable) forceable.push_back(method);
    if (!verdict.accepts) others.push_back(method);
  }
  if (!accepting.empty()) return "use " + Join(accepting, " or ");
  std::string why;
  for (const SolverMethod method : others) {
    why += (why.empty() ? "" : "; ") + Name(method) + ": " + Assess(method).reason;
  }
  return "no method of servokit solves it (" + why + ")";
}

std::pair<SolverMethod, std::string> MethodChooser::Choose(SolverMethod asked) {
  std::vector<SolverMethod> accepting, forceable;
  if (asked != SolverMethod::kAuto) {
    const MethodVerdict verdict = Assess(asked);
    if (verdict.accepts) return {asked, "asked for"};
    if (verdict.forceable) forceable.push_back(asked);
    const std::string alternatives = Alternatives(asked, accepting, forceable);
    throw MethodRefused(verdict.reason + "; " + alternatives, accepting, forceable);
  }
  // P singular at the operating point: whether the model's own relative degree is defined
  // there (the derivation says); if not, no exact inverse passes through it, and the
  // projected-DAE methods, which would take over, are not what auto should offer.
  if (classification_.decoupling.rank < classification_.decoupling.decoupling_matrix.rows()) {
    DeriveOutputNormalForm();
  }
  const SolverMethod recommended = classification_.recommended_solver;
  const std::string class_text =
      (classification_.flat
           ? std::string("flat")
           : std::string(ToString(classification_.zero_dynamics.stability)) + " zero dynamics") +
      ", projected index " + std::to_string(classification_.structure.projected_index);
  if (relative_degree_undefined_) {
    std::vector<SolverMethod> unused;
    const std::string why = RefusalReasons(unused);
    throw MethodRefused(
        "no method of servokit solves this problem exactly (" + class_text +
            "): the relative degree is not defined at the operating point, so no exact inverse "
            "passes through it (" +
            why +
            "); the method `linearized` inverts the linearization "
            "at the operating point instead (an approximation: the forward check measures it); "
            "radau and euler, the paper's projected-DAE methods, may be asked for by name",
        {}, {});
  }
  if (Assess(recommended).accepts) {
    return {recommended, "auto: recommended for this class (" + class_text + ")"};
  }
  for (const SolverMethod method : MethodsInOrderOfPreference()) {
    if (method == SolverMethod::kEuler || !Assess(method).accepts) continue;
    return {method, "auto: " + Name(recommended) + ", recommended for this class (" + class_text +
                        "), does not fit: " + Assess(recommended).reason + "; so " + Name(method)};
  }
  const std::string why = RefusalReasons(forceable);
  throw MethodRefused("no method of servokit solves this problem (" + class_text + "): " + why +
                          "; the method `linearized` inverts the linearization at the "
                          "operating point instead (an approximation: the forward check "
                          "measures it)",
                      {}, forceable);
}

SolverMethod ExactLinearInverseMethod(const Classification& linear) {
  if (linear.flat) return SolverMethod::kAlgebraic;
  const Stability stability = linear.zero_dynamics.stability;
  return stability == Stability::kAsymptoticallyStable || stability == Stability::kCritical
             ? SolverMethod::kNormalForm
             : SolverMethod::kStableInversion;
}

}  // namespace servokit
