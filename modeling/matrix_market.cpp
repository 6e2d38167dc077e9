#include "modeling/matrix_market.h"

#include <algorithm>
#include <cctype>
#include <cerrno>
#include <charconv>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstring>
#include <functional>
#include <limits>
#include <memory>
#include <string>
#include <system_error>
#include <vector>

#include "base/errors.h"
#include "base/number_format.h"
#include "base/text.h"
#include "files/output_file.h"

namespace servokit {
namespace {

using SparseMatrix = Eigen::SparseMatrix<double>;
using Triplet = Eigen::Triplet<double>;

constexpr std::string_view kBanner = "%%MatrixMarket";
// Eigen's default StorageIndex is int: rows, columns and stored entries must fit.
constexpr long long kMaxIndex = std::numeric_limits<int>::max();
// The shortest line an entry can have: "1 1 1\n".
constexpr std::size_t kShortestEntryLine = 6;
// Room for an int or a double in shortest form ("-2.2250738585072014e-308" has 24 chars).
constexpr std::size_t kMaxNumberChars = 32;
// The writer flushes its buffer to the file in chunks of this size.
constexpr std::size_t kWriteChunk = 1 << 20;

std::string Lower(std::string_view text) {
  std::string lower(text);
  for (char& c : lower) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  return lower;
}

// Splits `text` into blank-separated words.
std::vector<std::string_view> Words(std::string_view text) {
  std::vector<std::string_view> words;
  std::size_t i = 0;
  while (true) {
    i = text.find_first_not_of(kBlanks, i);
    if (i == std::string_view::npos) break;
    std::size_t end = text.find_first_of(kBlanks, i);
    if (end == std::string_view::npos) end = text.size();
    words.push_back(text.substr(i, end - i));
    i = end;
  }
  return words;
}

// Walks the text line by line, counting lines from 1; a trailing '\r' is dropped.
class LineReader {
 public:
  explicit LineReader(std::string_view text) : text_(text) {}
  bool Next(std::string_view& line) {
    if (position_ >= text_.size()) return false;
    std::size_t end = text_.find('\n', position_);
    if (end == std::string_view::npos) end = text_.size();
    line = text_.substr(position_, end - position_);
    if (!line.empty() && line.back() == '\r') line.remove_suffix(1);
    position_ = end + 1;
    ++number_;
    return true;
  }
  std::size_t number() const { return number_; }

 private:
  std::string_view text_;
  std::size_t position_ = 0;
  std::size_t number_ = 0;
};

class Parser {
 public:
  Parser(std::string_view text, const std::string& source)
      : text_(text), reader_(text), source_(source) {}

  SparseMatrix Parse() {
    ReadBanner();
    ReadSize();
    std::vector<Triplet> triplets;
    // An entry line takes at least 6 bytes ("1 1 1\n"): a size line that promises more entries
    // than the file can hold must not reserve for them (1e9 entries in 300 bytes tried to take
    // 16 GB; found by fuzzing). ReadEntries reports the missing lines.
    const auto possible_entries = std::min<long long>(
        entries_, static_cast<long long>(text_.size() / kShortestEntryLine) + 1);
    triplets.reserve(
        static_cast<std::size_t>(symmetric_ ? 2 * possible_entries : possible_entries));
    ReadEntries([&](std::size_t, int i, int j, double value) {
      triplets.emplace_back(i, j, value);
      if (symmetric_ && i != j) triplets.emplace_back(j, i, value);
    });
    SparseMatrix matrix(rows_, cols_);
    std::size_t duplicates = 0;
    matrix.setFromTriplets(triplets.begin(), triplets.end(), [&](double a, double) {
      ++duplicates;
      return a;
    });
    if (duplicates > 0) ReportDuplicate(std::move(triplets));
    matrix.makeCompressed();
    return matrix;
  }

 private:
  [[noreturn]] void FailAt(std::size_t line, const std::string& problem) const {
    throw ModelError(source_ + ":" + std::to_string(line) + ": " + problem);
  }
  [[noreturn]] void Fail(const std::string& problem) const {
    throw ModelError(source_ + ": " + problem);
  }

  void ReadBanner() {
    std::string_view line;
    if (!reader_.Next(line)) Fail("empty file (expected a Matrix Market file)");
    const std::vector<std::string_view> words = Words(line);
    if (words.empty() || words[0] != kBanner) {
      FailAt(1, "expected the header '%%MatrixMarket matrix coordinate real general'");
    }
    if (words.size() != 5) {
      FailAt(1, "expected 4 words after %%MatrixMarket (matrix coordinate real general), found " +
                    std::to_string(words.size() - 1));
    }
    if (Lower(words[1]) != "matrix") {
      FailAt(1, "object '" + std::string(words[1]) + "' is not supported (expected matrix)");
    }
    if (Lower(words[2]) != "coordinate") {
      FailAt(1, "format '" + std::string(words[2]) +
                    "' is not supported (expected coordinate, the sparse format)");
    }
    const std::string field = Lower(words[3]);
    if (field != "real" && field != "integer") {
      FailAt(1,
             "field '" + std::string(words[3]) + "' is not supported (expected real or integer)");
    }
    const std::string symmetry = Lower(words[4]);
    if (symmetry != "general" && symmetry != "symmetric") {
      FailAt(1, "symmetry '" + std::string(words[4]) +
                    "' is not supported (expected general or symmetric)");
    }
    symmetric_ = symmetry == "symmetric";
  }

  // A whole word as a non-negative integer no larger than kMaxIndex, or -1.
  static long long ParseCount(std::string_view word) {
    long long value = 0;
    const auto [end, error] = std::from_chars(word.data(), word.data() + word.size(), value);
    if (error != std::errc() || end != word.data() + word.size() || value < 0 ||
        value > kMaxIndex) {
      return -1;
    }
    return value;
  }

  void ReadSize() {
    std::string_view line;
    while (reader_.Next(line)) {
      const std::string_view trimmed = TrimBlanks(line);
      if (trimmed.empty() || trimmed.front() == '%') continue;
      const std::vector<std::string_view> words = Words(trimmed);
      if (words.size() != 3) {
        FailAt(reader_.number(), "expected the size line 'rows columns entries', found '" +
                                     std::string(trimmed) + "'");
      }
      const long long rows = ParseCount(words[0]);
      const long long cols = ParseCount(words[1]);
      const long long entries = ParseCount(words[2]);
      if (rows < 1 || cols < 1 || entries < 0) {
        FailAt(reader_.number(), "bad size line '" + std::string(trimmed) +
                                     "' (rows and columns from 1 to " + std::to_string(kMaxIndex) +
                                     ", entries from 0)");
      }
      if (rows > kMaxMatrixDimension || cols > kMaxMatrixDimension) {
        FailAt(reader_.number(), std::to_string(rows) + " x " + std::to_string(cols) +
                                     " is larger than servokit reads (at most " +
                                     std::to_string(kMaxMatrixDimension) + " rows and columns)");
      }
      if (symmetric_ && rows != cols) {
        FailAt(reader_.number(), "a symmetric matrix must be square, found " +
                                     std::to_string(rows) + " x " + std::to_string(cols));
      }
      // Long double avoids overflow of rows * cols for large sizes.
      const long double capacity =
          symmetric_ ? static_cast<long double>(rows) * static_cast<long double>(rows + 1) / 2
                     : static_cast<long double>(rows) * static_cast<long double>(cols);
      if (static_cast<long double>(entries) > capacity) {
        FailAt(reader_.number(),
               std::to_string(entries) + " entries do not fit in a " + std::to_string(rows) +
                   " x " + std::to_string(cols) +
                   (symmetric_ ? " symmetric (lower triangle) matrix" : " matrix"));
      }
      if (symmetric_ && 2 * entries > kMaxIndex) {
        FailAt(reader_.number(),
               "too many entries for int indices once the symmetric matrix is "
               "expanded");
      }
      rows_ = static_cast<int>(rows);
      cols_ = static_cast<int>(cols);
      entries_ = entries;
      return;
    }
    Fail("missing the size line 'rows columns entries' after the header");
  }

  // Reads `entries_` lines "i j value" and passes (line, i - 1, j - 1, value) to `take`.
  template <typename Take>
  void ReadEntries(const Take& take) {
    std::string_view line;
    long long count = 0;
    while (count < entries_) {
      if (!reader_.Next(line)) {
        Fail("expected " + std::to_string(entries_) + " entries (size line), found " +
             std::to_string(count));
      }
      const std::size_t number = reader_.number();
      int i = 0, j = 0;
      double value = 0.0;
      ParseEntry(line, number, i, j, value);
      take(number, i - 1, j - 1, value);
      ++count;
    }
    while (reader_.Next(line)) {
      if (!TrimBlanks(line).empty()) {
        FailAt(reader_.number(),
               "more entries than the " + std::to_string(entries_) + " of the size line");
      }
    }
  }

  void ParseEntry(std::string_view line, std::size_t number, int& i, int& j, double& value) const {
    const char* position = line.data();
    const char* end = line.data() + line.size();
    // Blanks, then an optional '+' that some writers put before numbers (from_chars takes none).
    const auto skip_blanks = [&] {
      while (position < end && (*position == ' ' || *position == '\t')) ++position;
      if (position + 1 < end && *position == '+' && *(position + 1) != '-' &&
          *(position + 1) != '+') {
        ++position;
      }
    };
    const auto malformed = [&](const std::string& what) {
      FailAt(number,
             what + " in '" + std::string(TrimBlanks(line)) + "' (expected 'row column value')");
    };
    long long indices[2] = {0, 0};
    for (long long& index : indices) {
      skip_blanks();
      const auto [stop, error] = std::from_chars(position, end, index);
      if (error != std::errc() || (stop < end && *stop != ' ' && *stop != '\t')) {
        malformed(&index == indices ? "bad row index" : "bad column index");
      }
      position = stop;
    }
    skip_blanks();
    const auto [stop, error] = std::from_chars(position, end, value);
    if (error == std::errc::result_out_of_range) {
      FailAt(number,
             "value out of the range of a double in '" + std::string(TrimBlanks(line)) + "'");
    }
    if (error != std::errc() || (stop < end && *stop != ' ' && *stop != '\t')) {
      malformed(position == end ? "missing value" : "bad value");
    }
    position = stop;
    skip_blanks();
    if (position != end) malformed("extra text '" + std::string(position, end) + "'");
    if (!std::isfinite(value)) {
      FailAt(number, "non-finite value in '" + std::string(TrimBlanks(line)) + "'");
    }
    if (indices[0] < 1 || indices[0] > rows_ || indices[1] < 1 || indices[1] > cols_) {
      FailAt(number, "entry (" + std::to_string(indices[0]) + ", " + std::to_string(indices[1]) +
                         ") outside the " + std::to_string(rows_) + " x " + std::to_string(cols_) +
                         " matrix (indices count from 1)");
    }
    if (symmetric_ && indices[0] < indices[1]) {
      FailAt(number, "entry (" + std::to_string(indices[0]) + ", " + std::to_string(indices[1]) +
                         ") above the diagonal in a symmetric file (give the lower triangle)");
    }
    i = static_cast<int>(indices[0]);
    j = static_cast<int>(indices[1]);
  }

  // Only on the error path: finds the first entry given twice and the lines that give it.
  [[noreturn]] void ReportDuplicate(std::vector<Triplet> triplets) const {
    const auto before = [](const Triplet& a, const Triplet& b) {
      return a.col() != b.col() ? a.col() < b.col() : a.row() < b.row();
    };
    std::sort(triplets.begin(), triplets.end(), before);
    const auto same = [](const Triplet& a, const Triplet& b) {
      return a.row() == b.row() && a.col() == b.col();
    };
    const auto duplicate = std::adjacent_find(triplets.begin(), triplets.end(), same);
    const int row = duplicate->row(), col = duplicate->col();
    std::vector<std::size_t> lines;
    Parser again(text_, source_);
    again.ReadBanner();
    again.ReadSize();
    again.ReadEntries([&](std::size_t line, int i, int j, double) {
      if ((i == row && j == col) || (symmetric_ && i == col && j == row)) lines.push_back(line);
    });
    FailAt(lines.size() >= 2 ? lines[1] : 0,
           "entry (" + std::to_string(row + 1) + ", " + std::to_string(col + 1) +
               ") given twice (first on line " +
               (lines.empty() ? std::string("?") : std::to_string(lines[0])) + ")");
  }

  std::string_view text_;
  LineReader reader_;
  const std::string& source_;
  bool symmetric_ = false;
  int rows_ = 0, cols_ = 0;
  long long entries_ = 0;
};

// Appends text to a buffer and hands full chunks to `flush`.
class ChunkedWriter {
 public:
  explicit ChunkedWriter(std::function<void(std::string_view)> flush) : flush_(std::move(flush)) {
    buffer_.reserve(kWriteChunk + 3 * kMaxNumberChars);
  }
  void Append(std::string_view text) {
    buffer_.append(text);
    if (buffer_.size() >= kWriteChunk) Flush();
  }
  void AppendEntry(int row, int col, double value) {
    AppendShortest(buffer_, row + 1);
    buffer_.push_back(' ');
    AppendShortest(buffer_, col + 1);
    buffer_.push_back(' ');
    AppendShortest(buffer_, value);  // "-0" kept: the file reads back bit for bit
    buffer_.push_back('\n');
    if (buffer_.size() >= kWriteChunk) Flush();
  }
  void Flush() {
    if (!buffer_.empty()) flush_(buffer_);
    buffer_.clear();
  }

 private:
  std::function<void(std::string_view)> flush_;
  std::string buffer_;
};

void Format(const SparseMatrix& matrix, std::string_view comment, ChunkedWriter& writer) {
  writer.Append("%%MatrixMarket matrix coordinate real general\n");
  if (!comment.empty()) {
    writer.Append("% ");
    writer.Append(comment);
    writer.Append("\n");
  }
  writer.Append(std::to_string(matrix.rows()) + " " + std::to_string(matrix.cols()) + " " +
                std::to_string(matrix.nonZeros()) + "\n");
  for (int col = 0; col < matrix.outerSize(); ++col) {
    for (SparseMatrix::InnerIterator it(matrix, col); it; ++it) {
      writer.AppendEntry(static_cast<int>(it.row()), static_cast<int>(it.col()), it.value());
    }
  }
  writer.Flush();
}

}  // namespace

SparseMatrix ParseMatrixMarket(std::string_view text, const std::string& source) {
  return Parser(text, source).Parse();
}

std::string FormatMatrixMarket(const SparseMatrix& matrix, std::string_view comment) {
  std::string text;
  ChunkedWriter writer([&](std::string_view chunk) { text.append(chunk); });
  Format(matrix, comment, writer);
  return text;
}

void WriteMatrixMarket(const SparseMatrix& matrix,
                       const std::string& path,
                       std::string_view comment) {
  OutputFile file(path);
  ChunkedWriter writer([&](std::string_view chunk) { file.Write(chunk); });
  Format(matrix, comment, writer);
  file.Commit();
}

}  // namespace servokit
