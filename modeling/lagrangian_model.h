#pragma once
// The Lagrangian form of a model (`kind: lagrangian` and `kind: planar-bodies`,
// docs/model-files.md): the equations of motion M(q) q'' + f(q, q') = B(q) u derived from
// the kinetic energy T, the potential energy V, the Rayleigh dissipation function R and the
// generalized forces Q. The one place these formulas are written; modeling/model_loader.cpp reads
// the file, checks the result and hands M and f to the same SymbolicModel as the explicit form.
// Internal to modeling/ (namespace detail); runs under the loader's SymbolicLock
// (modeling/symbolic_lock.h).
#include <ginac/ginac.h>

#include <optional>
#include <stdexcept>
#include <string>
#include <vector>

#include "modeling/canonical_expression.h"

namespace servokit::detail {

/// The most terms BoundExpandTerms (modeling/expansion_bound.h) may promise for an entry of M
/// or f, or for T - 1/2 q'^T M q', before it is left unexpanded: expanded, terms that cancel do
/// so exactly (the shipped and test models need at most ...); past it, a product of sums or a
/// linkage's loop closure would be multiplied out without bound (issue #31), and the entry stays
/// as derived, the same function.
inline constexpr double kMaxExpandedTerms = 2000;

/// The most terms the derived M and f of one model may hold together (a sum counts its terms,
/// anything else one): loading and analysing a chain of 400 pendulums takes about 1 KB a term
/// (560 000 terms, 590 MB), so the budget keeps a model within about 2 GB. Past it, loading stops
/// with an error that names the entry, before memory runs out (issue #31).
inline constexpr double kMaxDerivedTerms = 2e6;

/// A derivation past its TermBudget; what() is the problem, naming the entry.
class DerivationTooLarge : public std::length_error {
 public:
  using std::length_error::length_error;
};

/// The terms of the entries derived so far, against a limit. `entry` is a callable returning
/// the entry's name, called only when the limit is passed (a projected chain charges n^3
/// products: no name, no std::function is built per charge).
class TermBudget {
 public:
  explicit TermBudget(double limit = kMaxDerivedTerms) : limit_(limit) {}
  /// Adds `terms`; past the limit, throws DerivationTooLarge naming `entry()`.
  template <class Entry>
  void Charge(double terms, const Entry& entry) {
    used_ += terms;
    if (used_ > limit_) Exceeded(entry());
  }
  /// Adds the terms of `derived` (its operands if a sum, else 1).
  template <class Entry>
  void Charge(const GiNaC::ex& derived, const Entry& entry) {
    Charge(GiNaC::is_a<GiNaC::add>(derived) ? double(derived.nops()) : 1.0, entry);
  }
  double used() const { return used_; }

 private:
  [[noreturn]] void Exceeded(const std::string& entry) const;

  double limit_;
  double used_ = 0;
};

/// T(q, q'), V(q), R(q, q') (zero when absent) and Q(q, q') (dof x 1, zeros when absent), in the
/// symbols of the model.
struct Energies {
  GiNaC::ex kinetic = 0;
  GiNaC::ex potential = 0;
  GiNaC::ex dissipation = 0;
  GiNaC::matrix generalized_forces;
};

/// The momenta dT/dq'_k, derived once for M and f. `velocities[k]` is q'_k.
std::vector<GiNaC::ex> Momenta(const GiNaC::ex& kinetic,
                               const std::vector<GiNaC::realsymbol>& velocities);

/// M = d2T/dq' dq' from the momenta, dof x dof, symmetric by construction (each entry derived
/// once, above the diagonal, and mirrored). Each entry is charged to `budget`, as are f's in
/// LagrangeForces and the products of ProjectedEquations.
GiNaC::matrix KineticMassMatrix(const std::vector<GiNaC::ex>& momenta,
                                const std::vector<GiNaC::realsymbol>& velocities,
                                TermBudget& budget);

/// Lagrange's equations d/dt dT/dq' - dT/dq + dV/dq + dR/dq' = Q (+ B u) written as
/// M q'' + f = B u: f = (d2T/dq' dq) q' - dT/dq + dV/dq + dR/dq' - Q, dof x 1, each entry
/// expanded within kMaxExpandedTerms. (d2T/dq' dq) q' is the time derivative of dT/dq' with the
/// accelerations zero (modeling/time_derivative.h): one walk, not one per coordinate.
GiNaC::matrix LagrangeForces(const Energies& energies,
                             const std::vector<GiNaC::ex>& momenta,
                             const std::vector<GiNaC::realsymbol>& coordinates,
                             const std::vector<GiNaC::realsymbol>& velocities,
                             TermBudget& budget);

/// One scalar position of a body, p(q) (a centre's x or y, an angle), and its constant weight w
/// (the mass, or the inertia about the centre): T = 1/2 sum w (dp/dt)^2 over a model's
/// positions.
struct WeightedPosition {
  GiNaC::ex weight;
  GiNaC::ex position;
};

/// M and f for T = 1/2 sum_c w_c (dp_c/dt)^2 with weights free of q, by projecting each
/// position's equation of motion (Jourdain's principle, the projected Newton-Euler equations of
/// multibody codes): with J_c = dp_c/dq and the convective acceleration gamma_c = d2p_c/dt2 at
/// q'' = 0 (modeling/time_derivative.h), M = sum_c w_c J_c^T J_c and
/// f = sum_c w_c J_c^T gamma_c + dV/dq + dR/dq' - Q: Lagrange's equations of that T, since
/// d/dt dT/dq'_i - dT/dq_i = sum_c w_c J_c,i d2p_c/dt2. Nothing is multiplied out: each J_c and
/// gamma_c is built once and shared by the entries that use it, so a chain of n bodies costs
/// about n^3, where differentiating its unexpanded T twice costs n^4 or more (issue #31).
struct EquationsOfMotion {
  GiNaC::matrix mass_matrix, forces;
};
EquationsOfMotion ProjectedEquations(const std::vector<WeightedPosition>& positions,
                                     const Energies& energies,
                                     const std::vector<GiNaC::realsymbol>& coordinates,
                                     const std::vector<GiNaC::realsymbol>& velocities,
                                     TermBudget& budget);

/// T, V, R and Q (dof entries) in canonical form, all in one store: the energies as the loader
/// reads them (modeling/expression_parser.h), or as ReadPlanarBodies builds them.
struct CanonicalEnergies {
  CanonicalExpressions::Scaled kinetic, potential, dissipation;
  std::vector<CanonicalExpressions::Scaled> generalized_forces;
};

/// M (dof x dof, row by row) and f (dof) in canonical form.
struct CanonicalEquationsOfMotion {
  std::vector<CanonicalExpressions::Scaled> mass_matrix, forces;
};

/// KineticMassMatrix and LagrangeForces on canonical forms (modeling/expanded_derivative.h):
/// each entry multiplied out, the form those give where they expand it, at a cost that grows
/// with the terms of the energies and of the result (issue #31: a chain of 400 pendulums in a
/// fraction of GiNaC's time). Each entry is charged to `budget`. nullopt when a derivative
/// leaves the forms ExpandedDerivatives takes; the caller then derives with GiNaC.
/// `coordinates` and `velocities` are the symbols' nodes in `store`.
std::optional<CanonicalEquationsOfMotion> ExpandedLagrangeEquations(
    CanonicalExpressions& store,
    const CanonicalEnergies& energies,
    const std::vector<CanonicalExpressions::NodeId>& coordinates,
    const std::vector<CanonicalExpressions::NodeId>& velocities,
    TermBudget& budget);

/// True when T - 1/2 q'^T M q' multiplies out to zero (QuadraticFormRemainder on canonical
/// forms, M row by row); false when it does not, or cannot be multiplied out within
/// kMaxExpandedTerms: then QuadraticFormRemainder decides.
bool ExpandsToQuadraticForm(CanonicalExpressions& store,
                            const CanonicalExpressions::Scaled& kinetic,
                            const std::vector<CanonicalExpressions::Scaled>& mass_matrix,
                            const std::vector<CanonicalExpressions::NodeId>& velocities);

/// T - 1/2 q'^T M q' with M = KineticMassMatrix(T): zero exactly when T is a quadratic form in
/// the velocities, T(q, s q') = s^2 T(q, q') with M free of q' (no term linear in q' and none
/// free of it). Expanded within kMaxExpandedTerms; a caller decides "zero" symbolically (when
/// that is cheap, BoundExpandedTerms) or numerically.
GiNaC::ex QuadraticFormRemainder(const GiNaC::ex& kinetic,
                                 const GiNaC::matrix& mass_matrix,
                                 const std::vector<GiNaC::realsymbol>& velocities);

}  // namespace servokit::detail
