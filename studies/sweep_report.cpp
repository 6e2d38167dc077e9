#include "studies/sweep_report.h"

#include <exception>
#include <map>
#include <sstream>
#include <string_view>
#include <utility>

#include "analysis/zero_dynamics.h"
#include "base/errors.h"
#include "base/number_format.h"
#include "files/input_file.h"
#include "reports/sweep_tables.h"
#include "studies/class_map.h"
#include "studies/sweep_store.h"

namespace servokit {
namespace {

// The fields of one line of a sweep table (RFC 4180 as CsvQuote writes them; no line breaks
// inside a field).
std::vector<std::string> CsvFields(const std::string& line) {
  std::vector<std::string> fields(1);
  bool quoted = false;
  for (std::size_t i = 0; i < line.size(); ++i) {
    const char c = line[i];
    if (quoted) {
      if (c == '"' && i + 1 < line.size() && line[i + 1] == '"') {
        fields.back() += '"';
        ++i;
      } else if (c == '"') {
        quoted = false;
      } else {
        fields.back() += c;
      }
    } else if (c == '"') {
      quoted = true;
    } else if (c == ',') {
      fields.emplace_back();
    } else {
      fields.back() += c;
    }
  }
  return fields;
}

// A table of a sweep: its header's column indices and its rows.
struct CsvTable {
  std::filesystem::path file;
  std::vector<std::string> header;
  std::vector<std::vector<std::string>> rows;

  std::size_t Column(std::string_view name) const {
    for (std::size_t i = 0; i < header.size(); ++i) {
      if (header[i] == name) return i;
    }
    throw UsageError(file.string() + ": no column " + std::string(name));
  }
};

CsvTable ReadCsvTable(const std::filesystem::path& file, const std::vector<std::string>& columns) {
  std::istringstream in(ReadInputFile(file.string(), "the sweep table", kTableFileLimit));
  CsvTable table{file, {}, {}};
  std::string line;
  if (!std::getline(in, line) || (table.header = CsvFields(line)) != columns) {
    throw UsageError(file.string() + ": its header is not that of the sweep's grid");
  }
  while (std::getline(in, line)) {
    table.rows.push_back(CsvFields(line));
    if (table.rows.back().size() != columns.size()) {
      throw UsageError(file.string() + ": line " + std::to_string(table.rows.size() + 1) + " has " +
                       std::to_string(table.rows.back().size()) + " fields, not " +
                       std::to_string(columns.size()));
    }
  }
  return table;
}

double ReadNumber(const CsvTable& table, const std::string& text) {
  try {
    std::size_t used = 0;
    const double value = std::stod(text, &used);
    if (used == text.size()) return value;
  } catch (const std::exception&) {
  }
  throw UsageError(table.file.string() + ": '" + text + "' is not a number");
}

// The points of a finished CSV sweep of `grid`, and each one's class as the map names it
// (oscillatory: a complex pair beyond `options`' imaginary-axis tolerance, as Classify decides).
StoredSweep ReadStoredSweep(const std::filesystem::path& directory,
                            const ParameterGrid& grid,
                            const ClassificationOptions& options) {
  const CsvTable points = ReadCsvTable(directory / "points.csv", PointsColumns(grid));
  const CsvTable eigenvalues =
      ReadCsvTable(directory / "eigenvalues.csv", EigenvaluesColumns(grid));
  if (points.rows.size() != grid.num_points()) {
    throw UsageError(points.file.string() + ": " + std::to_string(points.rows.size()) +
                     " points, the grid of sweep.json has " + std::to_string(grid.num_points()));
  }
  const std::size_t varied = grid.axes().size();
  // A point is found by its varied columns' text (the same FormatExact text in both tables).
  std::map<std::vector<std::string>, std::size_t> point_of;
  StoredSweep stored;
  const std::size_t error = points.Column("error"), realization = points.Column("realization"),
                    stability = points.Column("stability");
  for (std::size_t i = 0; i < points.rows.size(); ++i) {
    const std::vector<std::string>& row = points.rows[i];
    point_of[std::vector<std::string>(row.begin(), row.begin() + long(varied))] = i;
    SweepPoint point;
    point.ok = row[error].empty();
    point.error = row[error];
    stored.points.push_back(point);
  }
  const std::size_t re = eigenvalues.Column("re"), im = eigenvalues.Column("im");
  for (const std::vector<std::string>& row : eigenvalues.rows) {
    const auto found =
        point_of.find(std::vector<std::string>(row.begin(), row.begin() + long(varied)));
    if (found == point_of.end()) {
      throw UsageError(eigenvalues.file.string() + ": an eigenvalue of no point of points.csv");
    }
    stored.points[found->second].eigenvalues.emplace_back(ReadNumber(eigenvalues, row[re]),
                                                          ReadNumber(eigenvalues, row[im]));
  }
  for (std::size_t i = 0; i < points.rows.size(); ++i) {
    const SweepPoint& point = stored.points[i];
    stored.classes.push_back(
        point.ok
            ? MapClassName(
                  points.rows[i][realization], points.rows[i][stability],
                  !OscillatoryModes(point.eigenvalues, options.imaginary_axis_tolerance).empty())
            : "no solution");
  }
  return stored;
}

}  // namespace

FinishedSweepReport ReadFinishedSweep(const std::filesystem::path& directory,
                                      const std::string& label) {
  const SweepRecord record = ReadSweepRecord(directory, label);
  const std::string file = record.file.string();
  if (record.linear) {
    throw UsageError(file + ": a sweep of a linear model; a report reads multibody sweeps");
  }
  if (record.format != SweepFileFormat::kCsv) {
    throw UsageError(file + ": its tables are in " + SweepTableFileNames(record.format) +
                     "; a report reads CSV sweeps (format csv)");
  }
  if (!record.completed) {
    throw UsageError(file + ": the sweep is not completed; finish it (run the same sweep again) " +
                     "first");
  }
  if (!std::filesystem::is_regular_file(record.model_path)) {
    throw UsageError(file + ": its model " + record.model_path + " is missing");
  }
  std::vector<ParameterOverride> fixed;
  for (const auto& [name, value] : record.fixed_parameters)
    fixed.push_back({name, FormatExact(value)});
  Model model = LoadModel(record.model_path, fixed);
  if (model.content_hash() != record.content_hash) {
    throw UsageError(file + ": its model " + record.model_path + " has changed since the sweep " +
                     "(content hash " + model.content_hash() + ", recorded " + record.content_hash +
                     ")");
  }
  std::vector<GridAxis> axes = ResolveSweepAxes(record, model.parameter_names());
  const ParameterGrid grid(axes);
  StoredSweep stored = ReadStoredSweep(directory, grid, record.options);
  return {std::move(model), std::move(axes), record.options, std::move(stored)};
}

}  // namespace servokit
