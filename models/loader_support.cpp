#include "models/loader_support.h"

#include <cctype>
#include <cmath>
#include <sstream>

#include "models/errors.h"
#include "models/units.h"

namespace servokit::detail {
namespace {

constexpr std::uint64_t kFnvPrime = 1099511628211ull;

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
  std::size_t i = 0;
  while (i < text.size()) {
    const char c = text[i];
    if (std::isspace(static_cast<unsigned char>(c)) != 0) {
      ++i;
    } else if (IsDigit(c) || c == '.') {
      const std::size_t start = i;
      i = SkipNumber(text, i);
      if (i < text.size() && (IsIdentifierChar(text[i]) || text[i] == '.')) {
        while (i < text.size() && (IsIdentifierChar(text[i]) || text[i] == '.')) ++i;
        return "malformed number '" + text.substr(start, i - start) + "'";
      }
    } else if (IsIdentifierStart(c) || c == '_') {
      const std::size_t start = i;
      while (i < text.size() && IsIdentifierChar(text[i])) ++i;
      const std::string name = text.substr(start, i - start);
      const std::size_t next = text.find_first_not_of(" \t", i);
      const bool called = next != std::string::npos && text[next] == '(';
      if (auto problem = check_name(name, called)) return problem;
    } else if (std::string_view("+-*/^(),").find(c) == std::string_view::npos) {
      return std::string("unexpected character '") + c + "'";
    } else {
      ++i;
    }
  }
  return std::nullopt;
}

std::optional<std::string> FindUnsupported(const GiNaC::ex& expression) {
  if (GiNaC::is_a<GiNaC::numeric>(expression)) {
    const auto& number = GiNaC::ex_to<GiNaC::numeric>(expression);
    if (!number.is_real()) return "complex number " + Text(expression);
    if (!std::isfinite(number.to_double())) return "number out of range " + Text(expression);
    return std::nullopt;
  }
  if (GiNaC::is_a<GiNaC::constant>(expression) && !expression.is_equal(GiNaC::Pi)) {
    return "unsupported constant " + Text(expression);
  }
  if (GiNaC::is_a<GiNaC::function>(expression) &&
      !Contains(kModelFunctions, GiNaC::ex_to<GiNaC::function>(expression).get_name())) {
    return "unsupported function " + GiNaC::ex_to<GiNaC::function>(expression).get_name();
  }
  if (!GiNaC::is_a<GiNaC::symbol>(expression) && !GiNaC::is_a<GiNaC::constant>(expression) &&
      !GiNaC::is_a<GiNaC::add>(expression) && !GiNaC::is_a<GiNaC::mul>(expression) &&
      !GiNaC::is_a<GiNaC::power>(expression) && !GiNaC::is_a<GiNaC::function>(expression)) {
    return "unsupported expression " + Text(expression);
  }
  for (std::size_t i = 0; i < expression.nops(); ++i) {
    if (auto problem = FindUnsupported(expression.op(i))) return problem;
  }
  return std::nullopt;
}

void ApplyParameterOverrides(const std::vector<std::string>& parameter_names,
                             const std::vector<ParameterOverride>& overrides,
                             Eigen::VectorXd& parameters) {
  for (const ParameterOverride& override_ : overrides) {
    const std::string option = "--set " + override_.name + "=" + override_.value;
    const auto found = std::find(parameter_names.begin(), parameter_names.end(), override_.name);
    if (found == parameter_names.end()) {
      throw UsageError(option + ": unknown parameter '" + override_.name + "' (" +
                       (parameter_names.empty() ? std::string("the model has no parameters")
                                                : "known: " + Join(parameter_names)) +
                       ")");
    }
    const std::optional<double> value = ParseQuantity(override_.value);
    if (!value) throw UsageError(option + ": not a number " + std::string(kQuantityHint));
    parameters[static_cast<Eigen::Index>(found - parameter_names.begin())] = *value;
  }
}

}  // namespace servokit::detail
