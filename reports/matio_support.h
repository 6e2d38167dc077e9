#pragma once
// Code that talks to matio (Debian libmatio-dev): MAT v5 files, as MATLAB's `load` and
// scipy.io.loadmat read them, written whole and byte-identical run to run.
#include <Eigen/Core>
#include <nlohmann/json.hpp>
#include <optional>
#include <string>
#include <variant>
#include <vector>

struct _mat_t;    // matio's file handle (mat_t in <matio.h>, kept out of this header)
struct matvar_t;  // matio's variable

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

/// A MAT v5 file being written. It is created as PATH.partial and renamed to PATH by Commit(),
/// so an interrupted write never leaves a truncated PATH; destroyed uncommitted, it removes the
/// partial file. The header text is fixed (matio's default holds the creation time, which would
/// make every file differ) and nothing is compressed. Every call throws Error naming the file
/// when matio fails, UsageError when a name is not a MATLAB name.
class MatFileWriter {
 public:
  explicit MatFileWriter(const std::string& path);
  ~MatFileWriter();
  MatFileWriter(const MatFileWriter&) = delete;
  MatFileWriter& operator=(const MatFileWriter&) = delete;

  /// A double column vector (N x 1) named `name`.
  void WriteColumn(const std::string& name, const Eigen::Ref<const Eigen::VectorXd>& values);

  /// A JSON object as a 1 x 1 struct named `name`, fields in the object's order: a number
  /// becomes a double, true/false a logical, a string a char row (UTF-16, as MATLAB stores
  /// text), null and an empty array the empty double [], an object a struct, an array of
  /// numbers a double row vector, any other array a cell row. Characters beyond the Basic
  /// Multilingual Plane become U+FFFD (scipy.io.loadmat cannot read MATLAB's surrogate pairs).
  void WriteStruct(const std::string& name, const nlohmann::ordered_json& object);

  /// A table as a 1 x 1 struct named `name` whose fields are the columns, in order: numbers as
  /// an N x 1 double vector, text as an N x 1 cell array of char rows (UTF-16, as above).
  void WriteTable(const std::string& name, const std::vector<MatColumn>& columns);

  /// Closes the file and renames it into place.
  void Commit();

 private:
  // Writes `variable`, named `name` in messages.
  void Write(matvar_t* variable, const std::string& name);

  std::string path_;
  std::string partial_;
  _mat_t* file_ = nullptr;
};

}  // namespace servokit
