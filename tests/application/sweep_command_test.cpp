// `servokit sweep`: the files of docs/sweep.md (points.csv, eigenvalues.csv, sweep.json), the usage
// errors, bytes independent of the number of threads, and interruption: the real binary
// (SERVOKIT_BINARY) killed with SIGKILL at random moments, or stopped with SIGINT, then run again
// to completion, must leave the same bytes as an uninterrupted run.
#include <fcntl.h>
#include <signal.h>
#include <spawn.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <catch2/catch.hpp>
#include <charconv>
#include <chrono>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <numbers>
#include <optional>
#include <random>
#include <sstream>
#include <string>
#include <thread>
#include <vector>

#include "application/command_line.h"
#include "application/progress.h"
#include "studies/sweep_store.h"
#include "tests/application/run_servokit.h"
#include "tests/test_files.h"
#include "tests/test_paths.h"
#include "tests/test_process.h"

extern char** environ;

namespace servokit {
namespace {

using testing::Lines;
using testing::ReadFile;
using testing::TemporaryDirectory;

namespace fs = std::filesystem;
using testing::ModelPath;
using testing::TestDataPath;

using testing::Run;
using testing::RunServokit;

std::vector<std::string> Sweep(const std::string& model,
                               const std::vector<std::string>& vary,
                               const fs::path& out,
                               const std::vector<std::string>& more = {}) {
  std::vector<std::string> arguments = {"sweep", model};
  for (const std::string& text : vary) arguments.insert(arguments.end(), {"--vary", text});
  arguments.insert(arguments.end(), {"--out", out.string()});
  arguments.insert(arguments.end(), more.begin(), more.end());
  return arguments;
}

void CheckSameTables(const fs::path& a, const fs::path& b) {
  for (const char* table : {"points.csv", "eigenvalues.csv"}) {
    INFO(table);
    const std::string first = ReadFile(a / table);
    CHECK_FALSE(first.empty());
    CHECK((first == ReadFile(b / table)));  // not CHECK(a == b): Catch would print 100 MB
  }
}

void CheckOnlyFinalFiles(const fs::path& directory) {
  std::vector<std::string> names;
  for (const auto& entry : fs::directory_iterator(directory)) {
    names.push_back(entry.path().filename().string());
  }
  std::sort(names.begin(), names.end());
  CHECK(names == std::vector<std::string>{"eigenvalues.csv", "points.csv", "sweep.json"});
}

// ---- the real binary -------------------------------------------------------------------------

// The kill tests' sweep: 60 000 points of the six-mass chain observed at its third mass (six
// zero-dynamics eigenvalues a point), over a second on two cores, with a checkpoint every 0.1 s,
// so that a run can be stopped before, between and after its checkpoints.
std::vector<std::string> LongSweep(const fs::path& out) {
  return Sweep(TestDataPath("chain_output_x3.yaml"), {"m=0.5:2:200", "k=50:150:300"}, out,
               {"--threads", "2", "--checkpoint-interval", "0.1"});
}
constexpr std::size_t kLongSweepPoints = 60000;

/// The uninterrupted run the kill tests compare with, computed once per test process.
fs::path ReferenceSweep() {
  static TemporaryDirectory directory;
  static const bool done = [] {
    const Run run = RunServokit(LongSweep(directory / "reference"));
    REQUIRE(run.status == 0);
    return true;
  }();
  REQUIRE(done);
  return directory / "reference";
}

/// Starts SERVOKIT_BINARY with `arguments`; stdout is discarded, stderr goes to `stderr_path`.
pid_t Spawn(const std::vector<std::string>& arguments, const fs::path& stderr_path) {
  std::vector<std::string> all = {SERVOKIT_BINARY};
  all.insert(all.end(), arguments.begin(), arguments.end());
  std::vector<char*> argv;
  for (std::string& argument : all) argv.push_back(argument.data());
  argv.push_back(nullptr);
  posix_spawn_file_actions_t actions;
  REQUIRE(posix_spawn_file_actions_init(&actions) == 0);
  REQUIRE(posix_spawn_file_actions_addopen(&actions, STDOUT_FILENO, "/dev/null", O_WRONLY, 0) == 0);
  REQUIRE(posix_spawn_file_actions_addopen(&actions, STDERR_FILENO, stderr_path.c_str(),
                                           O_WRONLY | O_CREAT | O_TRUNC, 0644) == 0);
  pid_t child = 0;
  const int error = posix_spawn(&child, argv[0], &actions, nullptr, argv.data(), environ);
  posix_spawn_file_actions_destroy(&actions);
  REQUIRE(error == 0);
  return child;
}

int WaitFor(pid_t child) {
  int status = 0;
  REQUIRE(::waitpid(child, &status, 0) == child);
  return status;
}

std::optional<std::size_t> CheckpointPointsDone(const fs::path& directory) {
  const std::string text = ReadFile(directory / ".sweep-checkpoint");
  const std::size_t key = text.find("\npoints_done=");
  if (key == std::string::npos) return std::nullopt;
  return std::stoull(text.substr(key + std::string("\npoints_done=").size()));
}

/// Waits until the checkpoint in `directory` records more than `points_done` points, or the
/// child exits (then returns its wait status).
std::optional<int> WaitForProgress(pid_t child,
                                   const fs::path& directory,
                                   std::size_t points_done) {
  // A generous bound: a checkpoint is due every 0.1 s, even on a loaded machine.
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(60);
  while (std::chrono::steady_clock::now() < deadline) {
    int status = 0;
    if (::waitpid(child, &status, WNOHANG) == child) return status;
    if (CheckpointPointsDone(directory).value_or(0) > points_done) return std::nullopt;
    std::this_thread::sleep_for(std::chrono::milliseconds(5));
  }
  ::kill(child, SIGKILL);
  WaitFor(child);
  FAIL("the sweep made no progress for 60 s");
  return std::nullopt;
}

// ---- files -----------------------------------------------------------------------------------

TEST_CASE("sweep writes points.csv and eigenvalues.csv with the columns of docs/sweep.md",
          "[reports]") {
  const TemporaryDirectory work;
  const Run run = RunServokit(
      Sweep(ModelPath("mass_on_car.yaml"), {"alpha=0deg,90deg", "d=0:1:n=2"}, work / "out"));
  REQUIRE(run.status == 0);
  CHECK(run.out == "swept 4 points of mass_on_car into " + (work / "out").string() +
                       " (points.csv, eigenvalues.csv, sweep.json); 0 without a solution\n");
  CHECK(run.err.empty());
  const std::vector<std::string> points = Lines(ReadFile(work / "out" / "points.csv"));
  REQUIRE(points.size() == 5);
  CHECK(points[0] ==
        "alpha_deg,d,realization,P_rank,relative_degree,differentiation_index,"
        "internal_dynamics_order,stability,max_real_part,error");
  // The classes of the paper's mass-on-car cases (Sect. 3; index 3, 3, 4, 5 for cases 1-4:
  // docs/analyze.md "How it is computed"), P = sin^2(alpha) / (m1 + m2 sin^2(alpha)):
  //  - alpha = 0, d = 0 (case 4): P = 0, tangential; F first appears in the fourth derivative
  //    of y (relative degree 4, index 5), no internal dynamics (flat), so no eigenvalues:
  //    stability "none", max_real_part empty;
  //  - alpha = 0, d = 1 (case 3): tangential, relative degree 3 (index 4), one internal state
  //    with the eigenvalue -k/d < 0 (asymptotically stable, a negative max_real_part);
  //  - alpha = 90 deg, d = 0 (case 1): H = [1, 0], ker H = [0, 1] and D^T B = 0: ideal
  //    orthogonal, rank 1, relative degree 2, index 3, internal order 2 n - 2 = 2; the undamped
  //    vibration +-i sqrt(k / m2) is critical.
  // alpha was given in degrees (by the model file and by --vary): its column is alpha_deg and
  // 90 deg reads 90, not pi/2 (docs/sweep.md "The files": Units of the parameter columns).
  const std::string right_angle = "90";
  CHECK(points[1] == "0,0,tangential,0,4,5,0,none,,");
  CHECK_THAT(points[2], Catch::StartsWith("0,1,tangential,0,3,4,1,asymptotically-stable,-"));
  CHECK_THAT(points[3], Catch::StartsWith(right_angle + ",0,ideal-orthogonal,1,2,3,2,critical,"));
  const std::vector<std::string> eigenvalues = Lines(ReadFile(work / "out" / "eigenvalues.csv"));
  REQUIRE(eigenvalues.size() == 6);  // one root at (0, 1), a pair at each alpha = 90 deg point
  CHECK(eigenvalues[0] == "alpha_deg,d,eigenvalue_index,re,im,frequency_hz,damping_ratio");
  // alpha = 0, d = 1: the root -k/d = -5 of d s + k, a real mode (frequency 5/2pi, damping 1).
  double alpha = 0, d = 0, re = 0, im = 0, frequency = 0, damping = 0;
  int k = -1;
  char comma = 0;
  std::istringstream row(eigenvalues[1]);
  row >> alpha >> comma >> d >> comma >> k >> comma >> re >> comma >> im >> comma >> frequency >>
      comma >> damping;
  CHECK(alpha == 0.0);
  CHECK(d == 1.0);
  CHECK(k == 0);
  CHECK(re == Approx(-5.0).epsilon(1e-12));
  CHECK(im == 0.0);
  CHECK(frequency == Approx(5.0 / (2 * std::numbers::pi)).epsilon(1e-12));
  CHECK(damping == 1.0);
  // alpha = 90 deg, d = 0: the pair +-i sqrt(k / m2), real part 0, positive imaginary part first.
  CHECK_THAT(eigenvalues[2], Catch::StartsWith(right_angle + ",0,0,0,"));
  CHECK_THAT(eigenvalues[3], Catch::StartsWith(right_angle + ",0,1,0,-"));
  CheckOnlyFinalFiles(work / "out");
}

// A closed chain sweeps as the same mechanism in minimal coordinates (docs/model-files.md,
// "Closed kinematic chains"): the paper's arm cut at its joint against models/rotational_arm.yaml
// over s, across the threshold s/l = 2/3; every class column equal, the zeros' largest real part
// to 1e-9 relative (the two linearizations round differently).
TEST_CASE("a closed chain sweeps as the same mechanism in minimal coordinates", "[reports]") {
  const TemporaryDirectory work;
  const std::vector<std::string> grid = {"s=0.1:2:n=20"};
  REQUIRE(RunServokit(Sweep(ModelPath("rotational_arm.yaml"), grid, work / "minimal")).status == 0);
  REQUIRE(
      RunServokit(Sweep(TestDataPath("loops/rotational_arm_redundant.yaml"), grid, work / "loop"))
          .status == 0);
  const std::vector<std::string> minimal = Lines(ReadFile(work / "minimal" / "points.csv"));
  const std::vector<std::string> loop = Lines(ReadFile(work / "loop" / "points.csv"));
  REQUIRE(minimal.size() == 21);
  REQUIRE(loop.size() == minimal.size());
  const std::vector<std::string> header = testing::CsvFields(minimal[0]);
  const auto column_of = [&header](const std::string& name) {
    return std::size_t(std::find(header.begin(), header.end(), name) - header.begin());
  };
  const std::size_t real_part = column_of("max_real_part"), stability = column_of("stability");
  REQUIRE(real_part < header.size());
  REQUIRE(stability < header.size());
  int stable = 0;
  for (std::size_t row = 1; row < minimal.size(); ++row) {
    const std::vector<std::string> a = testing::CsvFields(minimal[row]);
    const std::vector<std::string> b = testing::CsvFields(loop[row]);
    REQUIRE(a.size() == header.size());
    REQUIRE(b.size() == header.size());
    for (std::size_t column = 0; column < a.size(); ++column) {
      if (column == real_part) continue;
      INFO("row " << row << ", " << header[column]);
      CHECK(a[column] == b[column]);  // s, realization, rank, relative degree, ..., error
    }
    const double expected = std::stod(a[real_part]), got = std::stod(b[real_part]);
    CHECK(got == Approx(expected).epsilon(1e-9).margin(1e-12));
    stable += a[stability] == "asymptotically-stable";
  }
  CHECK(stable > 0);
  CHECK(stable < 20);  // the grid crosses s/l = 2/3
}

TEST_CASE("a parameter given in degrees gets a _deg column holding the degrees given, exactly",
          "[reports]") {
  const TemporaryDirectory work;
  const Run run =
      RunServokit(Sweep(ModelPath("mass_on_car.yaml"), {"alpha=5deg,30deg", "d=1"}, work / "out"));
  REQUIRE(run.status == 0);
  CHECK(run.err.empty());
  const std::vector<std::string> points = Lines(ReadFile(work / "out" / "points.csv"));
  REQUIRE(points.size() == 3);
  CHECK_THAT(points[0], Catch::StartsWith("alpha_deg,d,realization,"));
  // The given degrees, not 5 pi/180 * 180/pi (which the search in DisplayDegrees undoes).
  CHECK_THAT(points[1], Catch::StartsWith("5,1,"));
  CHECK_THAT(points[2], Catch::StartsWith("30,1,"));
  for (const std::string& row : Lines(ReadFile(work / "out" / "eigenvalues.csv"))) {
    CHECK((row.starts_with("alpha_deg,d,eigenvalue_index,re,im,") || row.starts_with("5,1,") ||
           row.starts_with("30,1,")));
  }
  // A --set in degrees marks its parameter too, and the unit is part of the sweep: the same
  // grid in SI is another sweep for --out.
  const Run set = RunServokit(
      Sweep(ModelPath("mass_on_car.yaml"), {"d=1,2"}, work / "set", {"--set", "alpha=30deg"}));
  REQUIRE(set.status == 0);
  CHECK_THAT(Lines(ReadFile(work / "set" / "points.csv"))[0], Catch::StartsWith("d,"));
  const Run degrees =
      RunServokit(Sweep(ModelPath("mass_on_car.yaml"), {"d=1deg,2deg"}, work / "degrees"));
  REQUIRE(degrees.status == 0);
  const std::vector<std::string> degree_points = Lines(ReadFile(work / "degrees" / "points.csv"));
  CHECK_THAT(degree_points[0], Catch::StartsWith("d_deg,"));
  CHECK_THAT(degree_points[1], Catch::StartsWith("1,"));
  const auto record = nlohmann::json::parse(ReadFile(work / "degrees" / "sweep.json"));
  CHECK(record["grid"][0]["values"][0].get<double>() == std::numbers::pi / 180);  // SI
  CHECK(record["grid"][0]["display_unit"] == "deg");
  const SweepModelInfo info{"m", "m.yaml", "0", {}, {}, std::nullopt};
  GridAxis axis{"d", 0, std::vector<double>{1.0}};
  const std::string si = SweepFingerprint(info, ParameterGrid({axis}), {});
  axis.display_unit = DisplayUnit::kDegree;
  CHECK(SweepFingerprint(info, ParameterGrid({axis}), {}) != si);
}

TEST_CASE("grid warnings go to stderr on one line each, never to stdout", "[reports]") {
  const TemporaryDirectory work;
  const Run matlab =
      RunServokit(Sweep(ModelPath("mass_on_car.yaml"), {"d=0:1:2"}, work / "matlab"));
  REQUIRE(matlab.status == 0);
  CHECK(matlab.err ==
        "servokit: warning: --vary d=0:1:2 is read as 2 values from 0 to 1 (servokit's a:b:n), "
        "not as MATLAB's start:step:end (0, 1, ..., 2); write d=0:1:n=2 for the first, "
        "d=0:2:step=1 for the second\n");
  CHECK_THAT(matlab.out, !Catch::Contains("warning"));
  REQUIRE(Lines(ReadFile(work / "matlab" / "points.csv")).size() == 3);  // two values
  // The model declares alpha in degrees: bare values are degrees (issue #34), nothing to warn.
  const Run angle =
      RunServokit(Sweep(ModelPath("mass_on_car.yaml"), {"alpha=0:90:n=3"}, work / "angle"));
  REQUIRE(angle.status == 0);
  CHECK(angle.err.empty());
  const std::vector<std::string> angle_rows = Lines(ReadFile(work / "angle" / "points.csv"));
  REQUIRE(angle_rows.size() == 4);
  CHECK_THAT(angle_rows[0], Catch::StartsWith("alpha_deg,"));
  CHECK_THAT(angle_rows[2], Catch::StartsWith("45,"));
  for (const std::vector<std::string>& vary : {std::vector<std::string>{"d=0:1:n=2"},
                                               {"d=0:2:step=1"},
                                               {"alpha=0deg:90deg:step=45deg"},
                                               {"alpha=0:1.5:n=3"}}) {
    INFO(vary[0]);
    const Run quiet = RunServokit(Sweep(ModelPath("mass_on_car.yaml"), vary, work / vary[0]));
    REQUIRE(quiet.status == 0);
    CHECK(quiet.err.empty());
  }
  // The step form counts: 0, 45, 90.
  CHECK(Lines(ReadFile(work / "alpha=0deg:90deg:step=45deg" / "points.csv")).size() == 4);
}

TEST_CASE("a varied parameter named like a column is refused, naming it", "[reports]") {
  const TemporaryDirectory work;
  const fs::path model = work / "clash.yaml";
  std::ofstream(model) << "name: clash\nparameters: {re: 1.0, k: 2.0}\ncoordinates: [x]\n"
                          "inputs: [F]\nmass_matrix: [[1]]\nforces: [re*k*x]\n"
                          "input_matrix: [[1]]\noutputs: [x]\n";
  const Run run = RunServokit(Sweep(model.string(), {"re=1,2"}, work / "out"));
  CHECK(run.status == 2);
  CHECK(run.err ==
        "servokit: error: --vary: parameter 're': its column 're' would also be a fixed column of "
        "eigenvalues.csv (a table cannot have two columns of one name); rename the parameter in "
        "the model file to vary it\n");
  CHECK_FALSE(fs::exists(work / "out"));
  // k, a stiffness, no longer clashes with the eigenvalue index column.
  REQUIRE(RunServokit(Sweep(model.string(), {"k=1,2"}, work / "k")).status == 0);
  CHECK(Lines(ReadFile(work / "k" / "eigenvalues.csv"))[0] ==
        "k,eigenvalue_index,re,im,frequency_hz,damping_ratio");
}

TEST_CASE("several outputs' relative degrees are joined with ';'", "[reports]") {
  const TemporaryDirectory work;
  REQUIRE(RunServokit(Sweep(ModelPath("gantry_crane.yaml"), {"m=5"}, work / "out")).status == 0);
  // At rest (theta = 0, L = L0): H = [[1, 0, L0], [0, 1, 0]] and H M^-1 B = [[0, 0], [0,
  // 1 / (mw + m)]] (the first row of H is M's third column over m L0, so H_1 M^-1 = [0, 0, 1 /
  // (m L0)], and B's third row is 0): rank 1 of 2, mixed. The rail position of the load feels F
  // through the swing (relative degree 4), the depth feels W directly (2); 4 + 2 = 2 n = 6
  // leaves no internal dynamics (flat: no eigenvalues, stability none); index 4 + 1 = 5.
  CHECK(Lines(ReadFile(work / "out" / "points.csv"))[1] ==
        "5,mixed-orthogonal-tangential,1,4;2,5,0,none,,");
}

TEST_CASE("a point without a solution gets its message in quotes and the sweep goes on",
          "[reports]") {
  const TemporaryDirectory work;
  const Run run = RunServokit(
      Sweep(TestDataPath("no_equilibrium.yaml"), {"a=-1,1"}, work / "out", {"--q0", "0,0.5"}));
  REQUIRE(run.status == 0);
  CHECK_THAT(run.out, Catch::EndsWith("; 1 without a solution\n"));
  const std::vector<std::string> points = Lines(ReadFile(work / "out" / "points.csv"));
  REQUIRE(points.size() == 3);
  CHECK_THAT(points[1], Catch::StartsWith("-1,non-ideal-orthogonal,1,2,3,2,critical,"));
  CHECK_THAT(points[1], Catch::EndsWith(","));
  CHECK_THAT(points[2], Catch::StartsWith("1,,,,,,,,\"no equilibrium found for y0 = [0]"));
  CHECK_THAT(points[2], Catch::EndsWith("\""));
  for (const std::string& row : Lines(ReadFile(work / "out" / "eigenvalues.csv"))) {
    CHECK_THAT(row, !Catch::StartsWith("1,"));
  }
  const auto record = nlohmann::json::parse(ReadFile(work / "out" / "sweep.json"));
  CHECK(record["points_without_solution"] == 1);
}

TEST_CASE("sweep.json names the route that classifies the points", "[reports]") {
  const TemporaryDirectory work;
  const auto route_of = [&](const std::string& model, const std::string& axis,
                            const std::string& out, std::vector<std::string> extra) {
    const Run run = RunServokit(Sweep(model, {axis}, work / out, std::move(extra)));
    INFO(model << ": " << run.err);
    REQUIRE(run.status == 0);
    return nlohmann::json::parse(ReadFile(work / out / "sweep.json"))["zero_dynamics_route"];
  };
  // The mass on a car has its closed-form polynomial; with a starting point for Newton the
  // polynomial (of the equilibrium at q = 0) does not apply; the chain of six masses has none.
  CHECK(route_of(ModelPath("mass_on_car.yaml"), "d=1,2", "car", {}) == "polynomial");
  CHECK(route_of(ModelPath("mass_on_car.yaml"), "d=1,2", "car_q0", {"--q0", "0,0"}) ==
        "eigenvalues");
  CHECK(route_of(ModelPath("mass_spring_chain.yaml"), "k=100,200", "chain", {}) == "eigenvalues");
}

TEST_CASE("sweep.json records the model, command line, grid, points, version and completion",
          "[reports]") {
  const TemporaryDirectory work;
  const std::vector<std::string> arguments =
      Sweep(ModelPath("mass_on_car.yaml"), {"alpha=0deg:90deg:3", "d=0,2"}, work / "out",
            {"--set", "k=6"});
  REQUIRE(RunServokit(arguments).status == 0);
  const auto record = nlohmann::json::parse(ReadFile(work / "out" / "sweep.json"));
  CHECK(record["model"] == "mass_on_car");
  CHECK(record["model_path"] == ModelPath("mass_on_car.yaml"));
  CHECK(record["content_hash"].get<std::string>().size() == 16);
  std::vector<std::string> command_line = {"servokit"};
  command_line.insert(command_line.end(), arguments.begin(), arguments.end());
  CHECK(record["command_line"] == command_line);
  CHECK(record["fixed_parameters"] == nlohmann::json({{"m1", 1.0}, {"m2", 2.0}, {"k", 6.0}}));
  // --vary alpha=0deg:90deg:3 (in SI: 0 to pi/2) and d=0,2.
  CHECK(record["grid"] ==
        nlohmann::json::array(
            {nlohmann::json{{"name", "alpha"},
                            {"a", 0},
                            {"b", std::numbers::pi / 2},
                            {"n", 3},
                            {"display_unit", "deg"},
                            {"column", "alpha_deg"}},
             nlohmann::json{
                 {"name", "d"}, {"values", {0, 2}}, {"display_unit", "SI"}, {"column", "d"}}}));
  CHECK(record["grid"][0]["b"].get<double>() == std::numbers::pi / 2);  // reads back exactly
  CHECK(record["points"] == 6);
  CHECK(record["servokit_version"].is_string());
  CHECK(record["completed"] == true);
}

TEST_CASE("--threads 1 and --threads 2 write the same bytes", "[reports]") {
  const TemporaryDirectory work;
  for (const char* threads : {"1", "2"}) {
    REQUIRE(
        RunServokit(Sweep(ModelPath("mass_on_car.yaml"), {"alpha=0deg:90deg:100", "d=0:2:n=200"},
                          work / threads, {"--threads", threads}))
            .status == 0);
  }
  CheckSameTables(work / "1", work / "2");
}

// ---- usage -----------------------------------------------------------------------------------

TEST_CASE("sweep usage errors exit 2 with one line and create nothing", "[reports]") {
  const TemporaryDirectory work;
  const fs::path out = work / "out";
  const std::string model = ModelPath("mass_on_car.yaml");
  const std::vector<std::pair<std::vector<std::string>, std::string>> cases = {
      {Sweep(model, {"beta=0:1:3"}, out),
       "--vary beta=0:1:3: unknown parameter 'beta' (the model has m1, m2, k, d, alpha)"},
      {Sweep(model, {"alpha"}, out),
       "--vary alpha: expected name=a:b:n or name=v1,v2,... (e.g. --vary alpha=0deg:90deg:91)"},
      {Sweep(model, {"alpha=0:1:0"}, out),
       "--vary alpha=0:1:0: the number of values must be at least 1, got 0"},
      {Sweep(model, {"alpha=0:1:n=2", "alpha=3"}, out),
       "--vary alpha: the parameter is varied twice (give all its values in one --vary)"},
      {Sweep(model, {"alpha=0:1:n=2"}, out, {"--threads", "0"}),
       "--threads 0: must be at least 1 (default: all cores)"},
      // libgomp crashed on 100000 threads; 4e9 points per block took 7.8 GB for 3 points.
      {Sweep(model, {"alpha=0:1:n=2"}, out, {"--threads", "100000"}),
       "--threads 100000: must be at most 1024"},
      {Sweep(model, {"alpha=0:1:n=2"}, out, {"--block-size", "4000000000"}),
       "--block-size 4000000000: must be at most 65536"},
      {Sweep(model, {"alpha=0:1:n=2"}, ""), "--out \"\": must name a file or directory"},
      {Sweep(model, {"alpha=0:1:n=2"}, out, {"--checkpoint-interval", "0"}),
       "--checkpoint-interval 0: must be > 0 seconds"},
      {Sweep(model, {"alpha=0:1:n=2"}, out, {"--set", "alpha=1"}),
       "--vary alpha: the parameter is also given by --set; drop one of them"},
      {{"sweep", model, "--vary", "alpha=0:1:n=2"}, "--out is required"},
  };
  for (const auto& [arguments, message] : cases) {
    const Run run = RunServokit(arguments);
    INFO(run.err);
    CHECK(run.status == 2);
    CHECK(run.err == "servokit: error: " + message + "\n");
    CHECK_FALSE(fs::exists(out));
  }
}

TEST_CASE("OMP_NUM_THREADS above the limit is a usage error naming it, not a crash", "[reports]") {
  const TemporaryDirectory work;
  const testing::ProcessResult run =
      testing::RunProcess(work.path(),
                          {SERVOKIT_BINARY, "sweep", ModelPath("mass_on_car.yaml"), "--vary",
                           "d=0:1:n=3", "--out", "out"},
                          {{{"OMP_NUM_THREADS", "100000"}}});
  CHECK(run.status == 2);
  const std::string message = "OMP_NUM_THREADS=100000: 100000 threads: must be at most 1024";
  CHECK(run.err == "servokit: error: " + message + "\n");
  CHECK_FALSE(fs::exists(work / "out"));
}

TEST_CASE("the most threads on a grid of fewer points run one thread per point, same bytes",
          "[reports]") {
  const TemporaryDirectory work;
  for (const char* threads : {"1", "1024"}) {
    const Run run = RunServokit(Sweep(ModelPath("mass_on_car.yaml"), {"d=0:1:n=3"}, work / threads,
                                      {"--threads", threads, "--block-size", "65536"}));
    INFO(run.err);
    REQUIRE(run.status == 0);
  }
  CheckSameTables(work / "1", work / "1024");
}

TEST_CASE("a finished sweep run again is reported complete and not computed again", "[reports]") {
  const TemporaryDirectory work;
  const std::vector<std::string> arguments =
      Sweep(ModelPath("mass_on_car.yaml"), {"d=0:1:n=11"}, work / "out");
  REQUIRE(RunServokit(arguments).status == 0);
  const auto written = fs::last_write_time(work / "out" / "points.csv");
  const Run again = RunServokit(arguments);
  CHECK(again.status == 0);
  CHECK(again.err == "servokit: " + (work / "out").string() +
                         " already holds this sweep, complete (11 points); nothing to do\n");
  CHECK(fs::last_write_time(work / "out" / "points.csv") == written);
}

// The moment sweep_kill_test once hit by chance: the last block's checkpoint says every point is
// done, Finish() starts to write the same checkpoint again and is killed inside WriteDurably,
// before the renames. The run that resumes writes no checkpoint, so it must remove the
// temporary itself.
TEST_CASE("a sweep killed while writing its last checkpoint finishes with no temporary left",
          "[reports]") {
  const TemporaryDirectory work;
  const fs::path reference = work / "reference", out = work / "out";
  const std::string model = ModelPath("mass_on_car.yaml");
  REQUIRE(RunServokit(Sweep(model, {"d=0:1:n=11"}, reference)).status == 0);
  REQUIRE(RunServokit(Sweep(model, {"d=0:1:n=11"}, out)).status == 0);
  // Back to the moment of the kill: partial tables, an all-done checkpoint, a torn temporary.
  fs::rename(out / "points.csv", out / "points.csv.partial");
  fs::rename(out / "eigenvalues.csv", out / "eigenvalues.csv.partial");
  const nlohmann::json record = nlohmann::json::parse(ReadFile(out / "sweep.json"));
  const std::string checkpoint =
      "servokit-sweep-checkpoint 1\nfingerprint=" + record["fingerprint"].get<std::string>() +
      "\npoints_done=11\npoints_without_solution=0\npoints_bytes=" +
      std::to_string(fs::file_size(out / "points.csv.partial")) +
      "\neigenvalues_bytes=" + std::to_string(fs::file_size(out / "eigenvalues.csv.partial")) +
      "\n";
  std::ofstream(out / ".sweep-checkpoint") << checkpoint;
  std::ofstream(out / ".sweep-checkpoint.tmp") << checkpoint.substr(0, checkpoint.size() / 2);
  std::ofstream(out / "sweep.json.tmp") << "{\"model\": ";
  const Run resumed = RunServokit(Sweep(model, {"d=0:1:n=11"}, out));
  INFO("stderr: " << resumed.err);
  REQUIRE(resumed.status == 0);
  CheckSameTables(reference, out);
  CheckOnlyFinalFiles(out);
  CHECK(nlohmann::json::parse(ReadFile(out / "sweep.json"))["completed"] == true);
}

TEST_CASE("a stale temporary that cannot be removed stops the sweep with status 1", "[reports]") {
  const TemporaryDirectory work;
  // A directory with a file in it, where the checkpoint's temporary would be.
  fs::create_directories(work / "out" / ".sweep-checkpoint.tmp" / "inside");
  const Run run = RunServokit(Sweep(ModelPath("mass_on_car.yaml"), {"d=0:1:n=11"}, work / "out"));
  CHECK(run.status == 1);
  CHECK_THAT(run.err, Catch::StartsWith("servokit: error: "));
  CHECK_THAT(run.err, Catch::Contains(".sweep-checkpoint.tmp: cannot remove"));
  CHECK(std::count(run.err.begin(), run.err.end(), '\n') == 1);
  CHECK_FALSE(fs::exists(work / "out" / "points.csv.partial"));
}

TEST_CASE("a directory holding another sweep is refused, finished or not", "[reports]") {
  const TemporaryDirectory work;
  const std::string model = ModelPath("mass_on_car.yaml");
  const std::string refusal = "servokit: error: --out " + (work / "out").string() +
                              " holds another sweep (a different model, grid or options); use " +
                              "another --out or delete that directory\n";
  REQUIRE(RunServokit(Sweep(model, {"d=0:1:n=11"}, work / "out")).status == 0);
  for (const auto& other :
       {Sweep(model, {"d=0:1:n=12"}, work / "out"),
        Sweep(model, {"d=0:1:n=11"}, work / "out", {"--set", "k=4"}),
        Sweep(model, {"d=0:1:n=11"}, work / "out", {"--rank-tolerance", "1e-8"}),
        Sweep(TestDataPath("no_equilibrium.yaml"), {"a=1"}, work / "out")}) {
    const Run run = RunServokit(other);
    CHECK(run.status == 2);
    CHECK(run.err == refusal);
  }
  // An unfinished sweep: its checkpoint names what it computes.
  fs::create_directories(work / "unfinished");
  std::ofstream(work / "unfinished" / ".sweep-checkpoint")
      << "servokit-sweep-checkpoint 1\nfingerprint=another\npoints_done=0\n"
         "points_without_solution=0\npoints_bytes=0\neigenvalues_bytes=0\n";
  const Run run = RunServokit(Sweep(model, {"d=0:1:n=11"}, work / "unfinished"));
  CHECK(run.status == 2);
  CHECK_THAT(run.err, Catch::Contains("unfinished holds another sweep"));
}

// ---- interruption ----------------------------------------------------------------------------

TEST_CASE("a sweep killed with SIGKILL at random moments resumes to the same bytes",
          "[reports][slow]") {
  const fs::path reference = ReferenceSweep();
  const TemporaryDirectory work;
  const fs::path out = work / "out";
  std::mt19937 random(std::random_device{}());
  std::uniform_int_distribution<int> delay_ms(10, 200);
  int kills = 0, kills_after_progress = 0;
  bool finished = false;
  // Even rounds: a kill soon after start (before the first checkpoint, or while resuming).
  // Odd rounds: a kill once the checkpoint has recorded new points, a little later still.
  for (int round = 0; round < 4 && !finished; ++round) {
    const std::size_t done_before = fs::exists(out) ? CheckpointPointsDone(out).value_or(0) : 0;
    const pid_t child = Spawn(LongSweep(out), work / "stderr.txt");
    const bool after_progress = round % 2 == 1;
    std::optional<int> exited;
    if (after_progress) exited = WaitForProgress(child, out, done_before);
    if (!exited) {
      std::this_thread::sleep_for(std::chrono::milliseconds(delay_ms(random)));
      ::kill(child, SIGKILL);
      exited = WaitFor(child);
    }
    if (WIFEXITED(*exited)) {  // it finished before the kill
      CHECK(WEXITSTATUS(*exited) == 0);
      finished = true;
    } else {
      CHECK(WTERMSIG(*exited) == SIGKILL);
      ++kills;
      kills_after_progress += after_progress ? 1 : 0;
    }
  }
  CHECK(kills >= 2);
  CHECK(kills_after_progress >= 1);
  if (!finished) {
    const Run run = RunServokit(LongSweep(out));
    REQUIRE(run.status == 0);
  }
  CheckSameTables(reference, out);
  CheckOnlyFinalFiles(out);
  CHECK(nlohmann::json::parse(ReadFile(out / "sweep.json"))["completed"] == true);
}

TEST_CASE("SIGINT stops a sweep with status 130 at a checkpoint; the same command resumes it",
          "[reports][slow]") {
  const fs::path reference = ReferenceSweep();
  const TemporaryDirectory work;
  const fs::path out = work / "out";
  const pid_t child = Spawn(LongSweep(out), work / "stderr.txt");
  // Ctrl-C during the sweep, at a random moment after its first checkpoint: the handler is in
  // place by then. (Before, the process is still loading the model; under the sanitizers that
  // alone takes 0.3 to 0.6 s, longer than a fixed delay allowed for.)
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(120);
  while (!fs::exists(out / ".sweep-checkpoint") && std::chrono::steady_clock::now() < deadline) {
    std::this_thread::sleep_for(std::chrono::milliseconds(5));
  }
  std::mt19937 random(std::random_device{}());
  std::this_thread::sleep_for(
      std::chrono::milliseconds(std::uniform_int_distribution<int>(0, 300)(random)));
  ::kill(child, SIGINT);
  const int status = WaitFor(child);
  REQUIRE(WIFEXITED(status));
  REQUIRE(WEXITSTATUS(status) == 130);
  const std::size_t done = CheckpointPointsDone(out).value();
  CHECK(done < kLongSweepPoints);
  CHECK(ReadFile(work / "stderr.txt") ==
        "servokit: error: interrupted at point " + std::to_string(done) + " of " +
            std::to_string(kLongSweepPoints) + "; run the same command again to resume\n");
  CHECK(nlohmann::json::parse(ReadFile(out / "sweep.json"))["completed"] == false);
  // The interrupt checkpoints at once: nothing past the recorded sizes.
  const std::string checkpoint = ReadFile(out / ".sweep-checkpoint");
  CHECK_THAT(checkpoint,
             Catch::Contains("\npoints_bytes=" +
                             std::to_string(fs::file_size(out / "points.csv.partial")) + "\n"));
  const Run resumed = RunServokit(LongSweep(out));
  REQUIRE(resumed.status == 0);
  CHECK(resumed.err == "servokit: resuming at point " + std::to_string(done) + " of " +
                           std::to_string(kLongSweepPoints) + "\n");
  CheckSameTables(reference, out);
  CheckOnlyFinalFiles(out);
}

// ---- helpers of the output -------------------------------------------------------------------

TEST_CASE("CsvQuote wraps a field in quotes and doubles the quotes inside", "[reports]") {
  CHECK(CsvQuote("say \"hi\", twice") == "\"say \"\"hi\"\", twice\"");
  CHECK(CsvQuote("") == "\"\"");
}

TEST_CASE("the progress line shows the bar, points, rate and time left", "[reports]") {
  CHECK(FormatProgress(350000, 1000000, 150000.0) ==
        "[####........]  35.0%  350000/1000000  150000 points/s  0:00:05 left");
  CHECK(FormatProgress(0, 10, 0.0) == "[............]   0.0%  0/10  -- points/s");
  CHECK(FormatProgress(10, 10, 3.0) == "[############] 100.0%  10/10  3 points/s  0:00:00 left");
  // The longest line the bar is meant for fits 80 columns.
  CHECK(FormatProgress(1, 1000000000, 9999999.0).size() <= 80);
}

TEST_CASE("the progress bar draws only when enabled and erases itself", "[reports]") {
  std::ostringstream quiet;
  CHECK_FALSE(IsTerminalStderr(quiet));
  {
    ProgressBar bar(quiet, 10, 0, false);
    bar.Update(5);
  }
  CHECK(quiet.str().empty());
  std::ostringstream shown;
  {
    ProgressBar bar(shown, 10, 0, true);
    bar.Update(5);
    bar.Update(6);  // within kProgressRedrawInterval of the first: not drawn
  }
  CHECK_THAT(shown.str(), Catch::StartsWith("\r\033[K[######......]  50.0%  5/10  "));
  CHECK_THAT(shown.str(), !Catch::Contains("6/10"));
  CHECK_THAT(shown.str(), Catch::EndsWith("\r\033[K"));
}

}  // namespace
}  // namespace servokit
