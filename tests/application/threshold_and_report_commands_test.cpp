// `servokit threshold` (the JSON contract of docs/threshold.md) and `servokit report MODEL` from
// the command line. The numbers themselves are tested in tests/analysis/thresholds_test.cpp.
#include <catch2/catch.hpp>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <numbers>
#include <regex>
#include <sstream>
#include <string>
#include <vector>

#include "tests/application/run_servokit.h"
#include "tests/test_files.h"
#include "tests/test_paths.h"

namespace servokit {
namespace {

using testing::CsvFields;
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

TEST_CASE("threshold names the unit and gives a degree parameter's values in degrees too",
          "[reports]") {
  // mass_on_car.yaml gives alpha in degrees. At d = 1 the zero dynamics m2 sin^2(alpha) s^2 +
  // d s + k = 0 are over-damped where d^2 >= 4 m2 k sin^2(alpha): alpha = asin(sqrt(1/40))
  // (m2 = 2, k = 5), 9.0974 deg (tests/servokit/api_test.cpp).
  const double expected = std::asin(std::sqrt(1.0 / 40.0));
  const auto run =
      RunServokit({"threshold", ModelPath("mass_on_car.yaml"), "--vary", "alpha=1deg:80deg",
                   "--event", "oscillation", "--set", "d=1", "--no-closed-form"});
  REQUIRE(run.status == 0);
  CHECK(run.err.empty());
  const auto object = nlohmann::json::parse(run.out);
  CHECK(object["unit"] == "rad");
  CHECK(object["display_unit"] == "deg");
  REQUIRE(object["events"].size() == 1);
  const auto& event = object["events"][0];
  const double value = event["value"].get<double>();
  CHECK(value == Approx(expected).epsilon(1e-9));  // SI, as before
  CHECK(event["value_deg"].get<double>() == value * 180.0 / std::numbers::pi);
  CHECK(event["value_deg"].get<double>() ==
        Approx(expected * 180.0 / std::numbers::pi).epsilon(1e-9));
  // The contract's keys are all still there.
  for (const char* key : {"value", "from", "to"}) CHECK(event.contains(key));
  // A parameter in SI: "unit": "SI", no display_unit, no value_deg.
  const auto si =
      nlohmann::json::parse(RunServokit({"threshold", ModelPath("rotational_arm.yaml"), "--vary",
                                         "s=0:1", "--event", "stability", "--no-closed-form"})
                                .out);
  CHECK(si["unit"] == "SI");
  CHECK_FALSE(si.contains("display_unit"));
  CHECK_FALSE(si["events"][0].contains("value_deg"));
  // Bare ends of an angle the model declares in degrees are degrees (issue #34): 0.1:10 holds
  // the over-damping threshold asin(1/sqrt(40)) = 9.0974 deg, and nothing is warned.
  const auto bare =
      RunServokit({"threshold", ModelPath("mass_on_car.yaml"), "--vary", "alpha=0.1:10", "--event",
                   "oscillation", "--set", "d=1", "--no-closed-form"});
  REQUIRE(bare.status == 0);
  CHECK(bare.err.empty());
  const nlohmann::json bare_json = nlohmann::json::parse(bare.out);
  CHECK(bare_json["display_unit"] == "deg");
  REQUIRE(bare_json["events"].size() == 1);
  CHECK(bare_json["events"][0]["value_deg"].get<double>() ==
        Approx(std::asin(1.0 / std::sqrt(40.0)) * 180.0 / 3.14159265358979323846).epsilon(1e-9));
}

TEST_CASE("report MODEL shows a parameter given in degrees in degrees", "[reports]") {
  const servokit::testing::TemporaryDirectory scratch_directory(/*create=*/false);
  const std::filesystem::path directory = scratch_directory.path();
  std::filesystem::remove_all(directory);
  const auto run = RunServokit({"report", ModelPath("mass_on_car.yaml"), "--set", "d=1", "--vary",
                                "alpha=1deg:80deg:n=80", "--out", directory.string()});
  REQUIRE(run.status == 0);
  CHECK(run.err.empty());
  std::ifstream file(directory / "report.md");
  std::stringstream text;
  text << file.rdbuf();
  CHECK_THAT(text.str(), Catch::Contains("## Study of alpha [deg] from 1 to 80") &&
                             Catch::Contains("value [deg]"));
  // The oscillation row holds the threshold in degrees: asin(sqrt(1/40)) = 9.0974 deg.
  static const std::regex oscillation_row(R"(\| oscillation \| alpha \| ([^ |]+) \|)");
  std::smatch row;
  const std::string report = text.str();
  REQUIRE(std::regex_search(report, row, oscillation_row));
  CHECK(std::stod(row[1].str()) ==
        Approx(std::asin(std::sqrt(1.0 / 40.0)) * 180.0 / std::numbers::pi).epsilon(1e-9));
  std::ifstream plot(directory / "study_alpha_real_part.gp");
  std::stringstream script;
  script << plot.rdbuf();
  CHECK_THAT(script.str(), Catch::Contains("α [deg]"));
  std::filesystem::remove_all(directory);
}

TEST_CASE("report MODEL writes the classification, a study per axis and its figures", "[reports]") {
  const servokit::testing::TemporaryDirectory scratch_directory(/*create=*/false);
  const std::filesystem::path directory = scratch_directory.path();
  std::filesystem::remove_all(directory);
  const auto run = RunServokit({"report", ModelPath("rotational_arm.yaml"), "--vary", "s=0:1:n=51",
                                "--out", directory.string()});
  REQUIRE(run.status == 0);
  std::ifstream file(directory / "report.md");
  std::stringstream text;
  text << file.rdbuf();
  CHECK_THAT(text.str(),
             Catch::Contains("## Study of s") && Catch::Contains("non-ideal-orthogonal"));
  // The stability event's row "| stability | s | value | from | to | located to |": the
  // leading coefficient m l^2 (2l - 3s) of Eq. (56) changes sign at s = 2l/3 (l = 1, Table 2).
  // Tolerance: the bracket width the row states, plus half a unit of the twelfth significant
  // digit that the value is printed with (5e-13 at 2/3).
  static const std::regex stability_row(
      R"(\| stability \| s \| ([^ |]+) \| [^|]* \| [^|]* \| ([^ |]+) \|)");
  std::smatch row;
  const std::string report = text.str();
  REQUIRE(std::regex_search(report, row, stability_row));
  // The stated bracket is at least as narrow as the 1e-9 the JSON test above asks of the value
  // (else the check below would say little).
  const double located_to = std::stod(row[2].str());
  CHECK(located_to <= 1e-9);
  CHECK(std::abs(std::stod(row[1].str()) - 2.0 / 3.0) <= located_to + 5e-13);
  CHECK(std::filesystem::exists(directory / "study_s_root_locus.svg"));
  CHECK(std::filesystem::exists(directory / "report.html"));
  std::filesystem::remove_all(directory);
}

TEST_CASE("report MODEL with two axes writes the class map and its traced curves", "[reports]") {
  // Mass on car (k = 5, m2 = 2): the zero dynamics m2 sin^2(a) s^2 + d s + k has a double root
  // where d = 2 sqrt(k m2) |sin a| (the over-damping curve), and the realization is tangential
  // at a = 0 only.
  const servokit::testing::TemporaryDirectory scratch_directory(/*create=*/false);
  const std::filesystem::path directory = scratch_directory.path();
  std::filesystem::remove_all(directory);
  const auto run =
      RunServokit({"report", ModelPath("mass_on_car.yaml"), "--vary", "alpha=-40deg:60deg:n=21",
                   "--vary", "d=0.5:4:n=15", "--out", directory.string()});
  REQUIRE(run.status == 0);
  for (const char* extension : {".png", ".svg", ".pdf"}) {
    CHECK(std::filesystem::exists(directory / (std::string("map_alpha_d") + extension)));
  }
  std::ifstream report_file(directory / "report.md");
  std::stringstream report;
  report << report_file.rdbuf();
  CHECK_THAT(report.str(), Catch::Contains("## Map over alpha and d") &&
                               Catch::Contains("| non-ideal-orthogonal, asymptotically-stable, "
                                               "oscillatory |"));
  std::ifstream csv(directory / "map_alpha_d_curves.csv");
  std::string line;
  std::getline(csv, line);
  CHECK(line == "curve,event,from,to,via,traced_along,alpha_deg,d,bracket_width");
  const double scale = 2.0 * std::sqrt(5.0 * 2.0), degree = std::numbers::pi / 180.0;
  int oscillation = 0, realization = 0;
  while (std::getline(csv, line)) {
    const std::vector<std::string> field = CsvFields(line);
    REQUIRE(field.size() == 9);
    const double alpha = std::stod(field[6]) * degree, d = std::stod(field[7]);
    INFO(line);
    if (field[1] == "oscillation") {
      ++oscillation;
      if (field[5] == "alpha") {
        CHECK(std::abs(std::abs(alpha) - std::asin(d / scale)) <= 1e-8);
      } else {
        CHECK(std::abs(d - scale * std::abs(std::sin(alpha))) <= 1e-8 * d);
      }
    } else if (field[1] == "realization") {
      ++realization;
      CHECK(field[4] == "tangential");
      CHECK(alpha == 0.0);
    }
  }
  // Along alpha: both arms of the curve on each of the 41 lines; the line a = 0 on each.
  CHECK(oscillation >= 2 * 41);
  CHECK(realization == 41);
  std::filesystem::remove_all(directory);
}

TEST_CASE("threshold and report take the operating point from --q0 and --y0", "[reports]") {
  // The two-link arm with its second link inverted (Newton from q = (0, pi)) rests at
  // q2 = pi / (1 - kappa), where P = H M^-1 B ~ M22 - kappa M21(q2) vanishes when
  // kappa (2 + 3 cos q2) = 2 (l1 = l2): at kappa = 4/7 (q2 = 7 pi / 3, cos q2 = 1/2) among
  // others; at rest hanging (the default) only at kappa = 0.4 (q2 = 0).
  const auto inverted =
      RunServokit({"threshold", testing::TestDataPath("two_link_arm_gravity.yaml"), "--vary",
                   "kappa=0.5:0.6", "--event", "realization", "--q0", "0,3.141592653589793"});
  REQUIRE(inverted.status == 0);
  const auto object = nlohmann::json::parse(inverted.out);
  REQUIRE(object["events"].size() == 1);
  const auto& event = object["events"][0];
  CHECK(std::abs(event["value"].get<double>() - 4.0 / 7.0) <=
        0.5 * event["bracket_width"].get<double>());
  CHECK(event["via"] == "tangential");
  CHECK_FALSE(object.contains("closed_form"));  // derived at q = 0 only
  const auto hanging = RunServokit({"threshold", testing::TestDataPath("two_link_arm_gravity.yaml"),
                                    "--vary", "kappa=0.5:0.6", "--event", "realization"});
  REQUIRE(hanging.status == 0);
  CHECK(nlohmann::json::parse(hanging.out)["events"].empty());

  // report MODEL: the located realization row of the same study at --y0 0 --q0 0,pi.
  const servokit::testing::TemporaryDirectory scratch_directory(/*create=*/false);
  const std::filesystem::path directory = scratch_directory.path();
  std::filesystem::remove_all(directory);
  const auto report = RunServokit({"report", testing::TestDataPath("two_link_arm_gravity.yaml"),
                                   "--vary", "kappa=0.5:0.6:11", "--y0", "0", "--q0",
                                   "0,3.141592653589793", "--out", directory.string()});
  REQUIRE(report.status == 0);
  std::ifstream file(directory / "report.md");
  std::stringstream text;
  text << file.rdbuf();
  static const std::regex realization_row(R"(\| realization \| kappa \| ([^ |]+) \|)");
  std::smatch row;
  const std::string markdown = text.str();
  REQUIRE(std::regex_search(markdown, row, realization_row));
  // Printed to 12 significant digits.
  CHECK(std::abs(std::stod(row[1].str()) - 4.0 / 7.0) <= 1e-11);
  std::filesystem::remove_all(directory);
}

TEST_CASE("threshold reports the change of the index at d = 0 (event structure)", "[reports]") {
  // Paper Sect. 3: at alpha = 0, index 4 with damping (case 3), 5 without (case 4).
  const auto run = RunServokit({"threshold", ModelPath("mass_on_car.yaml"), "--vary", "d=-1:1",
                                "--event", "structure", "--set", "alpha=0", "--no-closed-form"});
  REQUIRE(run.status == 0);
  const auto object = nlohmann::json::parse(run.out);
  CHECK(object["event"] == "structure");
  REQUIRE(object["events"].size() == 1);
  CHECK(object["events"][0]["value"].get<double>() == 0.0);
  CHECK(object["events"][0]["via"] == "relative degree 4, index 5");
}

TEST_CASE("report paper refuses --vary", "[reports]") {
  const auto run = RunServokit({"report", "paper", "--out", "/tmp/unused", "--vary", "s=0:1:n=3"});
  CHECK(run.status == 2);
  CHECK_THAT(run.err, Catch::Contains("--vary and --set are for `report MODEL`"));
}

}  // namespace
}  // namespace servokit
