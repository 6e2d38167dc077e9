#include "reports/sweep_mat.h"

#include <optional>
#include <string>
#include <vector>

#include "base/errors.h"
#include "reports/mat_file.h"

namespace servokit {
namespace {

// Rows read from the records at a time.
constexpr std::size_t kRowsPerRead = std::size_t{1} << 16;

// The whole table as columns (MAT 5 writes a variable whole); nullopt once `stop_requested`
// says true.
std::optional<std::vector<MatColumn>> ReadColumns(TableRecordReader& table,
                                                  const std::function<bool()>& stop_requested) {
  const std::vector<TableColumn>& columns = table.columns();
  std::vector<MatColumn> result;
  for (const TableColumn& column : columns) {
    MatColumn mat_column{column.name, {}};
    if (column.kind == ColumnKind::kText) mat_column.values = std::vector<std::string>();
    result.push_back(std::move(mat_column));
  }
  table.Rewind();
  TableChunk chunk;
  while (const std::size_t count = table.Read(kRowsPerRead, chunk)) {
    if (stop_requested && stop_requested()) return std::nullopt;
    for (std::size_t c = 0; c < columns.size(); ++c) {
      if (auto* numbers = std::get_if<std::vector<double>>(&result[c].values)) {
        numbers->insert(numbers->end(), chunk.numbers[c].begin(), chunk.numbers[c].end());
      } else {
        auto& texts = std::get<std::vector<std::string>>(result[c].values);
        texts.insert(texts.end(), chunk.texts[c].begin(), chunk.texts[c].begin() + count);
      }
    }
  }
  return result;
}

// The unit of each column, as an object of text fields named by the columns.
nlohmann::ordered_json Units(const std::vector<TableColumn>& columns) {
  nlohmann::ordered_json units = nlohmann::ordered_json::object();
  for (const TableColumn& column : columns) units[column.name] = column.unit;
  return units;
}

}  // namespace

bool WriteSweepMat(const std::filesystem::path& path,
                   const SweepFileMetadata& metadata,
                   TableRecordReader& points,
                   TableRecordReader& eigenvalues,
                   const std::function<bool()>& stop_requested) {
  const std::unique_ptr<MatFileWriter> file = CreateMatFile(path.string());
  file->WriteStruct("sweep", {{"model", metadata.model},
                              {"model_content_hash", metadata.content_hash},
                              {"grid", metadata.grid},
                              {"servokit_version", metadata.servokit_version},
                              {"points_units", Units(points.columns())},
                              {"eigenvalues_units", Units(eigenvalues.columns())}});
  for (auto [name, table] :
       {std::pair{"points", &points}, std::pair{"eigenvalues", &eigenvalues}}) {
    const std::optional<std::vector<MatColumn>> columns = ReadColumns(*table, stop_requested);
    if (!columns) return false;  // the writer, destroyed uncommitted, removes its file
    file->WriteTable(name, *columns);
  }
  if (stop_requested && stop_requested()) return false;
  file->Commit();
  return true;
}

void CheckMatColumnNames(const ParameterGrid& grid) {
  std::vector<std::string> names = ColumnNames(PointsTableColumns(grid));
  for (const std::string& name : ColumnNames(EigenvaluesTableColumns(grid))) {
    names.push_back(name);
  }
  for (const std::string& name : names) {
    // The one rule for MATLAB names (reports/mat_file.h), as for a solve's MAT file.
    if (const std::optional<std::string> problem = MatlabNameProblem(name)) {
      throw UsageError("the column '" + name + "' cannot be a field of a MAT file's struct: " +
                       *problem + " (HDF5 and CSV can hold it)");
    }
  }
}

}  // namespace servokit
