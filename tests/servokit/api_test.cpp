// The public C++ API (servokit/servokit.h) against closed forms of the paper's mass on a car
// (Sect. 3, Eqs. 26-27, 36) and of a two-mass chain, and against the toolkit's own defaults.
// Only the public header is used, except in the defaults test, which compares with the
// internal options structs the API stands for.
#include <unistd.h>

#include <catch2/catch.hpp>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <sstream>

#include "analysis/linear_zero_dynamics.h"
#include "analysis/options.h"
#include "modeling/model_generators.h"
#include "servokit/servokit.h"
#include "tests/test_files.h"
#include "tests/test_paths.h"

namespace sk = servokit::api;
using servokit::testing::ModelPath;
using servokit::testing::ReadFile;

namespace {

constexpr double kPi = 3.14159265358979323846;

// Mass on car, d = 0 (paper Eq. 36 with y_d = 0): m2 sin^2(alpha) s'' + k s = 0, so the zero
// dynamics are +-i sqrt(k / (m2 sin^2 alpha)); m2 = 2, k = 5 (models/mass_on_car.yaml).
double UndampedFrequency(double alpha) {
  return std::sqrt(5.0 / (2.0 * std::pow(std::sin(alpha), 2)));
}

// Eq. (65) and its second and fourth derivatives in time: y0 + (yf - y0) p(tau), tau = t / T.
struct RestToRest {
  double y0, yf, T;
  double Derivative(double t, int order) const {
    const double coefficients[10] = {0, 0, 0, 0, 0, 126, -420, 540, -315, 70};
    double value = 0.0;
    for (int power = order; power <= 9; ++power) {
      double falling = 1.0;
      for (int k = 0; k < order; ++k) falling *= power - k;
      value += coefficients[power] * falling * std::pow(t / T, power - order);
    }
    return (order == 0 ? y0 : 0.0) + (yf - y0) * value / std::pow(T, order);
  }
};

}  // namespace

TEST_CASE("the API's default options are the toolkit's", "[servokit]") {
  // The defaults are written once, in the toolkit's option structs; the API's start from them
  // (DefaultAnalyzeOptions, ...). This checks that each field is wired to its own.
  const sk::AnalyzeOptions analyze;
  const servokit::ClassificationOptions classification;
  CHECK(analyze.rank_tolerance == classification.rank_tolerance);
  CHECK(analyze.imaginary_axis_tolerance == classification.imaginary_axis_tolerance);
  const servokit::LinearZeroDynamicsOptions linear;
  CHECK(analyze.eigenvalues == linear.arpack.eigenvalues);
  CHECK(analyze.shift == linear.shift);
  CHECK(analyze.eigen_solver == linear.solver);
  CHECK(analyze.which == linear.target);
  const sk::ChainModel chain;
  const servokit::ChainOptions chain_options;
  CHECK(chain.masses == chain_options.masses);
  CHECK(chain.mass == chain_options.mass);
  CHECK(chain.stiffness == chain_options.stiffness);
  CHECK(chain.damping == chain_options.damping);
  CHECK(chain.input_mass == chain_options.input_mass);
  CHECK(chain.output_mass == chain_options.output_mass);
  const sk::BeamModel beam;
  const servokit::BeamOptions beam_options;
  CHECK(beam.elements == beam_options.elements);
  CHECK(beam.length == beam_options.length);
  CHECK(beam.hub_inertia == beam_options.hub_inertia);
  CHECK(beam.mass_per_length == beam_options.mass_per_length);
  CHECK(beam.bending_stiffness == beam_options.bending_stiffness);
  CHECK(beam.damping_factor == beam_options.damping_factor);
}

TEST_CASE("analyze through the API: the undamped mass on car at 5 deg vibrates at 2.887 Hz",
          "[servokit][paper]") {
  const sk::Model model =
      sk::Model::FromFile(ModelPath("mass_on_car.yaml"), {{"alpha", "5 deg"}, {"d", "0"}});
  CHECK(model.kind() == sk::ModelKind::kMultibody);
  CHECK(model.name() == "mass_on_car");
  CHECK(model.dof() == 2);
  CHECK(model.coordinate_names() == std::vector<std::string>{"x", "s"});  // the model file's
  CHECK(model.input_names() == std::vector<std::string>{"F"});
  CHECK(model.output_names() == std::vector<std::string>{"y1"});
  const sk::Analysis analysis = sk::Analyze(model);
  CHECK(analysis.realization == sk::Realization::kNonIdealOrthogonal);
  CHECK(sk::ToString(analysis.realization) == "non-ideal-orthogonal");
  CHECK(analysis.relative_degree == std::vector<int>{2});
  CHECK(analysis.zero_dynamics.stability == sk::Stability::kCritical);
  REQUIRE(analysis.zero_dynamics.eigenvalues.size() == 2);
  const double omega = UndampedFrequency(5.0 * kPi / 180.0);
  for (const auto& eigenvalue : analysis.zero_dynamics.eigenvalues) {
    CHECK(eigenvalue.real() == Approx(0.0).margin(1e-9));  // eigen round-off
    CHECK(std::abs(eigenvalue.imag()) == Approx(omega).epsilon(1e-10));
  }
  REQUIRE(analysis.zero_dynamics.modes.size() == 1);
  CHECK(analysis.zero_dynamics.modes[0].frequency_hz == Approx(omega / (2 * kPi)).epsilon(1e-10));
  CHECK(analysis.json.find("\"realization\": \"non-ideal-orthogonal\"") != std::string::npos);
}

TEST_CASE("a model from a string is the model from its file", "[servokit]") {
  const std::string yaml = ReadFile(ModelPath("mass_on_car.yaml"));
  const sk::Model from_string = sk::Model::FromString(yaml, "inline", {{"alpha", "30 deg"}});
  const sk::Model from_file =
      sk::Model::FromFile(ModelPath("mass_on_car.yaml"), {{"alpha", "30 deg"}});
  CHECK(from_string.source() == "inline");
  CHECK(from_string.parameters() == from_file.parameters());
  const sk::Analysis a = sk::Analyze(from_string), b = sk::Analyze(from_file);
  CHECK(a.zero_dynamics.eigenvalues == b.zero_dynamics.eigenvalues);
}

TEST_CASE("API errors carry their kind", "[servokit]") {
  const auto kind_of = [](auto&& call) {
    try {
      call();
    } catch (const servokit::Error& error) {
      return error.kind();
    }
    return servokit::ErrorKind::kOther;
  };
  CHECK(kind_of([] { sk::Model::FromString("name: x\ncoordinates: [q]\n", "broken"); }) ==
        servokit::ErrorKind::kModel);
  CHECK(kind_of([] {
          sk::Model::FromFile(ModelPath("mass_on_car.yaml"), {{"nope", "1"}});
        }) == servokit::ErrorKind::kUsage);
  const sk::Model model = sk::Model::FromFile(ModelPath("mass_on_car.yaml"));
  sk::ThresholdQuery query;
  query.parameter = "alpha";
  query.low = 0.1;
  query.high = 1.0;
  query.parameter = "weather";
  CHECK(kind_of([&] { sk::LocateThresholds(model, query); }) == servokit::ErrorKind::kUsage);
}

TEST_CASE("sweep through the API, in memory and to files, follows the closed form", "[servokit]") {
  const sk::Model model = sk::Model::FromFile(ModelPath("mass_on_car.yaml"), {{"d", "0"}});
  const std::vector<sk::SweepAxis> axes = {{"alpha", {0.2, 0.5, 1.0, 1.5}}};
  const std::vector<sk::SweepPoint> points = sk::Sweep(model, axes);
  REQUIRE(points.size() == 4);
  for (const sk::SweepPoint& point : points) {
    REQUIRE(point.solved);
    CHECK(point.stability == sk::Stability::kCritical);
    REQUIRE(point.eigenvalues.size() == 2);
    const double omega = UndampedFrequency(point.parameter_values[0]);
    CHECK(std::abs(point.eigenvalues[0].imag()) == Approx(omega).epsilon(1e-10));
    // Undamped: the largest real part is 0 up to round-off, each eigenvalue's mode is omega / 2
    // pi with damping ratio 0.
    CHECK(point.max_real_part == Approx(0.0).margin(1e-9 * omega));
    REQUIRE(point.eigenvalue_modes.size() == 2);
    for (const sk::OscillatoryMode& mode : point.eigenvalue_modes) {
      CHECK(mode.frequency_hz == Approx(omega / (2 * kPi)).epsilon(1e-10));
      CHECK(mode.damping_ratio == Approx(0.0).margin(1e-9));
    }
  }
  const std::filesystem::path directory =
      std::filesystem::temp_directory_path() / "servokit_api_sweep_test";
  std::filesystem::remove_all(directory);
  CHECK(sk::SweepToFiles(model, axes, directory.string()) == 4);
  std::istringstream rows(ReadFile(directory / "points.csv"));
  std::string line;
  std::getline(rows, line);
  // alpha is given in degrees by the model file: its column is alpha_deg, in degrees.
  CHECK(line.rfind("alpha_deg,realization,", 0) == 0);
  int count = 0;
  while (std::getline(rows, line)) ++count;
  CHECK(count == 4);
  std::filesystem::remove_all(directory);
}

TEST_CASE("a sweep stops after the block in which its caller asks it to", "[servokit]") {
  // 5000 points are two blocks (SweepOptions::stop_requested: 4096, then the rest); asked to
  // stop at the first question, the sweep returns the first block, the grid's first points.
  const sk::Model model = sk::Model::FromFile(ModelPath("mass_on_car.yaml"), {{"d", "0"}});
  std::vector<double> alphas(5000);
  for (std::size_t i = 0; i < alphas.size(); ++i) alphas[i] = 0.1 + 1e-4 * double(i);
  sk::SweepOptions options;
  int questions = 0;
  options.stop_requested = [&questions] { return ++questions >= 1; };
  const std::vector<sk::SweepPoint> first_block = sk::Sweep(model, {{"alpha", alphas}}, options);
  CHECK(questions == 1);
  REQUIRE(first_block.size() == 4096);
  CHECK(first_block.back().parameter_values[0] == alphas[4095]);
  options.stop_requested = [&questions] { return ++questions < 0; };  // never
  CHECK(sk::Sweep(model, {{"alpha", alphas}}, options).size() == 5000);
  CHECK(questions == 3);  // asked after each of the two blocks
}

TEST_CASE("thresholds through the API: over-damped below 9.1 deg at d = 1", "[servokit][paper]") {
  // m2 sin^2(alpha) s^2 + d s + k = 0 has a double root where d^2 = 4 m2 k sin^2(alpha):
  // alpha = asin(sqrt(1 / 40)) = 9.0974 deg.
  const sk::Model model = sk::Model::FromFile(ModelPath("mass_on_car.yaml"), {{"d", "1"}});
  sk::ThresholdQuery query;
  query.parameter = "alpha";
  query.low = 1.0 * kPi / 180.0;
  query.high = 80.0 * kPi / 180.0;
  query.event = sk::ThresholdEvent::kOscillation;
  const std::vector<sk::Threshold> thresholds = sk::LocateThresholds(model, query);
  REQUIRE(thresholds.size() == 1);
  CHECK(thresholds[0].value == Approx(std::asin(std::sqrt(1.0 / 40.0))).epsilon(1e-9));
  // alpha is given in degrees (mass_on_car.yaml): the value in degrees too.
  REQUIRE(thresholds[0].value_deg.has_value());
  CHECK(*thresholds[0].value_deg == thresholds[0].value * 180.0 / kPi);
  query.parameter = "k";
  query.low = 1.0;
  query.high = 2.0;
  for (const sk::Threshold& threshold : sk::LocateThresholds(model, query)) {
    CHECK_FALSE(threshold.value_deg.has_value());
  }
}

TEST_CASE("a threshold search's report brackets the closed form and says what it was asked",
          "[servokit][paper]") {
  // The over-damping threshold of the test above, alpha = asin(sqrt(1 / 40)), with the search's
  // own settings and report; k is in SI units, so show_degrees alone gives its value in degrees.
  const sk::Model model = sk::Model::FromFile(ModelPath("mass_on_car.yaml"), {{"d", "1"}});
  sk::ThresholdQuery query;
  query.parameter = "alpha";
  query.low = 1.0 * kPi / 180.0;
  query.high = 80.0 * kPi / 180.0;
  query.event = sk::ThresholdEvent::kOscillation;
  query.relative_tolerance = 1e-10;
  query.scan_intervals = 50;
  const sk::ThresholdReport report = sk::SearchThresholds(model, query);
  REQUIRE(report.thresholds.size() == 1);
  const sk::Threshold& threshold = report.thresholds[0];
  const double exact = std::asin(std::sqrt(1.0 / 40.0));
  CHECK(threshold.bracket_width > 0.0);
  CHECK(threshold.bracket_width <= 1e-10 * (query.high - query.low));
  CHECK(std::abs(threshold.value - exact) <= threshold.bracket_width / 2.0 + 1e-12);
  CHECK(report.classifications > 50);  // the scan, then bisection
  CHECK(report.json.find("\"scan_intervals\": 50,") != std::string::npos);
  CHECK(report.json.find("closed_form") == std::string::npos);  // not asked for
  CHECK(report.text.find("1 event") != std::string::npos);

  const sk::ThresholdSettings defaults = sk::DefaultThresholdSettings();
  CHECK(defaults.scan_intervals >= 1);
  CHECK(defaults.scan_intervals <= defaults.max_scan_intervals);
  query.scan_intervals = defaults.max_scan_intervals + 1;
  CHECK_THROWS_AS(sk::SearchThresholds(model, query), servokit::UsageError);

  // k of m2 sin^2(alpha) s^2 + d s + k at alpha = 5 deg: over-damped while d^2 > 4 m2 k
  // sin^2(alpha), k < 1 / (8 sin^2(5 deg)) = 16.46 N/m.
  query = {};
  query.parameter = "k";
  query.low = 1.0;
  query.high = 30.0;
  query.event = sk::ThresholdEvent::kOscillation;
  query.show_degrees = true;
  query.closed_form = true;
  const sk::ThresholdReport k_report = sk::SearchThresholds(
      sk::Model::FromFile(ModelPath("mass_on_car.yaml"), {{"d", "1"}, {"alpha", "5 deg"}}), query);
  REQUIRE(k_report.thresholds.size() == 1);
  const double sine = std::sin(5.0 * kPi / 180.0);
  CHECK(k_report.thresholds[0].value == Approx(1.0 / (8.0 * sine * sine)).epsilon(1e-9));
  REQUIRE(k_report.thresholds[0].value_deg.has_value());
  CHECK(*k_report.thresholds[0].value_deg == k_report.thresholds[0].value * 180.0 / kPi);
  CHECK(k_report.json.find("\"closed_form\"") != std::string::npos);
  CHECK(k_report.text.find("characteristic polynomial: ") != std::string::npos);
}

TEST_CASE("the API names the sweep columns and gives a degree parameter in degrees", "[servokit]") {
  const sk::Model model = sk::Model::FromFile(ModelPath("mass_on_car.yaml"), {{"d", "0"}});
  CHECK(model.parameter_display_units() == std::vector<std::string>{"SI", "SI", "SI", "SI", "deg"});
  const double five = 5.0 * kPi / 180.0, thirty = 30.0 * kPi / 180.0;
  const std::vector<sk::SweepAxis> axes = {{"alpha", {five, thirty}}, {"k", {5.0}}};
  const sk::SweepColumns columns = sk::SweepTableColumns(model, axes);
  CHECK(columns.points == std::vector<std::string>{"alpha_deg", "k", "realization", "P_rank",
                                                   "relative_degree", "differentiation_index",
                                                   "internal_dynamics_order", "stability",
                                                   "max_real_part", "error"});
  CHECK(columns.eigenvalues == std::vector<std::string>{"alpha_deg", "k", "eigenvalue_index", "re",
                                                        "im", "frequency_hz", "damping_ratio"});
  const std::vector<sk::SweepPoint> points = sk::Sweep(model, axes);
  REQUIRE(points.size() == 2);
  CHECK(points[0].parameter_values == std::vector<double>{five, 5.0});
  CHECK(points[0].parameter_display_values == std::vector<double>{5.0, 5.0});
  CHECK(points[1].parameter_display_values == std::vector<double>{30.0, 5.0});
}

namespace {

// The flat mass on car (alpha = 0, d = 0): y = x + s and m2 y'' = -k s, so s = -(m2/k) y'' and
// F = (m1 + m2) y'' + (m1 m2 / k) y'''' (flat: no internal dynamics). Solves `trajectory`
// (Eq. 65 from 0.5 at 0 to 2.5 at 6, in whatever form) every `sample_time` up to t = 8 and
// checks the force against that closed form to `margin`; returns the solve.
sk::Feedforward CheckFlatForce(const sk::OutputTrajectory& trajectory,
                               double margin,
                               double sample_time = 0.25) {
  const sk::Model model =
      sk::Model::FromFile(ModelPath("mass_on_car.yaml"), {{"alpha", "0"}, {"d", "0"}});
  sk::SolveOptions options;
  options.t_end = 8.0;
  options.sample_time = sample_time;
  options.verify = true;
  const sk::Feedforward feedforward = sk::Solve(model, trajectory, options);
  const sk::SolveSummary& summary = feedforward.summary;
  CHECK(summary.method == sk::SolverMethod::kAlgebraic);
  CHECK(summary.status == sk::SolveStatus::kConverged);
  CHECK(feedforward.usable);
  REQUIRE(summary.verification);
  CHECK(summary.verification->passed);
  CHECK(summary.verification->max_tracking_error <= summary.verification->bound);
  CHECK(summary.samples == feedforward.t.size());
  CHECK(summary.t_end == 8.0);
  CHECK(summary.sample_time == sample_time);
  CHECK(summary.classification.flat);  // what made auto choose the algebraic inverse
  CHECK_FALSE(summary.window);         // no stable inversion
  REQUIRE(feedforward.t.size() == std::size_t(std::lround(8.0 / sample_time)) + 1);
  const RestToRest desired{0.5, 2.5, 6.0};
  for (std::size_t i = 0; i < feedforward.t.size(); ++i) {
    const double t = feedforward.t[i];
    const double force = 3.0 * desired.Derivative(std::min(t, 6.0), 2) +
                         (t < 6.0 ? 0.4 * desired.Derivative(t, 4) : 0.0);
    INFO("t = " << t);
    CHECK(feedforward.u(Eigen::Index(i), 0) == Approx(force).margin(margin));
  }
  return feedforward;
}

}  // namespace

TEST_CASE("solve through the API: the flat mass on car (alpha = 0) follows its closed form",
          "[servokit][paper]") {
  sk::OutputTrajectory trajectory;
  trajectory.y0 = Eigen::VectorXd::Constant(1, 0.5);
  trajectory.yf = Eigen::VectorXd::Constant(1, 2.5);
  trajectory.t0 = 0.0;
  trajectory.tf = 6.0;
  // 17 rows every 0.5 s; the force to the round-off of p''''.
  const sk::Feedforward feedforward = CheckFlatForce(trajectory, 1e-9, 0.5);
  const RestToRest desired{0.5, 2.5, 6.0};
  for (std::size_t i = 0; i < feedforward.t.size(); ++i) {
    const double t = feedforward.t[i];
    // The toolkit evaluates Eq. (65) in another form than the monomials here: round-off only.
    CHECK(feedforward.y_d(Eigen::Index(i), 0) ==
          Approx(desired.Derivative(std::min(t, 6.0), 0)).epsilon(1e-12));
  }
}

TEST_CASE("solve through the API writes its file in the format asked for or named", "[servokit]") {
  const sk::Model model = sk::Model::FromFile(ModelPath("mass_on_car.yaml"));
  sk::OutputTrajectory trajectory;
  trajectory.y0 = Eigen::VectorXd::Constant(1, 0.5);
  trajectory.yf = Eigen::VectorXd::Constant(1, 2.5);
  trajectory.t0 = 0.0;
  trajectory.tf = 6.0;
  sk::SolveOptions options;
  options.t_end = 8.0;
  options.sample_time = 0.5;
  const std::filesystem::path directory =
      std::filesystem::temp_directory_path() / "servokit_api_test_solve_files";
  std::filesystem::create_directories(directory);
  const auto first_line = [](const std::filesystem::path& path) {
    const std::string text = ReadFile(path);
    return text.substr(0, text.find('\n'));
  };

  options.out_file = (directory / "u.mat").string();  // the format from the name
  sk::Solve(model, trajectory, options);
  CHECK(ReadFile(options.out_file).rfind("MATLAB 5.0 MAT-file, written by servokit", 0) == 0);
  options.out_file = (directory / "u.txt").string();
  options.file_format = sk::SolveFileFormat::kModelica;
  sk::Solve(model, trajectory, options);
  CHECK(first_line(options.out_file) == "#1");
  options.file_format.reset();
  sk::Solve(model, trajectory, options);
  CHECK(first_line(options.out_file) == "t,x,s,x_dot,s_dot,F,y1_d");

  options.out_file = (directory / "v.csv").string();
  for (const sk::SolveFileFormat refused :
       {sk::SolveFileFormat::kMat, sk::SolveFileFormat::kModelica}) {
    options.file_format = refused;
    CHECK_THROWS_MATCHES(sk::Solve(model, trajectory, options), servokit::Error,
                         Catch::Predicate<servokit::Error>([](const servokit::Error& error) {
                           return error.kind() == servokit::ErrorKind::kUsage &&
                                  std::string(error.what()).find("file_format") !=
                                      std::string::npos;
                         }));
  }
  CHECK_FALSE(std::filesystem::exists(options.out_file));
  std::filesystem::remove_all(directory);
}

TEST_CASE("a generated two-mass chain through the API: zero dynamics of the free mass",
          "[servokit]") {
  // Force and output on mass 1: holding it, mass 2 hangs on one spring-damper, so the zero
  // dynamics are m s^2 + d s + k = 0: s = -0.005 +- i sqrt(1 - 0.005^2) (m = k = 1, d = 0.01).
  const std::filesystem::path directory =
      std::filesystem::temp_directory_path() / "servokit_api_chain_test";
  std::filesystem::remove_all(directory);
  sk::ChainModel chain;
  chain.masses = 2;
  const std::string path = sk::Generate(chain, directory.string());
  const sk::Model model = sk::Model::FromFile(path);
  CHECK(model.kind() == sk::ModelKind::kLinear);
  CHECK(model.coordinate_names() == std::vector<std::string>{"q1", "q2"});
  CHECK(model.input_names() == std::vector<std::string>{"u1"});
  CHECK(model.output_names() == std::vector<std::string>{"y1"});
  const sk::Analysis analysis = sk::Analyze(model);
  REQUIRE(analysis.zero_dynamics.eigenvalues.size() == 2);
  for (const auto& eigenvalue : analysis.zero_dynamics.eigenvalues) {
    CHECK(eigenvalue.real() == Approx(-0.005).epsilon(1e-10));
    CHECK(std::abs(eigenvalue.imag()) == Approx(std::sqrt(1.0 - 0.005 * 0.005)).epsilon(1e-10));
  }
  sk::AnalyzeOptions at_another_point;
  at_another_point.y0 = Eigen::VectorXd::Constant(1, 1.0);
  CHECK_THROWS_AS(sk::Analyze(model, at_another_point), servokit::UsageError);
  std::filesystem::remove_all(directory);
}

TEST_CASE("solve from samples: Eq. (65) sampled at uneven times gives its closed-form force",
          "[servokit][paper]") {
  // The spline of degree 9 at rest to order 4 at both ends reproduces every such polynomial of
  // degree <= 9, Eq. (65) among them: the samples give back the closed form, to round-off.
  const RestToRest desired{0.5, 2.5, 6.0};
  sk::OutputTrajectory trajectory;
  trajectory.sample_times = {0.0, 0.7, 1.1, 2.0, 2.9, 3.3, 4.5, 5.2, 6.0};
  trajectory.sample_values.resize(Eigen::Index(trajectory.sample_times.size()), 1);
  for (std::size_t i = 0; i < trajectory.sample_times.size(); ++i) {
    trajectory.sample_values(Eigen::Index(i), 0) =
        desired.Derivative(trajectory.sample_times[i], 0);
  }
  CheckFlatForce(trajectory, 1e-7);
}

TEST_CASE("solve from a function of the caller's: Eq. (65) as a function gives its force",
          "[servokit][paper]") {
  const RestToRest desired{0.5, 2.5, 6.0};
  sk::OutputTrajectory trajectory;
  trajectory.function = [desired](double t, int highest, Eigen::MatrixXd& derivatives) {
    for (int order = 0; order <= highest; ++order) {
      // At rest after t = 6: the value stays, every derivative is 0.
      derivatives(0, order) =
          t <= 6.0 ? desired.Derivative(std::max(t, 0.0), order) : (order == 0 ? 2.5 : 0.0);
      if (t < 0.0 && order > 0) derivatives(0, order) = 0.0;
    }
  };
  trajectory.function_breakpoints = {0.0, 6.0};
  CheckFlatForce(trajectory, 1e-9);

  trajectory.function_continuous_derivatives = 2;  // the flat inverse reads y_d''''
  CHECK_THROWS_WITH(CheckFlatForce(trajectory, 1e-9),
                    Catch::Contains("OutputTrajectory::function_continuous_derivatives = 2"));
}

TEST_CASE("a trajectory of two kinds at once is refused", "[servokit]") {
  const sk::Model model = sk::Model::FromFile(ModelPath("mass_on_car.yaml"));
  sk::OutputTrajectory trajectory;
  trajectory.waypoint_file = "waypoints.yaml";
  trajectory.sample_times = {0.0, 1.0};
  trajectory.sample_values = Eigen::MatrixXd::Zero(2, 1);
  sk::SolveOptions options;
  options.t_end = 1.0;
  CHECK_THROWS_AS(sk::Solve(model, trajectory, options), servokit::UsageError);
}

TEST_CASE("the grid text through the API: a degree range is spaced evenly in degrees",
          "[servokit]") {
  const sk::Model model = sk::Model::FromFile(ModelPath("mass_on_car.yaml"), {{"d", "0"}});
  std::vector<std::string> warnings;
  const std::vector<sk::SweepAxis> axes =
      sk::ParseSweepAxes(model, {"alpha=5deg:85deg:9", "d=0.5,1"}, "axis", &warnings);
  CHECK(warnings.empty());
  REQUIRE(axes.size() == 2);
  REQUIRE(axes[0].range.has_value());
  CHECK(axes[0].range->count == 9);
  CHECK(axes[0].degrees == true);
  CHECK(axes[1].values == std::vector<double>{0.5, 1.0});
  // 5, 15, ..., 85 degrees, each the double that "<n> deg" gives in a model file.
  const std::vector<sk::SweepPoint> points = sk::Sweep(model, {axes[0]});
  REQUIRE(points.size() == 9);
  for (std::size_t i = 0; i < points.size(); ++i) {
    const int degrees = 5 + 10 * int(i);
    CHECK(points[i].parameter_display_values[0] == double(degrees));
    CHECK(points[i].parameter_values[0] ==
          sk::ParseQuantity(std::to_string(degrees) + " deg")->value);
  }
  CHECK_THROWS_WITH(sk::ParseSweepAxes(model, {"beta=0:1:3"}, "axis"),
                    Catch::StartsWith("axis beta=0:1:3: unknown parameter 'beta'"));
  CHECK_THROWS_WITH(sk::ParseSweepAxes(model, {"d=0:1:3", "d=2"}, "axis"),
                    Catch::StartsWith("axis d: the parameter is varied twice"));
  // A bare a:b:n that MATLAB reads as start:step:end is read as servokit's, with a warning.
  sk::ParseSweepAxes(model, {"d=0:2:4"}, "axis", &warnings);
  REQUIRE(warnings.size() == 1);
  CHECK(warnings[0].rfind("axis d=0:2:4 is read as 4 values from 0 to 2", 0) == 0);
}

TEST_CASE("a directory sweep stopped and resumed writes the bytes of one run, as SweepToFiles",
          "[servokit]") {
  const sk::Model model = sk::Model::FromFile(ModelPath("mass_on_car.yaml"), {{"d", "0"}});
  const std::vector<sk::SweepAxis> axes = sk::ParseSweepAxes(model, {"alpha=5deg:85deg:9"}, "axis");
  const std::filesystem::path root = std::filesystem::temp_directory_path() /
                                     ("servokit_api_directory_sweep_" + std::to_string(::getpid()));
  std::filesystem::remove_all(root);
  sk::DirectorySweepOptions options;
  options.block_size = 2;
  {
    sk::DirectorySweep sweep(model, axes, {}, options);
    sweep.Open((root / "resumed").string());
    CHECK(sweep.num_points() == 9);
    CHECK(sweep.first_point() == 0);
    int questions = 0;
    std::size_t progress = 0;
    CHECK(sweep.Run([&] { return ++questions >= 2; }, [&](std::size_t done) { progress = done; }) ==
          sk::DirectorySweep::End::kStopped);
    CHECK(sweep.points_done() == 4);  // two blocks of two
    CHECK(progress == 4);
    CHECK_FALSE(std::filesystem::exists(root / "resumed" / "points.csv"));
  }
  {
    sk::DirectorySweep sweep(model, axes, {}, options);
    sweep.Open((root / "resumed").string());
    CHECK_FALSE(sweep.already_complete());
    CHECK(sweep.first_point() == 4);
    CHECK(sweep.Run() == sk::DirectorySweep::End::kFinished);
    CHECK(sweep.points_done() == 9);
    CHECK(sweep.points_without_solution() == 0);
    CHECK(sweep.table_file_names() == "points.csv, eigenvalues.csv");
  }
  // The second route: the same tables from one uninterrupted in-memory run.
  CHECK(sk::SweepToFiles(model, axes, (root / "whole").string()) == 9);
  CHECK(ReadFile(root / "resumed" / "points.csv") == ReadFile(root / "whole" / "points.csv"));
  CHECK(ReadFile(root / "resumed" / "eigenvalues.csv") ==
        ReadFile(root / "whole" / "eigenvalues.csv"));
  CHECK(ReadFile(root / "resumed" / "sweep.json").find("\"completed\": true") != std::string::npos);
  {
    sk::DirectorySweep again(model, axes, {}, options);
    again.Open((root / "resumed").string());
    CHECK(again.already_complete());
  }
  // Another grid in the same directory is refused, in the caller's words for it.
  sk::DirectorySweepOptions labelled = options;
  labelled.directory_label = "folder";
  sk::DirectorySweep other(model, sk::ParseSweepAxes(model, {"alpha=1deg,2deg"}, "axis"), {},
                           labelled);
  CHECK_THROWS_WITH(
      other.Open((root / "resumed").string()),
      Catch::StartsWith("folder " + (root / "resumed").string() + " holds another sweep"));
  std::filesystem::remove_all(root);
}

// Issue #33: solve takes its operating point where the motion starts. The ball and beam
// (tests/data/ball_and_beam.yaml) moved from r = 0.3 m by the linearized inverse must invert
// its linearization at r0 = 0.3 (theta = 0, tau0 = M G r0), derived by hand:
//   Ir r'' + M G theta = 0, I0 theta'' + M G r = tau, Ir = Jb/R^2 + M, I0 = M r0^2 + J + Jb,
// so tau = M G y - I0 Ir / (M G) y''''. At r = 0 (where h(0) is) I0 would lack M r0^2: a
// force off by M r0^2 Ir / (M G) y'''' (up to 4e-6 N m here), far outside the tolerance below.
TEST_CASE("solve classifies and linearizes where the motion starts, not at h(0)", "[servokit]") {
  const sk::Model model =
      sk::Model::FromFile(servokit::testing::TestDataPath("ball_and_beam.yaml"));
  constexpr double kMass = 0.05, kRadius = 0.01, kBeam = 0.02, kGravity = 9.81, kStart = 0.3;
  const double ball_spin = 0.4 * kMass * kRadius * kRadius;
  const double rolling = ball_spin / (kRadius * kRadius) + kMass;
  const double beam_inertia = kMass * kStart * kStart + kBeam + ball_spin;
  sk::OutputTrajectory trajectory;
  trajectory.y0 = Eigen::VectorXd::Constant(1, kStart);
  trajectory.yf = Eigen::VectorXd::Constant(1, kStart + 0.01);
  trajectory.t0 = 0.0;
  trajectory.tf = 3.0;
  sk::SolveOptions options;
  options.method = servokit::SolverMethod::kLinearized;
  options.t_end = 3.0;
  options.sample_time = 0.05;
  const sk::Feedforward feedforward = sk::Solve(model, trajectory, options);
  REQUIRE(feedforward.usable);
  CHECK(feedforward.summary.operating_point_time == 0.0);
  CHECK(feedforward.summary.classification.q(0) == Approx(kStart).epsilon(1e-14));
  CHECK(std::abs(feedforward.summary.classification.q(1)) < 1e-14);
  CHECK(feedforward.summary.json.find("\"t\": 0.0") != std::string::npos);
  const RestToRest desired{kStart, kStart + 0.01, 3.0};
  for (std::size_t i = 0; i < feedforward.t.size(); ++i) {
    const double t = feedforward.t[i];
    const double torque = kMass * kGravity * desired.Derivative(t, 0) -
                          beam_inertia * rolling / (kMass * kGravity) * desired.Derivative(t, 4);
    INFO("t = " << t);
    CHECK(std::abs(feedforward.u(Eigen::Index(i), 0) - torque) < 1e-10);
  }
}

// Issue #33: a motion that starts (and ends) in motion. The flat mass on car (case 4) has no
// free state: y_d and its derivatives determine q, q' and F, so y_d = 0.5 + sin(t), moving at
// t = 0, is inverted from there, F = (m1 + m2) y'' + m1 m2 / k y'''' = -2.6 sin(t) (Eq. 47),
// and the forward check starts from the solution's own (moving) state.
TEST_CASE("a flat problem is inverted from a start in motion", "[servokit][paper]") {
  const sk::Model model =
      sk::Model::FromFile(ModelPath("mass_on_car.yaml"), {{"alpha", "0"}, {"d", "0"}});
  sk::OutputTrajectory trajectory;
  trajectory.function = [](double t, int highest, Eigen::MatrixXd& derivatives) {
    for (int order = 0; order <= highest; ++order) {
      // sin's derivatives cycle: sin, cos, -sin, -cos.
      const double cycle[4] = {std::sin(t), std::cos(t), -std::sin(t), -std::cos(t)};
      derivatives(0, order) = (order == 0 ? 0.5 : 0.0) + cycle[order % 4];
    }
  };
  trajectory.function_breakpoints = {0.0, 4.0};
  sk::SolveOptions options;
  options.t_end = 4.0;
  options.sample_time = 0.1;
  options.verify = true;
  const sk::Feedforward feedforward = sk::Solve(model, trajectory, options);
  REQUIRE(feedforward.usable);
  CHECK(feedforward.summary.method == sk::SolverMethod::kAlgebraic);
  REQUIRE(feedforward.summary.verification);
  CHECK(feedforward.summary.verification->passed);
  CHECK(feedforward.summary.json.find("\"start\": \"solution\"") != std::string::npos);
  for (std::size_t i = 0; i < feedforward.t.size(); ++i) {
    const double t = feedforward.t[i];
    INFO("t = " << t);
    CHECK(feedforward.u(Eigen::Index(i), 0) == Approx(-2.6 * std::sin(t)).margin(1e-9));
    // y' = x' + s' (alpha = 0): the start state carries the output's velocity.
    CHECK(feedforward.q_dot(Eigen::Index(i), 0) + feedforward.q_dot(Eigen::Index(i), 1) ==
          Approx(std::cos(t)).margin(1e-9));
  }
}

// Issue #33: a solve that stops says why. The TORA observed at its cart (tests/data/tora.yaml,
// a = 0, rotor at 0.5 rad on its curve of equilibria) moved 0 -> 0.01 m in 2 s: holding x = x_d
// the rotor obeys m e (sin theta)'' = -(M + m) x_d'' - k x_d, so from rest
//   sin(theta(t)) = sin(0.5) - ((M + m) x_d(t) + k X(t)) / (m e),  X = the double integral of x_d,
// and P = H M^-1 B, proportional to cos(theta), vanishes where sin(theta) reaches -1: there u_d
// grows without bound. The normal form stops there, and its message names the singularity.
TEST_CASE("a solve that stops at a singularity of P says so, with the time", "[servokit]") {
  const sk::Model model =
      sk::Model::FromFile(servokit::testing::TestDataPath("tora.yaml"), {{"a", "0"}});
  constexpr double kCart = 1.3608, kRotor = 0.096, kEccentricity = 0.0592, kSpring = 186.3;
  const RestToRest desired{0.0, 0.01, 2.0};
  // sin(theta) along the motion by the trapezoidal rule twice over, at 1e-6 s.
  double singular_time = 0.0, integral = 0.0, double_integral = 0.0;
  constexpr double kStep = 1e-6;
  for (double t = 0.0; t < 2.0; t += kStep) {
    const double before = desired.Derivative(t, 0), after = desired.Derivative(t + kStep, 0);
    const double previous_integral = integral;
    integral += kStep * (before + after) / 2;
    double_integral += kStep * (previous_integral + integral) / 2;
    const double sine = std::sin(0.5) - ((kCart + kRotor) * after + kSpring * double_integral) /
                                            (kRotor * kEccentricity);
    if (sine <= -1.0) {
      singular_time = t + kStep;
      break;
    }
  }
  REQUIRE(singular_time > 0.0);
  sk::OutputTrajectory trajectory;
  trajectory.y0 = Eigen::VectorXd::Zero(1);
  trajectory.yf = Eigen::VectorXd::Constant(1, 0.01);
  trajectory.t0 = 0.0;
  trajectory.tf = 2.0;
  sk::SolveOptions options;
  options.t_end = 3.0;
  options.q_guess = Eigen::Vector2d(0.0, 0.5);
  const sk::Feedforward feedforward = sk::Solve(model, trajectory, options);
  CHECK_FALSE(feedforward.usable);
  CHECK(feedforward.summary.stop_time == Approx(singular_time).margin(1e-3));
  CHECK_THAT(feedforward.summary.message,
             Catch::Contains("P = H M^-1 B, regular at the operating point, is nearly singular"));
}
