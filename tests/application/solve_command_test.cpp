// `servokit solve` (docs/solve.md): the CSV columns and the JSON keys of the contract, the
// forward check, the refusal of unstable internal dynamics, and one clear error per bad input.
// The numbers themselves are tested against the paper in tests/solvers/inverse_model_test.cpp;
// here the case-4 force is checked once more against Eq. (47) through the files a user reads.
#include <unistd.h>

#include <catch2/catch.hpp>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <sstream>

#include "tests/application/run_servokit.h"
#include "tests/test_paths.h"
#include "trajectories/trajectory.h"

namespace servokit {
namespace {

using testing::ModelPath;
using testing::RunServokit;
using testing::TestDataPath;

// Named by the process too, so that two runs of the suite at once never share a file.
std::filesystem::path TemporaryFile(const std::string& name) {
  return std::filesystem::temp_directory_path() /
         ("servokit_solve_test_" + std::to_string(::getpid()) + "_" + name);
}

std::vector<std::vector<std::string>> ReadCsv(const std::filesystem::path& path) {
  std::ifstream file(path);
  std::vector<std::vector<std::string>> rows;
  for (std::string line; std::getline(file, line);) {
    std::vector<std::string> cells;
    std::stringstream stream(line);
    for (std::string cell; std::getline(stream, cell, ',');) cells.push_back(cell);
    rows.push_back(cells);
  }
  return rows;
}

const std::vector<std::string> kCase4 = {"solve",        ModelPath("mass_on_car.yaml"),
                                         "--set",        "alpha=0",
                                         "--set",        "d=0",
                                         "--trajectory", "rest-to-rest",
                                         "--y0",         "0.5",
                                         "--yf",         "2.5",
                                         "--t0",         "0",
                                         "--tf",         "6",
                                         "--t-end",      "10"};

std::vector<std::string> With(std::vector<std::string> arguments,
                              const std::vector<std::string>& more) {
  arguments.insert(arguments.end(), more.begin(), more.end());
  return arguments;
}

TEST_CASE("solve writes the CSV columns and JSON keys of docs/solve.md", "[reports]") {
  const auto csv = TemporaryFile("case4.csv");
  const auto run = RunServokit(With(kCase4, {"--step", "0.01", "--verify", "--out", csv.string()}));
  INFO(run.err);
  REQUIRE(run.status == 0);
  const auto json = nlohmann::json::parse(run.out);
  for (const char* key :
       {"method", "classification", "steps", "max_servo_residual", "verification"}) {
    CHECK(json.contains(key));
  }
  CHECK(json["method"] == "algebraic");
  CHECK(json["classification"]["flat"] == true);
  CHECK(json["verification"]["max_tracking_error"].get<double>() < 1e-6);
  const auto rows = ReadCsv(csv);
  REQUIRE(rows.size() == 1002);  // header, t = 0, 0.01, ..., 10
  CHECK(rows[0] == std::vector<std::string>{"t", "x", "s", "x_dot", "s_dot", "F", "y1_d"});
  // Eq. (47) at t = 2 s (row 201): F = (m1 + m2) y'' + (m1 m2 / k) y''''.
  const RestToRestTrajectory trajectory(Eigen::VectorXd::Constant(1, 0.5),
                                        Eigen::VectorXd::Constant(1, 2.5), 0.0, 6.0);
  CHECK(std::stod(rows[201][0]) == Approx(2.0));
  CHECK(std::stod(rows[201][5]) ==
        Approx(3.0 * trajectory.Derivative(2.0, 2)(0) + 0.4 * trajectory.Derivative(2.0, 4)(0))
            .epsilon(1e-12));
  CHECK(std::stod(rows[201][6]) == Approx(trajectory.Derivative(2.0, 0)(0)).epsilon(1e-15));
  std::filesystem::remove(csv);
}

TEST_CASE("solve reads a trajectory file of waypoints", "[reports]") {
  const auto file = TemporaryFile("waypoints.yaml");
  std::ofstream(file) << "waypoints:\n  - {t: 0, y: [0.5]}\n  - {t: 6, y: [2.5]}\n";
  const auto csv = TemporaryFile("file.csv");
  const auto run =
      RunServokit({"solve", ModelPath("mass_on_car.yaml"), "--set", "d=0", "--trajectory",
                   file.string(), "--t-end", "8", "--out", csv.string()});
  INFO(run.err);
  REQUIRE(run.status == 0);
  const auto json = nlohmann::json::parse(run.out);
  CHECK(json["method"] == "normal-form");  // critical zero dynamics at 5 deg, d = 0
  CHECK(json["max_servo_residual"].get<double>() < 1e-12);
  std::filesystem::remove(file);
  std::filesystem::remove(csv);
}

TEST_CASE(
    "solve: unstable internal dynamics get stable inversion; forward methods refuse "
    "unless forced (exit 3)",
    "[reports]") {
  const auto csv = TemporaryFile("arm.csv");
  const std::vector<std::string> arm = {"solve",        ModelPath("rotational_arm.yaml"),
                                        "--set",        "s=0.9",
                                        "--trajectory", "rest-to-rest",
                                        "--y0",         "0",
                                        "--yf",         "0.1",
                                        "--t0",         "1",
                                        "--tf",         "3",
                                        "--t-end",      "3.5",
                                        "--out",        csv.string()};
  const auto automatic = RunServokit(arm);
  INFO(automatic.err);
  REQUIRE(automatic.status == 0);
  const auto inverted = nlohmann::json::parse(automatic.out);
  CHECK(inverted["method"] == "stable-inversion");
  // docs/solve.md "Stable inversion": it gives where the input departs from rest; it starts
  // early.
  CHECK(inverted["pre_actuation_start"].get<double>() < 1.0);
  CHECK(inverted["post_actuation_end"].get<double>() > 3.0);
  CHECK(inverted["boundary_value_residual"].get<double>() <= 1e-8);
  const auto rows = ReadCsv(csv);
  CHECK(std::stod(rows.at(1).at(0)) < 1.0);  // the CSV starts before the motion

  const auto refused = RunServokit(With(arm, {"--method", "normal-form"}));
  CHECK(refused.status == 3);
  CHECK_THAT(refused.err, Catch::StartsWith("servokit: error: the zero dynamics are unstable"));
  CHECK_THAT(refused.err, Catch::Contains("stable-inversion"));
  // Forced, the normal form runs forward; e^(16 t) growth makes it fail within half a second
  // of the motion (exit 3 with the time), which is why it was refused.
  const auto forced = RunServokit(With(arm, {"--method", "normal-form", "--force"}));
  const auto json = nlohmann::json::parse(forced.out);
  CHECK(json["method"] == "normal-form");
  CHECK(json["steps"].get<long>() > 0);
  std::filesystem::remove(csv);
}

TEST_CASE("solve: each bad argument gives one error line and exit 2", "[reports]") {
  const auto csv = TemporaryFile("bad.csv").string();
  struct Bad {
    std::vector<std::string> extra;
    const char* says;
  };
  for (const Bad& bad : {Bad{{"--method", "rk4", "--out", csv}, "--method rk4"},
                         Bad{{"--step", "-1", "--method", "euler", "--out", csv}, "step"},
                         Bad{{"--rtol", "2", "--out", csv}, "rtol"}}) {
    const auto run = RunServokit(With(kCase4, bad.extra));
    CHECK(run.status == 2);
    CHECK_THAT(run.err, Catch::StartsWith("servokit: error:") && Catch::Contains(bad.says));
    CHECK(std::count(run.err.begin(), run.err.end(), '\n') == 1);
  }
  const auto missing = RunServokit({"solve", ModelPath("mass_on_car.yaml"), "--trajectory",
                                    "rest-to-rest", "--t-end", "1", "--out", csv});
  CHECK(missing.status == 2);
  CHECK_THAT(missing.err, Catch::Contains("--y0, --yf, --t0 and --tf"));
  // A folder that cannot be made: a file (the model) stands where it would go.
  const std::string under_a_file = ModelPath("mass_on_car.yaml") + "/x.csv";
  const auto no_directory = RunServokit(With(kCase4, {"--out", under_a_file}));
  CHECK(no_directory.status == 2);
  CHECK_THAT(no_directory.err, Catch::Contains("--out " + under_a_file +
                                               ": cannot make the "
                                               "directory"));
  const auto no_file = RunServokit({"solve", ModelPath("mass_on_car.yaml"), "--trajectory",
                                    "nowhere.yaml", "--t-end", "1", "--out", csv});
  CHECK(no_file.status == 2);
  CHECK_THAT(no_file.err, Catch::Contains("nowhere.yaml"));
}

TEST_CASE("solve with a method that does not fit the class says which does (exit 3)", "[reports]") {
  const auto csv = TemporaryFile("bdf.csv").string();
  const auto run = RunServokit(With(kCase4, {"--method", "bdf", "--out", csv}));
  CHECK(run.status == 3);
  CHECK_THAT(run.err, Catch::Contains("use algebraic or normal-form"));
}

TEST_CASE(
    "solve --sample-time writes the controller's grid; --verify that fails is exit 4 and "
    "never 'converged'",
    "[reports]") {
  const auto csv = TemporaryFile("cart.csv");
  const std::vector<std::string> cart = {"solve",         testing::TestDataPath("cart_pole.yaml"),
                                         "--trajectory",  "rest-to-rest",
                                         "--y0",          "0",
                                         "--yf",          "1",
                                         "--t0",          "0",
                                         "--tf",          "2",
                                         "--t-end",       "5",
                                         "--sample-time", "0.002",
                                         "--verify",      "--out",
                                         csv.string()};
  const auto good = RunServokit(With(cart, {"--t-start", "-3"}));
  INFO(good.err);
  REQUIRE(good.status == 0);
  const auto json = nlohmann::json::parse(good.out);
  CHECK(json["status"] == "converged");
  CHECK(json["sample_time"].get<double>() == 0.002);
  CHECK(json["verification"]["passed"] == true);
  CHECK(json["verification"]["segments"].get<int>() > 1);  // the inverted pendulum
  const auto rows = ReadCsv(csv);
  REQUIRE(rows.size() == 1 + 4001);  // header, -3, -2.998, ..., 5
  CHECK(rows[1][0] == "-3");
  CHECK(rows[2][0] == "-2.998");
  CHECK(rows.back()[0] == "5");
  // The pre-actuation cut to 0.3 s: the cart cannot follow from rest.
  const auto cut = RunServokit(With(cart, {"--pre-actuation", "0.3", "--t-start", "-0.3"}));
  INFO(cut.err);
  CHECK(cut.status == 4);
  const auto failed = nlohmann::json::parse(cut.out);
  CHECK(failed["status"] == "verification-failed");
  CHECK(failed["verification"]["passed"] == false);
  CHECK(failed["verification"]["solution_starts_at_rest"] == false);
  CHECK_THAT(cut.err, Catch::Contains("servokit: warning: the solution does not start at rest"));
  CHECK_THAT(cut.err, Catch::EndsWith("\n") &&
                          Catch::Contains("servokit: error: the verification failed: "));
  std::filesystem::remove(csv);
}

// Mixed realizations through the dynamic extension (issue: the crane's 1 m in 3 s "stops" with
// Radau): the algebraic inverse, checked by the forward simulation of --verify, which must
// track y_d to 1e-8 (the bound is 100 x (1e-10 max|y_d| + 1e-12) with the forward solve's
// tolerance 1000 x tighter).
TEST_CASE("solve: the gantry crane and a PVTOL invert exactly through the dynamic extension",
          "[reports]") {
  const auto csv = TemporaryFile("mixed.csv");
  const std::vector<std::pair<std::string, std::string>> cases = {
      {ModelPath("gantry_crane.yaml"), "2"}, {TestDataPath("pvtol.yaml"), "0"}};
  for (const auto& [model, depth] : cases) {
    INFO(model);
    const auto run = RunServokit({"solve", model, "--trajectory", "rest-to-rest", "--y0",
                                  "0," + depth, "--yf", "1," + depth, "--t0", "0", "--tf", "3",
                                  "--t-end", "4", "--verify", "--out", csv.string()});
    REQUIRE(run.status == 0);
    const auto json = nlohmann::json::parse(run.out);
    CHECK(json["method"] == "algebraic");
    CHECK(json["verification"]["passed"] == true);
    CHECK(json["verification"]["max_tracking_error"].get<double>() <= 1e-8);
  }
  std::filesystem::remove(csv);
}

// The double-pendulum crane's P vanishes at rest only: no method inverts it exactly there and
// the refusal offers the method `linearized`; that runs, warns, and --verify measures it honestly
// (the linearization's inverse is not exact: exit 4 at the exact inverse's bound).
TEST_CASE("solve --method linearized where the relative degree is undefined at rest", "[reports]") {
  const auto csv = TemporaryFile("linearized.csv");
  const std::vector<std::string> crane = {
      "solve",        TestDataPath("double_pendulum_crane.yaml"),
      "--trajectory", "rest-to-rest",
      "--y0",         "0",
      "--yf",         "0.2",
      "--t0",         "0",
      "--tf",         "3",
      "--t-end",      "4",
      "--out",        csv.string()};
  const auto refused = RunServokit(crane);
  CHECK(refused.status == 3);
  CHECK_THAT(refused.err, Catch::Contains("no exact inverse passes through it") &&
                              Catch::Contains("the method `linearized`"));
  const auto run = RunServokit(With(crane, {"--method", "linearized", "--verify"}));
  CHECK(run.status == 4);
  const auto json = nlohmann::json::parse(run.out);
  CHECK(json["method"] == "linearized");
  CHECK_THAT(json["method_reason"].get<std::string>(), Catch::Contains("(algebraic)"));
  CHECK_THAT(run.err, Catch::Contains("linearized: u_d inverts the linearization"));
  const double error = json["verification"]["max_tracking_error"].get<double>();
  // A 0.2 m move in 3 s swings the ropes by a few degrees: the nonlinear terms leave an error
  // far above the exact inverse's bound, yet small against the move.
  CHECK(error > json["verification"]["bound"].get<double>());
  CHECK(error < 1e-2 * 0.2);
  std::filesystem::remove(csv);
}

}  // namespace
}  // namespace servokit
