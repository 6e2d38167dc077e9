// Trajectory files: waypoints joined by rest-to-rest segments (issue #4), against the single
// segment of Eq. (65) and hand-checked hold and error cases.
#include "solvers/waypoint_trajectory.h"

#include <catch2/catch.hpp>
#include <numbers>

#include "models/errors.h"

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

}  // namespace
}  // namespace servokit
