#include "reports/sweep_mat.h"

#include <matio.h>

#include <algorithm>
#include <cctype>
#include <memory>
#include <string>
#include <vector>

#include "models/errors.h"
#include "reports/matio_support.h"

namespace servokit {
namespace {

// The 116-byte text at the start of every MAT 5 file; fixed, so that the bytes do not change.
constexpr const char* kMatHeader = "MATLAB 5.0 MAT-file, written by servokit (sweep.mat)";
constexpr std::size_t kRowsPerRead = std::size_t{1} << 16;

struct MatVariableDeleter {
  void operator()(matvar_t* variable) const { Mat_VarFree(variable); }
};
using MatVariable = std::unique_ptr<matvar_t, MatVariableDeleter>;

struct MatFileCloser {
  void operator()(mat_t* file) const { Mat_Close(file); }
};

MatVariable Checked(matvar_t* variable, const std::filesystem::path& path) {
  if (variable == nullptr) throw Error(path.string() + ": matio failed to make a variable");
  return MatVariable(variable);
}

MatVariable CharRow(std::string_view text, const std::filesystem::path& path) {
  std::size_t dims[2] = {text.empty() ? 0u : 1u, text.size()};
  return Checked(
      Mat_VarCreate(nullptr, MAT_C_CHAR, MAT_T_UINT8, 2, dims, const_cast<char*>(text.data()), 0),
      path);
}

// A 1x1 struct with the given fields, each set from `values` (ownership passes to the struct).
MatVariable Struct(const char* name,
                   const std::vector<std::string>& fields,
                   std::vector<MatVariable> values,
                   const std::filesystem::path& path) {
  std::vector<const char*> field_names;
  for (const std::string& field : fields) field_names.push_back(field.c_str());
  field_names.push_back(nullptr);
  const std::size_t dims[2] = {1, 1};
  MatVariable structure = Checked(Mat_VarCreateStruct2(name, 2, dims, field_names.data()), path);
  for (std::size_t f = 0; f < fields.size(); ++f) {
    Mat_VarSetStructFieldByName(structure.get(), fields[f].c_str(), 0, values[f].release());
  }
  return structure;
}

// The whole table as a struct of columns.
MatVariable TableStruct(const char* name,
                        TableRecordReader& table,
                        const std::filesystem::path& path) {
  const std::vector<TableColumn>& columns = table.columns();
  const std::size_t rows = table.rows();
  std::vector<std::vector<double>> numbers(columns.size());
  std::vector<MatVariable> values;
  std::size_t dims[2] = {rows, 1};
  for (const TableColumn& column : columns) {
    if (column.kind == ColumnKind::kText) {
      values.push_back(
          Checked(Mat_VarCreate(nullptr, MAT_C_CELL, MAT_T_CELL, 2, dims, nullptr, 0), path));
    } else {
      values.emplace_back();
    }
  }
  for (std::size_t c = 0; c < columns.size(); ++c) {
    if (columns[c].kind == ColumnKind::kNumber) numbers[c].reserve(rows);
  }
  table.Rewind();
  TableChunk chunk;
  std::size_t row = 0;
  while (const std::size_t count = table.Read(kRowsPerRead, chunk)) {
    for (std::size_t c = 0; c < columns.size(); ++c) {
      if (columns[c].kind == ColumnKind::kNumber) {
        numbers[c].insert(numbers[c].end(), chunk.numbers[c].begin(), chunk.numbers[c].end());
        continue;
      }
      for (std::size_t i = 0; i < count; ++i) {
        Mat_VarSetCell(values[c].get(), static_cast<int>(row + i),
                       CharRow(chunk.texts[c][i], path).release());
      }
    }
    row += count;
  }
  const std::vector<std::string> fields = ColumnNames(columns);
  for (std::size_t c = 0; c < columns.size(); ++c) {
    if (columns[c].kind == ColumnKind::kNumber) {
      values[c] = Checked(
          Mat_VarCreate(nullptr, MAT_C_DOUBLE, MAT_T_DOUBLE, 2, dims, numbers[c].data(), 0), path);
    }
  }
  return Struct(name, fields, std::move(values), path);
}

// The unit of each column, as a struct of char fields named by the columns.
MatVariable UnitsStruct(const std::vector<TableColumn>& columns,
                        const std::filesystem::path& path) {
  std::vector<MatVariable> values;
  for (const TableColumn& column : columns) values.push_back(CharRow(column.unit, path));
  return Struct(nullptr, ColumnNames(columns), std::move(values), path);
}

void Write(mat_t* file, MatVariable variable, const std::filesystem::path& path) {
  if (Mat_VarWrite(file, variable.get(), MAT_COMPRESSION_NONE) != 0) {
    throw Error(path.string() + ": matio failed to write the variable '" + variable->name +
                "' (MAT 5 holds at most 2 GiB per variable; use --format hdf5)");
  }
}

}  // namespace

void WriteSweepMat(const std::filesystem::path& path,
                   const SweepFileMetadata& metadata,
                   TableRecordReader& points,
                   TableRecordReader& eigenvalues) {
  std::unique_ptr<mat_t, MatFileCloser> file(Mat_CreateVer(path.c_str(), kMatHeader, MAT_FT_MAT5));
  if (!file) throw Error(path.string() + ": matio cannot create the file");
  std::vector<MatVariable> about;
  for (const std::string* text :
       {&metadata.model, &metadata.content_hash, &metadata.grid, &metadata.servokit_version}) {
    about.push_back(CharRow(*text, path));
  }
  about.push_back(UnitsStruct(points.columns(), path));
  about.push_back(UnitsStruct(eigenvalues.columns(), path));
  Write(file.get(),
        Struct("sweep",
               {"model", "model_content_hash", "grid", "servokit_version", "points_units",
                "eigenvalues_units"},
               std::move(about), path),
        path);
  Write(file.get(), TableStruct("points", points, path), path);
  Write(file.get(), TableStruct("eigenvalues", eigenvalues, path), path);
}

void CheckMatColumnNames(const ParameterGrid& grid) {
  std::vector<std::string> names = ColumnNames(PointsTableColumns(grid));
  for (const std::string& name : ColumnNames(EigenvaluesTableColumns(grid))) {
    names.push_back(name);
  }
  for (const std::string& name : names) {
    // The one rule for MATLAB names (reports/matio_support.h), as for a solve's MAT file.
    if (const std::optional<std::string> problem = MatlabNameProblem(name)) {
      throw UsageError("the column '" + name + "' cannot be a field of a MAT file's struct: " +
                       *problem + " (HDF5 and CSV can hold it)");
    }
  }
}

}  // namespace servokit
