#include "modeling/planar_bodies.h"

#include <algorithm>
#include <cmath>
#include <map>
#include <optional>
#include <utility>

#include "base/errors.h"
#include "modeling/loader_support.h"
#include "modeling/time_derivative.h"

namespace servokit::detail {
namespace {

constexpr std::array<std::string_view, 4> kBodyKeys = {"mass", "inertia", "position", "angle"};
constexpr std::array<std::string_view, 4> kSpringKeys = {"stiffness", "coordinate", "between",
                                                         "rest"};
constexpr std::array<std::string_view, 3> kDamperKeys = {"damping", "coordinate", "between"};
constexpr std::array<std::string_view, 5> kActuatorKeys = {"on", "force", "at", "torque",
                                                           "reaction"};
constexpr std::array<std::string_view, 2> kPointKeys = {"body", "at"};
// A revolute joint that closes a loop: the two points coincide.
constexpr std::array<std::string_view, 1> kJointKeys = {"between"};

// A point of the plane as an expression pair.
using Vector2 = std::array<GiNaC::ex, 2>;

struct Body {
  GiNaC::ex mass, inertia, angle;
  Vector2 position;
};

// sin and cos of a sum as sums of products of sin and cos of its terms (angle addition), so
// that products of positions of bodies in a chain can cancel.
struct ExpandAngleSums : GiNaC::map_function {
  GiNaC::ex operator()(const GiNaC::ex& expression) override {
    const GiNaC::ex mapped = expression.map(*this);
    const bool is_sin = GiNaC::is_the_function<GiNaC::sin_SERIAL>(mapped);
    if ((!is_sin && !GiNaC::is_the_function<GiNaC::cos_SERIAL>(mapped)) ||
        !GiNaC::is_a<GiNaC::add>(mapped.op(0))) {
      return mapped;
    }
    const GiNaC::ex first = mapped.op(0).op(0), rest = mapped.op(0) - first;
    const GiNaC::ex sin_first = GiNaC::sin(first), cos_first = GiNaC::cos(first);
    const GiNaC::ex sin_rest = (*this)(GiNaC::sin(rest)), cos_rest = (*this)(GiNaC::cos(rest));
    return is_sin ? sin_first * cos_rest + cos_first * sin_rest
                  : cos_first * cos_rest - sin_first * sin_rest;
  }
};

// An upper bound on the terms of ExpandAngleSums(expression).expand() without expanding: the
// sine or cosine of a sum of k terms becomes 2^(k-1) products, a product multiplies its factors'
// counts, a sum adds them, an integer power raises its base's. Saturates at infinity.
double AngleExpansionTerms(const GiNaC::ex& expression) {
  if (GiNaC::is_a<GiNaC::add>(expression)) {
    double sum = 0.0;
    for (const GiNaC::ex& term : expression) sum += AngleExpansionTerms(term);
    return sum;
  }
  if (GiNaC::is_a<GiNaC::mul>(expression)) {
    double product = 1.0;
    for (const GiNaC::ex& factor : expression) product *= AngleExpansionTerms(factor);
    return product;
  }
  if (GiNaC::is_a<GiNaC::power>(expression) && expression.op(1).info(GiNaC::info_flags::posint)) {
    return std::pow(AngleExpansionTerms(expression.op(0)),
                    GiNaC::ex_to<GiNaC::numeric>(expression.op(1)).to_double());
  }
  if ((GiNaC::is_the_function<GiNaC::sin_SERIAL>(expression) ||
       GiNaC::is_the_function<GiNaC::cos_SERIAL>(expression)) &&
      GiNaC::is_a<GiNaC::add>(expression.op(0))) {
    return std::pow(2.0, double(expression.op(0).nops()) - 1.0);
  }
  return 1.0;
}

// The most terms AngleExpansionTerms may promise before ReduceTrigonometric is skipped: a chain
// of n links with relative joint angles has sines of sums of up to n angles, 2^(n-1) products
// each (issue #31: ten links never finished loading). The shipped and test models need at most
// 644 (the three-link arm); past the budget M and f are projected from the bodies' positions
// (ProjectedEquations), or, where a mass depends on q, derived from T as written.
constexpr double kMaxAngleExpansionTerms = 2e4;

// The kinetic energy of bodies written with positions as the user gives them holds
// sin(u)^2 + cos(u)^2 and the angle-addition products of a chain uncancelled, which makes M and
// f several times larger than the hand-written ones (and the symbolic steps of the analysis
// slower). Angle sums expanded, sin^2 replaced by 1 - cos^2 and expanded again, they cancel:
// the same function, in a form as small as a hand derivation.
GiNaC::ex ReduceTrigonometric(const GiNaC::ex& expression) {
  ExpandAngleSums expand_sums;
  const GiNaC::ex expanded = expand_sums(expression).expand();
  const GiNaC::ex u = GiNaC::wild(0);
  return expanded
      .subs(GiNaC::pow(GiNaC::sin(u), 2) == 1 - GiNaC::pow(GiNaC::cos(u), 2),
            GiNaC::subs_options::algebraic)
      .expand();
}

class Reader {
 public:
  Reader(const YAML::Node& root,
         const std::string& source,
         const ExpressionReader& read,
         const std::vector<std::string>& coordinate_names,
         const std::vector<GiNaC::realsymbol>& coordinates,
         const std::vector<GiNaC::realsymbol>& velocities)
      : root_(root),
        source_(source),
        read_(read),
        coordinate_names_(coordinate_names),
        coordinates_(coordinates),
        velocities_(velocities),
        rate_(coordinates, velocities) {}

  PlanarBodies Read(const std::vector<std::string>& input_names) {
    PlanarBodies result;
    ReadBodies();
    const Vector2 gravity = ReadGravity();
    std::vector<WeightedPosition> positions;
    for (const auto& [name, body] : bodies_) {
      const Vector2 velocity = {Rate(body.position[0]), Rate(body.position[1])};
      const GiNaC::ex angular_rate = Rate(body.angle);
      result.energies.kinetic +=
          body.mass * (velocity[0] * velocity[0] + velocity[1] * velocity[1]) / 2 +
          body.inertia * angular_rate * angular_rate / 2;
      result.energies.potential -=
          body.mass * (gravity[0] * body.position[0] + gravity[1] * body.position[1]);
      positions.push_back({body.mass, body.position[0]});
      positions.push_back({body.mass, body.position[1]});
      positions.push_back({body.inertia, body.angle});
    }
    result.energies.potential += ReadSprings();
    ReadJoints(result);
    result.energies.dissipation = ReadDampers();
    result.energies.generalized_forces = GiNaC::matrix(unsigned(coordinates_.size()), 1);
    if (AngleExpansionTerms(result.energies.kinetic) <= kMaxAngleExpansionTerms) {
      result.energies.kinetic = ReduceTrigonometric(result.energies.kinetic);
    } else if (std::none_of(positions.begin(), positions.end(), [this](const auto& moving) {
                 return DependsOnCoordinates(moving.weight);
               })) {
      // Too large to reduce: project instead of differentiating T twice.
      TermBudget budget;
      result.projected =
          ProjectedEquations(positions, result.energies, coordinates_, velocities_, budget);
    }
    result.input_matrix = ReadActuators(input_names);
    return result;
  }

 private:
  YAML::Node Entry(const std::string& key) const { return std::as_const(root_)[key]; }

  [[noreturn]] void Fail(const std::string& where, const std::string& problem) const {
    throw ModelError(source_ + ": " + where + ": " + problem);
  }

  // Every key of the map `node` (at `where`) is one of `keys`.
  template <std::size_t N>
  void CheckKeys(const YAML::Node& node,
                 const std::string& where,
                 const std::array<std::string_view, N>& keys) const {
    for (const auto& entry : node) {
      const std::string key = entry.first.IsScalar() ? entry.first.Scalar() : "";
      if (!Contains(keys, key)) {
        Fail(where + "." + key, "unknown key (expected " + Join(keys) + ")");
      }
    }
  }

  bool DependsOnCoordinates(const GiNaC::ex& expression) const {
    return FirstSymbolIn(expression, coordinates_) != nullptr;
  }

  // An expression of the parameters and coordinates only.
  GiNaC::ex Positional(const YAML::Node& node, const std::string& where) const {
    const GiNaC::ex expression = read_(node, where);
    if (const GiNaC::realsymbol* velocity = FirstSymbolIn(expression, velocities_)) {
      Fail(where, "depends on the velocity '" + velocity->get_name() +
                      "'; positions, angles, masses, forces and directions may depend on "
                      "parameters and coordinates only");
    }
    return expression;
  }

  Vector2 ReadVector2(const YAML::Node& node, const std::string& where) const {
    if (!node.IsSequence() || node.size() != 2) {
      Fail(where, "expected a vector [x, y] of two expressions, found " +
                      (node.IsSequence() ? std::to_string(node.size()) + " entries"
                                         : std::string("no list")));
    }
    return {Positional(node[0], Indexed(where, 0)), Positional(node[1], Indexed(where, 1))};
  }

  // d expression / dt = sum_k d expression / dq_k q'_k (modeling/time_derivative.h: one walk,
  // each subexpression shared by the bodies of a chain differentiated once).
  GiNaC::ex Rate(const GiNaC::ex& expression) const { return rate_(expression); }

  void ReadBodies() {
    const YAML::Node bodies = Entry("bodies");
    if (!bodies.IsMap() || bodies.size() == 0) {
      Fail("bodies", "expected a map of body name: {mass, inertia, position, angle}");
    }
    for (const auto& entry : bodies) {
      const std::string name = entry.first.IsScalar() ? entry.first.Scalar() : "";
      const std::string where = "bodies." + name;
      if (!IsIdentifier(name))
        Fail("bodies", "body names must be plain names, found '" + name + "'");
      if (name == kGroundName) {
        Fail(where,
             "'" + std::string(kGroundName) + "' is the fixed frame; name the body otherwise");
      }
      if (FindBody(name) != nullptr) Fail(where, "duplicate body name");
      const YAML::Node node = entry.second;
      if (!node.IsMap()) Fail(where, "expected a map with the keys " + Join(kBodyKeys));
      CheckKeys(node, where, kBodyKeys);
      if (!node["mass"]) Fail(where + ".mass", "missing required key (the body's mass)");
      if (!node["position"]) {
        Fail(where + ".position", "missing required key (the body's centre [x, y] in terms of q)");
      }
      Body body;
      body.mass = Positional(node["mass"], where + ".mass");
      body.position = ReadVector2(node["position"], where + ".position");
      body.inertia = node["inertia"] ? Positional(node["inertia"], where + ".inertia") : 0;
      body.angle = node["angle"] ? Positional(node["angle"], where + ".angle") : 0;
      bodies_.emplace_back(name, std::move(body));
    }
  }

  const Body* FindBody(const std::string& name) const {
    const auto found = std::find_if(bodies_.begin(), bodies_.end(),
                                    [&](const auto& body) { return body.first == name; });
    return found == bodies_.end() ? nullptr : &found->second;
  }

  // A body's name, or ground (nullptr) when `allow_ground`.
  const Body* ReadBodyName(const YAML::Node& node,
                           const std::string& where,
                           bool allow_ground) const {
    const std::string name = node.IsScalar() ? node.Scalar() : "";
    if (allow_ground && name == kGroundName) return nullptr;
    if (const Body* body = FindBody(name)) return body;
    std::vector<std::string> known;
    for (const auto& body : bodies_) known.push_back(body.first);
    if (allow_ground) known.emplace_back(kGroundName);
    Fail(where, "unknown body '" + name + "' (bodies: " + Join(known) + ")");
  }

  Vector2 ReadGravity() const {
    const YAML::Node gravity = Entry("gravity");
    if (!gravity) return {GiNaC::ex(0), GiNaC::ex(0)};
    return ReadVector2(gravity, "gravity");
  }

  // A point: a body's name (its centre; ground: the origin) or {body: name, at: [x, y]} with
  // `at` in the body's frame (turned by its angle), or in the plane for ground.
  Vector2 ReadPoint(const YAML::Node& node, const std::string& where) const {
    if (node.IsScalar()) {
      const Body* body = ReadBodyName(node, where, /*allow_ground=*/true);
      return body ? body->position : Vector2{GiNaC::ex(0), GiNaC::ex(0)};
    }
    if (!node.IsMap() || !node["body"]) {
      Fail(where, "expected a body name or {body: name, at: [x, y]}");
    }
    CheckKeys(node, where, kPointKeys);
    const Body* body = ReadBodyName(node["body"], where + ".body", /*allow_ground=*/true);
    const Vector2 at =
        node["at"] ? ReadVector2(node["at"], where + ".at") : Vector2{GiNaC::ex(0), GiNaC::ex(0)};
    return Attached(body, at);
  }

  // The point `at` of `body` (in its frame) in the plane; ground: `at` itself.
  static Vector2 Attached(const Body* body, const Vector2& at) {
    if (body == nullptr) return at;
    const GiNaC::ex c = GiNaC::cos(body->angle), s = GiNaC::sin(body->angle);
    return {body->position[0] + c * at[0] - s * at[1], body->position[1] + s * at[0] + c * at[1]};
  }

  // springs[i] or dampers[i]: on a coordinate (its value) or between two points (the squared
  // distance and the two points' difference).
  struct Element {
    std::optional<GiNaC::ex> coordinate;
    Vector2 difference;  // between: P1 - P2
  };

  Element ReadElement(const YAML::Node& node, const std::string& where) const {
    const bool on_coordinate = bool(node["coordinate"]), between = bool(node["between"]);
    if (on_coordinate == between) {
      Fail(where, "expected exactly one of coordinate: <name> or between: [point, point]");
    }
    Element element;
    if (on_coordinate) {
      const std::string name = node["coordinate"].IsScalar() ? node["coordinate"].Scalar() : "";
      const auto found = std::find(coordinate_names_.begin(), coordinate_names_.end(), name);
      if (found == coordinate_names_.end()) {
        Fail(where + ".coordinate",
             "unknown coordinate '" + name + "' (coordinates: " + Join(coordinate_names_) + ")");
      }
      element.coordinate = coordinates_[std::size_t(found - coordinate_names_.begin())];
      return element;
    }
    const YAML::Node points = node["between"];
    if (!points.IsSequence() || points.size() != 2) {
      Fail(where + ".between", "expected two points [first, second]");
    }
    const Vector2 first = ReadPoint(points[0], Indexed(where + ".between", 0));
    const Vector2 second = ReadPoint(points[1], Indexed(where + ".between", 1));
    element.difference = {first[0] - second[0], first[1] - second[1]};
    return element;
  }

  template <std::size_t N>
  YAML::Node CheckedList(const std::string& key,
                         const std::array<std::string_view, N>& keys) const {
    YAML::Node list = Entry(key);
    // Absent and empty (`springs:` followed by comments only) are the same: no elements.
    if (!list || list.IsNull()) return YAML::Node(YAML::NodeType::Sequence);
    if (!list.IsSequence()) Fail(key, "expected a list of maps");
    for (std::size_t i = 0; i < list.size(); ++i) {
      if (!list[i].IsMap()) Fail(Indexed(key, i), "expected a map with the keys " + Join(keys));
      CheckKeys(list[i], Indexed(key, i), keys);
    }
    return list;
  }

  // V of the springs: k/2 (s - rest)^2 for a coordinate s, k/2 (|P1 - P2| - rest)^2 between two
  // points (k/2 |P1 - P2|^2 without a rest length: no square root).
  GiNaC::ex ReadSprings() const {
    const YAML::Node springs = CheckedList("springs", kSpringKeys);
    GiNaC::ex potential = 0;
    for (std::size_t i = 0; i < springs.size(); ++i) {
      const std::string where = Indexed("springs", i);
      const YAML::Node node = springs[i];
      if (!node["stiffness"]) Fail(where + ".stiffness", "missing required key");
      const GiNaC::ex stiffness = Positional(node["stiffness"], where + ".stiffness");
      const GiNaC::ex rest = node["rest"] ? Positional(node["rest"], where + ".rest") : 0;
      const Element element = ReadElement(node, where);
      if (element.coordinate) {
        potential += stiffness * GiNaC::pow(*element.coordinate - rest, 2) / 2;
        continue;
      }
      const GiNaC::ex squared =
          GiNaC::pow(element.difference[0], 2) + GiNaC::pow(element.difference[1], 2);
      potential += rest.is_zero() ? stiffness * squared / 2
                                  : stiffness * GiNaC::pow(GiNaC::sqrt(squared) - rest, 2) / 2;
    }
    return potential;
  }

  // The joints: P1 - P2 = 0, two constraints each (x, y).
  void ReadJoints(PlanarBodies& result) const {
    const YAML::Node joints = CheckedList("joints", kJointKeys);
    for (std::size_t i = 0; i < joints.size(); ++i) {
      const std::string where = Indexed("joints", i);
      if (!joints[i]["between"]) Fail(where + ".between", "missing required key");
      const Element element = ReadElement(joints[i], where);
      for (std::size_t axis = 0; axis < 2; ++axis) {
        result.loop_constraints.push_back(element.difference[axis]);
        result.loop_constraint_names.push_back(where + (axis == 0 ? ".x" : ".y"));
      }
    }
  }

  // R of the dampers: d/2 s'^2 for a coordinate, d/2 (d|P1 - P2|/dt)^2 between two points, with
  // d|D|/dt = D . D' / |D|.
  GiNaC::ex ReadDampers() const {
    const YAML::Node dampers = CheckedList("dampers", kDamperKeys);
    GiNaC::ex dissipation = 0;
    for (std::size_t i = 0; i < dampers.size(); ++i) {
      const std::string where = Indexed("dampers", i);
      const YAML::Node node = dampers[i];
      if (!node["damping"]) Fail(where + ".damping", "missing required key");
      const GiNaC::ex damping = Positional(node["damping"], where + ".damping");
      const Element element = ReadElement(node, where);
      if (element.coordinate) {
        dissipation += damping * GiNaC::pow(Rate(*element.coordinate), 2) / 2;
        continue;
      }
      const Vector2& d = element.difference;
      const GiNaC::ex squared = GiNaC::pow(d[0], 2) + GiNaC::pow(d[1], 2);
      const GiNaC::ex stretch_power = d[0] * Rate(d[0]) + d[1] * Rate(d[1]);
      dissipation += damping * GiNaC::pow(stretch_power, 2) / (2 * squared);
    }
    return dissipation;
  }

  // Column k of B from the virtual work of actuator k, u_k (dP/dq)^T direction for a force,
  // u_k torque (dtheta/dq - dtheta_reaction/dq)^T for a torque.
  GiNaC::matrix ReadActuators(const std::vector<std::string>& input_names) const {
    const YAML::Node actuators = Entry("actuators");
    if (!actuators.IsMap()) {
      Fail("actuators",
           "expected a map of input name: {on: body, force: [x, y]} or {on: body, "
           "torque: expression}");
    }
    for (const auto& entry : actuators) {
      const std::string name = entry.first.IsScalar() ? entry.first.Scalar() : "";
      if (!Contains(input_names, name)) {
        Fail("actuators." + name, "not an input (inputs: " + Join(input_names) + ")");
      }
    }
    const auto dof = unsigned(coordinates_.size());
    GiNaC::matrix input_matrix(dof, unsigned(input_names.size()));
    for (std::size_t k = 0; k < input_names.size(); ++k) {
      const std::string where = "actuators." + input_names[k];
      const YAML::Node node = std::as_const(actuators)[input_names[k]];
      if (!node) Fail(where, "missing: every input needs an actuator");
      if (!node.IsMap()) Fail(where, "expected a map with the keys " + Join(kActuatorKeys));
      CheckKeys(node, where, kActuatorKeys);
      if (!node["on"]) Fail(where + ".on", "missing required key (the body it acts on)");
      const Body* body = ReadBodyName(node["on"], where + ".on", /*allow_ground=*/false);
      if (bool(node["force"]) == bool(node["torque"])) {
        Fail(where, "expected exactly one of force: [x, y] or torque: <expression>");
      }
      if (node["force"]) {
        if (node["reaction"]) Fail(where + ".reaction", "only a torque has a reaction body");
        const Vector2 direction = ReadVector2(node["force"], where + ".force");
        const Vector2 at = node["at"] ? ReadVector2(node["at"], where + ".at")
                                      : Vector2{GiNaC::ex(0), GiNaC::ex(0)};
        const Vector2 point = Attached(body, at);
        for (unsigned j = 0; j < dof; ++j) {
          input_matrix(j, unsigned(k)) = (point[0].diff(coordinates_[j]) * direction[0] +
                                          point[1].diff(coordinates_[j]) * direction[1])
                                             .expand();
        }
        continue;
      }
      if (node["at"]) Fail(where + ".at", "a torque acts on the whole body; 'at' is for forces");
      const GiNaC::ex torque = Positional(node["torque"], where + ".torque");
      GiNaC::ex angle = body->angle;
      if (node["reaction"]) {
        if (const Body* reaction = ReadBodyName(node["reaction"], where + ".reaction", true)) {
          angle -= reaction->angle;
        }
      }
      for (unsigned j = 0; j < dof; ++j) {
        input_matrix(j, unsigned(k)) = (torque * angle.diff(coordinates_[j])).expand();
      }
    }
    return input_matrix;
  }

  const YAML::Node& root_;
  const std::string& source_;
  const ExpressionReader& read_;
  const std::vector<std::string>& coordinate_names_;
  const std::vector<GiNaC::realsymbol>& coordinates_;
  const std::vector<GiNaC::realsymbol>& velocities_;
  mutable TimeDerivative rate_;  // its memo only: Rate is a function of its argument
  std::vector<std::pair<std::string, Body>> bodies_;  // in the file's order
};

}  // namespace

PlanarBodies ReadPlanarBodies(const YAML::Node& root,
                              const std::string& source,
                              const ExpressionReader& read,
                              const std::vector<std::string>& coordinate_names,
                              const std::vector<GiNaC::realsymbol>& coordinates,
                              const std::vector<GiNaC::realsymbol>& velocities,
                              const std::vector<std::string>& input_names) {
  return Reader(root, source, read, coordinate_names, coordinates, velocities).Read(input_names);
}

}  // namespace servokit::detail
