// `servokit report --from DIR`: the report of a finished sweep, its map coloured from the
// sweep's own tables, and the sweeps it refuses.
#include <algorithm>
#include <catch2/catch.hpp>
#include <cmath>
#include <complex>
#include <filesystem>
#include <fstream>
#include <map>
#include <set>
#include <sstream>
#include <string>
#include <utility>
#include <vector>

#include "tests/application/run_servokit.h"
#include "tests/test_files.h"
#include "tests/test_paths.h"

namespace servokit {
namespace {

using testing::CsvFields;
using testing::ModelPath;
using testing::ReadFile;
using testing::RunServokit;
using Cell = std::pair<std::string, std::string>;  // the x and y text of a grid point

std::vector<std::vector<std::string>> CsvRows(const std::filesystem::path& path) {
  std::ifstream in(path);
  std::string line;
  std::vector<std::vector<std::string>> rows;
  while (std::getline(in, line)) rows.push_back(CsvFields(line));
  return rows;
}

// The class of every grid point from the sweep's tables: realization and stability from
// points.csv, "oscillatory" when eigenvalues.csv gives the point an eigenvalue off the real
// axis (the grid keeps clear of the double roots, so a plain relative test decides).
std::map<Cell, std::string> ClassesFromTables(const std::filesystem::path& sweep) {
  const auto points = CsvRows(sweep / "points.csv");
  const auto eigenvalues = CsvRows(sweep / "eigenvalues.csv");
  REQUIRE(points.at(0) == std::vector<std::string>{"alpha_deg", "d", "realization", "P_rank",
                                                   "relative_degree", "differentiation_index",
                                                   "internal_dynamics_order", "stability",
                                                   "max_real_part", "error"});
  REQUIRE(eigenvalues.at(0).at(3) == "re");
  REQUIRE(eigenvalues.at(0).at(4) == "im");
  std::set<Cell> oscillatory;
  for (std::size_t i = 1; i < eigenvalues.size(); ++i) {
    const std::complex<double> value(std::stod(eigenvalues[i][3]), std::stod(eigenvalues[i][4]));
    if (std::abs(value.imag()) > 1e-9 * std::abs(value)) {
      oscillatory.insert({eigenvalues[i][0], eigenvalues[i][1]});
    }
  }
  std::map<Cell, std::string> classes;
  for (std::size_t i = 1; i < points.size(); ++i) {
    const Cell cell{points[i][0], points[i][1]};
    classes[cell] = !points[i][9].empty()
                        ? "no solution"
                        : points[i][2] + ", " + points[i][7] + ", " +
                              (oscillatory.count(cell) ? "oscillatory" : "non-oscillatory");
  }
  return classes;
}

// The grid points of the map's figure data (map_alpha_d.dat: one block per series, "# title"
// first), by class; the curves' blocks (titled "... (along ...)" or untitled) are left out.
std::map<Cell, std::string> ClassesFromMap(const std::filesystem::path& data,
                                           const std::set<std::string>& class_names) {
  std::ifstream in(data);
  std::string line, title;
  std::map<Cell, std::string> classes;
  while (std::getline(in, line)) {
    if (line.rfind("# ", 0) == 0) {
      title = line.substr(2);
    } else if (!line.empty() && class_names.count(title)) {
      const auto space = line.find(' ');
      const Cell cell{line.substr(0, space), line.substr(space + 1)};
      CHECK(classes.count(cell) == 0);
      classes[cell] = title;
    }
  }
  return classes;
}

TEST_CASE("report --from colours the map of a finished sweep from its points.csv", "[reports]") {
  const servokit::testing::TemporaryDirectory scratch_root(/*create=*/false);
  const std::filesystem::path root = scratch_root.path();
  std::filesystem::remove_all(root);
  const std::vector<std::string> grid = {"--vary", "alpha=-40deg:60deg:n=6", "--vary",
                                         "d=0.5:4:n=8"};
  std::vector<std::string> sweep = {"sweep", ModelPath("mass_on_car.yaml")};
  sweep.insert(sweep.end(), grid.begin(), grid.end());
  sweep.insert(sweep.end(), {"--out", (root / "sweep").string()});
  REQUIRE(RunServokit(sweep).status == 0);
  const auto run = RunServokit(
      {"report", "--from", (root / "sweep").string(), "--out", (root / "from").string()});
  INFO(run.err);
  REQUIRE(run.status == 0);
  for (const char* file : {"report.md", "report.html", "map_alpha_d.png", "map_alpha_d.svg",
                           "map_alpha_d.pdf", "map_alpha_d_curves.csv", "study_d_root_locus.png"}) {
    CHECK(std::filesystem::exists(root / "from" / file));
  }
  const std::map<Cell, std::string> expected = ClassesFromTables(root / "sweep");
  CHECK(expected.size() == 6 * 8);
  std::set<std::string> names;
  for (const auto& [cell, name] : expected) names.insert(name);
  CHECK(names.size() >= 2);  // tangential at alpha = 0, and both sides of the over-damping curve
  CHECK(ClassesFromMap(root / "from" / "map_alpha_d.dat", names) == expected);

  // A second method: `report MODEL` over the same grid classifies every point again.
  std::vector<std::string> report = {"report", ModelPath("mass_on_car.yaml")};
  report.insert(report.end(), grid.begin(), grid.end());
  report.insert(report.end(), {"--out", (root / "model").string()});
  REQUIRE(RunServokit(report).status == 0);
  CHECK(ReadFile(root / "from" / "map_alpha_d.dat") ==
        ReadFile(root / "model" / "map_alpha_d.dat"));
  CHECK(ReadFile(root / "from" / "report.md") == ReadFile(root / "model" / "report.md"));
  std::filesystem::remove_all(root);
}

TEST_CASE("report --from takes a one-axis study's eigenvalues from the sweep", "[reports]") {
  const servokit::testing::TemporaryDirectory scratch_root(/*create=*/false);
  const std::filesystem::path root = scratch_root.path();
  std::filesystem::remove_all(root);
  REQUIRE(RunServokit({"sweep", ModelPath("mass_on_car.yaml"), "--vary", "alpha=5deg:90deg:n=9",
                       "--set", "d=1", "--out", (root / "sweep").string()})
              .status == 0);
  REQUIRE(RunServokit(
              {"report", "--from", (root / "sweep").string(), "--out", (root / "from").string()})
              .status == 0);
  // The locus holds every eigenvalue of eigenvalues.csv, with alpha [deg] as its colour.
  std::multiset<std::string> expected, drawn;
  const auto eigenvalues = CsvRows(root / "sweep" / "eigenvalues.csv");
  for (std::size_t i = 1; i < eigenvalues.size(); ++i) {
    expected.insert(eigenvalues[i][2] + " " + eigenvalues[i][3] + " " + eigenvalues[i][0]);
  }
  std::ifstream data(root / "from" / "study_alpha_root_locus.dat");
  std::string line;
  while (std::getline(data, line)) {
    if (!line.empty() && line[0] != '#') drawn.insert(line);
  }
  CHECK(expected.size() == 2 * 9);
  CHECK(drawn == expected);
  std::filesystem::remove_all(root);
}

TEST_CASE("report --from refuses what is not a finished sweep of an unchanged model", "[reports]") {
  const servokit::testing::TemporaryDirectory scratch_root(/*create=*/false);
  const std::filesystem::path root = scratch_root.path();
  std::filesystem::remove_all(root);
  std::filesystem::create_directories(root / "empty");
  const auto model = root / "car.yaml";
  std::filesystem::copy_file(ModelPath("mass_on_car.yaml"), model);
  REQUIRE(RunServokit({"sweep", model.string(), "--vary", "d=0.5:1:n=3", "--out",
                       (root / "sweep").string()})
              .status == 0);
  const auto refuse = [&root](const std::filesystem::path& sweep, const std::string& fragment) {
    const auto run =
        RunServokit({"report", "--from", sweep.string(), "--out", (root / "out").string()});
    INFO(run.err);
    CHECK(run.status == 2);
    CHECK(run.err.rfind("servokit: error: ", 0) == 0);
    CHECK(std::count(run.err.begin(), run.err.end(), '\n') == 1);
    CHECK(run.err.find(fragment) != std::string::npos);
    CHECK_FALSE(std::filesystem::exists(root / "out"));
  };
  refuse(root / "empty", "no sweep.json there");
  const std::string record = (root / "sweep" / "sweep.json").string();

  // Not completed.
  std::string json = ReadFile(record);
  const std::string done = "\"completed\": true";
  REQUIRE(json.find(done) != std::string::npos);
  std::ofstream(record) << std::string(json).replace(json.find(done), done.size(),
                                                     "\"completed\": false");
  refuse(root / "sweep", record + ": the sweep is not completed");
  std::ofstream(record) << json;

  // The model changed since the sweep, then missing.
  std::ofstream(model, std::ios::app) << "# edited\n";
  refuse(root / "sweep", record + ": its model " + model.string() + " has changed");
  std::filesystem::remove(model);
  refuse(root / "sweep", record + ": its model " + model.string() + " is missing");
  std::filesystem::remove_all(root);
}

}  // namespace
}  // namespace servokit
