#pragma once
// MAT v5 files, as MATLAB's `load` and scipy.io.loadmat read them, written whole and
// byte-identical run to run, with matio (Debian libmatio-dev) in the data-files plugin.
#include <Eigen/Core>
#include <memory>
#include <nlohmann/json.hpp>
#include <optional>
#include <string>
#include <variant>
#include <vector>

namespace servokit {

/// Why `name` cannot name a MATLAB variable or struct field (MATLAB's isvarname: a letter, then
/// letters, digits and _, at most 63 characters, not a keyword such as `end`), or nullopt.
std::optional<std::string> MatlabNameProblem(const std::string& name);

/// One column of a table written as a struct of columns (MatFileWriter::WriteTable): numbers,
/// or text.
struct MatColumn {
  std::string name;
  std::variant<std::vector<double>, std::vector<std::string>> values;
};

/// A MAT v5 file being written (CreateMatFile). It is written to a temporary file and renamed to
/// PATH by Commit() once its structure is checked complete (files/output_file.h), so an
/// interrupted write or a full disk never leaves a truncated PATH; destroyed uncommitted, it
/// removes the temporary file. The header text is fixed (matio's default holds the
/// creation time, which would make every file differ) and nothing is compressed. Every call
/// throws Error naming the file when matio fails, UsageError when a name is not a MATLAB name.
class MatFileWriter {
 public:
  virtual ~MatFileWriter() = default;
  /// A double column vector (N x 1) named `name`.
  virtual void WriteColumn(const std::string& name,
                           const Eigen::Ref<const Eigen::VectorXd>& values) = 0;
  /// A JSON object as a 1 x 1 struct named `name`, fields in the object's order: a number
  /// becomes a double, true/false a logical, a string a char row (UTF-16, as MATLAB stores
  /// text), null and an empty array the empty double [], an object a struct, an array of
  /// numbers a double row vector, any other array a cell row. Characters beyond the Basic
  /// Multilingual Plane become U+FFFD (scipy.io.loadmat cannot read MATLAB's surrogate pairs).
  virtual void WriteStruct(const std::string& name, const nlohmann::ordered_json& object) = 0;
  /// A table as a 1 x 1 struct named `name` whose fields are the columns, in order: numbers as
  /// an N x 1 double vector, text as an N x 1 cell array of char rows (UTF-16, as above).
  virtual void WriteTable(const std::string& name, const std::vector<MatColumn>& columns) = 0;
  /// Closes the file and renames it into place.
  virtual void Commit() = 0;
};

/// Starts writing the MAT file `path` with matio, in the data-files plugin
/// (reports/data_files_plugin.h), which this loads on first use.
std::unique_ptr<MatFileWriter> CreateMatFile(const std::string& path);

}  // namespace servokit
