#include "modeling/lagrangian_model.h"

#include <algorithm>
#include <cassert>
#include <iterator>
#include <optional>
#include <unordered_map>
#include <unordered_set>
#include <utility>

#include "modeling/expairseq_pairs.h"
#include "modeling/expanded_derivative.h"
#include "modeling/expansion_bound.h"
#include "modeling/time_derivative.h"

namespace servokit::detail {
namespace {

// An expression's terms indexed by the symbols each contains, so that d/dx walks only the terms
// that hold x: differentiating a sum of N terms by each of n symbols then costs about N, not
// n N (GiNaC's diff walks every term), and a chain of n bodies' T, with n^2 terms, n^2 rather
// than n^3 (issue #31). The sum is the same as GiNaC's: every other term's derivative is 0.
class IndexedSum {
 public:
  explicit IndexedSum(const GiNaC::ex& expression) {
    if (GiNaC::is_a<GiNaC::add>(expression)) {
      for (const GiNaC::ex& term : expression) terms_.push_back(term);
    } else {
      terms_.push_back(expression);
    }
    for (std::size_t t = 0; t < terms_.size(); ++t) {
      std::unordered_set<GiNaC::ex, std::hash<GiNaC::ex>, GiNaC::ex_is_equal> symbols;
      for (auto node = terms_[t].preorder_begin(); node != terms_[t].preorder_end(); ++node) {
        if (GiNaC::is_a<GiNaC::symbol>(*node) && symbols.insert(*node).second) {
          by_symbol_[*node].push_back(t);
        }
      }
    }
  }

  GiNaC::ex Derivative(const GiNaC::realsymbol& symbol) const {
    const auto found = by_symbol_.find(symbol);
    if (found == by_symbol_.end()) return 0;
    GiNaC::exvector derivatives;
    derivatives.reserve(found->second.size());
    for (const std::size_t t : found->second) {
      derivatives.push_back(PartialDerivative(terms_[t], symbol));
    }
    return SumOf(std::move(derivatives));
  }

 private:
  std::vector<GiNaC::ex> terms_;
  // By GiNaC's hash, never iterated (each list is in term order).
  std::unordered_map<GiNaC::ex, std::vector<std::size_t>, std::hash<GiNaC::ex>, GiNaC::ex_is_equal>
      by_symbol_;
};

// The product of `factors` (evaluated expressions), with its sums kept as they are. GiNaC's
// mul::eval pulls each sum's integer content out, a walk over the sum's terms and, where the
// content is not 1, a copy of the sum, for every product built; a chain's projected M has n^3
// products of Jacobian entries that are sums of n terms each, so n^4 time and memory (issue
// #31). That is the only rule of eval left for two or more factors once the constructor has
// merged equal bases and gathered the numbers into the overall coefficient, so the product is
// marked evaluated as it is, unless that coefficient is not 1: a sum that holds the product
// copies it without its number and evaluates that copy again (add::split_ex_to_pair), so there
// the flag would buy nothing.
GiNaC::ex ProductKeepingSums(GiNaC::exvector factors) {
  const GiNaC::mul& product = GiNaC::dynallocate<GiNaC::mul>(std::move(factors));
  if (ExpairseqPairs::Of(product).size() >= 2 && ExpairseqPairs::OverallCoefficient(product) == 1) {
    product.setflag(GiNaC::status_flags::evaluated);
  }
  return product;
}

// `weight` as its number times the rest (1 for a number).
std::pair<GiNaC::ex, GiNaC::ex> SplitNumericFactor(const GiNaC::ex& weight) {
  if (GiNaC::is_a<GiNaC::numeric>(weight)) return {weight, 1};
  if (!GiNaC::is_a<GiNaC::mul>(weight)) return {1, weight};
  GiNaC::ex number = 1;
  for (const GiNaC::ex& factor : weight) {
    if (GiNaC::is_a<GiNaC::numeric>(factor)) number *= factor;
  }
  return {number, weight / number};
}

// The terms of a canonical form, as TermBudget::Charge counts them for a GiNaC expression.
double Terms(const CanonicalExpressions& store, const CanonicalExpressions::Scaled& value) {
  const CanonicalExpressions::Node& node = store.node(value.node);
  return node.kind == CanonicalExpressions::Kind::kSum ? double(node.operands.size()) : 1.0;
}

}  // namespace

void TermBudget::Exceeded(const std::string& entry) const {
  throw DerivationTooLarge("too large: its equations of motion pass the budget of " +
                           std::to_string(static_cast<long long>(limit_)) +
                           " terms (about 1 KB each; docs/model-files.md) at " + entry);
}

std::vector<GiNaC::ex> Momenta(const GiNaC::ex& kinetic,
                               const std::vector<GiNaC::realsymbol>& velocities) {
  const IndexedSum indexed(kinetic);
  std::vector<GiNaC::ex> momenta;
  momenta.reserve(velocities.size());
  for (const GiNaC::realsymbol& velocity : velocities)
    momenta.push_back(indexed.Derivative(velocity));
  return momenta;
}

GiNaC::matrix KineticMassMatrix(const std::vector<GiNaC::ex>& momenta,
                                const std::vector<GiNaC::realsymbol>& velocities,
                                TermBudget& budget) {
  const auto dof = static_cast<unsigned>(velocities.size());
  GiNaC::matrix mass(dof, dof);
  for (unsigned i = 0; i < dof; ++i) {
    const IndexedSum momentum(momenta[i]);  // dT/dq'_i
    for (unsigned j = i; j < dof; ++j) {
      mass(i, j) = ExpandWithinBudget(momentum.Derivative(velocities[j]), kMaxExpandedTerms);
      budget.Charge(mass(i, j), [&] {
        return "M's entry d2T/d" + velocities[i].get_name() + " d" + velocities[j].get_name();
      });
      mass(j, i) = mass(i, j);
    }
  }
  return mass;
}

GiNaC::matrix LagrangeForces(const Energies& energies,
                             const std::vector<GiNaC::ex>& momenta,
                             const std::vector<GiNaC::realsymbol>& coordinates,
                             const std::vector<GiNaC::realsymbol>& velocities,
                             TermBudget& budget) {
  assert(coordinates.size() == velocities.size());
  const auto dof = static_cast<unsigned>(coordinates.size());
  assert(energies.generalized_forces.rows() == dof && energies.generalized_forces.cols() == 1);
  const IndexedSum kinetic(energies.kinetic), potential(energies.potential),
      dissipation(energies.dissipation);
  TimeDerivative rate(coordinates, velocities);
  GiNaC::matrix forces(dof, 1);
  for (unsigned i = 0; i < dof; ++i) {
    GiNaC::exvector terms;
    // d/dt dT/dq'_i = sum_j d2T/dq'_i dq'_j q''_j + sum_j d2T/dq'_i dq_j q'_j; the first sum
    // is M q'', the second, D(dT/dq'_i) with the accelerations zero, belongs to f.
    terms.push_back(rate(momenta[i]));
    terms.push_back(-kinetic.Derivative(coordinates[i]));
    terms.push_back(potential.Derivative(coordinates[i]));
    terms.push_back(dissipation.Derivative(velocities[i]));
    terms.push_back(-energies.generalized_forces(i, 0));
    forces(i, 0) = ExpandWithinBudget(SumOf(std::move(terms)), kMaxExpandedTerms);
    budget.Charge(forces(i, 0), [&] { return "f's entry for " + coordinates[i].get_name(); });
  }
  return forces;
}

EquationsOfMotion ProjectedEquations(const std::vector<WeightedPosition>& positions,
                                     const Energies& energies,
                                     const std::vector<GiNaC::realsymbol>& coordinates,
                                     const std::vector<GiNaC::realsymbol>& velocities,
                                     TermBudget& budget) {
  assert(coordinates.size() == velocities.size());
  const std::size_t dof = coordinates.size();
  TimeDerivative rate(coordinates, velocities);
  // d/dq_k with one memo each across all positions: a chain's positions share their terms (link
  // a's sin(q_1 + ... + q_a) is in every later position), so each term is differentiated once
  // per coordinate, and a function's outer derivative built once, not once per position.
  std::vector<DirectionalDerivative> partials;
  partials.reserve(dof);
  for (const GiNaC::realsymbol& coordinate : coordinates) {
    partials.emplace_back(std::vector<std::pair<GiNaC::ex, GiNaC::ex>>{{coordinate, 1}});
  }
  std::vector<GiNaC::exvector> mass_terms(dof * dof), force_terms(dof);
  for (const WeightedPosition& moving : positions) {
    if (moving.weight.is_zero()) continue;
    const GiNaC::ex convective = rate(rate(moving.position));  // D of q' is 0: q'' = 0
    std::vector<GiNaC::ex> jacobian(dof);
    for (std::size_t k = 0; k < dof; ++k) jacobian[k] = partials[k](moving.position);
    // w dp/dq_i dp/dq_j as (number of w) dp/dq_i times the rest of w times dp/dq_j: the number
    // goes into the row's entry once (a sum stays a sum), so the product has none.
    const auto [number, rest] = SplitNumericFactor(moving.weight);
    for (std::size_t i = 0; i < dof; ++i) {
      if (jacobian[i].is_zero()) continue;
      const GiNaC::ex weighted_row = number * jacobian[i];
      const auto term = [&rest = rest, &weighted_row](const GiNaC::ex& other) {
        return rest.is_equal(1) ? ProductKeepingSums({weighted_row, other})
                                : ProductKeepingSums({rest, weighted_row, other});
      };
      force_terms[i].push_back(term(convective));
      budget.Charge(1.0, [&] { return "f's entry for " + coordinates[i].get_name(); });
      for (std::size_t j = i; j < dof; ++j) {
        if (jacobian[j].is_zero()) continue;
        mass_terms[i * dof + j].push_back(term(jacobian[j]));
        budget.Charge(1.0, [&] {
          return "M's entry for " + coordinates[i].get_name() + " and " + coordinates[j].get_name();
        });
      }
    }
  }
  const IndexedSum potential(energies.potential), dissipation(energies.dissipation);
  EquationsOfMotion equations{GiNaC::matrix(unsigned(dof), unsigned(dof)),
                              GiNaC::matrix(unsigned(dof), 1)};
  for (unsigned i = 0; i < dof; ++i) {
    for (unsigned j = i; j < dof; ++j) {
      equations.mass_matrix(i, j) = SumOf(std::move(mass_terms[i * dof + j]));
      equations.mass_matrix(j, i) = equations.mass_matrix(i, j);
    }
    GiNaC::exvector& terms = force_terms[i];
    terms.push_back(potential.Derivative(coordinates[i]));
    terms.push_back(dissipation.Derivative(velocities[i]));
    terms.push_back(-energies.generalized_forces(i, 0));
    equations.forces(i, 0) = SumOf(std::move(terms));
  }
  return equations;
}

std::optional<CanonicalEquationsOfMotion> ExpandedLagrangeEquations(
    CanonicalExpressions& store,
    const CanonicalEnergies& energies,
    const std::vector<CanonicalExpressions::NodeId>& coordinates,
    const std::vector<CanonicalExpressions::NodeId>& velocities,
    TermBudget& budget) {
  using Scaled = CanonicalExpressions::Scaled;
  assert(coordinates.size() == velocities.size());
  assert(energies.generalized_forces.size() == coordinates.size());
  const std::size_t dof = coordinates.size();
  ExpandedDerivatives derive(store, kMaxExpandedTerms);
  std::vector<std::size_t> by_velocity, by_coordinate;
  std::vector<std::pair<CanonicalExpressions::NodeId, Scaled>> rates;
  for (std::size_t k = 0; k < dof; ++k) {
    by_velocity.push_back(derive.AddDirection({{velocities[k], store.Number(1)}}));
    by_coordinate.push_back(derive.AddDirection({{coordinates[k], store.Number(1)}}));
    rates.emplace_back(coordinates[k], Scaled{1, velocities[k]});
  }
  const std::size_t along_motion = derive.AddDirection(rates);  // D, the accelerations zero

  std::vector<Scaled> momenta;  // dT/dq'_i
  momenta.reserve(dof);
  for (std::size_t i = 0; i < dof; ++i) {
    const std::optional<Scaled> momentum = derive.Derive(energies.kinetic, by_velocity[i]);
    if (!momentum) return std::nullopt;
    momenta.push_back(*momentum);
  }
  CanonicalEquationsOfMotion equations;
  equations.mass_matrix.assign(dof * dof, store.Number(0));
  for (std::size_t i = 0; i < dof; ++i) {
    for (std::size_t j = i; j < dof; ++j) {
      const std::optional<Scaled> entry = derive.Derive(momenta[i], by_velocity[j]);
      if (!entry) return std::nullopt;
      budget.Charge(Terms(store, *entry), [&] {
        return "M's entry d2T/d" + store.node(velocities[i]).name + " d" +
               store.node(velocities[j]).name;
      });
      equations.mass_matrix[i * dof + j] = equations.mass_matrix[j * dof + i] = *entry;
    }
  }
  // f = D(dT/dq') - dT/dq + dV/dq + dR/dq' - Q, as LagrangeForces.
  for (std::size_t i = 0; i < dof; ++i) {
    const std::optional<Scaled> parts[] = {
        derive.Derive(momenta[i], along_motion), derive.Derive(energies.kinetic, by_coordinate[i]),
        derive.Derive(energies.potential, by_coordinate[i]),
        derive.Derive(energies.dissipation, by_velocity[i]),
        store.Expanded(energies.generalized_forces[i], kMaxExpandedTerms)};
    if (!std::all_of(std::begin(parts), std::end(parts),
                     [](const std::optional<Scaled>& part) { return part.has_value(); })) {
      return std::nullopt;
    }
    const Scaled entry = store.Sum(
        {*parts[0], store.Scale(-1, *parts[1]), *parts[2], *parts[3], store.Scale(-1, *parts[4])});
    budget.Charge(Terms(store, entry),
                  [&] { return "f's entry for " + store.node(coordinates[i]).name; });
    equations.forces.push_back(entry);
  }
  return equations;
}

bool ExpandsToQuadraticForm(CanonicalExpressions& store,
                            const CanonicalExpressions::Scaled& kinetic,
                            const std::vector<CanonicalExpressions::Scaled>& mass_matrix,
                            const std::vector<CanonicalExpressions::NodeId>& velocities) {
  using Scaled = CanonicalExpressions::Scaled;
  const std::size_t dof = velocities.size();
  const std::optional<Scaled> expanded = store.Expanded(kinetic, kMaxExpandedTerms);
  if (!expanded) return false;
  std::vector<Scaled> terms = {*expanded};
  // -1/2 q'^T M q': each entry above the diagonal twice, by symmetry.
  for (std::size_t i = 0; i < dof; ++i) {
    for (std::size_t j = i; j < dof; ++j) {
      const Scaled& entry = mass_matrix[i * dof + j];
      if (entry.coefficient.is_zero()) continue;
      const GiNaC::numeric weight = i == j ? GiNaC::numeric(-1, 2) : GiNaC::numeric(-1);
      const std::optional<Scaled> term = store.ExpandedProduct(
          store.Scale(weight, entry), store.Monomial(1, {{velocities[i], 1}, {velocities[j], 1}}),
          kMaxExpandedTerms);
      if (!term) return false;
      terms.push_back(*term);
    }
  }
  const Scaled remainder = store.Sum(std::move(terms));
  return remainder.coefficient.is_zero();
}

GiNaC::ex QuadraticFormRemainder(const GiNaC::ex& kinetic,
                                 const GiNaC::matrix& mass_matrix,
                                 const std::vector<GiNaC::realsymbol>& velocities) {
  GiNaC::exvector quadratic_form;
  for (unsigned i = 0; i < velocities.size(); ++i) {
    for (unsigned j = 0; j < velocities.size(); ++j) {
      if (mass_matrix(i, j).is_zero()) continue;
      quadratic_form.push_back(mass_matrix(i, j) * velocities[i] * velocities[j]);
    }
  }
  return ExpandWithinBudget(kinetic - SumOf(std::move(quadratic_form)) / 2, kMaxExpandedTerms);
}

}  // namespace servokit::detail
