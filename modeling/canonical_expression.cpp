#include "modeling/canonical_expression.h"

#include <algorithm>
#include <limits>
#include <sstream>
#include <stdexcept>

#include "modeling/expairseq_pairs.h"
#include "modeling/symbolic_lock.h"

namespace servokit {
namespace {

std::string GinacText(const GiNaC::ex& expression) {
  std::ostringstream stream;
  stream << expression;
  return stream.str();
}

std::string NumberText(const GiNaC::numeric& number) { return GinacText(number); }

// Where a value is printed; each level needs parentheses around more kinds of operand.
enum PrintContext : int {
  kTopLevel = 0,   // a whole expression, a term of a sum, a function's argument
  kFactor = 1,     // a factor of a product
  kPowerBase = 2,  // the base of a power
  kExponent = 3,   // the exponent of a power
};

// The order of kinds in the total order of nodes. Numbers come last, so that a sum's constant
// term is its last (x-1, not -1+x) and does not decide the sum's sign.
int KindRank(CanonicalExpressions::Kind kind) {
  using Kind = CanonicalExpressions::Kind;
  switch (kind) {
    case Kind::kConstant:
      return 0;
    case Kind::kSymbol:
      return 1;
    case Kind::kPower:
      return 2;
    case Kind::kProduct:
      return 3;
    case Kind::kSum:
      return 4;
    case Kind::kFunction:
      return 5;
    case Kind::kOpaque:
      return 6;
    case Kind::kNumber:
      return 7;
  }
  return 8;
}

int Sign(int value) { return (value > 0) - (value < 0); }

}  // namespace

CanonicalExpressions::CanonicalExpressions(const std::vector<GiNaC::ex>& ordered_symbols) {
  Node unit;
  unit.kind = Kind::kNumber;
  unit.number = 1;
  one_ = Intern(std::move(unit));
  for (std::size_t i = 0; i < ordered_symbols.size(); ++i) {
    symbol_ordinals_.emplace(ordered_symbols[i], i);
  }
}

std::size_t CanonicalExpressions::NodeHash::operator()(NodeId id) const {
  // GiNaC's hashes are seeded with addresses, but this table only looks nodes up within one
  // run and is never iterated, so its order cannot reach any output.
  const Node& node = self->nodes_[id];
  std::size_t hash = std::hash<int>()(static_cast<int>(node.kind));
  const auto mix = [&hash](std::size_t value) {
    hash ^= value + 0x9e3779b97f4a7c15ull + (hash << 6) + (hash >> 2);
  };
  mix(std::hash<std::string>()(node.name));
  if (node.kind == Kind::kSymbol || node.kind == Kind::kOpaque) mix(node.original.gethash());
  for (const Scaled& operand : node.operands) {
    mix(operand.node);
    mix(operand.coefficient.gethash());
  }
  return hash;
}

bool CanonicalExpressions::NodeEqual::operator()(NodeId a, NodeId b) const {
  const Node& x = self->nodes_[a];
  const Node& y = self->nodes_[b];
  if (x.kind != y.kind || x.name != y.name || x.operands.size() != y.operands.size()) {
    return false;
  }
  // Distinct symbols of one name stay distinct nodes (Convert() refuses two of one name that
  // are not both in the ordered list).
  if ((x.kind == Kind::kSymbol || x.kind == Kind::kOpaque) && !x.original.is_equal(y.original)) {
    return false;
  }
  for (std::size_t i = 0; i < x.operands.size(); ++i) {
    if (x.operands[i].node != y.operands[i].node ||
        !x.operands[i].coefficient.is_equal(y.operands[i].coefficient)) {
      return false;
    }
  }
  return true;
}

CanonicalExpressions::NodeId CanonicalExpressions::Intern(Node node) {
  // The candidate goes in last; if an equal node is known, the candidate is taken back out.
  nodes_.push_back(std::move(node));
  const auto id = NodeId(nodes_.size() - 1);
  const auto [found, inserted] = interned_.insert(id);
  if (!inserted) nodes_.pop_back();
  return *found;
}

CanonicalExpressions::Scaled CanonicalExpressions::Add(const GiNaC::ex& expression) {
  return Convert(expression);
}

CanonicalExpressions::Scaled CanonicalExpressions::Convert(const GiNaC::ex& expression) {
  if (const auto found = converted_.find(expression); found != converted_.end()) {
    return found->second;
  }
  Scaled result{1, one_};
  if (GiNaC::is_a<GiNaC::numeric>(expression)) {
    result = {GiNaC::ex_to<GiNaC::numeric>(expression), one_};
  } else if (GiNaC::is_a<GiNaC::symbol>(expression)) {
    Node node;
    node.kind = Kind::kSymbol;
    node.name = GiNaC::ex_to<GiNaC::symbol>(expression).get_name();
    node.original = expression;
    const auto ordinal = symbol_ordinals_.find(expression);
    node.ordinal = ordinal == symbol_ordinals_.end() ? symbol_ordinals_.size() : ordinal->second;
    if (ordinal == symbol_ordinals_.end()) {
      // A symbol outside the ordered list is known by its name alone.
      const auto [previous, inserted] = unlisted_symbols_.emplace(node.name, expression);
      if (!inserted && !previous->second.is_equal(expression)) {
        throw std::invalid_argument("two different symbols are named '" + node.name + "'");
      }
    }
    result = {1, Intern(std::move(node))};
  } else if (GiNaC::is_a<GiNaC::constant>(expression)) {
    Node node;
    node.kind = Kind::kConstant;
    node.name = GinacText(expression);
    node.original = expression;
    result = {1, Intern(std::move(node))};
  } else if (GiNaC::is_a<GiNaC::add>(expression)) {
    result = ConvertSum(expression);
  } else if (GiNaC::is_a<GiNaC::mul>(expression)) {
    result = ConvertProduct(expression);
  } else if (GiNaC::is_a<GiNaC::power>(expression)) {
    result = ConvertPower(expression);
  } else if (GiNaC::is_a<GiNaC::function>(expression) &&
             !GiNaC::is_a<GiNaC::fderivative>(expression)) {
    Node node;
    node.kind = Kind::kFunction;
    node.name = GiNaC::ex_to<GiNaC::function>(expression).get_name();
    for (std::size_t i = 0; i < expression.nops(); ++i) {
      node.operands.push_back(Convert(expression.op(i)));
    }
    result = {1, Intern(std::move(node))};
  } else {
    // A list, a relation, a matrix, a derivative of an unknown function: kept whole, compared
    // and printed by GiNaC's text (none of them is evaluated numerically).
    Node node;
    node.kind = Kind::kOpaque;
    node.original = expression;
    result = {1, Intern(std::move(node))};
  }
  converted_.emplace(expression, result);
  Remember(result, expression);
  return result;
}

CanonicalExpressions::Scaled CanonicalExpressions::ConvertSum(const GiNaC::ex& sum) {
  // Each pair coefficient * rest as op(i) would recombine it, without building that product.
  const auto& add = GiNaC::ex_to<GiNaC::add>(sum);
  std::vector<Scaled> terms;
  terms.reserve(sum.nops());
  for (const GiNaC::expair& pair : detail::ExpairseqPairs::Of(add)) {
    Scaled term = Convert(pair.rest);
    term.coefficient *= GiNaC::ex_to<GiNaC::numeric>(pair.coeff);
    terms.push_back(std::move(term));
  }
  const GiNaC::numeric& constant = detail::ExpairseqPairs::OverallCoefficient(add);
  if (!constant.is_zero()) terms.push_back({constant, one_});
  return Sum(std::move(terms));
}

CanonicalExpressions::Scaled CanonicalExpressions::Sum(std::vector<Scaled> terms) {
  // A multiple of a sum: GiNaC would have distributed the number (mul::eval) and flattened the
  // sum into this one (add's make_flat).
  // A sum's terms are sorted already: the other terms are sorted, and each sorted run merged in,
  // so that adding a term to a long sum costs a merge, not a sort of the whole.
  const auto before = [this](const Scaled& a, const Scaled& b) {
    return Compare(a.node, b.node) < 0;
  };
  std::vector<Scaled> flat;
  std::vector<const Scaled*> runs;  // the multiples of sums, merged in after the others
  for (Scaled& term : terms) {
    if (nodes_[term.node].kind == Kind::kSum) {
      runs.push_back(&term);
    } else {
      flat.push_back(std::move(term));
    }
  }
  std::sort(flat.begin(), flat.end(), before);
  for (const Scaled* run : runs) {
    const std::size_t middle = flat.size();
    for (const Scaled& inner : nodes_[run->node].operands) {
      flat.push_back({inner.coefficient * run->coefficient, inner.node});
    }
    std::inplace_merge(flat.begin(), flat.begin() + std::ptrdiff_t(middle), flat.end(), before);
  }
  // Terms GiNaC kept apart can be one node here (the same sum signed two ways): merge them.
  std::vector<Scaled> merged;
  for (Scaled& term : flat) {
    if (!merged.empty() && merged.back().node == term.node) {
      merged.back().coefficient += term.coefficient;
    } else {
      merged.push_back(std::move(term));
    }
  }
  std::erase_if(merged, [](const Scaled& term) { return term.coefficient.is_zero(); });
  if (merged.empty()) return {0, one_};
  if (merged.size() == 1) return merged.front();
  // The sign convention: the first term positive; -1 goes to whoever refers to the sum.
  // (A complex first coefficient is left as it is; numeric programs refuse complex numbers.)
  GiNaC::numeric sign = 1;
  if (merged.front().coefficient.is_real() && merged.front().coefficient.is_negative()) {
    sign = -1;
    for (Scaled& term : merged) term.coefficient = -term.coefficient;
  }
  Node node;
  node.kind = Kind::kSum;
  node.operands = std::move(merged);
  return {sign, Intern(std::move(node))};
}

CanonicalExpressions::Scaled CanonicalExpressions::Monomial(
    GiNaC::numeric coefficient, std::vector<std::pair<NodeId, GiNaC::numeric>> powers) {
  std::sort(powers.begin(), powers.end(),
            [this](const auto& a, const auto& b) { return Compare(a.first, b.first) < 0; });
  std::vector<Scaled> factors;
  for (std::size_t i = 0; i < powers.size();) {
    const NodeId base = powers[i].first;
    GiNaC::numeric exponent = 0;
    for (; i < powers.size() && powers[i].first == base; ++i) exponent += powers[i].second;
    if (exponent.is_zero()) continue;
    factors.push_back({1, SymbolPower(base, exponent)});
  }
  if (factors.empty() || coefficient.is_zero()) return {coefficient, one_};
  if (factors.size() == 1) return {coefficient, factors.front().node};
  std::sort(factors.begin(), factors.end(),
            [this](const Scaled& a, const Scaled& b) { return Compare(a.node, b.node) < 0; });
  Node node;
  node.kind = Kind::kProduct;
  node.operands = std::move(factors);
  return {coefficient, Intern(std::move(node))};
}

bool CanonicalExpressions::AppendMonomialFactors(
    NodeId id,
    bool divides,
    std::vector<std::pair<NodeId, GiNaC::numeric>>& powers,
    std::vector<NodeId>& atoms) const {
  const Node& node = nodes_[id];
  const GiNaC::numeric sign = divides ? -1 : 1;
  switch (node.kind) {
    case Kind::kSymbol:
      powers.emplace_back(id, sign);
      return true;
    case Kind::kFunction:
    case Kind::kConstant:
      if (divides) return false;
      powers.emplace_back(id, 1);
      atoms.push_back(id);
      return true;
    case Kind::kPower: {
      const Scaled& base = node.operands[0];
      const Scaled& exponent = node.operands[1];
      if (base.coefficient != 1 || nodes_[base.node].kind != Kind::kSymbol ||
          exponent.node != one_ || !exponent.coefficient.is_integer()) {
        return false;
      }
      powers.emplace_back(base.node, sign * exponent.coefficient);
      return true;
    }
    case Kind::kProduct:
      for (const Scaled& factor : node.operands) {
        if (!AppendMonomialFactors(factor.node, divides, powers, atoms)) return false;
      }
      return true;
    default:
      return false;
  }
}

bool CanonicalExpressions::AtomsOnce(std::vector<NodeId>& atoms) {
  std::sort(atoms.begin(), atoms.end());
  return std::adjacent_find(atoms.begin(), atoms.end()) == atoms.end();
}

CanonicalExpressions::Scaled CanonicalExpressions::Scale(const GiNaC::numeric& factor,
                                                         const Scaled& value) {
  const GiNaC::numeric coefficient = factor * value.coefficient;
  if (coefficient.is_zero()) return {0, one_};
  // A sum keeps its node for the signs (its first coefficient is positive either way).
  if (nodes_[value.node].kind != Kind::kSum || coefficient == 1 || coefficient == -1) {
    return {coefficient, value.node};
  }
  return Sum({{coefficient, value.node}});
}

CanonicalExpressions::Scaled CanonicalExpressions::HeldFunction(std::string name,
                                                                std::vector<Scaled> arguments) {
  Node node;
  node.kind = Kind::kFunction;
  node.name = std::move(name);
  node.operands = std::move(arguments);
  return {1, Intern(std::move(node))};
}

bool CanonicalExpressions::IsAtom(NodeId id) const {
  const Node& node = nodes_[id];
  switch (node.kind) {
    case Kind::kSymbol:
    case Kind::kConstant:
    case Kind::kFunction:
      return true;
    case Kind::kPower: {
      // A power of a symbol, a constant or a function: expand() leaves it as it is.
      const Scaled& base = node.operands[0];
      const Kind base_kind = nodes_[base.node].kind;
      return base.coefficient == 1 && (base_kind == Kind::kSymbol || base_kind == Kind::kConstant ||
                                       base_kind == Kind::kFunction);
    }
    default:
      return false;
  }
}

bool CanonicalExpressions::IsAtomicProduct(NodeId id) const {
  if (id == one_ || IsAtom(id)) return true;
  const Node& node = nodes_[id];
  return node.kind == Kind::kProduct &&
         std::all_of(node.operands.begin(), node.operands.end(),
                     [this](const Scaled& factor) { return IsAtom(factor.node); });
}

std::optional<CanonicalExpressions::Scaled> CanonicalExpressions::Expanded(const Scaled& value,
                                                                           double max_terms) {
  if (IsAtomicProduct(value.node)) return value;
  const Kind kind = nodes_[value.node].kind;
  // Copied: expanding adds nodes, which may move nodes_.
  const std::vector<Scaled> operands = nodes_[value.node].operands;
  switch (kind) {
    case Kind::kSum: {
      if (std::all_of(operands.begin(), operands.end(),
                      [this](const Scaled& term) { return IsAtomicProduct(term.node); })) {
        return value;
      }
      std::vector<Scaled> terms;
      terms.reserve(operands.size());
      for (const Scaled& term : operands) {
        std::optional<Scaled> expanded = Expanded(term, max_terms);
        if (!expanded) return std::nullopt;
        terms.push_back(std::move(*expanded));
      }
      return Scale(value.coefficient, Sum(std::move(terms)));
    }
    case Kind::kProduct: {
      Scaled product{value.coefficient, one_};
      for (const Scaled& factor : operands) {
        const std::optional<Scaled> expanded = Expanded(factor, max_terms);
        if (!expanded) return std::nullopt;
        const std::optional<Scaled> next = ExpandedProduct(product, *expanded, max_terms);
        if (!next) return std::nullopt;
        product = *next;
      }
      return product;
    }
    case Kind::kPower: {
      // A positive integer power of a sum or a product, multiplied out. Any other power (a
      // quotient by a sum) expand() would rewrite inside: not taken.
      const Scaled& base = operands[0];
      const Scaled& exponent = operands[1];
      if (exponent.node != one_ || !exponent.coefficient.is_pos_integer() ||
          base.coefficient != 1) {
        return std::nullopt;
      }
      const std::optional<Scaled> expanded_base = Expanded(base, max_terms);
      if (!expanded_base) return std::nullopt;
      Scaled power{value.coefficient, one_};
      for (GiNaC::numeric k = 0; k < exponent.coefficient; ++k) {
        const std::optional<Scaled> next = ExpandedProduct(power, *expanded_base, max_terms);
        if (!next) return std::nullopt;
        power = *next;
      }
      return power;
    }
    default:
      return std::nullopt;
  }
}

std::optional<CanonicalExpressions::Scaled> CanonicalExpressions::ExpandedProduct(
    const Scaled& a, const Scaled& b, double max_terms) {
  if (a.node == one_) return Scale(a.coefficient, b);
  if (b.node == one_) return Scale(b.coefficient, a);
  const bool a_sum = nodes_[a.node].kind == Kind::kSum;
  const bool b_sum = nodes_[b.node].kind == Kind::kSum;
  if (a_sum || b_sum) {
    // Copied: multiplying adds nodes, which may move nodes_.
    const std::vector<Scaled> a_terms =
        a_sum ? nodes_[a.node].operands : std::vector<Scaled>{{1, a.node}};
    const std::vector<Scaled> b_terms =
        b_sum ? nodes_[b.node].operands : std::vector<Scaled>{{1, b.node}};
    if (double(a_terms.size()) * double(b_terms.size()) > max_terms) return std::nullopt;
    std::vector<Scaled> terms;
    terms.reserve(a_terms.size() * b_terms.size());
    for (const Scaled& a_term : a_terms) {
      for (const Scaled& b_term : b_terms) {
        std::optional<Scaled> term = ExpandedProduct(a_term, b_term, max_terms);
        if (!term) return std::nullopt;
        terms.push_back(std::move(*term));
      }
    }
    return Scale(a.coefficient * b.coefficient, Sum(std::move(terms)));
  }
  std::vector<std::pair<NodeId, GiNaC::numeric>> powers;
  std::vector<NodeId> atoms;
  if (AppendMonomialFactors(a.node, false, powers, atoms) &&
      AppendMonomialFactors(b.node, false, powers, atoms) && AtomsOnce(atoms)) {
    return Monomial(a.coefficient * b.coefficient, std::move(powers));
  }
  if (!IsAtomicProduct(a.node) || !IsAtomicProduct(b.node)) return std::nullopt;
  // Powers of functions and constants, or a function twice: GiNaC's rules for them
  // (exp(x)*exp(x) is exp(2*x)).
  return Add(Expression(a) * Expression(b));
}

double CanonicalExpressions::TreeSize(const Scaled& value, double limit) const {
  double size = 0.0;
  std::vector<Scaled> pending = {value};
  while (!pending.empty() && size <= limit) {
    const Scaled next = std::move(pending.back());
    pending.pop_back();
    size += next.coefficient == 1 || next.node == one_ ? 1.0 : 2.0;
    const Node& node = nodes_[next.node];
    pending.insert(pending.end(), node.operands.begin(), node.operands.end());
  }
  return size;
}

void CanonicalExpressions::Remember(const Scaled& value, const GiNaC::ex& expression) {
  if (value.node == one_) return;
  if (expressions_.size() <= value.node) expressions_.resize(nodes_.size());
  if (!expressions_[value.node].has_value()) {
    expressions_[value.node] = KnownExpression{value.coefficient, expression};
  }
}

CanonicalExpressions::NodeId CanonicalExpressions::SymbolPower(NodeId base,
                                                               const GiNaC::numeric& exponent) {
  // The powers of a model's symbols recur in every term of a polynomial: each is interned once.
  constexpr int kMaxKeptExponent = 1 << 20;
  if (exponent == 1) return base;  // most factors of a monomial
  if (!exponent.is_integer() || GiNaC::abs(exponent) > kMaxKeptExponent) {
    return PowerOf({1, base}, {exponent, one_}).node;
  }
  const auto key = std::make_pair(base, exponent.to_int());
  if (const auto found = symbol_powers_.find(key); found != symbol_powers_.end()) {
    return found->second;
  }
  const NodeId power = PowerOf({1, base}, {exponent, one_}).node;
  symbol_powers_.emplace(key, power);
  return power;
}

GiNaC::ex CanonicalExpressions::Expression(const Scaled& value) {
  if (value.node == one_) return value.coefficient;
  if (value.node >= expressions_.size() || !expressions_[value.node].has_value()) {
    BuildExpression(value);
  }
  const KnownExpression& known = *expressions_[value.node];
  if (known.coefficient.is_equal(value.coefficient)) return known.expression;
  const GiNaC::ex scaled = (value.coefficient / known.coefficient) * known.expression;
  converted_.emplace(scaled, value);  // Add() of it finds its form without converting it
  return scaled;
}

void CanonicalExpressions::BuildExpression(const Scaled& value) {
  const Node& node = nodes_[value.node];  // building expressions adds no node
  GiNaC::exvector operands;
  operands.reserve(node.operands.size() + 1);
  for (const Scaled& operand : node.operands) operands.push_back(Expression(operand));
  Scaled built = {1, value.node};
  GiNaC::ex result;
  switch (node.kind) {
    case Kind::kNumber:
      result = node.number;
      break;
    case Kind::kConstant:
    case Kind::kSymbol:
    case Kind::kOpaque:
      result = node.original;
      break;
    case Kind::kPower:
      result = EvaluatedPower(operands[0], operands[1]);
      break;
    case Kind::kProduct:
      // With its number, as one GiNaC product (the terms of a sum are mostly such), not as the
      // node's product times the number.
      operands.push_back(value.coefficient);
      built = value;
      result = GiNaC::mul(operands);
      break;
    case Kind::kSum:
      result = GiNaC::add(operands);
      break;
    case Kind::kFunction:
      result = GiNaC::function(GiNaC::function::find_function(node.name, unsigned(operands.size())),
                               operands);
      break;
  }
  converted_.emplace(result, built);
  Remember(built, result);
}

CanonicalExpressions::Scaled CanonicalExpressions::ConvertProduct(const GiNaC::ex& product) {
  // Each pair rest ^ coefficient as op(i) would recombine it, without building that power.
  const auto& mul = GiNaC::ex_to<GiNaC::mul>(product);
  GiNaC::numeric coefficient = detail::ExpairseqPairs::OverallCoefficient(mul);
  std::vector<Scaled> factors;
  for (const GiNaC::expair& pair : detail::ExpairseqPairs::Of(mul)) {
    const GiNaC::numeric& exponent = GiNaC::ex_to<GiNaC::numeric>(pair.coeff);
    const Scaled factor =
        exponent == 1 ? Convert(pair.rest) : PowerOf(Convert(pair.rest), {exponent, one_});
    coefficient *= factor.coefficient;
    if (factor.node == one_) continue;
    const Node& converted = nodes_[factor.node];
    if (converted.kind == Kind::kProduct) {
      factors.insert(factors.end(), converted.operands.begin(), converted.operands.end());
    } else {
      factors.push_back({1, factor.node});
    }
  }
  std::sort(factors.begin(), factors.end(),
            [this](const Scaled& a, const Scaled& b) { return Compare(a.node, b.node) < 0; });
  if (factors.empty() || coefficient.is_zero()) return {coefficient, one_};
  if (factors.size() == 1) return {coefficient, factors.front().node};
  Node node;
  node.kind = Kind::kProduct;
  node.operands = std::move(factors);
  return {coefficient, Intern(std::move(node))};
}

CanonicalExpressions::Scaled CanonicalExpressions::ConvertPower(const GiNaC::ex& power) {
  return PowerOf(Convert(power.op(0)), Convert(power.op(1)));
}

CanonicalExpressions::Scaled CanonicalExpressions::PowerOf(const Scaled& base,
                                                           const Scaled& exponent) {
  Node node;
  node.kind = Kind::kPower;
  if (exponent.node == one_ && exponent.coefficient.is_integer()) {
    // (c b)^n = c^n b^n: the sign and the factor go outward, as for a product.
    const GiNaC::numeric coefficient =
        base.coefficient == 1 ? base.coefficient : base.coefficient.power(exponent.coefficient);
    if (base.node == one_ || exponent.coefficient.is_zero()) return {coefficient, one_};
    if (exponent.coefficient == 1) return {coefficient, base.node};
    node.operands = {{1, base.node}, exponent};
    return {coefficient, Intern(std::move(node))};
  }
  // A fractional or symbolic exponent: (-x)^(1/2) is not -(x^(1/2)), so the base keeps its
  // coefficient.
  node.operands = {base, exponent};
  return {1, Intern(std::move(node))};
}

int CanonicalExpressions::CompareScaled(const Scaled& a, const Scaled& b) const {
  if (const int nodes = Compare(a.node, b.node); nodes != 0) return nodes;
  return Sign(a.coefficient.compare(b.coefficient));
}

int CanonicalExpressions::Compare(NodeId a, NodeId b) const {
  if (a == b) return 0;
  const Node& x = nodes_[a];
  const Node& y = nodes_[b];
  if (x.kind != y.kind) return KindRank(x.kind) < KindRank(y.kind) ? -1 : 1;
  switch (x.kind) {
    case Kind::kNumber:
      return Sign(x.number.compare(y.number));
    case Kind::kConstant:
      return Sign(x.name.compare(y.name));
    case Kind::kSymbol: {
      if (const int names = x.name.compare(y.name); names != 0) return Sign(names);
      return x.ordinal < y.ordinal ? -1 : (x.ordinal > y.ordinal ? 1 : 0);
    }
    case Kind::kOpaque:
      return Sign(GinacText(x.original).compare(GinacText(y.original)));
    case Kind::kProduct:
      // Factors have coefficient 1: their nodes decide.
      if (x.operands.size() != y.operands.size()) {
        return x.operands.size() < y.operands.size() ? -1 : 1;
      }
      for (std::size_t i = 0; i < x.operands.size(); ++i) {
        if (const int factors = Compare(x.operands[i].node, y.operands[i].node); factors != 0) {
          return factors;
        }
      }
      return 0;
    case Kind::kFunction:
      // Arguments keep their coefficients (sin(2*x), sin(-x)): compared with them, below.
      if (const int names = x.name.compare(y.name); names != 0) return Sign(names);
      [[fallthrough]];
    case Kind::kPower:
    case Kind::kSum:
      if (x.operands.size() != y.operands.size()) {
        return x.operands.size() < y.operands.size() ? -1 : 1;
      }
      for (std::size_t i = 0; i < x.operands.size(); ++i) {
        if (const int operands = CompareScaled(x.operands[i], y.operands[i]); operands != 0) {
          return operands;
        }
      }
      return 0;
  }
  return 0;
}

std::string CanonicalExpressions::Text(const Scaled& value) const {
  std::string out;
  Print(value, kTopLevel, out);
  return out;
}

void CanonicalExpressions::Print(const Scaled& value, int context, std::string& out) const {
  GiNaC::numeric coefficient = value.coefficient;
  if (value.node == one_) {
    const bool plain = coefficient.is_integer() && !coefficient.is_negative();
    const bool wrap = context >= kFactor && !plain;
    if (wrap) out += '(';
    out += NumberText(coefficient);
    if (wrap) out += ')';
    return;
  }
  // The factors, split into a numerator and a denominator (negative numeric exponents).
  const Node& node = nodes_[value.node];
  std::vector<Scaled> numerator;
  std::vector<NodeId> denominator;  // powers with a negative numeric exponent
  const std::vector<Scaled> single = {{1, value.node}};
  for (const Scaled& factor : node.kind == Kind::kProduct ? node.operands : single) {
    const Node& power = nodes_[factor.node];
    const bool reciprocal = power.kind == Kind::kPower && power.operands[1].node == one_ &&
                            power.operands[1].coefficient.is_real() &&
                            power.operands[1].coefficient.is_negative();
    if (reciprocal) {
      denominator.push_back(factor.node);
    } else {
      numerator.push_back(factor);
    }
  }
  if (coefficient == 1 && denominator.empty() && numerator.size() == 1) {
    PrintNode(value.node, context, out);
    return;
  }
  // -x, 1/2*x, -2*x*y/(a+b): a product with a numeric factor, as GiNaC writes it, with the
  // negative powers as a quotient.
  const bool wrap = context >= kPowerBase ||
                    (context == kFactor && coefficient.is_real() && coefficient.is_negative());
  if (wrap) out += '(';
  if (coefficient.is_real() && coefficient.is_negative()) {
    out += '-';
    coefficient = -coefficient;
  }
  if (coefficient != 1 || numerator.empty()) {
    const bool plain = coefficient.is_rational();
    if (!plain) out += '(';
    out += NumberText(coefficient);
    if (!plain) out += ')';
    if (!numerator.empty()) out += '*';
  }
  for (std::size_t i = 0; i < numerator.size(); ++i) {
    if (i > 0) out += '*';
    Print(numerator[i], kFactor, out);
  }
  if (!denominator.empty()) {
    out += '/';
    if (denominator.size() > 1) out += '(';
    for (std::size_t i = 0; i < denominator.size(); ++i) {
      if (i > 0) out += '*';
      const Node& power = nodes_[denominator[i]];
      const GiNaC::numeric exponent = -power.operands[1].coefficient;
      if (exponent == 1) {
        Print(power.operands[0], denominator.size() > 1 ? kFactor : kPowerBase, out);
      } else {
        PrintPower(power.operands[0], exponent, kFactor, out);
      }
    }
    if (denominator.size() > 1) out += ')';
  }
  if (wrap) out += ')';
}

void CanonicalExpressions::PrintPower(const Scaled& base,
                                      const GiNaC::numeric& exponent,
                                      int context,
                                      std::string& out) const {
  if (exponent == 1) {
    Print(base, context, out);
    return;
  }
  if (exponent == GiNaC::numeric(1, 2)) {
    out += "sqrt(";
    Print(base, kTopLevel, out);
    out += ')';
    return;
  }
  const bool wrap = context >= kPowerBase;
  if (wrap) out += '(';
  Print(base, kPowerBase, out);
  out += '^';
  Print({exponent, one_}, kExponent, out);
  if (wrap) out += ')';
}

void CanonicalExpressions::PrintNode(NodeId id, int context, std::string& out) const {
  const Node& node = nodes_[id];
  switch (node.kind) {
    case Kind::kNumber:
      out += NumberText(node.number);
      return;
    case Kind::kConstant:
    case Kind::kSymbol:
      out += node.name;
      return;
    case Kind::kOpaque:
      out += GinacText(node.original);
      return;
    case Kind::kFunction:
      out += node.name;
      out += '(';
      for (std::size_t i = 0; i < node.operands.size(); ++i) {
        if (i > 0) out += ',';
        Print(node.operands[i], kTopLevel, out);
      }
      out += ')';
      return;
    case Kind::kPower: {
      const Scaled& base = node.operands[0];
      const Scaled& exponent = node.operands[1];
      if (exponent.node == one_) {
        PrintPower(base, exponent.coefficient, context, out);
        return;
      }
      const bool wrap = context >= kPowerBase;
      if (wrap) out += '(';
      Print(base, kPowerBase, out);
      out += '^';
      Print(exponent, kExponent, out);
      if (wrap) out += ')';
      return;
    }
    case Kind::kProduct: {
      const bool wrap = context >= kPowerBase;
      if (wrap) out += '(';
      for (std::size_t i = 0; i < node.operands.size(); ++i) {
        if (i > 0) out += '*';
        Print(node.operands[i], kFactor, out);
      }
      if (wrap) out += ')';
      return;
    }
    case Kind::kSum: {
      const bool wrap = context >= kFactor;
      if (wrap) out += '(';
      for (std::size_t i = 0; i < node.operands.size(); ++i) {
        const Scaled& term = node.operands[i];
        if (i > 0 && term.coefficient.is_real() && term.coefficient.is_negative()) {
          out += '-';
          Print({-term.coefficient, term.node}, kTopLevel, out);
        } else {
          if (i > 0) out += '+';
          Print(term, kTopLevel, out);
        }
      }
      if (wrap) out += ')';
      return;
    }
  }
}

DependenceOn::DependenceOn(const CanonicalExpressions& canonical,
                           const std::vector<CanonicalExpressions::NodeId>& symbols)
    : canonical_(canonical) {
  for (const CanonicalExpressions::NodeId symbol : symbols) {
    if (decided_.size() <= symbol) decided_.resize(symbol + 1, -1);
    decided_[symbol] = 1;
  }
}

bool DependenceOn::operator()(const CanonicalExpressions::Scaled& value) {
  return Decide(value.node);
}

bool DependenceOn::Decide(CanonicalExpressions::NodeId id) {
  if (id < decided_.size() && decided_[id] >= 0) return decided_[id] == 1;
  bool contains = false;
  for (const CanonicalExpressions::Scaled& operand : canonical_.node(id).operands) {
    if (Decide(operand.node)) {
      contains = true;
      break;
    }
  }
  if (decided_.size() <= id) decided_.resize(id + 1, -1);
  decided_[id] = contains ? 1 : 0;
  return contains;
}

GiNaC::ex EvaluatedPower(const GiNaC::ex& base, const GiNaC::ex& exponent) {
  const GiNaC::power power(base, exponent);
  return GiNaC::ex(power);  // evaluates; copied to the heap only once that succeeded
}

std::string CanonicalText(const GiNaC::ex& expression) {
  const SymbolicLock lock;
  CanonicalExpressions canonical;
  return canonical.Text(canonical.Add(expression));
}

GiNaC::ex CanonicalNormal(const GiNaC::ex& expression) {
  const SymbolicLock lock;
  const GiNaC::ex fraction = expression.numer_denom();
  return fraction.op(0).expand() / fraction.op(1).expand();
}

}  // namespace servokit
