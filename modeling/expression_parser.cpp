#include "modeling/expression_parser.h"

#include <algorithm>
#include <cctype>
#include <string_view>
#include <utility>
#include <vector>

namespace servokit {
namespace {

using Scaled = CanonicalExpressions::Scaled;
using Kind = CanonicalExpressions::Kind;
using NodeId = CanonicalExpressions::NodeId;

// Text this reader does not take: GiNaC's parser reads it again for its message.
struct SyntaxFailure {};

// One factor of a product: the value and whether it divides.
struct Factor {
  Scaled value;
  bool divides = false;
};

// Recursive descent with GiNaC's grammar: + and - bind loosest, then * and /, then ^ (one per
// operand: GiNaC refuses a^b^c), a sign only at the start of an expression (FindLexicalProblem
// allows no other).
class Reader {
 public:
  Reader(CanonicalExpressions& canonical, const GiNaC::symtab& names, std::string_view text)
      : canonical_(canonical), names_(names), text_(text) {}

  Scaled ReadWhole() {
    const Scaled value = Expression();
    if (Peek() != '\0') throw SyntaxFailure{};
    return value;
  }

 private:
  char Peek() {
    while (position_ < text_.size() && std::isspace(static_cast<unsigned char>(text_[position_]))) {
      ++position_;
    }
    return position_ < text_.size() ? text_[position_] : '\0';
  }

  Scaled Expression() {
    std::vector<Scaled> terms;
    bool negative = false;
    if (Peek() == '+' || Peek() == '-') negative = text_[position_++] == '-';
    terms.push_back(Product());
    if (negative) terms.back().coefficient = -terms.back().coefficient;
    while (Peek() == '+' || Peek() == '-') {
      const bool minus = text_[position_++] == '-';
      terms.push_back(Product());
      if (minus) terms.back().coefficient = -terms.back().coefficient;
    }
    if (terms.size() == 1) return terms.front();
    return canonical_.Sum(std::move(terms));
  }

  Scaled Product() {
    std::vector<Factor> factors;
    factors.push_back({Power(), false});
    while (Peek() == '*' || Peek() == '/') {
      const bool divides = text_[position_++] == '/';
      factors.push_back({Power(), divides});
    }
    if (factors.size() == 1) return factors.front().value;
    return Multiply(factors);
  }

  Scaled Multiply(const std::vector<Factor>& factors) {
    // Numbers, powers of symbols with integer exponents and functions or constants each once:
    // a monomial, built here.
    GiNaC::numeric coefficient = 1;
    std::vector<std::pair<NodeId, GiNaC::numeric>> powers;
    std::vector<NodeId> atoms;
    const Factor* other = nullptr;  // the one factor that is neither, if only one
    std::size_t others = 0;
    for (const Factor& factor : factors) {
      // x/c divides by the number: c^(-1), which GiNaC refuses for 0 as its parser does.
      coefficient *=
          factor.divides ? Reciprocal(factor.value.coefficient) : factor.value.coefficient;
      if (factor.value.node == canonical_.one()) continue;
      const std::size_t known_powers = powers.size(), known_atoms = atoms.size();
      if (!canonical_.AppendMonomialFactors(factor.value.node, factor.divides, powers, atoms)) {
        powers.resize(known_powers);
        atoms.resize(known_atoms);
        other = &factor;
        ++others;
      }
    }
    const bool atoms_once = CanonicalExpressions::AtomsOnce(atoms);
    if (others == 0 && atoms_once) {
      return canonical_.Monomial(std::move(coefficient), std::move(powers));
    }
    // A number times one sum: GiNaC's mul distributes the number over the terms.
    if (others == 1 && atoms_once && powers.empty() && !other->divides &&
        canonical_.node(other->value.node).kind == Kind::kSum) {
      return canonical_.Sum({{coefficient, other->value.node}});
    }
    // Anything else (a sum among other factors, whose integer content GiNaC draws out; a
    // function; a power of a sum) is GiNaC's to evaluate.
    GiNaC::exvector operands;
    operands.reserve(factors.size());
    for (const Factor& factor : factors) {
      const GiNaC::ex value = canonical_.Expression(factor.value);
      operands.push_back(factor.divides ? EvaluatedPower(value, -1) : value);
    }
    return canonical_.Add(GiNaC::mul(operands));
  }

  GiNaC::numeric Reciprocal(const GiNaC::numeric& number) const {
    return GiNaC::ex_to<GiNaC::numeric>(EvaluatedPower(number, -1));
  }

  Scaled Power() {
    const Scaled base = Primary();
    if (Peek() != '^') return base;
    ++position_;
    const Scaled exponent = Primary();
    if (Peek() == '^') throw SyntaxFailure{};  // GiNaC's parser refuses a^b^c
    const bool integer_exponent =
        exponent.node == canonical_.one() && exponent.coefficient.is_integer();
    if (integer_exponent && base.coefficient == 1 &&
        canonical_.node(base.node).kind == Kind::kSymbol) {
      return canonical_.Monomial(1, {{base.node, exponent.coefficient}});
    }
    return canonical_.Add(
        EvaluatedPower(canonical_.Expression(base), canonical_.Expression(exponent)));
  }

  Scaled Primary() {
    const char c = Peek();
    if (std::isdigit(static_cast<unsigned char>(c)) || c == '.') return Number();
    if (std::isalpha(static_cast<unsigned char>(c))) {
      const std::string name = Name();
      if (Peek() == '(') return Call(name);
      return Named(name);
    }
    if (c == '(') {
      ++position_;
      const Scaled inner = Expression();
      Expect(')');
      return inner;
    }
    throw SyntaxFailure{};
  }

  // GiNaC's lexer: [0-9.]+, then an exponent written with 'E' and an explicit sign.
  Scaled Number() {
    std::string digits;
    const auto is_digit = [this](std::size_t i) {
      return i < text_.size() && std::isdigit(static_cast<unsigned char>(text_[i]));
    };
    while (is_digit(position_) || (position_ < text_.size() && text_[position_] == '.')) {
      digits += text_[position_++];
    }
    if (position_ < text_.size() && (text_[position_] == 'e' || text_[position_] == 'E')) {
      digits += 'E';
      ++position_;
      if (is_digit(position_)) {
        digits += '+';
      } else if (position_ < text_.size() && (text_[position_] == '+' || text_[position_] == '-')) {
        digits += text_[position_++];
      }
      if (!is_digit(position_)) throw SyntaxFailure{};
      while (is_digit(position_)) digits += text_[position_++];
    }
    // An integer of a few digits is the same number built from a long, without CLN's reader.
    constexpr std::size_t kLongDigits = 18;
    if (digits.size() <= kLongDigits &&
        digits.find_first_not_of("0123456789") == std::string::npos) {
      return canonical_.Number(GiNaC::numeric(std::stol(digits)));
    }
    return canonical_.Number(GiNaC::numeric(digits.c_str()));
  }

  std::string Name() {
    const std::size_t start = position_;
    while (
        position_ < text_.size() &&
        (std::isalnum(static_cast<unsigned char>(text_[position_])) || text_[position_] == '_')) {
      ++position_;
    }
    return std::string(text_.substr(start, position_ - start));
  }

  Scaled Named(const std::string& name) {
    const auto found = names_.find(name);
    if (found == names_.end()) throw SyntaxFailure{};
    return canonical_.Add(found->second);
  }

  Scaled Call(const std::string& name) {
    ++position_;  // '('
    GiNaC::exvector arguments;
    arguments.push_back(canonical_.Expression(Expression()));
    while (Peek() == ',') {
      ++position_;
      arguments.push_back(canonical_.Expression(Expression()));
    }
    Expect(')');
    // GiNaC's parser reads sqrt as a power; every other function of the model language is a
    // GiNaC function of that name.
    if (name == "sqrt" && arguments.size() == 1) {
      return canonical_.Add(EvaluatedPower(arguments.front(), GiNaC::numeric(1, 2)));
    }
    unsigned serial = 0;
    try {
      serial = GiNaC::function::find_function(name, unsigned(arguments.size()));
    } catch (const std::runtime_error&) {
      throw SyntaxFailure{};
    }
    return canonical_.Add(GiNaC::function(serial, arguments));
  }

  void Expect(char c) {
    if (Peek() != c) throw SyntaxFailure{};
    ++position_;
  }

  CanonicalExpressions& canonical_;
  const GiNaC::symtab& names_;
  std::string_view text_;
  std::size_t position_ = 0;
};

}  // namespace

CanonicalExpressions::Scaled ExpressionParser::Parse(const std::string& text) {
  try {
    return Reader(canonical_, names_, text).ReadWhole();
  } catch (const SyntaxFailure&) {
  }
  // GiNaC's parser says what is wrong, in the words users of earlier versions saw.
  GiNaC::parser ginac(names_, /*strict=*/true);
  ginac(text);
  throw GiNaC::parse_error("the expression does not parse");
}

}  // namespace servokit
