// The column names and units of the sweep tables in the files other tools read (issue #17,
// reports/sweep_tables.h, reports/sweep_hdf5.h, reports/sweep_mat.h): names unique where HDF5 and
// MAT need them, MATLAB identifiers checked before a sweep starts, and each column's unit.
// The files themselves are read back against the CSV in tests/python/test_sweep_files.py.
#include <catch2/catch.hpp>
#include <fstream>
#include <memory>
#include <string>
#include <vector>

#include "analysis/parameter_grid.h"
#include "base/errors.h"
#include "reports/sweep_hdf5.h"
#include "reports/sweep_mat.h"
#include "reports/sweep_records.h"
#include "reports/sweep_tables.h"
#include "tests/test_files.h"

namespace servokit {
namespace {

ParameterGrid GridOf(const std::vector<std::string>& names) {
  std::vector<GridAxis> axes;
  for (std::size_t i = 0; i < names.size(); ++i) {
    axes.push_back({names[i], i, ValueRange{0.0, 1.0, 2}, DisplayUnit::kSI});
  }
  return ParameterGrid(std::move(axes));
}

std::vector<std::string> Names(const std::vector<TableColumn>& columns) {
  std::vector<std::string> names;
  for (const TableColumn& column : columns) names.push_back(column.name);
  return names;
}

TEST_CASE("the table columns with kinds and units name the CSV's columns", "[reports]") {
  const ParameterGrid grid = GridOf({"m", "d"});
  CHECK(Names(PointsTableColumns(grid)) == PointsColumns(grid));
  CHECK(Names(EigenvaluesTableColumns(grid)) == EigenvaluesColumns(grid));
  const std::vector<TableColumn> eigenvalues = EigenvaluesTableColumns(grid);
  // m, d, k, re, im, frequency_hz, damping_ratio
  CHECK(eigenvalues[0].unit.empty());  // SI, unit not named by the model file
  CHECK(eigenvalues[2].kind == ColumnKind::kNumber);
  CHECK(eigenvalues[3].unit == "1/s");
  CHECK(eigenvalues[4].unit == "1/s");
  CHECK(eigenvalues[5].unit == "Hz");
  CHECK(eigenvalues[6].unit == "1");
  const std::vector<TableColumn> points = PointsTableColumns(grid);
  CHECK(points[2].kind == ColumnKind::kText);  // realization
  CHECK(points[4].kind == ColumnKind::kText);  // relative_degree, "4;2"
  CHECK(points[8].unit == "1/s");              // max_real_part
}

TEST_CASE("a parameter shown in degrees has the unit deg", "[reports]") {
  std::vector<GridAxis> axes = {{"alpha", 0, ValueRange{0.0, 1.0, 2}, DisplayUnit::kDegree}};
  const ParameterGrid grid(std::move(axes));
  const std::vector<TableColumn> points = PointsTableColumns(grid);
  CHECK(points[0].name == grid.axes()[0].ColumnName());
  CHECK(points[0].unit == "deg");
}

TEST_CASE("a parameter named k keeps its name beside the eigenvalue index", "[reports]") {
  const ParameterGrid grid = GridOf({"m", "k"});
  CHECK(ColumnNames(EigenvaluesTableColumns(grid)) ==
        std::vector<std::string>{"m", "k", "eigenvalue_index", "re", "im", "frequency_hz",
                                 "damping_ratio"});
  CHECK(ColumnNames(PointsTableColumns(grid)) == PointsColumns(grid));
  CHECK_NOTHROW(CheckMatColumnNames(grid));
  CHECK_NOTHROW(CheckHdf5ColumnNames(grid));
}

TEST_CASE("a parameter named like a fixed column is refused in every format", "[reports]") {
  CHECK_THROWS_WITH(CheckSweepColumns(GridOf({"re"})),
                    Catch::Contains("parameter 're': its column 're' would also be a fixed column "
                                    "of eigenvalues.csv"));
  CHECK_THROWS_AS(PointsColumns(GridOf({"stability"})), UsageError);
}

TEST_CASE("a column that is not a MATLAB name cannot go into a MAT file", "[reports]") {
  for (const std::string& name :
       std::vector<std::string>{"2m", "_m", "m.x", std::string(64, 'm')}) {
    INFO(name);
    const ParameterGrid grid = GridOf({name});
    CHECK_THROWS_AS(CheckMatColumnNames(grid), UsageError);
  }
  CHECK_THROWS_WITH(CheckMatColumnNames(GridOf({"m.x"})),
                    Catch::Contains("the column 'm.x' cannot be a field of a MAT file's struct: "
                                    "not a MATLAB name"));
  CHECK_NOTHROW(CheckMatColumnNames(GridOf({std::string(63, 'm')})));
  CHECK_THROWS_WITH(CheckHdf5ColumnNames(GridOf({"a/b"})),
                    Catch::Contains("the column 'a/b' cannot name an HDF5 dataset"));
}

// sweep.h5's error column comes from the errors kept in memory, or, past their limit, from the
// points records read again at the end: the two routes must write the same file.
TEST_CASE("sweep.h5 is the same whether its errors were kept or read from the records",
          "[reports][hdf5]") {
  const ParameterGrid grid = GridOf({"d"});  // d = 0, 1
  std::vector<SweepPoint> points(2);
  points[0].ok = true;
  points[0].realization = Realization::kNonIdealOrthogonal;
  points[0].rank = 1;
  points[0].relative_degree = {2};
  points[0].differentiation_index = 3;
  points[0].internal_dynamics_order = 2;
  points[0].stability = Stability::kUnstable;
  points[0].eigenvalues = {{1.5, 0.0}, {-1.5, 0.0}};
  points[0].max_real_part = 1.5;
  points[1].ok = false;
  points[1].error = "no equilibrium found for y0 = [0]";
  std::string point_records, eigenvalue_records;
  AppendRecordRows(0, points, point_records, eigenvalue_records);
  const testing::TemporaryDirectory directory;
  {
    std::ofstream file(directory / "points.records", std::ios::binary);
    file << point_records;
  }
  const RecordDecoder decoder(grid);
  TableChunk point_rows, eigenvalue_rows;
  REQUIRE(decoder.DecodePoints(point_records, 0, point_rows) == 2);
  REQUIRE(decoder.DecodeEigenvalues(eigenvalue_records, eigenvalue_rows) == 2);
  const SweepFileMetadata metadata = {"test", "0123456789abcdef", "d=0:1:2", "0.0.0"};
  const auto write = [&](const std::string& name, std::size_t most_kept_error_bytes) {
    const std::unique_ptr<SweepHdf5Writer> writer = CreateSweepHdf5(
        directory / name, metadata, grid, RelativeDegreeTextWidth(2, 1), most_kept_error_bytes);
    writer->AppendPoints(point_rows);
    writer->AppendEigenvalues(eigenvalue_rows);
    writer->Finish(*OpenPointRecords(grid, directory / "points.records"));
    return testing::ReadFile(directory / name);
  };
  const std::string kept = write("kept.h5", kMostKeptErrorBytes);
  const std::string read_again = write("read_again.h5", 0);  // past the limit at the first error
  CHECK(kept.find(points[1].error) != std::string::npos);
  CHECK(kept == read_again);
}

}  // namespace
}  // namespace servokit
