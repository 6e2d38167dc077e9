// `servokit threshold` (the JSON contract of DESIGN.md) and `servokit report MODEL` from the
// command line. The numbers themselves are tested in tests/analysis/thresholds_test.cpp.
#include <catch2/catch.hpp>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <sstream>

#include "tests/application/run_servokit.h"
#include "tests/test_paths.h"

namespace servokit {
namespace {

using testing::ModelPath;
using testing::RunServokit;

TEST_CASE("threshold prints parameter, event and events with value, from and to", "[reports]") {
  const auto run = RunServokit(
      {"threshold", ModelPath("rotational_arm.yaml"), "--vary", "s=0:1", "--event", "stability"});
  REQUIRE(run.status == 0);
  const auto object = nlohmann::json::parse(run.out);
  CHECK(object["parameter"] == "s");
  CHECK(object["event"] == "stability");
  REQUIRE(object["events"].size() == 1);
  CHECK(object["events"][0]["value"].get<double>() == Approx(2.0 / 3.0).epsilon(1e-9));
  CHECK(object["events"][0]["from"] == "asymptotically-stable");
  CHECK(object["events"][0]["to"] == "unstable");
  CHECK(object["closed_form"]["degree"] == 2);
}

TEST_CASE("threshold accepts degrees and rejects a bad event or range", "[reports]") {
  const auto degrees =
      RunServokit({"threshold", ModelPath("mass_on_car.yaml"), "--vary", "alpha=1deg:90deg",
                   "--event", "oscillation", "--set", "d=1", "--no-closed-form"});
  REQUIRE(degrees.status == 0);
  CHECK(nlohmann::json::parse(degrees.out)["events"].size() == 1);
  const auto bad_event = RunServokit(
      {"threshold", ModelPath("mass_on_car.yaml"), "--vary", "d=0:1", "--event", "speed"});
  CHECK(bad_event.status == 2);
  CHECK_THAT(bad_event.err, Catch::Contains("--event speed"));
  const auto reversed = RunServokit(
      {"threshold", ModelPath("mass_on_car.yaml"), "--vary", "d=1:0", "--event", "stability"});
  CHECK(reversed.status == 2);
  CHECK_THAT(reversed.err, Catch::Contains("low < high"));
  const auto unknown = RunServokit(
      {"threshold", ModelPath("mass_on_car.yaml"), "--vary", "q=0:1", "--event", "stability"});
  CHECK(unknown.status == 2);
  CHECK_THAT(unknown.err, Catch::Contains("no parameter 'q'"));
}

TEST_CASE("report MODEL writes the classification, a study per axis and its figures", "[reports]") {
  const auto directory = std::filesystem::temp_directory_path() / "servokit_model_report_test";
  std::filesystem::remove_all(directory);
  const auto run = RunServokit({"report", ModelPath("rotational_arm.yaml"), "--vary", "s=0:1:51",
                                "--out", directory.string()});
  REQUIRE(run.status == 0);
  std::ifstream file(directory / "report.md");
  std::stringstream text;
  text << file.rdbuf();
  CHECK_THAT(text.str(), Catch::Contains("## Study of s") &&
                             Catch::Contains("| stability | s | 0.666666666667") &&
                             Catch::Contains("non-ideal-orthogonal"));
  CHECK(std::filesystem::exists(directory / "study_s_root_locus.svg"));
  CHECK(std::filesystem::exists(directory / "report.html"));
  std::filesystem::remove_all(directory);
}

TEST_CASE("report paper refuses --vary", "[reports]") {
  const auto run = RunServokit({"report", "paper", "--out", "/tmp/unused", "--vary", "s=0:1:3"});
  CHECK(run.status == 2);
  CHECK_THAT(run.err, Catch::Contains("--vary and --set are for `report MODEL`"));
}

}  // namespace
}  // namespace servokit
