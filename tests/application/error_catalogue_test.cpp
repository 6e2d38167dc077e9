// The error catalogue of docs/errors.md (issue #7; in the README until issue #30): every row that
// gives an example command is run in-process, from the repository root, and must exit with the
// row's status and print exactly one error line on stderr, "servokit: error: ...", containing the
// row's fragment, after at most some "servokit: warning: ..." lines. Rows without a command (`—`)
// name the test that covers them instead.
#include <algorithm>
#include <catch2/catch.hpp>
#include <filesystem>
#include <set>
#include <sstream>
#include <string>
#include <vector>

#include "tests/application/run_servokit.h"
#include "tests/test_files.h"

namespace servokit {
namespace {

using testing::RunServokit;
using testing::TemporaryDirectory;

// Rows the catalogue holds when this test was written: deleting rows fails the test.
constexpr std::size_t kCatalogueRows = 177;
// The statuses docs/errors.md documents for errors.
const std::set<int> kDocumentedStatuses = {1, 2, 3, 4, 130};
constexpr std::string_view kCatalogue = "docs/errors.md";
constexpr std::string_view kHeader = "| status | situation | example command | message contains |";
// Output paths under /tmp in the catalogue are moved into a fresh directory of the test.
constexpr std::string_view kTemporaryPrefix = "/tmp/";

struct CatalogueRow {
  int status = -1;
  std::string situation, command, fragment;
  std::size_t line = 0;  // in docs/errors.md, for messages
};

std::string Trim(const std::string& text) {
  const auto first = text.find_first_not_of(" \t");
  if (first == std::string::npos) return "";
  return text.substr(first, text.find_last_not_of(" \t") - first + 1);
}

// `text` without its enclosing backquotes ("" when it is not one code span).
std::string CodeSpan(const std::string& cell) {
  if (cell.size() < 2 || cell.front() != '`' || cell.back() != '`') return "";
  return cell.substr(1, cell.size() - 2);
}

std::vector<std::string> Cells(const std::string& line) {
  std::vector<std::string> cells;
  std::string cell;
  // The row starts and ends with '|'; the cells are between.
  for (std::size_t i = 1; i + 1 < line.size(); ++i) {
    if (line[i] == '|') {
      cells.push_back(Trim(cell));
      cell.clear();
    } else {
      cell += line[i];
    }
  }
  cells.push_back(Trim(cell));
  return cells;
}

// Every row of every catalogue table (a table under kHeader) of the page.
std::vector<CatalogueRow> ReadCatalogue(const std::string& page) {
  const std::vector<std::string> lines = testing::Lines(page);
  std::vector<CatalogueRow> rows;
  bool in_table = false;
  for (std::size_t n = 0; n < lines.size(); ++n) {
    const std::string& line = lines[n];
    if (line == kHeader) {
      in_table = true;
      continue;
    }
    if (line.empty() || line.front() != '|') {
      in_table = false;
      continue;
    }
    if (!in_table || line.rfind("| ---", 0) == 0) continue;
    const std::vector<std::string> cells = Cells(line);
    INFO(kCatalogue << " line " << n + 1 << ": " << line);
    REQUIRE(cells.size() == 4);
    CatalogueRow row;
    row.status = std::stoi(cells[0]);
    row.situation = cells[1];
    row.command = cells[2] == "—" ? "" : CodeSpan(cells[2]);
    row.fragment = CodeSpan(cells[3]);
    row.line = n + 1;
    REQUIRE((cells[2] == "—" || row.command.rfind("servokit", 0) == 0));
    REQUIRE(!row.fragment.empty());
    rows.push_back(row);
  }
  return rows;
}

// The command's words after "servokit", split on blanks, with /tmp/ paths moved to `scratch`.
std::vector<std::string> Arguments(const std::string& command,
                                   const std::filesystem::path& scratch) {
  std::istringstream words(command);
  std::vector<std::string> arguments;
  for (std::string word; words >> word;) {
    if (word.rfind(kTemporaryPrefix, 0) == 0) {
      word = (scratch / word.substr(kTemporaryPrefix.size())).string();
    }
    arguments.push_back(word);
  }
  arguments.erase(arguments.begin());  // "servokit"
  return arguments;
}

// The first `tests/...` file the situation names ("" when none).
std::string NamedTest(const std::string& situation) {
  const std::size_t start = situation.find("`tests/");
  if (start == std::string::npos) return "";
  const std::size_t end = situation.find('`', start + 1);
  if (end == std::string::npos) return "";
  return situation.substr(start + 1, end - start - 1);
}

std::filesystem::path RepositoryRoot() {
  return std::filesystem::canonical(std::filesystem::path(SERVOKIT_MODELS_DIR) / "..");
}

TEST_CASE("every error in the catalogue of docs/errors.md is what its example command prints",
          "[reports]") {
  std::filesystem::current_path(RepositoryRoot());  // the examples' paths are relative to it
  const std::vector<CatalogueRow> rows = ReadCatalogue(testing::ReadFile(std::string(kCatalogue)));
  CHECK(rows.size() >= kCatalogueRows);
  for (const CatalogueRow& row : rows) {
    DYNAMIC_SECTION(kCatalogue << " line " << row.line << ": " << row.command) {
      INFO("situation: " << row.situation);
      CHECK(kDocumentedStatuses.count(row.status) == 1);
      if (row.command.empty()) {
        // Not triggered by one command: the situation names the test that covers it, and that
        // test expects the message.
        const std::string test = NamedTest(row.situation);
        REQUIRE(!test.empty());
        CHECK_THAT(testing::ReadFile(test), Catch::Contains(row.fragment));
        continue;
      }
      const TemporaryDirectory scratch;
      const testing::Run run = RunServokit(Arguments(row.command, scratch.path()));
      INFO("stderr: " << run.err);
      CHECK(run.status == row.status);
      // Warnings and notes may come first; then the one error line.
      std::string error = run.err;
      while (
          (error.rfind("servokit: warning: ", 0) == 0 || error.rfind("servokit: note: ", 0) == 0) &&
          error.find('\n') != std::string::npos) {
        error.erase(0, error.find('\n') + 1);
      }
      CHECK(std::count(error.begin(), error.end(), '\n') == 1);
      CHECK((!error.empty() && error.back() == '\n'));
      CHECK_THAT(error, Catch::StartsWith("servokit: error: "));
      CHECK_THAT(error, Catch::Contains(row.fragment));
    }
  }
}

}  // namespace
}  // namespace servokit
