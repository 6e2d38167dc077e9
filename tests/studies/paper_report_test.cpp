// The answer file (docs/development.md, "Testing"): `servokit report paper` against the reviewed
// copy tests/data/paper_report.md. The copy's numbers were checked against the paper and the
// closed forms (the table of the four cases: Eqs. 30, 34, 36, 40, 47; the quoted 0.25 Hz,
// 2.88 Hz and 9.1 deg; s/l = 2/3 and the discriminant of Eq. 56) and, for the solver figures
// of Sect. 5, against Eq. (47), the exact one-step-delay form of Euler backward's error and
// the closed-form numerical damping (1 + (omega h)^2)^(-1/2) per step (see
// tests/solvers/inverse_model_test.cpp). Update it only after checking new numbers the same way.
//
// Numbers are compared within a relative 1e-6 (the report prints 6 to 12 digits); words
// exactly; `backquoted` closed forms exactly (their text is canonical, the same in every run:
// modeling/canonical_expression.h); `backquoted` measured numbers (a solver's agreement, a
// residual) are shown, not compared: they move with any change of a solver's steps.
#include "studies/paper_report.h"

#include <catch2/catch.hpp>
#include <cctype>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <regex>
#include <sstream>

#include "tests/test_files.h"
#include "tests/test_paths.h"

namespace servokit {
namespace {

using testing::Lines;
using testing::ReadFile;

// A backquoted span that is a measured number ("2.28626e-09", "-0.111666 s").
bool IsMeasuredNumber(const std::string& span) {
  static const std::regex number(R"([-+]?(\d+\.?\d*|\.\d+)([eE][-+]?\d+)?( s)?)");
  return std::regex_match(span, number);
}

// Tokens: numbers and words outside backquotes, and each backquoted closed form whole.
std::vector<std::string> Tokens(const std::string& line) {
  std::string outside;
  std::vector<std::string> closed_forms;
  std::string span;
  bool in_code = false;
  for (const char c : line) {
    if (c == '`') {
      in_code = !in_code;
      if (in_code) {
        span.clear();
      } else {
        outside += " <code> ";
        if (!IsMeasuredNumber(span)) closed_forms.push_back("`" + span + "`");
      }
    } else if (in_code) {
      span += c;
    } else {
      outside += c;
    }
  }
  static const std::regex token(R"([-+]?(\d+\.?\d*|\.\d+)([eE][-+]?\d+)?|[^\s\d]+)");
  std::vector<std::string> tokens;
  for (auto it = std::sregex_iterator(outside.begin(), outside.end(), token);
       it != std::sregex_iterator(); ++it) {
    tokens.push_back(it->str());
  }
  tokens.insert(tokens.end(), closed_forms.begin(), closed_forms.end());
  return tokens;
}

bool LooksNumeric(const std::string& token) {
  // strtod would also read words such as "infinity" and "nan" as numbers.
  return !token.empty() &&
         (std::isdigit(static_cast<unsigned char>(token[0])) ||
          (token.size() > 1 && std::string("+-.").find(token[0]) != std::string::npos &&
           (std::isdigit(static_cast<unsigned char>(token[1])) || token[1] == '.')));
}

bool SameToken(const std::string& expected, const std::string& actual) {
  if (!LooksNumeric(expected) || !LooksNumeric(actual)) return expected == actual;
  char* end_expected = nullptr;
  char* end_actual = nullptr;
  const double a = std::strtod(expected.c_str(), &end_expected);
  const double b = std::strtod(actual.c_str(), &end_actual);
  if (*end_expected == '\0' && *end_actual == '\0' && !expected.empty() && !actual.empty()) {
    return std::abs(a - b) <= 1e-6 * std::max(std::abs(a), std::abs(b)) + 1e-9;
  }
  return expected == actual;
}

TEST_CASE("report paper matches the reviewed answer file", "[studies][paper]") {
  const auto directory = std::filesystem::temp_directory_path() / "servokit_paper_report_test";
  std::filesystem::remove_all(directory);
  WritePaperReport(directory.string(), SERVOKIT_MODELS_DIR);
  const auto actual = Lines(ReadFile(directory / "report.md"));
  const auto expected = Lines(ReadFile(testing::TestDataPath("paper_report.md")));
  REQUIRE(actual.size() == expected.size());
  for (std::size_t i = 0; i < expected.size(); ++i) {
    const auto expected_tokens = Tokens(expected[i]);
    const auto actual_tokens = Tokens(actual[i]);
    INFO("line " << i + 1 << "\nexpected: " << expected[i] << "\nactual:   " << actual[i]);
    REQUIRE(actual_tokens.size() == expected_tokens.size());
    for (std::size_t k = 0; k < expected_tokens.size(); ++k) {
      CHECK(SameToken(expected_tokens[k], actual_tokens[k]));
    }
  }
  for (const char* figure :
       {"fig6_root_locus", "fig6_frequency", "fig8_root_locus", "fig8_real_part"}) {
    CHECK(std::filesystem::file_size(directory / (std::string(figure) + ".png")) > 1000);
    CHECK(std::filesystem::file_size(directory / (std::string(figure) + ".svg")) > 1000);
    CHECK(ReadFile(directory / (std::string(figure) + ".pdf")).rfind("%PDF", 0) == 0);
  }
  // The HTML names nothing a user does not have and shows its figures without other files.
  const std::string html = ReadFile(directory / "report.html");
  CHECK_THAT(html, !Catch::Contains("DESIGN.md") && !Catch::Contains("<img src=\"fig"));
  CHECK_THAT(ReadFile(directory / "report.md"), !Catch::Contains("DESIGN.md"));
  std::filesystem::remove_all(directory);
}

}  // namespace
}  // namespace servokit
