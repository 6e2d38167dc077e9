#pragma once
// Derivatives on canonical forms (modeling/canonical_expression.h), multiplied out as they are
// built: Lagrange's equations of energies that are polynomials in their atoms (symbols, and
// functions of anything), the kinetic energy of a serial chain written out as a sum.
//
// GiNaC derives M and f of a chain of 400 pendulums in about 7 s, and servokit then converted
// the result into the canonical form to compile it: each diff() builds and evaluates GiNaC
// products, expand() builds them again (issue #31). Here the derivative of each term is built as
// canonical monomials directly (CanonicalExpressions::Monomial, ExpandedProduct), each node's
// derivative once per direction, and a long sum's terms are indexed by the symbols they hold,
// so that d/dx visits only the terms that hold x. The result is the form GiNaC's diff()
// followed by expand() gives (expand() leaves function arguments as they are; so does this),
// so a model derived either way compiles to the same program; a test holds the two equal
// (tests/modeling/expanded_derivative_test.cpp).
//
// A derivative that leaves those forms (a quotient by a sum, whose denominator expand() would
// rewrite; a product of sums past the budget) is refused as a whole: the caller derives with
// GiNaC instead. Internal to modeling/ (namespace detail); runs under a SymbolicLock.
#include <ginac/ginac.h>

#include <cstddef>
#include <map>
#include <optional>
#include <tuple>
#include <unordered_map>
#include <utility>
#include <vector>

#include "modeling/canonical_expression.h"

namespace servokit::detail {

class ExpandedDerivatives {
 public:
  using Scaled = CanonicalExpressions::Scaled;
  using NodeId = CanonicalExpressions::NodeId;

  /// Derivatives of forms in `store`, which must outlive this. A product that would multiply
  /// out more than `max_products` pairs of terms is refused (CanonicalExpressions::Expanded).
  ExpandedDerivatives(CanonicalExpressions& store, double max_products);

  /// A direction of differentiation: D s = rate for each (s, rate) of `seeds` (s a symbol's
  /// node), 0 for every other symbol. {x: 1} is d/dx; {q_k: q'_k for every coordinate} the time
  /// derivative with the accelerations zero. Returns the index that Derive takes.
  std::size_t AddDirection(const std::vector<std::pair<NodeId, Scaled>>& seeds);

  /// D value along `direction`, multiplied out; nullopt where that leaves the forms above.
  std::optional<Scaled> Derive(const Scaled& value, std::size_t direction);

 private:
  struct NotExpandable {};
  struct Direction {
    std::vector<NodeId> symbols;               // the seeded symbols, sorted
    std::unordered_map<NodeId, Scaled> rates;  // D of nodes known so far, seeds included
  };
  // d F(p_0, ..., p_(k-1)) / d p_i for a function F of placeholder symbols p: `held` when it is
  // coefficient * G(p_0, ..., p_(k-1)) for a function G whose evaluation looks at nothing but
  // numbers, constants and functions in its arguments (sin, cos, sinh, cosh, exp); else the
  // expression, to be substituted.
  struct FunctionPartialForm {
    bool held = false;
    GiNaC::numeric coefficient;
    std::string name;
    GiNaC::ex expression;
  };

  Scaled Rate(const Scaled& value, std::size_t direction);  // these throw NotExpandable
  // `known_to_move`: the caller knows `id` holds a seeded symbol (a sum's index said so).
  Scaled Rate(NodeId id, std::size_t direction, bool known_to_move = false);
  Scaled RateOfSum(NodeId id, std::size_t direction);
  Scaled RateOfProduct(NodeId id, std::size_t direction);
  Scaled RateOfPower(NodeId id, std::size_t direction);
  Scaled RateOfFunction(NodeId id, std::size_t direction);
  Scaled Product(const Scaled& a, const Scaled& b);
  bool AppendTimes(const std::vector<std::pair<NodeId, GiNaC::numeric>>& powers,
                   const std::vector<NodeId>& atoms,
                   const Scaled& value,
                   std::vector<Scaled>& terms);
  Scaled FunctionPartial(NodeId function, std::size_t argument);
  const FunctionPartialForm& PartialForm(const std::string& name,
                                         std::size_t arguments,
                                         std::size_t argument);
  // The symbols `id` holds, sorted; whether any of them is seeded in `direction`.
  const std::vector<NodeId>& Symbols(NodeId id);
  bool Moves(NodeId id, const Direction& direction);
  // A long sum's terms by the symbols they hold.
  const std::unordered_map<NodeId, std::vector<std::size_t>>& TermsBySymbol(NodeId sum);

  CanonicalExpressions& store_;
  double max_products_;
  std::vector<Direction> directions_;
  std::vector<std::optional<std::vector<NodeId>>> symbols_;  // by NodeId
  std::unordered_map<NodeId, std::unordered_map<NodeId, std::vector<std::size_t>>> term_index_;
  std::map<std::pair<NodeId, std::size_t>, Scaled> function_partials_;
  std::map<std::tuple<std::string, std::size_t, std::size_t>, FunctionPartialForm> partial_forms_;
  std::vector<GiNaC::realsymbol> placeholders_;  // a function's arguments in PartialForm
};

}  // namespace servokit::detail
