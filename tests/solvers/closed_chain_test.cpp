// The inverse model of closed kinematic chains (solvers/closed_chain.h), against references
// derived here, not by the code under test:
//   - the paper's rotational arm (Sect. 4.2) written in redundant coordinates with its joint as
//     two loop constraints, solved by every method, against the same arm in minimal coordinates
//     (models/rotational_arm.yaml): the same u_d and motion, and multipliers that are link 2's
//     inertia forces (Newton's law for the link, whose only horizontal force is the joint's);
//   - the gantry crane in absolute coordinates against its feedforward in closed form from the
//     load's equations (lambda from zL'', the trolley from xL'', the rope from the constraint);
//   - Andrews' squeezing mechanism against the DAE test set's reference solution, forward, and
//     back to its constant motor torque.
#include "solvers/closed_chain.h"

#include <catch2/catch.hpp>
#include <cmath>
#include <string>
#include <vector>

#include "integrators/dense_output.h"
#include "solvers/forward_model.h"
#include "solvers/inverse_model.h"
#include "solvers/solve_settings.h"
#include "solvers/verification.h"
#include "tests/solvers/solve_support.h"
#include "tests/test_paths.h"

namespace servokit {
namespace {

using testing::ClassifiedModel;
using testing::LoadClassified;
using testing::ModelPath;
using testing::SolveUsable;
using testing::TestDataPath;

// tests/data/loops/rotational_arm_redundant.yaml and models/rotational_arm.yaml.
constexpr double kLinkLength = 1.0, kLinkMass = 3.438;

// The largest entry of a list of vectors (a scale for relative comparisons).
double Largest(const std::vector<Eigen::VectorXd>& rows) {
  double largest = 0.0;
  for (const Eigen::VectorXd& row : rows)
    largest = std::max(largest, row.lpNorm<Eigen::Infinity>());
  return largest;
}

// The forward check must keep the loops closed to round-off, and pass unless told otherwise.
void RequireVerified(const Model& model,
                     const OutputTrajectory& trajectory,
                     const FeedforwardSolution& solution,
                     bool must_pass = true) {
  const Verification verification = VerifyFeedforward(model, trajectory, solution);
  INFO(ToString(solution.method) << ": error " << verification.max_tracking_error << ", bound "
                                 << verification.bound << ", " << verification.summary.message);
  CHECK(verification.summary.IsUsable());
  if (must_pass) CHECK(verification.passed);
  REQUIRE(verification.max_constraint_violation.has_value());
  CHECK(*verification.max_constraint_violation < 1e-12);
}

// The state and input of a solution at t, from its continuous extension.
struct StateAt {
  Eigen::VectorXd q, q_dot, u;
};
StateAt Evaluated(const FeedforwardSolution& solution, double t) {
  StateAt state;
  std::string why;
  INFO("t = " << t);
  REQUIRE(solution.extension->Evaluate(t, state.q, state.q_dot, state.u, why));
  return state;
}

// Coordinate invariance of the inverse: the arm in (alpha, x2, y2, theta2) with the joint closed
// by c = 0 must give the minimal model's u_d and alpha, with theta2 = alpha + beta, to the
// methods' tolerances (1e-6 of max |u_d|: both runs err independently, at rtol 1e-10 where the
// method takes one). Below s/l = 2/3 the zero dynamics are stable (every forward method); at
// s = l unstable (stable inversion, non-causal, with its own pre-actuation). The multipliers are
// link 2's inertia: the link's centre moves only under the joint force C^T lambda =
// (lambda1, lambda2) in x2 and y2, so lambda = m (x2'', y2''), here by a fourth-order central
// difference of the solution's own x2', y2' on its sample grid.
TEST_CASE("a closed chain's inverse is its minimal-coordinate twin's, by every method",
          "[solvers]") {
  struct Case {
    std::string s;
    std::vector<SolverMethod> methods;
  };
  for (const Case& tested : {Case{"0.5",
                                  {SolverMethod::kAuto, SolverMethod::kRadau, SolverMethod::kBdf,
                                   SolverMethod::kNormalForm, SolverMethod::kEuler}},
                             Case{"1.0", {SolverMethod::kStableInversion}}}) {
    const ClassifiedModel minimal =
        LoadClassified(ModelPath("rotational_arm.yaml"), {{"s", tested.s}});
    const ClassifiedModel loops =
        LoadClassified(TestDataPath("loops/rotational_arm_redundant.yaml"), {{"s", tested.s}});
    const RestToRestTrajectory trajectory(Eigen::VectorXd::Zero(1), Eigen::VectorXd::Ones(1), 0.0,
                                          1.0);
    for (const SolverMethod method : tested.methods) {
      INFO("s = " << tested.s << ", " << ToString(method));
      InverseModelOptions options;
      options.sample_time = 1e-3;
      // Radau IIA runs at its defaults (rtol 1e-8): at 1e-10 its forward check fails on the
      // minimal arm too (1.6e-8 against a bound of 1e-8), an index-3 DAE's order reduction.
      const bool radau = method == SolverMethod::kRadau;
      if (method == SolverMethod::kBdf || method == SolverMethod::kNormalForm ||
          method == SolverMethod::kAuto) {
        options.rtol = 1e-10;
        options.atol = 1e-12;
      }
      const FeedforwardSolution reference = SolveUsable(minimal, trajectory, method, 2.0, options);
      const FeedforwardSolution solution = SolveUsable(loops, trajectory, method, 2.0, options);
      REQUIRE(solution.multipliers.size() == solution.times.size());
      // Radau IIA's u_d on the loop form misses its forward check by a factor of two (1.9e-6
      // against 1.0e-6; 8.3e-8 on the minimal form): known, and said by the check itself.
      RequireVerified(loops.model, trajectory, solution, !radau);
      if (method == SolverMethod::kEuler) continue;  // first order: both lag by about a step
      // Radau's inputs and multipliers are the DAE's index-2 and -3 parts, whose errors at
      // rtol 1e-8 are some thousand times rtol relative to their size.
      const double input_tolerance = radau ? 1e-5 : 1e-6;
      const double multiplier_tolerance = radau ? 1e-2 : 1e-5;
      const double input_scale = Largest(reference.u);
      for (int k = 0; k <= 200; ++k) {
        const double t = 0.01 * k;
        const StateAt expected = Evaluated(reference, t), state = Evaluated(solution, t);
        const double alpha = expected.q(0), beta = expected.q(1);
        INFO("t = " << t);
        CHECK(std::abs(state.u(0) - expected.u(0)) <= input_tolerance * input_scale);
        CHECK(std::abs(state.q(0) - alpha) <= 1e-6);
        CHECK(std::abs(state.q(3) - (alpha + beta)) <= 1e-6);
        // On the loop: link 2's centre half a link beyond the arm's end.
        const Eigen::VectorXd& q = state.q;
        const double closure = radau ? 1e-7 : 1e-9;
        CHECK(std::abs(q(1) - kLinkLength * (std::cos(q(0)) + std::cos(q(3)) / 2)) <= closure);
        CHECK(std::abs(q(2) - kLinkLength * (std::sin(q(0)) + std::sin(q(3)) / 2)) <= closure);
      }
      const double multiplier_scale = Largest(solution.multipliers);
      const auto centre_velocity = [&](std::size_t i) -> Eigen::Vector2d {
        return solution.q_dot[i].segment(1, 2);
      };
      for (std::size_t i = 2; i + 2 < solution.times.size(); ++i) {
        const double h = solution.times[i + 1] - solution.times[i];
        const Eigen::Vector2d acceleration = (centre_velocity(i - 2) - 8 * centre_velocity(i - 1) +
                                              8 * centre_velocity(i + 1) - centre_velocity(i + 2)) /
                                             (12 * h);
        INFO("t = " << solution.times[i]);
        CHECK((solution.multipliers[i] - kLinkMass * acceleration).lpNorm<Eigen::Infinity>() <=
              multiplier_tolerance * multiplier_scale);
      }
    }
  }
}

// The five-bar (models/five_bar.yaml: crank angles and the couplers' absolute angles, the
// coupler joint two constraints) against the same linkage in its two crank angles with the
// closure solved by atan2 and sqrt (tests/data/loops/five_bar_minimal.yaml): the same u_d and
// crank motion by auto (BDF: stable, lightly damped zero dynamics), to the solves' tolerance.
// And the linearized inverse, a linear method, gives the arm's u_d in either coordinates.
TEST_CASE("the five-bar's inverse in redundant and in minimal coordinates", "[solvers]") {
  const ClassifiedModel loops = LoadClassified(ModelPath("five_bar.yaml"));
  const ClassifiedModel minimal = LoadClassified(TestDataPath("loops/five_bar_minimal.yaml"));
  const RestToRestTrajectory trajectory(Eigen::VectorXd::Ones(1), Eigen::VectorXd::Constant(1, 1.1),
                                        0.0, 2.0);
  InverseModelOptions options;
  options.sample_time = 0.01;
  options.rtol = 1e-10;
  options.atol = 1e-12;
  const FeedforwardSolution solution =
      SolveUsable(loops, trajectory, SolverMethod::kAuto, 4.0, options);
  const FeedforwardSolution reference =
      SolveUsable(minimal, trajectory, SolverMethod::kAuto, 4.0, options);
  CHECK(solution.method == reference.method);
  REQUIRE(solution.times == reference.times);
  const double input_scale = Largest(reference.u);
  for (std::size_t i = 0; i < solution.times.size(); ++i) {
    INFO("t = " << solution.times[i]);
    CHECK(std::abs(solution.u[i](0) - reference.u[i](0)) <= 1e-6 * input_scale);
    CHECK(std::abs(solution.q[i](0) - reference.q[i](0)) <= 1e-8);  // the cranks
    CHECK(std::abs(solution.q[i](1) - reference.q[i](1)) <= 1e-8);
  }
  RequireVerified(loops.model, trajectory, solution);

  const ClassifiedModel arm = LoadClassified(ModelPath("rotational_arm.yaml"), {{"s", "0.5"}});
  const ClassifiedModel arm_loops =
      LoadClassified(TestDataPath("loops/rotational_arm_redundant.yaml"), {{"s", "0.5"}});
  const RestToRestTrajectory small(Eigen::VectorXd::Zero(1), Eigen::VectorXd::Constant(1, 0.01),
                                   0.0, 1.0);
  InverseModelOptions linear;
  linear.sample_time = 0.01;
  const FeedforwardSolution arm_linear =
      SolveUsable(arm, small, SolverMethod::kLinearized, 2.0, linear);
  const FeedforwardSolution loops_linear =
      SolveUsable(arm_loops, small, SolverMethod::kLinearized, 2.0, linear);
  REQUIRE(loops_linear.times == arm_linear.times);
  for (std::size_t i = 0; i < arm_linear.times.size(); ++i) {
    CHECK(std::abs(loops_linear.u[i](0) - arm_linear.u[i](0)) <= 1e-8 * Largest(arm_linear.u));
  }
}

// Value, first and second time derivative of a function of t, with the arithmetic that carries
// them (product and chain rules): the crane's closed form needs x'' and r'' of quantities that
// are themselves formulas in y_d and its derivatives.
struct Jet {
  double value, rate, acceleration;
};
Jet operator+(Jet a, Jet b) {
  return {a.value + b.value, a.rate + b.rate, a.acceleration + b.acceleration};
}
Jet operator-(Jet a, Jet b) {
  return {a.value - b.value, a.rate - b.rate, a.acceleration - b.acceleration};
}
Jet operator*(Jet a, Jet b) {
  return {a.value * b.value, a.rate * b.value + a.value * b.rate,
          a.acceleration * b.value + 2 * a.rate * b.rate + a.value * b.acceleration};
}
Jet operator*(double a, Jet b) { return {a * b.value, a * b.rate, a * b.acceleration}; }
Jet Reciprocal(Jet a) {
  const double inverse = 1.0 / a.value;
  return {inverse, -a.rate * inverse * inverse,
          2 * a.rate * a.rate * inverse * inverse * inverse - a.acceleration * inverse * inverse};
}
Jet Sqrt(Jet a) {  // s^2 = a: 2 s s' = a', 2 s s'' + 2 s'^2 = a''
  const double root = std::sqrt(a.value);
  const double rate = a.rate / (2 * root);
  return {root, rate, (a.acceleration - 2 * rate * rate) / (2 * root)};
}

// models/gantry_crane_absolute.yaml.
constexpr double kTrolleyMass = 10.0, kDrumMass = 2.0, kLoadMass = 5.0, kGravity = 9.81,
                 kRopeAtZero = 2.0;

// The crane's feedforward in closed form. With M = diag(mt, mw, m, m), f = (0, 0, 0, -m g) and
// c = (xL - x)^2 + zL^2 - (L0 + r)^2, the rows of M q'' + f = B u + C^T lambda are
//   mt x'' = F - 2 (xL - x) lambda,   mw r'' = W - 2 (L0 + r) lambda,
//   m xL'' = 2 (xL - x) lambda,       m zL'' - m g = 2 zL lambda.
// The load's rows give lambda = m (zL'' - g) / (2 zL) and xL - x = m xL'' / (2 lambda); the
// constraint gives L0 + r = sqrt((xL - x)^2 + zL^2); the first two rows then give F and W.
struct CraneFeedforward {
  double x, r, x_dot, r_dot, force, winch, multiplier;
};

CraneFeedforward CraneInClosedForm(const OutputTrajectory& trajectory, double t) {
  const auto jet = [&](int output, int order) {
    return Jet{trajectory.Derivative(t, order)(output), trajectory.Derivative(t, order + 1)(output),
               trajectory.Derivative(t, order + 2)(output)};
  };
  const Jet load_x = jet(0, 0), load_z = jet(1, 0);
  const Jet load_x_acceleration = jet(0, 2), load_z_acceleration = jet(1, 2);
  const Jet multiplier =
      (kLoadMass / 2) * (load_z_acceleration - Jet{kGravity, 0, 0}) * Reciprocal(load_z);
  const Jet offset = (kLoadMass / 2) * load_x_acceleration * Reciprocal(multiplier);  // xL - x
  const Jet trolley = load_x - offset;
  const Jet rope = Sqrt(offset * offset + load_z * load_z);  // L0 + r
  return {trolley.value,
          rope.value - kRopeAtZero,
          trolley.rate,
          rope.rate,
          kTrolleyMass * trolley.acceleration + 2 * offset.value * multiplier.value,
          kDrumMass * rope.acceleration + 2 * rope.value * multiplier.value,
          multiplier.value};
}

// The crane in absolute coordinates is flat (mixed realization, index 5): the algebraic inverse
// must reproduce the closed form to 1e-8, and its forward check keep the rope taut.
TEST_CASE("the gantry crane in absolute coordinates is inverted in closed form", "[solvers]") {
  ClassifiedModel crane{LoadModel(ModelPath("gantry_crane_absolute.yaml")), {}};
  ClassificationOptions at_rest;
  at_rest.operating_point.y0 = Eigen::Vector2d(0.0, 2.0);
  at_rest.operating_point.q_guess = Eigen::Vector4d(0.0, 0.0, 0.0, 2.0);
  Workspace workspace(crane.model);
  crane.classification = Classify(crane.model, workspace, at_rest);
  REQUIRE(crane.classification.flat);
  // Out by 1 m and up by 0.5 m in 2 s: the load swings ahead and behind the trolley.
  const RestToRestTrajectory trajectory(Eigen::Vector2d(0.0, 2.0), Eigen::Vector2d(1.0, 1.5), 0.0,
                                        2.0);
  InverseModelOptions options;
  options.sample_time = 0.01;
  const FeedforwardSolution solution =
      SolveUsable(crane, trajectory, SolverMethod::kAuto, 3.0, options);
  CHECK(solution.method == SolverMethod::kAlgebraic);
  REQUIRE(solution.times.size() == 301);
  for (std::size_t i = 0; i < solution.times.size(); ++i) {
    const CraneFeedforward expected = CraneInClosedForm(trajectory, solution.times[i]);
    INFO("t = " << solution.times[i]);
    const auto near = [](double value, double reference) {
      return std::abs(value - reference) <= 1e-8 * (1.0 + std::abs(reference));
    };
    CHECK(near(solution.q[i](0), expected.x));
    CHECK(near(solution.q[i](1), expected.r));
    CHECK(near(solution.q_dot[i](0), expected.x_dot));
    CHECK(near(solution.q_dot[i](1), expected.r_dot));
    CHECK(near(solution.u[i](0), expected.force));
    CHECK(near(solution.u[i](1), expected.winch));
    CHECK(near(solution.multipliers[i](0), expected.multiplier));
  }
  RequireVerified(crane.model, trajectory, solution);
}

}  // namespace
}  // namespace servokit

namespace servokit {
namespace {

// Andrews' squeezing mechanism (tests/data/loops/andrews_squeezer.yaml): the test set's
// reference at t = 0.03 s (PSIDE at tolerance 1e-14), angles and their rates.
constexpr double kSqueezerEnd = 0.03;
constexpr double kMotorTorque = 0.033;  // N m, constant
const std::vector<double> kSqueezerAngles = {
    0.1581077119629904e2, -0.1575637105984298e2, 0.4082224013073101e-1, -0.5347301163226948,
    0.5244099658805304,   0.5347301163226948,    0.1048080741042263e1};
const std::vector<double> kSqueezerRates = {
    0.1139920302151208e4, -0.1424379294994111e4, 0.1103291221937134e2, 0.1929337464421385e2,
    0.5735699284790808,   -0.1929337464421385e2, 0.3231791658026955};

// The crank angle of a forward run, as a desired output: its value and rate from CVODE's
// interpolant of the run, its acceleration from the model at that state.
class SimulatedCrankAngle final : public OutputTrajectory {
 public:
  SimulatedCrankAngle(const Model& model, DenseOutput states)
      : model_(model), states_(std::move(states)) {}
  Eigen::VectorXd Derivative(double t, int order) const override {
    const Eigen::VectorXd state = states_(t);
    const Eigen::Index f = state.size() / 2;
    if (order == 0) return state.head(1);
    if (order == 1) return state.segment(f, 1);
    Eigen::VectorXd q_ddot;
    std::string why;
    ForwardModel forward(model_);
    REQUIRE(forward.Acceleration(state.head(f), state.tail(f),
                                 Eigen::VectorXd::Constant(1, kMotorTorque), q_ddot, why));
    if (order == 2) return q_ddot.head(1);
    return Eigen::VectorXd::Zero(1);  // beyond the derivatives it declares continuous
  }
  Eigen::Index outputs() const override { return 1; }
  int continuous_derivatives() const override { return 2; }
  std::vector<double> breakpoints() const override { return {0.0, kSqueezerEnd}; }

 private:
  const Model& model_;
  DenseOutput states_;
};

// The forward simulation --verify runs (CVODE's BDF on the index-1 form, projected onto the
// loops after every step) driven by the constant motor torque from the test set's consistent
// start must reproduce the test set's reference at t = 0.03 s: the crank has turned 2.5 times
// and runs at 1140 rad/s. Then its crank angle, taken as the desired output, must be inverted
// back to the constant torque (the mechanism has one degree of freedom: flat).
TEST_CASE("Andrews' squeezing mechanism: the forward run and its inverse", "[solvers]") {
  const Model squeezer = LoadModel(TestDataPath("loops/andrews_squeezer.yaml"));
  REQUIRE(squeezer.num_constraints() == 6);
  ForwardModel forward(squeezer);
  const Eigen::Index f = forward.dof();
  Eigen::VectorXd start = Eigen::VectorXd::Zero(2 * f);
  start.head(f) = squeezer.operating_point_start();  // the test set's start, at rest
  IntegratorOptions options;
  options.rtol = 1e-12;
  options.atol = 1e-12;
  Eigen::VectorXd end;
  DenseOutput states(2 * f);
  const SolveSummary run = SimulateForward(
      forward,
      [](double, Eigen::VectorXd& u, std::string&) {
        u = Eigen::VectorXd::Constant(1, kMotorTorque);
        return true;
      },
      0.0, start, kSqueezerEnd, {}, options,
      [&](double, const Eigen::VectorXd& y, const Eigen::VectorXd&) {
        end = y;
        return true;
      },
      &states);
  INFO(run.message);
  REQUIRE(run.IsUsable());
  for (Eigen::Index i = 0; i < f; ++i) {
    INFO("angle " << i);
    CHECK(end(i) == Approx(kSqueezerAngles[std::size_t(i)]).epsilon(1e-8).margin(1e-8));
    // Rates to 1e-8 of the fastest (the crank's 1424 rad/s): the slow links' errors are the
    // fast ones' shared out by the loops.
    CHECK(end(f + i) == Approx(kSqueezerRates[std::size_t(i)]).margin(1.5e-5));
  }
  CHECK(forward.ConstraintViolation(end.head(f)) < 1e-14);

  ClassifiedModel problem{squeezer, {}};
  Workspace workspace(problem.model);
  problem.classification = Classify(problem.model, workspace);
  REQUIRE(problem.classification.flat);
  const SimulatedCrankAngle crank(squeezer, std::move(states));
  InverseModelOptions inverse;
  inverse.sample_time = 0.001;
  const FeedforwardSolution solution =
      SolveUsable(problem, crank, SolverMethod::kAuto, kSqueezerEnd, inverse);
  CHECK(solution.method == SolverMethod::kAlgebraic);
  REQUIRE(solution.times.size() == 31);
  for (std::size_t i = 0; i < solution.times.size(); ++i) {
    INFO("t = " << solution.times[i]);
    CHECK(solution.u[i](0) == Approx(kMotorTorque).epsilon(1e-6));
  }
  for (Eigen::Index i = 0; i < f; ++i) {
    CHECK(solution.q.back()(i) ==
          Approx(kSqueezerAngles[std::size_t(i)]).epsilon(1e-8).margin(1e-8));
  }
}

}  // namespace
}  // namespace servokit
