#include "reports/sweep_columns.h"

#include <initializer_list>
#include <utility>

#include "base/errors.h"
#include "base/number_format.h"

namespace servokit {
namespace {

// A parameter is in SI, whose unit the model file does not name (""), unless shown in degrees.
std::vector<TableColumn> ParameterTableColumns(const ParameterGrid& grid) {
  std::vector<TableColumn> columns;
  for (const GridAxis& axis : grid.axes()) {
    columns.push_back({axis.ColumnName(), ColumnKind::kNumber,
                       axis.display_unit == DisplayUnit::kDegree ? "deg" : ""});
  }
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

}  // namespace

void AppendRelativeDegrees(std::string& text, const std::vector<int>& relative_degree) {
  for (std::size_t i = 0; i < relative_degree.size(); ++i) {
    if (i > 0) text += ';';
    AppendShortest(text, relative_degree[i]);
  }
}

std::string JoinRelativeDegrees(const std::vector<int>& relative_degree) {
  std::string joined;
  AppendRelativeDegrees(joined, relative_degree);
  return joined;
}

std::vector<TableColumn> PointsTableColumns(const ParameterGrid& grid) {
  constexpr ColumnKind kNumber = ColumnKind::kNumber, kText = ColumnKind::kText;
  std::vector<TableColumn> columns = ParameterTableColumns(grid);
  for (TableColumn column :
       std::initializer_list<TableColumn>{{"realization", kText, ""},
                                          {"P_rank", kNumber, ""},
                                          {"relative_degree", kText, ""},
                                          {"differentiation_index", kNumber, ""},
                                          {"internal_dynamics_order", kNumber, ""},
                                          {"stability", kText, ""},
                                          {"max_real_part", kNumber, "1/s"},
                                          {"error", kText, ""}}) {
    columns.push_back(std::move(column));
  }
  return columns;
}

std::vector<TableColumn> EigenvaluesTableColumns(const ParameterGrid& grid) {
  constexpr ColumnKind kNumber = ColumnKind::kNumber;
  std::vector<TableColumn> columns = ParameterTableColumns(grid);
  for (TableColumn column :
       std::initializer_list<TableColumn>{{std::string(kEigenvalueIndexColumn), kNumber, ""},
                                          {"re", kNumber, "1/s"},
                                          {"im", kNumber, "1/s"},
                                          {"frequency_hz", kNumber, "Hz"},
                                          {"damping_ratio", kNumber, "1"}}) {
    columns.push_back(std::move(column));
  }
  return columns;
}

void CheckSweepColumns(const ParameterGrid& grid) {
  const std::vector<TableColumn> points = PointsTableColumns(grid);
  const std::vector<TableColumn> eigenvalues = EigenvaluesTableColumns(grid);
  const std::size_t parameters = grid.axes().size();
  for (std::size_t i = 0; i < parameters; ++i) {
    const std::string& column = points[i].name;
    const auto clash = [&](const std::string& where) {
      throw UsageError("parameter '" + grid.axes()[i].name + "': its column '" + column +
                       "' would also be " + where +
                       " (a table cannot have two columns of one name); rename the parameter " +
                       "in the model file to vary it");
    };
    for (std::size_t j = parameters; j < points.size(); ++j) {
      if (column == points[j].name) clash("a fixed column of points.csv");
    }
    for (std::size_t j = parameters; j < eigenvalues.size(); ++j) {
      if (column == eigenvalues[j].name) clash("a fixed column of eigenvalues.csv");
    }
    for (std::size_t j = 0; j < i; ++j) {
      if (column == points[j].name) {
        clash("the column of the varied parameter '" + grid.axes()[j].name + "'");
      }
    }
  }
}

std::vector<std::string> PointsColumns(const ParameterGrid& grid) {
  CheckSweepColumns(grid);
  return ColumnNames(PointsTableColumns(grid));
}

std::vector<std::string> EigenvaluesColumns(const ParameterGrid& grid) {
  CheckSweepColumns(grid);
  return ColumnNames(EigenvaluesTableColumns(grid));
}

std::string PointsCsvHeader(const ParameterGrid& grid) { return CsvHeader(PointsColumns(grid)); }

std::string EigenvaluesCsvHeader(const ParameterGrid& grid) {
  return CsvHeader(EigenvaluesColumns(grid));
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
