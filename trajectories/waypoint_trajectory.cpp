#include "trajectories/waypoint_trajectory.h"

#include <yaml-cpp/yaml.h>

#include <algorithm>
#include <cmath>
#include <fstream>
#include <optional>
#include <sstream>

#include "base/errors.h"
#include "files/input_file.h"
#include "modeling/units.h"
#include "modeling/yaml_document.h"

namespace servokit {

WaypointTrajectory::WaypointTrajectory(std::vector<double> times,
                                       std::vector<Eigen::VectorXd> outputs,
                                       int continuous_derivatives)
    : times_(std::move(times)), outputs_(outputs) {
  if (times_.size() < 2 || times_.size() != outputs.size()) {
    throw UsageError("a trajectory needs at least two waypoints, each with a time and outputs");
  }
  if (times_.size() > kMaxTrajectoryPoints) {
    throw UsageError("waypoints: " + std::to_string(times_.size()) + " waypoints: at most " +
                     std::to_string(kMaxTrajectoryPoints));
  }
  RequireContinuousDerivatives("waypoints", continuous_derivatives);
  segments_.reserve(times_.size() - 1);
  for (std::size_t i = 0; i + 1 < times_.size(); ++i) {
    try {
      segments_.emplace_back(outputs[i], outputs[i + 1], times_[i], times_[i + 1],
                             continuous_derivatives);
    } catch (const UsageError& error) {
      throw UsageError("waypoints[" + std::to_string(i) + "] to waypoints[" +
                       std::to_string(i + 1) + "]: " + error.what());
    }
  }
}

std::size_t WaypointTrajectory::SegmentAt(double t) const {
  // The last segment starting at or before t, clamped to the first and last segments, which
  // are at rest outside the waypoints.
  const auto after = std::upper_bound(times_.begin(), times_.end(), t);
  return std::size_t(std::clamp<std::ptrdiff_t>(after - times_.begin() - 1, 0,
                                                std::ptrdiff_t(segments_.size()) - 1));
}

Eigen::VectorXd WaypointTrajectory::Derivative(double t, int order) const {
  return segments_[SegmentAt(t)].Derivative(t, order);
}

namespace {

[[noreturn]] void Fail(const std::string& source,
                       const std::string& key,
                       const std::string& problem) {
  throw ModelError(source + ": " + key + ": " + problem);
}

double ReadNumber(const YAML::Node& node, const std::string& source, const std::string& key) {
  const std::optional<double> value = node.IsScalar() ? ParseQuantity(node.Scalar()) : std::nullopt;
  if (!value) Fail(source, key, "not a number (use e.g. 0.5 or \"90 deg\")");
  return *value;
}

WaypointTrajectory ParseWaypoints(const std::string& yaml_text, const std::string& source) {
  const YAML::Node root = LoadSingleYamlDocument(yaml_text, source, "a waypoint file");
  if (!root.IsMap()) Fail(source, "(top level)", "expected a map with the key 'waypoints'");
  for (const auto& entry : root) {
    if (!entry.first.IsScalar()) {
      Fail(source, "(top level)",
           "a key that is not a name (expected waypoints, "
           "continuous_derivatives)");
    }
    const std::string key = entry.first.Scalar();
    if (key != "waypoints" && key != "continuous_derivatives") {
      Fail(source, key, "unknown key (expected waypoints, continuous_derivatives)");
    }
  }
  int continuous_derivatives = 4;
  if (const YAML::Node node = root["continuous_derivatives"]) {
    const double value = ReadNumber(node, source, "continuous_derivatives");
    // Compared as a double first: int(value) of 1e12 would be undefined.
    if (!(value >= 1 && value <= kMaxContinuousDerivatives) || value != std::floor(value)) {
      std::ostringstream problem;
      problem << value << ": must be a whole number from 1 to " << kMaxContinuousDerivatives;
      Fail(source, "continuous_derivatives", problem.str());
    }
    continuous_derivatives = int(value);
  }
  const YAML::Node waypoints = root["waypoints"];
  if (!waypoints) Fail(source, "waypoints", "missing");
  if (!waypoints.IsSequence() || waypoints.size() < 2) {
    Fail(source, "waypoints", "expected a list of at least two {t: ..., y: [...]}");
  }
  if (waypoints.size() > kMaxTrajectoryPoints) {
    Fail(source, "waypoints",
         std::to_string(waypoints.size()) + " waypoints: at most " +
             std::to_string(kMaxTrajectoryPoints));
  }
  std::vector<double> times;
  std::vector<Eigen::VectorXd> outputs;
  for (std::size_t i = 0; i < waypoints.size(); ++i) {
    const std::string key = "waypoints[" + std::to_string(i) + "]";
    const YAML::Node waypoint = waypoints[i];
    if (!waypoint.IsMap() || !waypoint["t"] || !waypoint["y"]) {
      Fail(source, key, "expected {t: time, y: [value, ...]}");
    }
    const double t = ReadNumber(waypoint["t"], source, key + ".t");
    if (!times.empty() && !(t > times.back())) {
      std::ostringstream problem;
      problem << t << " is not after waypoints[" << i - 1 << "].t = " << times.back();
      Fail(source, key + ".t", problem.str());
    }
    const YAML::Node values = waypoint["y"];
    if (!values.IsSequence() || values.size() == 0) Fail(source, key + ".y", "expected a list");
    Eigen::VectorXd y(Eigen::Index(values.size()));
    for (std::size_t k = 0; k < values.size(); ++k) {
      y(Eigen::Index(k)) = ReadNumber(values[k], source, key + ".y[" + std::to_string(k) + "]");
    }
    if (!outputs.empty() && y.size() != outputs.front().size()) {
      Fail(source, key + ".y",
           std::to_string(y.size()) + " values, but waypoints[0].y has " +
               std::to_string(outputs.front().size()));
    }
    times.push_back(t);
    outputs.push_back(y);
  }
  try {
    return WaypointTrajectory(std::move(times), std::move(outputs), continuous_derivatives);
  } catch (const UsageError& error) {  // a segment that cannot be one (e.g. its derivatives)
    throw ModelError(source + ": " + error.what());
  }
}

}  // namespace

WaypointTrajectory LoadWaypointTrajectoryFromString(const std::string& yaml_text,
                                                    const std::string& source) {
  try {
    return ParseWaypoints(yaml_text, source);
  } catch (const YAML::Exception& error) {  // a node of a shape the reader did not foresee
    if (error.mark.is_null()) throw ModelError(source + ": " + error.msg);
    throw ModelError(source + ":" + std::to_string(error.mark.line + 1) + ":" +
                     std::to_string(error.mark.column + 1) + ": " + error.msg);
  }
}

WaypointTrajectory LoadWaypointTrajectory(const std::string& path) {
  return LoadWaypointTrajectoryFromString(
      ReadInputFile(path, "the trajectory file", kTrajectoryFileLimit, ErrorKind::kModel), path);
}

}  // namespace servokit
