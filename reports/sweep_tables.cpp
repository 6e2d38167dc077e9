#include "reports/sweep_tables.h"

#include <algorithm>
#include <array>
#include <cmath>

#include "analysis/sweep.h"
#include "analysis/types.h"
#include "analysis/zero_dynamics.h"
#include "models/errors.h"
#include "reports/number_format.h"

namespace servokit {
namespace {

// The columns after the varied parameters, in order (sweep_tables.h).
constexpr std::array<std::string_view, 8> kPointsFixedColumns = {"realization",
                                                                 "P_rank",
                                                                 "relative_degree",
                                                                 "differentiation_index",
                                                                 "internal_dynamics_order",
                                                                 "stability",
                                                                 "max_real_part",
                                                                 "error"};
constexpr std::array<std::string_view, 5> kEigenvaluesFixedColumns = {
    kEigenvalueIndexColumn, "re", "im", "frequency_hz", "damping_ratio"};

std::vector<std::string> ParameterColumns(const ParameterGrid& grid) {
  std::vector<std::string> columns;
  for (const GridAxis& axis : grid.axes()) columns.push_back(axis.ColumnName());
  return columns;
}

std::string CsvHeader(const std::vector<std::string>& columns) {
  std::string header;
  for (const std::string& column : columns) {
    if (!header.empty()) header += ',';
    header += column;
  }
  return header + '\n';
}

std::string JoinRelativeDegrees(const std::vector<int>& relative_degree) {
  std::string joined;
  for (std::size_t i = 0; i < relative_degree.size(); ++i) {
    if (i > 0) joined += ';';
    joined += std::to_string(relative_degree[i]);
  }
  return joined;
}

void AppendPointRow(const std::string& values, const SweepPoint& point, std::string& csv) {
  csv += values;
  if (!point.ok) {
    csv += ",,,,,,,";  // the seven class columns are empty
    csv += CsvQuote(point.error);
    csv += '\n';
    return;
  }
  csv += ToString(point.realization);
  csv += ',';
  csv += std::to_string(point.rank);
  csv += ',';
  // A negative internal order: the structure at infinity was not determined (a large linear
  // model whose Markov rows vanish numerically): its three columns are empty, not numbers.
  if (point.internal_dynamics_order >= 0) {
    csv += JoinRelativeDegrees(point.relative_degree);
    csv += ',';
    csv += std::to_string(point.differentiation_index);
    csv += ',';
    csv += std::to_string(point.internal_dynamics_order);
    csv += ',';
  } else {
    csv += ",,,";
  }
  csv += ToString(point.stability);
  csv += ',';
  // NaN means no eigenvalues (SweepPoint): an empty field, not "nan".
  if (!std::isnan(point.max_real_part)) AppendExact(csv, point.max_real_part);
  csv += ",\n";  // empty error
}

void AppendEigenvalueRows(const std::string& values, const SweepPoint& point, std::string& csv) {
  for (std::size_t k = 0; k < point.eigenvalues.size(); ++k) {
    const std::complex<double> eigenvalue = point.eigenvalues[k];
    const Mode mode = ModeOf(eigenvalue);
    csv += values;
    csv += std::to_string(k);
    for (const double number :
         {eigenvalue.real(), eigenvalue.imag(), mode.frequency_hz, mode.damping_ratio}) {
      csv += ',';
      AppendExact(csv, number);
    }
    csv += '\n';
  }
}

}  // namespace

void CheckSweepColumns(const ParameterGrid& grid) {
  const std::vector<std::string> parameters = ParameterColumns(grid);
  for (std::size_t i = 0; i < parameters.size(); ++i) {
    const std::string& name = grid.axes()[i].name;
    const auto clash = [&](const std::string& where) {
      throw UsageError("parameter '" + name + "': its column '" + parameters[i] +
                       "' would also be " + where +
                       " (a table cannot have two columns of one name); rename the parameter " +
                       "in the model file to vary it");
    };
    for (const std::string_view column : kPointsFixedColumns) {
      if (parameters[i] == column) clash("a fixed column of points.csv");
    }
    for (const std::string_view column : kEigenvaluesFixedColumns) {
      if (parameters[i] == column) clash("a fixed column of eigenvalues.csv");
    }
    for (std::size_t j = 0; j < i; ++j) {
      if (parameters[i] == parameters[j]) {
        clash("the column of the varied parameter '" + grid.axes()[j].name + "'");
      }
    }
  }
}

std::vector<std::string> PointsColumns(const ParameterGrid& grid) {
  CheckSweepColumns(grid);
  std::vector<std::string> columns = ParameterColumns(grid);
  columns.insert(columns.end(), kPointsFixedColumns.begin(), kPointsFixedColumns.end());
  return columns;
}

std::vector<std::string> EigenvaluesColumns(const ParameterGrid& grid) {
  CheckSweepColumns(grid);
  std::vector<std::string> columns = ParameterColumns(grid);
  columns.insert(columns.end(), kEigenvaluesFixedColumns.begin(), kEigenvaluesFixedColumns.end());
  return columns;
}

std::string PointsCsvHeader(const ParameterGrid& grid) { return CsvHeader(PointsColumns(grid)); }

std::string EigenvaluesCsvHeader(const ParameterGrid& grid) {
  return CsvHeader(EigenvaluesColumns(grid));
}

void AppendCsvRows(const ParameterGrid& grid,
                   std::size_t first,
                   std::span<const SweepPoint> points,
                   std::string& points_csv,
                   std::string& eigenvalues_csv) {
  std::vector<double> values(grid.axes().size());
  std::string value_columns;
  for (std::size_t i = 0; i < points.size(); ++i) {
    grid.PointValues(first + i, values);
    value_columns.clear();
    for (std::size_t axis = 0; axis < values.size(); ++axis) {
      AppendExact(value_columns, grid.axes()[axis].DisplayValue(values[axis]));
      value_columns += ',';
    }
    AppendPointRow(value_columns, points[i], points_csv);
    AppendEigenvalueRows(value_columns, points[i], eigenvalues_csv);
  }
}

void FormatBlock(const ParameterGrid& grid,
                 std::size_t first,
                 std::span<const SweepPoint> points,
                 int threads,
                 FormattedBlock& block) {
  // Formatting numbers costs about a tenth of a small model's analysis: done on one thread it
  // would cap the speed-up of many cores, so each thread formats one contiguous slice and the
  // slices are written in order (the bytes do not depend on the number of slices).
  const auto slices = static_cast<std::size_t>(std::max(threads, 1));
  block.first = first;
  block.points = points.size();
  block.points_without_solution = 0;
  for (const SweepPoint& point : points) block.points_without_solution += point.ok ? 0 : 1;
  block.points_csv.resize(slices);
  block.eigenvalues_csv.resize(slices);
  ParallelFor(slices, static_cast<int>(slices), 1, [&](std::size_t slice, int) {
    const std::size_t begin = points.size() * slice / slices;
    const std::size_t end = points.size() * (slice + 1) / slices;
    // Appended to as locals: the slices' string objects sit side by side, and a size field
    // written by two threads at once would bounce its cache line between them.
    std::string points_csv = std::move(block.points_csv[slice]);
    std::string eigenvalues_csv = std::move(block.eigenvalues_csv[slice]);
    points_csv.clear();
    eigenvalues_csv.clear();
    AppendCsvRows(grid, first + begin, points.subspan(begin, end - begin), points_csv,
                  eigenvalues_csv);
    block.points_csv[slice] = std::move(points_csv);
    block.eigenvalues_csv[slice] = std::move(eigenvalues_csv);
  });
}

std::string CsvQuote(const std::string& text) {
  std::string quoted = "\"";
  for (const char c : text) {
    if (c == '"') quoted += '"';
    quoted += c;
  }
  return quoted + "\"";
}

}  // namespace servokit
