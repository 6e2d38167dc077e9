#pragma once
// A small strict reader and writer of Matrix Market coordinate files (NIST, "The Matrix Market
// Exchange Formats"), for the matrices of large linear models (modeling/linear_model.h).
//
// Read: `%%MatrixMarket matrix coordinate real|integer general|symmetric` (keywords in any
// case), then comment lines (`%...`) and blank lines, then the size line `rows cols entries`,
// then exactly `entries` lines `i j value` with 1-based indices. Symmetric files hold the lower
// triangle (i >= j) and are expanded. Each line is checked: indices in range, a finite value, no
// entry twice, nothing after the last entry but blank lines. Explicit zeros are kept (they are
// part of the sparsity pattern). Eigen's SparseExtra loadMarket is not used because it accepts
// malformed lines silently.
#include <Eigen/SparseCore>
#include <string>
#include <string_view>

namespace servokit {

/// Most rows or columns a Matrix Market file may declare. A matrix of servokit's has one row
/// and column per coordinate: 10^6 coordinates take 1 GB to analyse (docs/benchmarks.md), so
/// 10^7 is well above any model one machine can analyse. Without a limit a
/// three-line file declaring 4e8 columns took 1.6 GB and seconds to read, since the compressed
/// column format costs 4 bytes per row and column (found by fuzzing, issue #7).
inline constexpr long long kMaxMatrixDimension = 10'000'000;

/// Parses the text of a Matrix Market file. `source` names the file in messages. Throws
/// ModelError "source:LINE: problem" (or "source: problem" for the whole file) for anything
/// that is not a well-formed real coordinate matrix that fits Eigen's int indices.
Eigen::SparseMatrix<double> ParseMatrixMarket(std::string_view text, const std::string& source);

/// `matrix` as Matrix Market text, coordinate real general, column by column, every stored entry
/// (explicit zeros too) in the shortest form that reads back to the same double
/// (std::to_chars), so ParseMatrixMarket(FormatMatrixMarket(A)) == A bit for bit.
/// `comment` (one line, may be empty) is written as a `%` line after the header.
std::string FormatMatrixMarket(const Eigen::SparseMatrix<double>& matrix,
                               std::string_view comment = {});

/// Writes FormatMatrixMarket(matrix, comment) to `path` without holding the whole text in
/// memory. Throws UsageError naming the path if the file cannot be written.
void WriteMatrixMarket(const Eigen::SparseMatrix<double>& matrix,
                       const std::string& path,
                       std::string_view comment = {});

}  // namespace servokit
