#include "modeling/expanded_derivative.h"

#include <algorithm>
#include <array>
#include <string_view>

namespace servokit::detail {
namespace {

using Kind = CanonicalExpressions::Kind;

// A sum with at least this many terms is differentiated through an index of its terms by
// symbol; a shorter one term by term.
constexpr std::size_t kIndexedTerms = 32;

// Functions whose evaluation (GiNaC's sin_eval, ...) changes a held f(x) only for a number, a
// constant or a function argument: their value at the arguments of another held function is
// held too, and can be built without GiNaC.
constexpr std::array<std::string_view, 5> kHeldWithSymbolicArguments = {"sin", "cos", "sinh",
                                                                        "cosh", "exp"};

}  // namespace

ExpandedDerivatives::ExpandedDerivatives(CanonicalExpressions& store, double max_products)
    : store_(store), max_products_(max_products) {}

std::size_t ExpandedDerivatives::AddDirection(const std::vector<std::pair<NodeId, Scaled>>& seeds) {
  Direction direction;
  for (const auto& [symbol, rate] : seeds) {
    direction.symbols.push_back(symbol);
    direction.rates.emplace(symbol, rate);
  }
  std::sort(direction.symbols.begin(), direction.symbols.end());
  directions_.push_back(std::move(direction));
  return directions_.size() - 1;
}

std::optional<ExpandedDerivatives::Scaled> ExpandedDerivatives::Derive(const Scaled& value,
                                                                       std::size_t direction) {
  try {
    return Rate(value, direction);
  } catch (const NotExpandable&) {
    return std::nullopt;
  }
}

ExpandedDerivatives::Scaled ExpandedDerivatives::Rate(const Scaled& value, std::size_t direction) {
  return store_.Scale(value.coefficient, Rate(value.node, direction));
}

ExpandedDerivatives::Scaled ExpandedDerivatives::Rate(NodeId id,
                                                      std::size_t direction,
                                                      bool known_to_move) {
  {
    Direction& along = directions_[direction];
    if (const auto found = along.rates.find(id); found != along.rates.end()) return found->second;
    // A symbol not seeded does not move (without a set of symbols for it).
    const Kind kind = store_.node(id).kind;
    if (kind == Kind::kSymbol || kind == Kind::kNumber || kind == Kind::kConstant) {
      return store_.Number(0);
    }
    if (!known_to_move && !Moves(id, along)) return store_.Number(0);
  }
  Scaled rate = store_.Number(0);
  switch (store_.node(id).kind) {
    case Kind::kNumber:
    case Kind::kConstant:
    case Kind::kSymbol:  // handled above
      break;
    case Kind::kSum:
      rate = RateOfSum(id, direction);
      break;
    case Kind::kProduct:
      rate = RateOfProduct(id, direction);
      break;
    case Kind::kPower:
      rate = RateOfPower(id, direction);
      break;
    case Kind::kFunction:
      rate = RateOfFunction(id, direction);
      break;
    case Kind::kOpaque:
      throw NotExpandable{};
  }
  directions_[direction].rates.emplace(id, rate);
  return rate;
}

ExpandedDerivatives::Scaled ExpandedDerivatives::RateOfSum(NodeId id, std::size_t direction) {
  const std::size_t size = store_.node(id).operands.size();
  std::vector<std::size_t> moving;
  const bool indexed = size >= kIndexedTerms;
  if (indexed) {
    const auto& by_symbol = TermsBySymbol(id);
    for (const NodeId symbol : directions_[direction].symbols) {
      if (const auto found = by_symbol.find(symbol); found != by_symbol.end()) {
        moving.insert(moving.end(), found->second.begin(), found->second.end());
      }
    }
    std::sort(moving.begin(), moving.end());
    moving.erase(std::unique(moving.begin(), moving.end()), moving.end());
  } else {
    for (std::size_t t = 0; t < size; ++t) moving.push_back(t);
  }
  std::vector<Scaled> rates;
  rates.reserve(moving.size());
  for (const std::size_t t : moving) {
    // Copied, one term at a time: deriving adds nodes, which may move the store's.
    const Scaled term = store_.node(id).operands[t];
    // An indexed term holds a seeded symbol.
    const Scaled rate = store_.Scale(term.coefficient, Rate(term.node, direction, indexed));
    if (!rate.coefficient.is_zero()) rates.push_back(rate);
  }
  return store_.Sum(std::move(rates));
}

// sum_i D(a_i) prod_(j != i) a_j, each product multiplied out.
ExpandedDerivatives::Scaled ExpandedDerivatives::RateOfProduct(NodeId id, std::size_t direction) {
  const std::vector<Scaled> factors = store_.node(id).operands;  // coefficient 1 each
  std::vector<Scaled> terms;
  for (std::size_t i = 0; i < factors.size(); ++i) {
    const Scaled factor_rate = Rate(factors[i].node, direction);
    if (factor_rate.coefficient.is_zero()) continue;
    // The other factors: a monomial built at once where they are atoms, else multiplied out.
    std::vector<std::pair<NodeId, GiNaC::numeric>> powers;
    std::vector<NodeId> atoms;
    bool monomial = true;
    for (std::size_t j = 0; j < factors.size() && monomial; ++j) {
      if (j != i) monomial = store_.AppendMonomialFactors(factors[j].node, false, powers, atoms);
    }
    if (monomial && AppendTimes(powers, atoms, factor_rate, terms)) continue;
    Scaled rest = store_.Number(1);
    for (std::size_t j = 0; j < factors.size(); ++j) {
      if (j == i) continue;
      const std::optional<Scaled> expanded = store_.Expanded(factors[j], max_products_);
      if (!expanded) throw NotExpandable{};
      rest = Product(rest, *expanded);
    }
    terms.push_back(Product(rest, factor_rate));
  }
  return store_.Sum(std::move(terms));
}

// The terms of the monomial `powers` (with function and constant `atoms`) times `value`, each
// a monomial built at once (no node for the monomial or for the sum), appended to `terms`.
// False, with `terms` as it was, where a product is not a monomial (a function twice).
bool ExpandedDerivatives::AppendTimes(const std::vector<std::pair<NodeId, GiNaC::numeric>>& powers,
                                      const std::vector<NodeId>& atoms,
                                      const Scaled& value,
                                      std::vector<Scaled>& terms) {
  const bool sum = store_.node(value.node).kind == Kind::kSum;
  const std::size_t count = sum ? store_.node(value.node).operands.size() : 1;
  const std::size_t known = terms.size();
  for (std::size_t k = 0; k < count; ++k) {
    // Copied, one at a time: building monomials adds nodes, which may move the store's.
    const Scaled term = sum ? store_.node(value.node).operands[k] : Scaled{1, value.node};
    std::vector<std::pair<NodeId, GiNaC::numeric>> term_powers = powers;
    std::vector<NodeId> term_atoms = atoms;
    const bool factors = term.node == store_.one() ||
                         store_.AppendMonomialFactors(term.node, false, term_powers, term_atoms);
    if (!factors || !CanonicalExpressions::AtomsOnce(term_atoms)) {
      terms.resize(known);
      return false;
    }
    terms.push_back(store_.Monomial(value.coefficient * term.coefficient, std::move(term_powers)));
  }
  return true;
}

// b^n with a number n: n b^(n-1) D(b), as GiNaC's power::derivative; a symbolic exponent is
// refused.
ExpandedDerivatives::Scaled ExpandedDerivatives::RateOfPower(NodeId id, std::size_t direction) {
  const Scaled base = store_.node(id).operands[0];
  const Scaled exponent = store_.node(id).operands[1];
  if (exponent.node != store_.one()) throw NotExpandable{};
  const Scaled base_rate = Rate(base, direction);
  if (base_rate.coefficient.is_zero()) return base_rate;
  const GiNaC::numeric lower = exponent.coefficient - 1;
  Scaled lowered = store_.Number(1);
  if (!lower.is_zero()) {
    if (base.coefficient == 1 && store_.node(base.node).kind == Kind::kSymbol &&
        lower.is_integer()) {
      lowered = store_.Monomial(1, {{base.node, lower}});
    } else {
      const std::optional<Scaled> expanded = store_.Expanded(
          store_.Add(EvaluatedPower(store_.Expression(base), lower)), max_products_);
      if (!expanded) throw NotExpandable{};
      lowered = *expanded;
    }
  }
  return Product(store_.Scale(exponent.coefficient, lowered), base_rate);
}

// sum_i dF/d(argument i) D(argument i).
ExpandedDerivatives::Scaled ExpandedDerivatives::RateOfFunction(NodeId id, std::size_t direction) {
  const std::vector<Scaled> arguments = store_.node(id).operands;
  std::vector<Scaled> terms;
  for (std::size_t i = 0; i < arguments.size(); ++i) {
    const Scaled argument_rate = Rate(arguments[i], direction);
    if (argument_rate.coefficient.is_zero()) continue;
    terms.push_back(Product(FunctionPartial(id, i), argument_rate));
  }
  return store_.Sum(std::move(terms));
}

ExpandedDerivatives::Scaled ExpandedDerivatives::Product(const Scaled& a, const Scaled& b) {
  const std::optional<Scaled> product = store_.ExpandedProduct(a, b, max_products_);
  if (!product) throw NotExpandable{};
  return *product;
}

ExpandedDerivatives::Scaled ExpandedDerivatives::FunctionPartial(NodeId function,
                                                                 std::size_t argument) {
  const auto key = std::make_pair(function, argument);
  if (const auto found = function_partials_.find(key); found != function_partials_.end()) {
    return found->second;
  }
  const std::string name = store_.node(function).name;
  const std::vector<Scaled> arguments = store_.node(function).operands;
  const FunctionPartialForm& form = PartialForm(name, arguments.size(), argument);
  const bool symbolic_arguments =
      std::all_of(arguments.begin(), arguments.end(), [this](const Scaled& value) {
        const Kind kind = store_.node(value.node).kind;
        return value.coefficient.is_real() && kind != Kind::kNumber && kind != Kind::kConstant &&
               kind != Kind::kFunction && kind != Kind::kOpaque;
      });
  Scaled partial = store_.Number(0);
  if (form.held && symbolic_arguments) {
    partial = store_.Scale(form.coefficient, store_.HeldFunction(form.name, arguments));
  } else {
    GiNaC::exmap at;
    for (std::size_t k = 0; k < arguments.size(); ++k) {
      at[placeholders_[k]] = store_.Expression(arguments[k]);
    }
    const std::optional<Scaled> expanded =
        store_.Expanded(store_.Add(form.expression.subs(at)), max_products_);
    if (!expanded) throw NotExpandable{};
    partial = *expanded;
  }
  function_partials_.emplace(key, partial);
  return partial;
}

const ExpandedDerivatives::FunctionPartialForm& ExpandedDerivatives::PartialForm(
    const std::string& name, std::size_t arguments, std::size_t argument) {
  const auto key = std::make_tuple(name, arguments, argument);
  if (const auto found = partial_forms_.find(key); found != partial_forms_.end()) {
    return found->second;
  }
  while (placeholders_.size() < arguments) {
    placeholders_.emplace_back("argument" + std::to_string(placeholders_.size()));
  }
  const GiNaC::exvector stand_ins(placeholders_.begin(),
                                  placeholders_.begin() + std::ptrdiff_t(arguments));
  const GiNaC::ex partial =
      GiNaC::function(GiNaC::function::find_function(name, unsigned(arguments)), stand_ins)
          .diff(placeholders_[argument]);
  FunctionPartialForm form;
  form.expression = partial;
  // coefficient * G(p_0, ..., p_(k-1)) for a G held at symbolic arguments.
  GiNaC::ex function = partial;
  form.coefficient = 1;
  if (GiNaC::is_a<GiNaC::mul>(partial) && partial.nops() == 2 &&
      GiNaC::is_a<GiNaC::numeric>(partial.op(1))) {
    function = partial.op(0);
    form.coefficient = GiNaC::ex_to<GiNaC::numeric>(partial.op(1));
  }
  if (GiNaC::is_a<GiNaC::function>(function) && !GiNaC::is_a<GiNaC::fderivative>(function) &&
      function.nops() == arguments) {
    const std::string function_name = GiNaC::ex_to<GiNaC::function>(function).get_name();
    bool same_arguments = true;
    for (std::size_t k = 0; k < arguments; ++k) {
      same_arguments = same_arguments && function.op(k).is_equal(placeholders_[k]);
    }
    form.held = same_arguments &&
                std::find(kHeldWithSymbolicArguments.begin(), kHeldWithSymbolicArguments.end(),
                          function_name) != kHeldWithSymbolicArguments.end();
    if (form.held) form.name = function_name;
  }
  return partial_forms_.emplace(key, std::move(form)).first->second;
}

const std::vector<ExpandedDerivatives::NodeId>& ExpandedDerivatives::Symbols(NodeId id) {
  if (symbols_.size() <= id) symbols_.resize(std::size_t(id) + 1);
  if (!symbols_[id]) {
    std::vector<NodeId> symbols;
    if (store_.node(id).kind == Kind::kSymbol) {
      symbols.push_back(id);
    } else {
      // The store gains no node here: its operands stay where they are.
      for (const Scaled& operand : store_.node(id).operands) {
        const std::vector<NodeId>& inner = Symbols(operand.node);
        std::vector<NodeId> merged;
        merged.reserve(symbols.size() + inner.size());
        std::set_union(symbols.begin(), symbols.end(), inner.begin(), inner.end(),
                       std::back_inserter(merged));
        symbols = std::move(merged);
      }
    }
    if (symbols_.size() <= id) symbols_.resize(std::size_t(id) + 1);
    symbols_[id] = std::move(symbols);
  }
  return *symbols_[id];
}

bool ExpandedDerivatives::Moves(NodeId id, const Direction& direction) {
  const std::vector<NodeId>& held = Symbols(id);
  auto a = held.begin();
  auto b = direction.symbols.begin();
  while (a != held.end() && b != direction.symbols.end()) {
    if (*a == *b) return true;
    if (*a < *b) {
      ++a;
    } else {
      ++b;
    }
  }
  return false;
}

const std::unordered_map<ExpandedDerivatives::NodeId, std::vector<std::size_t>>&
ExpandedDerivatives::TermsBySymbol(NodeId sum) {
  if (const auto found = term_index_.find(sum); found != term_index_.end()) return found->second;
  std::unordered_map<NodeId, std::vector<std::size_t>> by_symbol;
  const std::vector<Scaled>& terms = store_.node(sum).operands;  // Symbols adds no node
  for (std::size_t t = 0; t < terms.size(); ++t) {
    for (const NodeId symbol : Symbols(terms[t].node)) by_symbol[symbol].push_back(t);
  }
  return term_index_.emplace(sum, std::move(by_symbol)).first->second;
}

}  // namespace servokit::detail
