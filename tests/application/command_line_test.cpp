// `servokit analyze` from the command line: the JSON contract of docs/analyze.md, the formats,
// and the documented exit statuses with their one-line messages.
#include "application/command_line.h"

#include <catch2/catch.hpp>
#include <filesystem>
#include <nlohmann/json.hpp>
#include <sstream>
#include <string>
#include <vector>

#include "tests/application/run_servokit.h"
#include "tests/test_files.h"
#include "tests/test_paths.h"

namespace servokit {
namespace {

using testing::ModelPath;
using testing::TestDataPath;

using testing::Run;
using testing::RunServokit;

TEST_CASE("analyze --format json prints one object with every key of docs/analyze.md",
          "[reports]") {
  const Run run = RunServokit({"analyze", ModelPath("mass_on_car.yaml"), "--format", "json"});
  REQUIRE(run.status == 0);
  const auto object = nlohmann::json::parse(run.out);
  for (const char* key :
       {"model", "parameters", "dof", "inputs", "outputs", "operating_point", "P",
        "P_singular_values", "P_rank", "P_rank_deficiency", "realization", "relative_degree",
        "differentiation_index", "projected_index", "internal_dynamics_order", "flat",
        "zero_dynamics", "recommended_solver"}) {
    INFO(key);
    CHECK(object.contains(key));
  }
  for (const char* key : {"eigenvalues", "stability", "minimum_phase", "modes"}) {
    INFO(key);
    CHECK(object["zero_dynamics"].contains(key));
  }
  for (const char* key : {"q", "u", "y"}) CHECK(object["operating_point"].contains(key));
  CHECK(object["realization"] == "non-ideal-orthogonal");
  CHECK(object["parameters"]["alpha"].get<double>() == Approx(5 * 3.14159265358979 / 180));
  CHECK(run.err.empty());
}

// The routes a model's size allowed (docs/analyze.md): the mass on a car has symbolic Jacobians
// and its polynomial (two coordinates, one input); a chain of six masses has seven rows in
// its Rosenbrock matrix, over the polynomial's four; a force of 1200 monomials in q and q'
// is past the Jacobians' budget of 10^4 nodes.
TEST_CASE("analyze --format json says how the model's derivatives are taken", "[reports]") {
  const auto derivatives_of = [](const std::string& model) {
    const Run run = RunServokit({"analyze", model, "--format", "json"});
    INFO(model << ": " << run.err);
    REQUIRE(run.status == 0);
    return nlohmann::json::parse(run.out)["derivatives"];
  };
  const nlohmann::json car = derivatives_of(ModelPath("mass_on_car.yaml"));
  CHECK(car["jacobians"] == "symbolic");
  CHECK(car["zero_dynamics_polynomial"] == true);
  const nlohmann::json chain = derivatives_of(ModelPath("mass_spring_chain.yaml"));
  CHECK(chain["jacobians"] == "symbolic");
  CHECK(chain["zero_dynamics_polynomial"] == false);
  const nlohmann::json large = derivatives_of(TestDataPath("sizes/large_force.yaml"));
  CHECK(large["jacobians"] == "forward-mode");
  CHECK(large["zero_dynamics_polynomial"] == false);
}

// A closed chain (docs/model-files.md, "Closed kinematic chains"): the gantry crane in absolute
// coordinates holds its load on the rope, lambda = -m g / (2 zL) by the load's statics (m = 5,
// g = 9.81, zL = 1.5); the JSON says how many constraints and the multipliers, the text prints
// them, and an open chain's JSON has neither.
TEST_CASE("analyze prints a closed chain's constraints and multipliers", "[reports]") {
  const std::string crane = ModelPath("gantry_crane_absolute.yaml");
  const std::vector<std::string> point = {"--y0", "0.3,1.5", "--q0", "0,0,0,2"};
  std::vector<std::string> json_args = {"analyze", crane, "--format", "json"};
  json_args.insert(json_args.end(), point.begin(), point.end());
  const Run run = RunServokit(json_args);
  INFO(run.err);
  REQUIRE(run.status == 0);
  const nlohmann::json json = nlohmann::json::parse(run.out);
  CHECK(json["constraints"] == 1);
  REQUIRE(json["operating_point"]["multipliers"].size() == 1);
  CHECK(json["operating_point"]["multipliers"][0].get<double>() ==
        Approx(-5.0 * 9.81 / 3.0).epsilon(1e-12));
  std::vector<std::string> text_args = {"analyze", crane};
  text_args.insert(text_args.end(), point.begin(), point.end());
  const Run text = RunServokit(text_args);
  CHECK_THAT(text.out, Catch::Contains("lambda = [-16.35]") &&
                           Catch::Contains("constraints             1 (3 degrees of freedom"));
  const Run open = RunServokit({"analyze", ModelPath("gantry_crane.yaml"), "--format", "json"});
  const nlohmann::json open_json = nlohmann::json::parse(open.out);
  CHECK_FALSE(open_json.contains("constraints"));
  CHECK_FALSE(open_json["operating_point"].contains("multipliers"));
}

// solve inverts the same crane (flat: the algebraic inverse) from --q0's operating point: the
// file gains the multiplier's column after y_d, whose value at rest at the end is the load's
// statics again (zL = 1.5: -16.35), and --verify reports how well the forward run kept the rope
// taut; an open chain's file and verification have neither.
TEST_CASE("solve writes a closed chain's multipliers and checks its loops", "[reports]") {
  const std::string crane = ModelPath("gantry_crane_absolute.yaml");
  testing::TemporaryDirectory out;
  const std::string file = (out / "u.csv").string();
  const Run solve = RunServokit({"solve", crane, "--q0", "0,0,0,2", "--trajectory", "rest-to-rest",
                                 "--y0", "0.3,1.5", "--yf", "0.5,1.5", "--t0", "0", "--tf", "1",
                                 "--t-end", "1.5", "--verify", "--out", file});
  INFO(solve.err);
  REQUIRE(solve.status == 0);
  const nlohmann::json json = nlohmann::json::parse(solve.out);
  CHECK(json["method"] == "algebraic");
  CHECK(json["verification"]["passed"] == true);
  CHECK(json["verification"]["max_constraint_violation"].get<double>() < 1e-12);
  const std::vector<std::string> lines = testing::Lines(testing::ReadFile(file));
  REQUIRE(lines.size() > 2);
  CHECK(lines.front() == "t,x,r,xL,zL,x_dot,r_dot,xL_dot,zL_dot,F,W,y1_d,y2_d,lambda1");
  const std::string last = lines.back();
  CHECK(std::stod(last.substr(last.rfind(',') + 1)) == Approx(-5.0 * 9.81 / 3.0).epsilon(1e-12));

  const Run open = RunServokit({"solve", ModelPath("gantry_crane.yaml"), "--trajectory",
                                "rest-to-rest", "--y0", "0.3,1.5", "--yf", "0.5,1.5", "--t0", "0",
                                "--tf", "1", "--t-end", "1.5", "--verify", "--out", file});
  REQUIRE(open.status == 0);
  CHECK_FALSE(nlohmann::json::parse(open.out)["verification"].contains("max_constraint_violation"));
  CHECK(testing::Lines(testing::ReadFile(file)).front() ==
        "t,x,r,theta,x_dot,r_dot,theta_dot,F,W,y1_d,y2_d");
}

TEST_CASE("--set with deg, and the case-4 verdict in JSON", "[reports]") {
  const Run run = RunServokit({"analyze", ModelPath("mass_on_car.yaml"), "--set", "alpha=0 deg",
                               "--set", "d=0", "--format", "json"});
  REQUIRE(run.status == 0);
  const auto object = nlohmann::json::parse(run.out);
  CHECK(object["realization"] == "tangential");
  CHECK(object["differentiation_index"] == 5);
  CHECK(object["flat"] == true);
  CHECK(object["zero_dynamics"]["stability"] == "none");
  CHECK(object["recommended_solver"] == "algebraic");
}

TEST_CASE("text and Markdown formats name the realization and the stability", "[reports]") {
  const Run text = RunServokit({"analyze", ModelPath("rotational_arm.yaml")});
  REQUIRE(text.status == 0);
  CHECK_THAT(text.out, Catch::Contains("non-ideal-orthogonal") && Catch::Contains("unstable"));
  const Run markdown = RunServokit({"analyze", ModelPath("rotational_arm.yaml"), "--format", "md"});
  REQUIRE(markdown.status == 0);
  CHECK_THAT(markdown.out, Catch::Contains("| realization | non-ideal-orthogonal |"));
}

TEST_CASE("bad usage exits 2 with one line naming the problem", "[reports]") {
  const Run unknown_option = RunServokit({"analyze", ModelPath("mass_on_car.yaml"), "--colour"});
  CHECK(unknown_option.status == 2);
  CHECK_THAT(unknown_option.err,
             Catch::StartsWith("servokit: error: ") && Catch::Contains("--colour"));
  const Run bad_format =
      RunServokit({"analyze", ModelPath("mass_on_car.yaml"), "--format", "yaml"});
  CHECK(bad_format.status == 2);
  CHECK_THAT(bad_format.err, Catch::Contains("--format yaml"));
  const Run bad_set = RunServokit({"analyze", ModelPath("mass_on_car.yaml"), "--set", "alpha"});
  CHECK(bad_set.status == 2);
  CHECK_THAT(bad_set.err, Catch::Contains("--set alpha: expected name=value"));
  const Run no_command = RunServokit({});
  CHECK(no_command.status == 2);
}

TEST_CASE("a missing model file exits 2 naming the file", "[reports]") {
  const Run run = RunServokit({"analyze", "no/such/model.yaml"});
  CHECK(run.status == 2);
  CHECK_THAT(run.err,
             Catch::StartsWith("servokit: error: ") && Catch::Contains("no/such/model.yaml"));
  CHECK(std::count(run.err.begin(), run.err.end(), '\n') == 1);
}

TEST_CASE("no equilibrium exits 3", "[reports]") {
  const Run run = RunServokit({"analyze", TestDataPath("no_equilibrium.yaml")});
  CHECK(run.status == 3);
  CHECK_THAT(run.err, Catch::StartsWith("servokit: error: no equilibrium found"));
}

TEST_CASE("--version prints the project version", "[reports]") {
  const Run version = RunServokit({"--version"});
  CHECK(version.status == 0);
  CHECK(version.out == std::string("servokit ") + SERVOKIT_PROJECT_VERSION + "\n");
}

TEST_CASE("--help of servokit and of every subcommand exits 0 with an example of it", "[reports]") {
  const std::vector<std::vector<std::string>> subcommands = {
      {},         {"analyze"},  {"threshold"},         {"sweep"},           {"solve"},
      {"report"}, {"generate"}, {"generate", "chain"}, {"generate", "beam"}};
  for (const auto& subcommand : subcommands) {
    std::vector<std::string> arguments = subcommand;
    arguments.push_back("--help");
    const Run help = RunServokit(arguments);
    std::string invocation = "servokit";
    for (const auto& word : subcommand) invocation += " " + word;
    INFO(invocation << " --help");
    CHECK(help.status == 0);
    CHECK(help.err.empty());
    // The footer's example is a command line of this subcommand (its first word for generate).
    const std::string example = "\n  servokit " + (subcommand.empty() ? "analyze" : subcommand[0]);
    CHECK_THAT(help.out, Catch::Contains("Example"));
    CHECK_THAT(help.out, Catch::Contains(example));
  }
}

// The structure algorithm's verdict in analyze's JSON (nonlinear_structure): the gantry crane's
// hoist is delayed by two integrators (tests/analysis/nonlinear_structure_test.cpp derives why);
// the double-pendulum crane's relative degree is not defined at rest.
TEST_CASE("analyze reports the dynamic extension and a relative degree undefined at rest",
          "[reports]") {
  const Run crane = RunServokit({"analyze", ModelPath("gantry_crane.yaml"), "--format", "json"});
  REQUIRE(crane.status == 0);
  const auto structure = nlohmann::json::parse(crane.out)["nonlinear_structure"];
  CHECK(structure["derived"] == true);
  CHECK(structure["relative_degree"] == nlohmann::json({2, 2}));
  CHECK(structure["dynamic_extension"]["needed"] == true);
  CHECK(structure["dynamic_extension"]["delayed_inputs"] == nlohmann::json({"W"}));
  CHECK(structure["dynamic_extension"]["integrators"] == 2);
  CHECK(structure["dynamic_extension"]["relative_degree"] == nlohmann::json({4, 4}));

  const Run pendulum =
      RunServokit({"analyze", TestDataPath("double_pendulum_crane.yaml"), "--format", "json"});
  REQUIRE(pendulum.status == 0);
  const auto at_rest = nlohmann::json::parse(pendulum.out)["nonlinear_structure"];
  CHECK(at_rest["defined_at_operating_point"] == false);
  CHECK_THAT(at_rest["note"].get<std::string>(),
             Catch::Matchers::Contains("vanishes at the operating point only"));
  const Run text = RunServokit({"analyze", TestDataPath("double_pendulum_crane.yaml")});
  CHECK_THAT(text.out, Catch::Matchers::Contains("vanishes at the operating point only"));
}

}  // namespace
}  // namespace servokit

namespace servokit {
namespace {

// Issue #34: a misspelt option is the first thing said, with the nearest the command knows
// (CLI11 alone said "--t-end is required" for --tend), in (sub)subcommands too; `analyse` is
// `analyze`.
TEST_CASE("an unknown option is named first, with the nearest known one", "[application]") {
  const testing::Run solve =
      testing::RunServokit({"solve", testing::ModelPath("mass_on_car.yaml"), "--trajectory",
                            "rest-to-rest", "--tend", "3", "--out", "u.csv"});
  CHECK(solve.status == 2);
  CHECK(solve.err == "servokit: error: unknown option --tend for solve (did you mean --t-end?)\n");
  const testing::Run chain =
      testing::RunServokit({"generate", "chain", "--masess", "4", "--out", "chain"});
  CHECK(chain.err ==
        "servokit: error: unknown option --masess for chain (did you mean --masses?)\n");
  const testing::Run far =
      testing::RunServokit({"analyze", testing::ModelPath("mass_on_car.yaml"), "--colour"});
  CHECK(far.err == "servokit: error: unknown option --colour for analyze\n");
  const testing::Run british =
      testing::RunServokit({"analyse", testing::ModelPath("mass_on_car.yaml")});
  CHECK(british.status == 0);
  CHECK_THAT(british.out, Catch::Contains("realization"));
}

}  // namespace
}  // namespace servokit

namespace servokit {
namespace {

// Issue #34: solve's --out makes its missing folder, as sweep, report and generate make theirs,
// and a solve that ends in an error before writing leaves no folder behind (nor --plot's).
TEST_CASE("solve makes --out's folder, and an error leaves none behind", "[application]") {
  const testing::TemporaryDirectory directory;
  const std::filesystem::path made = directory.path() / "new" / "folder";
  const std::vector<std::string> motion = {"--trajectory", "rest-to-rest",
                                           "--y0",         "0",
                                           "--yf",         "1",
                                           "--t0",         "0",
                                           "--tf",         "1",
                                           "--t-end",      "2"};
  std::vector<std::string> good = {"solve", testing::ModelPath("mass_on_car.yaml")};
  good.insert(good.end(), motion.begin(), motion.end());
  good.insert(good.end(), {"--out", (made / "u.csv").string()});
  CHECK(testing::RunServokit(good).status == 0);
  CHECK(std::filesystem::is_regular_file(made / "u.csv"));

  const std::filesystem::path left = directory.path() / "left";
  std::vector<std::string> bad = {"solve", testing::TestDataPath("no_such_model.yaml")};
  bad.insert(bad.end(), motion.begin(), motion.end());
  bad.insert(bad.end(),
             {"--out", (left / "a" / "u.csv").string(), "--plot", (left / "figures").string()});
  CHECK(testing::RunServokit(bad).status == 2);
  CHECK_FALSE(std::filesystem::exists(left));
}

}  // namespace
}  // namespace servokit
