#include "modeling/loader_support.h"

#include <algorithm>
#include <array>
#include <cctype>
#include <cerrno>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <fstream>
#include <limits>
#include <sstream>
#include <string>
#include <unordered_set>
#include <utility>
#include <vector>

#include "base/errors.h"
#include "base/number_format.h"
#include "files/input_file.h"
#include "modeling/units.h"
#include "modeling/yaml_document.h"

namespace servokit::detail {
namespace {

constexpr std::uint64_t kFnvPrime = 1099511628211ull;
// Significant digits of the numbers in the expression checks' messages.
constexpr int kMessageDigits = 6;

bool IsDigit(char c) { return std::isdigit(static_cast<unsigned char>(c)) != 0; }

// Digits, an optional fraction and an optional exponent, starting at `i`.
std::size_t SkipNumber(const std::string& text, std::size_t i) {
  while (i < text.size() && (IsDigit(text[i]) || text[i] == '.')) ++i;
  if (i < text.size() && (text[i] == 'e' || text[i] == 'E')) {
    std::size_t exponent = i + 1;
    if (exponent < text.size() && (text[exponent] == '+' || text[exponent] == '-')) ++exponent;
    if (exponent < text.size() && IsDigit(text[exponent])) {
      i = exponent;
      while (i < text.size() && IsDigit(text[i])) ++i;
    }
  }
  return i;
}

// Finds powers that GiNaC's parser would evaluate for minutes or without end. GiNaC computes
// number^number exactly while it parses, so 9^(523^25) asks for a number of 10^68 digits (found
// by fuzzing, issue #7). This reads the expression once more (recursive descent, GiNaC's
// precedence: ^ binds tightest and to the right, then unary signs, then * /, then + -) and
// follows the magnitude of every sub-expression made of numbers only, in log10. Anything it
// cannot read it leaves to GiNaC's parser, which reports the syntax error.
class PowerChecker {
 public:
  explicit PowerChecker(const std::string& text) : text_(text) {}

  std::optional<std::string> Check() {
    Expression();
    return problem_;
  }

 private:
  // A sub-expression: `constant` when it has numbers only; then its value and log10 |value|
  // (the value may overflow a double where the logarithm does not). Otherwise the log10 of the
  // largest number made of numbers only inside it: GiNaC expands a^(n + x) into a^n a^x, and
  // a^(2 (n - x)) likewise, and computes a^n exactly.
  struct Term {
    bool constant = false;
    double value = 0;
    double log10_magnitude = 0;
    double largest_log10 = -std::numeric_limits<double>::infinity();
  };

  static Term Constant(double value, double log10_magnitude) {
    return {true, value, log10_magnitude};
  }
  static double Largest(const Term& term) {
    return term.constant ? term.log10_magnitude : term.largest_log10;
  }
  // A term with symbols made of `a` and `b`.
  static Term Symbolic(const Term& a, const Term& b) {
    Term result;
    result.largest_log10 = std::max(Largest(a), Largest(b));
    return result;
  }

  char Peek() {
    while (position_ < text_.size() && std::isspace(static_cast<unsigned char>(text_[position_]))) {
      ++position_;
    }
    return position_ < text_.size() ? text_[position_] : '\0';
  }

  bool Failed() const { return problem_.has_value() || unreadable_; }

  Term Expression() {
    Term result = Product();
    while (!Failed() && (Peek() == '+' || Peek() == '-')) {
      const char op = text_[position_++];
      const Term right = Product();
      result = result.constant && right.constant
                   ? Constant(op == '+' ? result.value + right.value : result.value - right.value,
                              std::max(result.log10_magnitude, right.log10_magnitude) + 1)
                   : Symbolic(result, right);
    }
    return result;
  }

  Term Product() {
    Term result = Signed();
    while (!Failed() && (Peek() == '*' || Peek() == '/')) {
      const char op = text_[position_++];
      const Term right = Signed();
      if (result.constant && right.constant) {
        result = op == '*' ? Constant(result.value * right.value,
                                      result.log10_magnitude + right.log10_magnitude)
                           : Constant(result.value / right.value,
                                      result.log10_magnitude - right.log10_magnitude);
        Limit(result);
      } else {
        result = Symbolic(result, right);
      }
    }
    return result;
  }

  Term Signed() {
    if (Peek() == '-' || Peek() == '+') {
      const bool negative = text_[position_++] == '-';
      Term operand = Signed();
      if (negative) operand.value = -operand.value;
      return operand;
    }
    return Power();
  }

  Term Power() {
    const Term base = Primary();
    if (Failed() || Peek() != '^') return base;
    ++position_;
    const Term exponent = Signed();  // right-associative, and 9^-2 is allowed
    if (Failed()) return Term{};
    if (!exponent.constant) {
      if (exponent.largest_log10 > std::log10(kMaxConstantExponent)) {
        problem_ = "a number in an exponent too large (about 10^" +
                   FormatSignificant(std::round(exponent.largest_log10), kMessageDigits) +
                   "; at most " + std::to_string(static_cast<int>(kMaxConstantExponent)) +
                   " in absolute value: GiNaC would compute a^(n + x) as a^n a^x, a^n exactly)";
      }
      return Symbolic(base, exponent);
    }
    if (!(std::abs(exponent.value) <= kMaxConstantExponent)) {
      problem_ = "exponent too large (" + FormatSignificant(exponent.value, kMessageDigits) +
                 "; at most " + std::to_string(static_cast<int>(kMaxConstantExponent)) +
                 " in absolute value)";
      return Term{};
    }
    if (!base.constant) return Symbolic(base, exponent);
    Term result =
        Constant(std::pow(base.value, exponent.value), exponent.value * base.log10_magnitude);
    Limit(result);
    return result;
  }

  Term Primary() {
    const char c = Peek();
    if (IsDigit(c) || c == '.') {
      const std::size_t start = position_;
      position_ = SkipNumber(text_, position_);
      const std::string digits = text_.substr(start, position_ - start);
      const double value = std::strtod(digits.c_str(), nullptr);
      if (!std::isfinite(value)) return Term{};  // FindUnsupported reports it after parsing
      return Constant(value, value == 0 ? 0 : std::log10(std::abs(value)));
    }
    if (IsIdentifierStart(c) || c == '_') {
      while (position_ < text_.size() && IsIdentifierChar(text_[position_])) ++position_;
      Term call;
      if (Peek() == '(') {
        ++position_;  // a function call: GiNaC keeps sin(2) and exp(700) unevaluated
        call = Symbolic(call, Expression());
        while (!Failed() && Peek() == ',') {
          ++position_;
          call = Symbolic(call, Expression());
        }
        Expect(')');
      }
      return call;
    }
    if (c == '(') {
      ++position_;
      const Term inner = Expression();
      Expect(')');
      return inner;
    }
    unreadable_ = true;
    return Term{};
  }

  void Expect(char c) {
    if (Failed()) return;
    if (Peek() == c) {
      ++position_;
    } else {
      unreadable_ = true;
    }
  }

  // A constant with more digits than kMaxConstantDigits (or as many after the point) is far
  // outside what a double holds and costly for GiNaC to compute exactly.
  void Limit(const Term& term) {
    if (!Failed() && std::abs(term.log10_magnitude) > kMaxConstantDigits) {
      problem_ = "number too large to compute (about 10^" +
                 FormatSignificant(term.log10_magnitude, kMessageDigits) + ")";
    }
  }

  const std::string& text_;
  std::size_t position_ = 0;
  std::optional<std::string> problem_;
  bool unreadable_ = false;
};

// A constant exponent of more than six digits, or above kMaxConstantDigits, in the number
// `number` (already read whole): CLN takes for ever on a decimal exponent of 20 digits, even of
// 0e...; any beyond 10^kMaxConstantDigits is far outside a double (found by fuzzing, issue #7).
std::optional<std::string> ExponentProblem(const std::string& number) {
  if (const std::size_t e = number.find_first_of("eE"); e != std::string::npos) {
    const std::string digits = number.substr(number.find_first_not_of("+-", e + 1));
    if (digits.size() > 6 || std::stod(digits) > kMaxConstantDigits) {
      return "number out of range '" + number + "'";
    }
  }
  return std::nullopt;
}

// The first pass of FindLexicalProblem: reads the expression one token at a time and returns the
// first problem. GiNaC's parser does not check how many arguments a function gets (cos()
// dereferences a null pointer), and it recurses once per parenthesis, per sign in a row and per
// power in a chain (a^b^c is a^(b^c)), so a long enough line overflows the stack. All three are
// checked here: each open parenthesis with the function it calls ("" for grouping), its commas,
// whether the argument being read has anything in it and the powers chained at its level.
class TokenScanner {
 public:
  TokenScanner(const std::string& text, const NameCheck& check_name)
      : text_(text), check_name_(check_name) {}

  std::optional<std::string> Scan() {
    while (position_ < text_.size()) {
      const char c = text_[position_];
      if (std::isspace(static_cast<unsigned char>(c)) != 0) {
        ++position_;
        continue;
      }
      if (auto problem = ReadToken(c)) return problem;
    }
    if (!open_.empty()) return "'(' without ')'";
    return std::nullopt;
  }

 private:
  struct Parenthesis {
    std::string function;
    std::size_t commas = 0;
    bool argument_has_text = false;
    std::size_t chained_powers = 0;
  };

  // Reads the token that starts with `c` (no blank) and moves past it.
  std::optional<std::string> ReadToken(char c) {
    if (c != ',' && c != ')' && !open_.empty()) open_.back().argument_has_text = true;
    const bool at_start = std::exchange(expression_start_, false);
    const char before = std::exchange(previous_, c);
    if (IsDigit(c) || c == '.') return ReadNumber();
    if (IsIdentifierStart(c) || c == '_') return ReadName();
    switch (c) {
      case '(':
        return OpenParenthesis();
      case ',':
        return NextArgument();
      case ')':
        return CloseParenthesis();
      case '^':
        return Power();
      default:
        break;
    }
    if ((c == '+' || c == '-') && !after_operand_) return Sign(c, at_start, before);
    if (c == '+' || c == '-' || c == '*' || c == '/') {
      chained_powers() = 0;
      after_operand_ = false;
      ++position_;
      return std::nullopt;
    }
    return std::string("unexpected character '") + c + "'";
  }

  std::optional<std::string> ReadNumber() {
    after_operand_ = true;
    const std::size_t start = position_;
    position_ = SkipNumber(text_, position_);
    const auto continues_number = [&] {
      return position_ < text_.size() &&
             (IsIdentifierChar(text_[position_]) || text_[position_] == '.');
    };
    if (continues_number()) {
      while (continues_number()) ++position_;
      return "malformed number '" + text_.substr(start, position_ - start) + "'";
    }
    return ExponentProblem(text_.substr(start, position_ - start));
  }

  // A name, checked by check_name_; a function's name when '(' follows it.
  std::optional<std::string> ReadName() {
    const std::size_t start = position_;
    while (position_ < text_.size() && IsIdentifierChar(text_[position_])) ++position_;
    const std::string name = text_.substr(start, position_ - start);
    const std::size_t next = text_.find_first_not_of(" \t", position_);
    const bool called = next != std::string::npos && text_[next] == '(';
    if (auto problem = check_name_(name, called)) return problem;
    if (called) called_function_ = name;
    after_operand_ = !called;
    return std::nullopt;
  }

  std::optional<std::string> OpenParenthesis() {
    if (open_.size() == kMaxParenthesisDepth) {
      return "parentheses nested deeper than " + std::to_string(kMaxParenthesisDepth);
    }
    open_.push_back({std::exchange(called_function_, {})});
    StartExpression();
    return std::nullopt;
  }

  std::optional<std::string> NextArgument() {
    if (open_.empty() || open_.back().function.empty()) return "',' outside a function's arguments";
    if (auto problem = ArgumentProblem(open_.back())) return problem;
    ++open_.back().commas;
    open_.back().argument_has_text = false;
    open_.back().chained_powers = 0;
    StartExpression();
    return std::nullopt;
  }

  std::optional<std::string> CloseParenthesis() {
    if (open_.empty()) return "')' without '('";
    const Parenthesis closed = open_.back();
    open_.pop_back();
    if (auto problem = ArgumentProblem(closed)) return problem;
    if (!closed.function.empty()) {
      const std::size_t expected = FunctionArity(closed.function);
      if (closed.commas + 1 != expected) {
        return closed.function + "() takes " + std::to_string(expected) + " argument" +
               (expected == 1 ? "" : "s") + ", found " + std::to_string(closed.commas + 1);
      }
    }
    after_operand_ = true;
    ++position_;
    return std::nullopt;
  }

  std::optional<std::string> Power() {
    if (++chained_powers() > kMaxChainedPowers) {
      return "more than " + std::to_string(kMaxChainedPowers) + " powers in a chain a^b^c...";
    }
    after_operand_ = false;
    ++position_;
    return std::nullopt;
  }

  // GiNaC's parser gives a sign after an operator the rest of the expression: it reads 2*-x+1
  // as 2*(1 - x), x^-2+1 as x^(-1) and x - -x + 1 as 2x - 1. A sign may therefore only open an
  // expression, a parenthesis or an argument, where GiNaC reads it as usual.
  std::optional<std::string> Sign(char sign, bool at_start, char before) {
    if (!at_start) {
      return std::string("'") + sign + "' right after '" + before +
             "': put the signed operand in parentheses, as 2*(-x) (GiNaC would read 2*-x+1 "
             "as 2*(-x+1))";
    }
    ++position_;
    return std::nullopt;
  }

  // After '(' or ',': a new expression, where a sign may stand.
  void StartExpression() {
    after_operand_ = false;
    expression_start_ = true;
    ++position_;
  }

  static std::optional<std::string> ArgumentProblem(const Parenthesis& parenthesis) {
    if (!parenthesis.argument_has_text) {
      return parenthesis.function.empty() ? "empty parentheses"
                                          : "empty argument of " + parenthesis.function + "()";
    }
    return std::nullopt;
  }

  // The powers chained at the current level: inside the innermost parenthesis, or outside all.
  std::size_t& chained_powers() {
    return open_.empty() ? chained_powers_outside_ : open_.back().chained_powers;
  }

  const std::string& text_;
  const NameCheck& check_name_;
  std::size_t position_ = 0;
  std::vector<Parenthesis> open_;
  std::size_t chained_powers_outside_ = 0;
  bool after_operand_ = false;    // a '+' or '-' here is binary, else a sign
  bool expression_start_ = true;  // at the start, after '(' or ','; a sign may stand only here
  char previous_ = '\0';          // the last character that is not a blank
  std::string called_function_;   // the name just read, when '(' follows it
};

}  // namespace

void ContentHasher::Add(std::string_view bytes) {
  for (const char byte : bytes) {
    hash_ ^= static_cast<unsigned char>(byte);
    hash_ *= kFnvPrime;
  }
}

std::string ContentHasher::Hex() const {
  std::ostringstream hex;
  hex.fill('0');
  hex.width(16);
  hex << std::hex << hash_;
  return hex.str();
}

std::optional<std::string> FreeTextProblem(std::string_view text, bool line_breaks_allowed) {
  for (std::size_t i = 0; i < text.size(); ++i) {
    const auto byte = static_cast<unsigned char>(text[i]);
    const bool line_break = byte == '\n' || byte == '\r' || byte == '\t';
    if ((byte < 0x20 || byte == 0x7f) && !(line_breaks_allowed && line_break)) {
      std::array<char, 8> code{};
      std::snprintf(code.data(), code.size(), "0x%02x", unsigned(byte));
      return "holds the control character " + std::string(code.data()) + " at character " +
             std::to_string(i + 1) + (line_breaks_allowed ? "" : " (a name is one line)");
    }
  }
  return std::nullopt;
}

bool IsIdentifierStart(char c) { return std::isalpha(static_cast<unsigned char>(c)) != 0; }
bool IsIdentifierChar(char c) {
  return std::isalnum(static_cast<unsigned char>(c)) != 0 || c == '_';
}
bool IsIdentifier(std::string_view name) {
  return !name.empty() && IsIdentifierStart(name.front()) &&
         std::all_of(name.begin(), name.end(), IsIdentifierChar);
}

std::optional<std::string> ReservedNameProblem(const std::string& name) {
  if (!IsIdentifier(name)) {
    return "invalid name '" + name + "' (use letters, digits and _, starting with a letter)";
  }
  if (Contains(kModelFunctions, name)) {
    return "name '" + name + "' clashes with the function " + name + "()";
  }
  if (name == kPiName || Contains(kParserLiterals, name)) {
    return "name '" + name + "' is reserved for a constant";
  }
  return std::nullopt;
}

const GiNaC::realsymbol* FirstSymbolIn(const GiNaC::ex& expression,
                                       const std::vector<GiNaC::realsymbol>& symbols) {
  // By GiNaC's hash, never iterated.
  std::unordered_set<GiNaC::ex, std::hash<GiNaC::ex>, GiNaC::ex_is_equal> held;
  for (auto node = expression.preorder_begin(); node != expression.preorder_end(); ++node) {
    if (GiNaC::is_a<GiNaC::symbol>(*node)) held.insert(*node);
  }
  const auto found = std::find_if(symbols.begin(), symbols.end(),
                                  [&](const GiNaC::realsymbol& s) { return held.contains(s); });
  return found == symbols.end() ? nullptr : &*found;
}

std::string Excerpt(const std::string& text) {
  constexpr std::size_t kWhole = 200, kShown = 160;
  if (text.size() <= kWhole) return text;
  std::size_t end = kShown;
  while (end > 0 && (static_cast<unsigned char>(text[end]) & 0xC0) == 0x80) --end;
  return text.substr(0, end) + "... (" + std::to_string(text.size()) + " bytes)";
}

std::string Indexed(std::string_view key, std::size_t i) {
  return std::string(key) + "[" + std::to_string(i) + "]";
}

std::string Text(const GiNaC::ex& expression) {
  std::ostringstream stream;
  stream << expression;
  return stream.str();
}

std::optional<std::string> FindLexicalProblem(const std::string& text,
                                              const NameCheck& check_name) {
  if (auto problem = TokenScanner(text, check_name).Scan()) return problem;
  return PowerChecker(text).Check();
}

std::optional<std::string> FindUnsupported(const CanonicalExpressions& canonical,
                                           const CanonicalExpressions::Scaled& value) {
  using Kind = CanonicalExpressions::Kind;
  const auto number_problem = [](const GiNaC::numeric& number) -> std::optional<std::string> {
    if (!number.is_real()) return "complex number " + Text(number);
    if (!std::isfinite(number.to_double())) return "number out of range " + Text(number);
    return std::nullopt;
  };
  // Depth first, each node once; its operands in their order.
  std::unordered_set<CanonicalExpressions::NodeId> seen;
  std::vector<CanonicalExpressions::Scaled> pending = {value};
  while (!pending.empty()) {
    const CanonicalExpressions::Scaled next = std::move(pending.back());
    pending.pop_back();
    if (auto problem = number_problem(next.coefficient)) return problem;
    if (!seen.insert(next.node).second) continue;
    const CanonicalExpressions::Node& node = canonical.node(next.node);
    switch (node.kind) {
      case Kind::kNumber:
        if (auto problem = number_problem(node.number)) return problem;
        break;
      case Kind::kConstant:
        if (!node.original.is_equal(GiNaC::Pi)) return "unsupported constant " + node.name;
        break;
      case Kind::kFunction:
        if (!Contains(kModelFunctions, node.name)) return "unsupported function " + node.name;
        break;
      case Kind::kOpaque:
        return "unsupported expression " + Text(node.original);
      case Kind::kSymbol:
      case Kind::kPower:
      case Kind::kProduct:
      case Kind::kSum:
        break;
    }
    pending.insert(pending.end(), node.operands.rbegin(), node.operands.rend());
  }
  return std::nullopt;
}

void ApplyParameterOverrides(const std::vector<std::string>& parameter_names,
                             const std::vector<ParameterOverride>& overrides,
                             Eigen::VectorXd& parameters,
                             std::vector<DisplayUnit>& units) {
  for (const ParameterOverride& override_ : overrides) {
    const auto found = std::find(parameter_names.begin(), parameter_names.end(), override_.name);
    if (found == parameter_names.end()) {
      throw ParameterOverrideError(
          override_.name, override_.value,
          "unknown parameter '" + override_.name + "' (" +
              (parameter_names.empty() ? std::string("the model has no parameters")
                                       : "known: " + Join(parameter_names)) +
              ")");
    }
    const std::optional<ParsedQuantity> written = ParseQuantityWithUnit(override_.value);
    if (!written) {
      throw ParameterOverrideError(override_.name, override_.value,
                                   "not a number " + std::string(kQuantityHint));
    }
    const auto index = static_cast<std::size_t>(found - parameter_names.begin());
    // In the unit the model declares: alpha=45 of "alpha: 5 deg" is 45 deg (issue #34).
    const ParsedQuantity value = InDeclaredUnit(*written, units[index]);
    parameters[static_cast<Eigen::Index>(index)] = value.value;
    if (value.unit == DisplayUnit::kDegree) units[index] = DisplayUnit::kDegree;
  }
}

ModelDocument ParseModelDocument(std::string yaml_text, std::string source) {
  ModelDocument document{std::move(source), std::move(yaml_text), {}};
  document.root = LoadSingleYamlDocument(document.text, document.source, "a model file");
  return document;
}

ModelDocument ReadModelDocument(const std::string& path) {
  return ParseModelDocument(
      ReadInputFile(path, "the model file", kModelFileLimit, ErrorKind::kModel), path);
}

}  // namespace servokit::detail
