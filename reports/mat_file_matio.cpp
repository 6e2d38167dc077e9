#include <matio.h>

#include <algorithm>
#include <array>
#include <cerrno>
#include <cstdint>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <memory>
#include <optional>
#include <variant>
#include <vector>

#include "base/errors.h"
#include "files/output_file.h"
#include "reports/data_files_plugin.h"

namespace servokit {
namespace {

// The text at the start of a MAT v5 file (116 bytes, the last a null from matio, the rest
// padded with spaces here as MATLAB pads its own). MATLAB's begins the same way; this one has
// no date, so that the file is the same each run.
constexpr std::size_t kHeaderTextLength = 115;
const std::string kHeaderText = [] {
  std::string text = "MATLAB 5.0 MAT-file, written by servokit";
  text.resize(kHeaderTextLength, ' ');
  return text;
}();

// What is wrong with the MAT v5 file at `path`, which should hold `variables` variables, or
// nothing: after the 128-byte header, each variable is a tag (type, byte count; 4 bytes each,
// in the file's byte order, which matio makes this machine's) and that many bytes, 8-aligned;
// together they must end exactly at the end of the file.
std::optional<std::string> MatFileStructureProblem(const std::string& path, std::size_t variables) {
  std::ifstream file(path, std::ios::binary | std::ios::ate);
  if (!file) return "cannot read it back";
  const auto size = static_cast<std::uint64_t>(file.tellg());
  constexpr std::uint64_t kHeaderBytes = 128, kTagBytes = 8;
  std::uint64_t offset = kHeaderBytes;
  std::size_t found = 0;
  while (offset + kTagBytes <= size) {
    std::array<std::uint32_t, 2> tag{};
    file.seekg(static_cast<std::streamoff>(offset));
    if (!file.read(reinterpret_cast<char*>(tag.data()), sizeof(tag))) return "cannot read it back";
    const std::uint64_t bytes = (std::uint64_t{tag[1]} + 7) / 8 * 8;
    offset += kTagBytes + bytes;
    ++found;
  }
  if (offset != size || found != variables) {
    return "matio left it incomplete (" + std::to_string(size) + " bytes)";
  }
  return std::nullopt;
}

struct VariableDeleter {
  void operator()(matvar_t* variable) const { Mat_VarFree(variable); }
};
using Variable = std::unique_ptr<matvar_t, VariableDeleter>;

Variable Checked(matvar_t* variable, const std::string& what) {
  if (variable == nullptr) throw Error("matio cannot make the MAT variable " + what);
  return Variable(variable);
}

Variable DoubleMatrix(const char* name, std::size_t rows, std::size_t columns, const double* data) {
  std::array<std::size_t, 2> dims = {rows, columns};
  // matio copies the data (no MAT_F_DONT_COPY_DATA), so `data` may be const and short-lived.
  return Checked(
      Mat_VarCreate(name, MAT_C_DOUBLE, MAT_T_DOUBLE, 2, dims.data(), const_cast<double*>(data), 0),
      name ? name : "(field)");
}

// UTF-8 to the UTF-16 code units MATLAB stores text in. A malformed byte, and a character
// beyond the Basic Multilingual Plane (two units in MATLAB, which scipy.io.loadmat cannot
// read), become U+FFFD. servokit's own text is ASCII; file names in messages may not be.
std::vector<std::uint16_t> Utf16(const std::string& text) {
  constexpr std::uint16_t kReplacement = 0xFFFD;
  std::vector<std::uint16_t> units;
  units.reserve(text.size());
  for (std::size_t i = 0; i < text.size();) {
    const auto lead = static_cast<unsigned char>(text[i]);
    const std::size_t length = lead < 0x80           ? 1
                               : (lead >> 5) == 0x6  ? 2
                               : (lead >> 4) == 0xE  ? 3
                               : (lead >> 3) == 0x1E ? 4
                                                     : 0;
    bool valid = length != 0 && i + length <= text.size();
    char32_t code = length == 1 ? lead : (lead & (0x7F >> length));
    for (std::size_t k = 1; valid && k < length; ++k) {
      const auto next = static_cast<unsigned char>(text[i + k]);
      valid = (next & 0xC0) == 0x80;
      code = (code << 6) | (next & 0x3F);
    }
    if (!valid) {
      units.push_back(kReplacement);
      ++i;
      continue;
    }
    units.push_back(code < 0x10000 ? static_cast<std::uint16_t>(code) : kReplacement);
    i += length;
  }
  return units;
}

Variable FromJson(const char* name, const nlohmann::ordered_json& value);

Variable CharRow(const char* name, const std::string& text) {
  std::vector<std::uint16_t> units = Utf16(text);
  std::array<std::size_t, 2> dims = {units.empty() ? std::size_t{0} : std::size_t{1}, units.size()};
  return Checked(Mat_VarCreate(name, MAT_C_CHAR, MAT_T_UINT16, 2, dims.data(), units.data(), 0),
                 name ? name : "(text)");
}

Variable Logical(const char* name, bool value) {
  std::array<std::size_t, 2> dims = {1, 1};
  std::uint8_t byte = value ? 1 : 0;
  return Checked(
      Mat_VarCreate(name, MAT_C_UINT8, MAT_T_UINT8, 2, dims.data(), &byte, MAT_F_LOGICAL),
      name ? name : "(logical)");
}

Variable Struct(const char* name, const nlohmann::ordered_json& object) {
  std::vector<std::string> keys;
  for (const auto& item : object.items()) {
    if (const std::optional<std::string> problem = MatlabNameProblem(item.key())) {
      throw UsageError("field '" + item.key() + "': " + *problem);
    }
    keys.push_back(item.key());
  }
  std::vector<const char*> fields;
  for (const std::string& key : keys) fields.push_back(key.c_str());
  fields.push_back(nullptr);  // matio reads the field names up to a null
  std::array<std::size_t, 2> dims = {1, 1};
  Variable variable =
      Checked(Mat_VarCreateStruct2(name, 2, dims.data(), fields.data()), name ? name : "(struct)");
  for (const auto& item : object.items()) {
    Variable field = FromJson(item.key().c_str(), item.value());
    // The struct owns the field from here; it returns the previous one (none).
    Mat_VarFree(Mat_VarSetStructFieldByName(variable.get(), item.key().c_str(), 0, field.get()));
    field.release();
  }
  return variable;
}

Variable Array(const char* name, const nlohmann::ordered_json& array) {
  if (array.empty()) return DoubleMatrix(name, 0, 0, nullptr);
  const bool numbers = std::all_of(array.begin(), array.end(),
                                   [](const auto& element) { return element.is_number(); });
  if (numbers) {
    std::vector<double> values;
    for (const auto& element : array) values.push_back(element.template get<double>());
    return DoubleMatrix(name, 1, values.size(), values.data());
  }
  std::array<std::size_t, 2> dims = {1, array.size()};
  Variable cell = Checked(Mat_VarCreate(name, MAT_C_CELL, MAT_T_CELL, 2, dims.data(), nullptr, 0),
                          name ? name : "(cell)");
  for (std::size_t i = 0; i < array.size(); ++i) {
    Variable element = FromJson(nullptr, array[i]);
    Mat_VarFree(Mat_VarSetCell(cell.get(), static_cast<int>(i), element.get()));
    element.release();
  }
  return cell;
}

Variable FromJson(const char* name, const nlohmann::ordered_json& value) {
  if (value.is_null()) return DoubleMatrix(name, 0, 0, nullptr);
  if (value.is_boolean()) return Logical(name, value.get<bool>());
  if (value.is_number()) {
    const double number = value.get<double>();
    return DoubleMatrix(name, 1, 1, &number);
  }
  if (value.is_string()) return CharRow(name, value.get<std::string>());
  if (value.is_object()) return Struct(name, value);
  return Array(name, value);
}

// MatFileWriter with matio.
class MatioFileWriter final : public MatFileWriter {
 public:
  explicit MatioFileWriter(const std::string& path);
  ~MatioFileWriter() override;
  MatioFileWriter(const MatioFileWriter&) = delete;
  MatioFileWriter& operator=(const MatioFileWriter&) = delete;
  void WriteColumn(const std::string& name,
                   const Eigen::Ref<const Eigen::VectorXd>& values) override;
  void WriteStruct(const std::string& name, const nlohmann::ordered_json& object) override;
  void WriteTable(const std::string& name, const std::vector<MatColumn>& columns) override;
  void Commit() override;

 private:
  // Writes `variable`, named `name` in messages.
  void Write(matvar_t* variable, const std::string& name);

  std::string path_;
  OutputFile output_;  // matio writes its temporary file by name
  mat_t* file_ = nullptr;
  std::size_t variables_ = 0;  // written so far
};

MatioFileWriter::MatioFileWriter(const std::string& path) : path_(path), output_(path) {
  file_ = Mat_CreateVer(output_.temporary_path().c_str(), kHeaderText.c_str(), MAT_FT_MAT5);
  if (file_ == nullptr) throw Error("cannot write " + path_ + " (matio cannot create it)");
}

MatioFileWriter::~MatioFileWriter() {
  if (file_ != nullptr) Mat_Close(file_);  // the OutputFile removes the uncommitted file
}

void MatioFileWriter::WriteColumn(const std::string& name,
                                  const Eigen::Ref<const Eigen::VectorXd>& values) {
  const Eigen::VectorXd contiguous = values;
  Variable variable =
      DoubleMatrix(name.c_str(), std::size_t(contiguous.size()), 1, contiguous.data());
  Write(variable.get(), name);
}

void MatioFileWriter::WriteStruct(const std::string& name, const nlohmann::ordered_json& object) {
  Variable variable = Struct(name.c_str(), object);
  Write(variable.get(), name);
}

void MatioFileWriter::WriteTable(const std::string& name, const std::vector<MatColumn>& columns) {
  std::vector<const char*> fields;
  for (const MatColumn& column : columns) {
    if (const std::optional<std::string> problem = MatlabNameProblem(column.name)) {
      throw UsageError("field '" + column.name + "': " + *problem);
    }
    fields.push_back(column.name.c_str());
  }
  fields.push_back(nullptr);  // matio reads the field names up to a null
  std::array<std::size_t, 2> dims = {1, 1};
  Variable table = Checked(Mat_VarCreateStruct2(name.c_str(), 2, dims.data(), fields.data()), name);
  for (const MatColumn& column : columns) {
    Variable field;
    if (const auto* numbers = std::get_if<std::vector<double>>(&column.values)) {
      field = DoubleMatrix(nullptr, numbers->size(), 1, numbers->data());
    } else {
      const auto& texts = std::get<std::vector<std::string>>(column.values);
      dims = {texts.size(), 1};
      field = Checked(Mat_VarCreate(nullptr, MAT_C_CELL, MAT_T_CELL, 2, dims.data(), nullptr, 0),
                      column.name);
      for (std::size_t i = 0; i < texts.size(); ++i) {
        Variable cell = CharRow(nullptr, texts[i]);
        Mat_VarFree(Mat_VarSetCell(field.get(), static_cast<int>(i), cell.get()));
        cell.release();
      }
    }
    // The struct owns the field from here; it returns the previous one (none).
    Mat_VarFree(Mat_VarSetStructFieldByName(table.get(), column.name.c_str(), 0, field.get()));
    field.release();
  }
  Write(table.get(), name);
}

void MatioFileWriter::Write(matvar_t* variable, const std::string& name) {
  if (Mat_VarWrite(file_, variable, MAT_COMPRESSION_NONE) != 0) {
    throw Error("cannot write " + path_ + " (matio failed on the variable " + name +
                "; MAT 5 holds at most 2 GiB per variable)");
  }
  ++variables_;
}

void MatioFileWriter::Commit() {
  const int closed = Mat_Close(file_);
  file_ = nullptr;
  if (closed != 0) throw Error("cannot write " + path_ + " (matio cannot close it)");
  // matio does not check every write it makes: a full disk would leave a short file behind a
  // successful close. The file's own structure says how long it must be.
  if (const std::optional<std::string> problem =
          MatFileStructureProblem(output_.temporary_path(), variables_)) {
    if (FileSystemFull(output_.temporary_path())) {
      throw Error("cannot write " + path_ + ": " + std::strerror(ENOSPC));
    }
    throw Error("cannot write " + path_ + ": " + *problem);
  }
  output_.Commit();
}

}  // namespace

std::unique_ptr<MatFileWriter> CreateMatioFile(const std::string& path) {
  return std::make_unique<MatioFileWriter>(path);
}

}  // namespace servokit
