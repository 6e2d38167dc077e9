#pragma once
// `kind: planar-bodies` (docs/model-files.md "Bodies: `kind: planar-bodies`"): rigid bodies in
// a plane, each with a mass, an inertia about its centre, a centre position r(q) and an angle
// theta(q); gravity; springs and dampers between two points or on a coordinate; inputs as forces or
// torques. Read into the energies T, V, R of modeling/lagrangian_model.h and the input matrix B,
// which then go the Lagrangian way, or, for a chain too long to reduce T, into M and f projected
// from the positions. Internal to modeling/ (namespace detail); runs under the
// loader's SymbolicLock (modeling/symbolic_lock.h).
#include <ginac/ginac.h>
#include <yaml-cpp/yaml.h>

#include <array>
#include <functional>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "modeling/lagrangian_model.h"

namespace servokit::detail {

/// The keys a planar-bodies file has beside name, description, parameters, coordinates, inputs
/// and outputs.
inline constexpr std::array<std::string_view, 2> kPlanarBodiesRequiredKeys = {"bodies",
                                                                              "actuators"};
inline constexpr std::array<std::string_view, 4> kPlanarBodiesOptionalKeys = {"gravity", "springs",
                                                                              "dampers", "joints"};
/// The name of the fixed frame, usable wherever a body is named in a point or a reaction.
inline constexpr std::string_view kGroundName = "ground";

/// Parses one expression of the file (the model loader's reader: names, limits, functions),
/// throwing ModelError "source: where: problem".
using ExpressionReader = std::function<GiNaC::ex(const YAML::Node& node, const std::string& where)>;

/// What the bodies define: T, V, R (no generalized forces: Q is zero, dof x 1) and B (dof x
/// inputs, column k from the virtual work of actuator k).
struct PlanarBodies {
  Energies energies;
  GiNaC::matrix input_matrix;
  /// M and f projected from the bodies' positions (ProjectedEquations), set when T is too large
  /// to reduce by trigonometric identities (a long chain) and no mass or inertia depends on q;
  /// otherwise the loader derives them from the energies.
  std::optional<EquationsOfMotion> projected;
  /// The loops the `joints` close (docs/model-files.md, "Closed kinematic chains"): two
  /// constraints c(q) = P1 - P2 = 0 per revolute joint, its x and y, each named by where it
  /// comes from ("joints[0].x").
  std::vector<GiNaC::ex> loop_constraints;
  std::vector<std::string> loop_constraint_names;
};

/// Reads gravity, bodies, springs, dampers, joints and actuators from the model file's `root`.
/// `coordinate_names` and `input_names` are the file's (one actuator per input), `coordinates`
/// and `velocities` their symbols. Throws ModelError "source: key.entry: problem" naming the
/// body, spring, damper or actuator: a missing or unknown key, a vector that is not [x, y], an
/// unknown body or coordinate, an expression that depends on a velocity.
PlanarBodies ReadPlanarBodies(const YAML::Node& root,
                              const std::string& source,
                              const ExpressionReader& read,
                              const std::vector<std::string>& coordinate_names,
                              const std::vector<GiNaC::realsymbol>& coordinates,
                              const std::vector<GiNaC::realsymbol>& velocities,
                              const std::vector<std::string>& input_names);

}  // namespace servokit::detail
