// Trajectory files: waypoints joined by rest-to-rest segments (issue #4), against the single
// segment of Eq. (65) and hand-checked hold and error cases.
#include "trajectories/waypoint_trajectory.h"

#include <catch2/catch.hpp>
#include <numbers>
#include <string>
#include <vector>

#include "base/errors.h"

namespace servokit {
namespace {

constexpr const char* kPaperMotion = R"(
waypoints:
  - {t: 0, y: [0.5]}
  - {t: 6, y: [2.5]}
  - {t: 8, y: [2.5]}
  - {t: 10, y: ["90 deg"]}
)";

TEST_CASE("a waypoint segment is the rest-to-rest motion between its waypoints", "[solvers]") {
  const WaypointTrajectory trajectory = LoadWaypointTrajectoryFromString(kPaperMotion, "t.yaml");
  const RestToRestTrajectory first(Eigen::VectorXd::Constant(1, 0.5),
                                   Eigen::VectorXd::Constant(1, 2.5), 0, 6);
  for (const double t : {-1.0, 0.0, 1.3, 3.0, 5.99}) {
    for (int order = 0; order <= 5; ++order) {
      CHECK(trajectory.Derivative(t, order)(0) ==
            Approx(first.Derivative(t, order)(0)).margin(1e-12));
    }
  }
  CHECK(trajectory.Derivative(7.0, 0)(0) == Approx(2.5));  // the hold
  CHECK(trajectory.Derivative(7.0, 1)(0) == 0.0);
  CHECK(trajectory.Derivative(9.0, 0)(0) == Approx((2.5 + std::numbers::pi / 2) / 2));
  CHECK(trajectory.Derivative(12.0, 0)(0) == Approx(std::numbers::pi / 2));  // rest after
  CHECK(trajectory.start_time() == 0.0);
  CHECK(trajectory.end_time() == 10.0);
}

TEST_CASE("a trajectory file with a problem names the entry", "[solvers]") {
  CHECK_THROWS_WITH(LoadWaypointTrajectoryFromString(
                        "waypoints:\n  - {t: 0, y: [0]}\n  - {t: 0, y: [1]}\n", "t.yaml"),
                    Catch::Contains("t.yaml: waypoints[1].t: 0 is not after waypoints[0].t = 0"));
  CHECK_THROWS_WITH(LoadWaypointTrajectoryFromString(
                        "waypoints:\n  - {t: 0, y: [0, 1]}\n  - {t: 1, y: [1]}\n", "t.yaml"),
                    Catch::Contains("waypoints[1].y: 1 values, but waypoints[0].y has 2"));
  CHECK_THROWS_WITH(LoadWaypointTrajectoryFromString(
                        "waypoints:\n  - {t: 0, y: [zero]}\n  - {t: 1, y: [1]}\n", "t.yaml"),
                    Catch::Contains("waypoints[0].y[0]: not a number"));
  CHECK_THROWS_WITH(LoadWaypointTrajectoryFromString("waypoint: []\n", "t.yaml"),
                    Catch::Contains("t.yaml: waypoint: unknown key"));
  CHECK_THROWS_WITH(LoadWaypointTrajectoryFromString("waypoints:\n  - {t: 0, y: [0]}\n", "t.yaml"),
                    Catch::Contains("at least two"));
  CHECK_THROWS_AS(LoadWaypointTrajectory("no/such/trajectory.yaml"), ModelError);
}

TEST_CASE("continuous_derivatives beyond the limit is refused naming the key, before any work",
          "[solvers]") {
  const auto with = [](const std::string& derivatives) {
    return "continuous_derivatives: " + derivatives +
           "\nwaypoints:\n  - {t: 0, y: [0.5]}\n  - {t: 6, y: [2.5]}\n";
  };
  // A million hung (a table of 10^12 terms); a thousand overflowed y_d to NaN, which a solve
  // then blamed on --y0.
  CHECK_THROWS_WITH(LoadWaypointTrajectoryFromString(with("1000000"), "t.yaml"),
                    "t.yaml: continuous_derivatives: 1e+06: must be a whole number from 1 to 32");
  CHECK_THROWS_WITH(LoadWaypointTrajectoryFromString(with("1000"), "t.yaml"),
                    "t.yaml: continuous_derivatives: 1000: must be a whole number from 1 to 32");
  CHECK_THROWS_WITH(LoadWaypointTrajectoryFromString(with("1e300"), "t.yaml"),
                    Catch::Contains("t.yaml: continuous_derivatives: 1e+300: must be a whole"));
  CHECK_THROWS_WITH(LoadWaypointTrajectoryFromString(with("2.5"), "t.yaml"),
                    Catch::Contains("t.yaml: continuous_derivatives: 2.5: must be a whole"));
  CHECK(LoadWaypointTrajectoryFromString(with("32"), "t.yaml").continuous_derivatives() == 32);
  const WaypointTrajectory file = LoadWaypointTrajectoryFromString(with("4"), "t.yaml");
  CHECK_THROWS_WITH(file.WithContinuousDerivatives(33),
                    "waypoints: continuous derivatives = 33: must be from 1 to 32");
}

TEST_CASE("a segment too short for its step is refused naming its waypoints", "[solvers]") {
  CHECK_THROWS_WITH(
      LoadWaypointTrajectoryFromString(
          "waypoints:\n  - {t: 0, y: [0]}\n  - {t: 1, y: [1]}\n  - {t: 1.0000000000000002, y: "
          "[1e300]}\n",
          "t.yaml"),
      Catch::Contains("t.yaml: waypoints[1] to waypoints[2]: rest-to-rest: y0 to yf"));
}

TEST_CASE("more waypoints than the limit are refused before the segments are built", "[solvers]") {
  const std::size_t too_many = kMaxTrajectoryPoints + 1;
  std::vector<double> times(too_many);
  for (std::size_t i = 0; i < too_many; ++i) times[i] = double(i);
  CHECK_THROWS_WITH(
      WaypointTrajectory(times, std::vector<Eigen::VectorXd>(too_many, Eigen::VectorXd::Zero(1))),
      "waypoints: 1000001 waypoints: at most 1000000");
}

}  // namespace
}  // namespace servokit
