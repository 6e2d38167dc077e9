#pragma once
// A desired output trajectory from a file: waypoints joined by rest-to-rest segments (Eq. 65),
// at rest before the first waypoint and after the last.
//
//   continuous_derivatives: 4        # optional, default 4 (Eq. 65)
//   waypoints:                       # times strictly increasing; y has one value per output
//     - {t: 0, y: [0.5]}
//     - {t: 6, y: [2.5]}
//     - {t: 8, y: [2.5]}             # equal y: a hold
//     - {t: 10, y: ["90 deg"]}       # values may end in deg
#include <string>
#include <vector>

#include "trajectories/trajectory.h"

namespace servokit {

class WaypointTrajectory final : public OutputTrajectory {
 public:
  /// Throws UsageError unless there are from two to kMaxTrajectoryPoints waypoints with
  /// increasing times and equally many finite output values, 1 <= continuous_derivatives <=
  /// kMaxContinuousDerivatives, and every segment's derivatives are finite (the message names
  /// the segment's waypoints).
  WaypointTrajectory(std::vector<double> times,
                     std::vector<Eigen::VectorXd> outputs,
                     int continuous_derivatives = 4);

  /// d^order y_d / dt^order at t, size outputs (see RestToRestTrajectory::Derivative); at a
  /// waypoint between two segments the later segment answers.
  Eigen::VectorXd Derivative(double t, int order) const override;
  void Derivatives(double t, int highest, Eigen::MatrixXd& derivatives) const override {
    segments_[SegmentAt(t)].Derivatives(t, highest, derivatives);
  }

  Eigen::Index outputs() const override { return segments_.front().outputs(); }
  int continuous_derivatives() const override { return segments_.front().continuous_derivatives(); }
  std::vector<double> breakpoints() const override { return times_; }
  double start_time() const { return times_.front(); }
  /// The same waypoints joined by segments with `continuous_derivatives` continuous derivatives
  /// (used when the problem needs more than the file asked for).
  WaypointTrajectory WithContinuousDerivatives(int continuous_derivatives) const {
    return WaypointTrajectory(times_, outputs_, continuous_derivatives);
  }
  double end_time() const { return times_.back(); }

 private:
  // The segment whose interval holds t (see Derivative()).
  std::size_t SegmentAt(double t) const;
  std::vector<double> times_;
  std::vector<Eigen::VectorXd> outputs_;
  std::vector<RestToRestTrajectory> segments_;  // segment i runs from times_[i] to times_[i+1]
};

/// Reads a trajectory file. Throws ModelError "file: key: problem" naming the entry
/// (e.g. "traj.yaml: waypoints[2].t: 5 is not after waypoints[1].t = 6"), also for more than
/// kMaxTrajectoryPoints waypoints and continuous_derivatives above kMaxContinuousDerivatives.
WaypointTrajectory LoadWaypointTrajectory(const std::string& path);

/// As LoadWaypointTrajectory, from YAML text; `source` names it in messages.
WaypointTrajectory LoadWaypointTrajectoryFromString(const std::string& yaml_text,
                                                    const std::string& source);

}  // namespace servokit
