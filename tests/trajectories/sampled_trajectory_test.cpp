// Trajectories from samples and from a caller's function (trajectories/sampled_trajectory.h),
// against closed forms: polynomials at rest at both ends, which the spline must reproduce, and
// a smooth motion of higher degree, for which the interpolation error must fall as h^(2k + 2).
#include "trajectories/sampled_trajectory.h"

#include <catch2/catch.hpp>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <limits>
#include <string>
#include <vector>

#include "base/errors.h"
#include "tests/test_files.h"

namespace servokit {
namespace {

// The rest-to-rest polynomial p_k(tau) = tau^(k+1) sum_j C(k+j, j) (1 - tau)^j and its
// derivatives in tau, summed term by term (no shared code with the toolkit): p_4 is the paper's
// Eq. (65).
double Binomial(int n, int k) {
  double value = 1.0;
  for (int i = 1; i <= k; ++i) value = value * (n - k + i) / i;
  return value;
}

// d^order/dtau^order of tau^a (1 - tau)^b, by Leibniz.
double MonomialDerivative(double tau, int a, int b, int order) {
  double sum = 0.0;
  for (int i = 0; i <= order; ++i) {
    const int j = order - i;  // derivatives on (1 - tau)^b
    if (i > a || j > b) continue;
    double left = 1.0, right = 1.0;
    for (int m = 0; m < i; ++m) left *= a - m;
    for (int m = 0; m < j; ++m) right *= -(b - m);
    sum += Binomial(order, i) * left * std::pow(tau, a - i) * right * std::pow(1.0 - tau, b - j);
  }
  return sum;
}

double RestToRest(int k, double tau, int order) {
  double value = 0.0;
  for (int j = 0; j <= k; ++j)
    value += Binomial(k + j, j) * MonomialDerivative(tau, k + 1, j, order);
  return value;
}

// y(t) = 1 - 3 p(t / 2) on [0, 2] (a motion from 1 to -2), order-th time derivative.
double Motion(int k, double t, int order) {
  return (order == 0 ? 1.0 : 0.0) - 3.0 * RestToRest(k, t / 2.0, order) / std::pow(2.0, order);
}

// The samples of Motion (and twice it as a second output) joined with the given tolerance; 0
// asks for the interpolating spline, whose error bounds the tests below check.
SampledTrajectory SampleMotion(int motion_order,
                               const std::vector<double>& times,
                               double tolerance = 0.0) {
  Eigen::MatrixXd values(Eigen::Index(times.size()), 2);
  for (std::size_t i = 0; i < times.size(); ++i) {
    values(Eigen::Index(i), 0) = Motion(motion_order, times[i], 0);
    values(Eigen::Index(i), 1) = 2.0 * Motion(motion_order, times[i], 0);  // a second output
  }
  return SampledTrajectory(times, values, 4, tolerance);
}

TEST_CASE("samples of Eq. (65) give Eq. (65) back, with its derivatives", "[solvers][paper]") {
  // Eq. (65) has degree 9 and rests to order 4 at both ends: it lies in the spline's space and
  // meets its conditions, so the unique interpolant is Eq. (65) itself, from any samples.
  for (const std::vector<double>& times :
       {std::vector<double>{0.0, 2.0}, std::vector<double>{0.0, 0.3, 0.35, 1.2, 1.9, 2.0}}) {
    const SampledTrajectory trajectory = SampleMotion(4, times);
    CHECK(trajectory.outputs() == 2);
    CHECK(trajectory.continuous_derivatives() == 4);
    for (double t = 0.0; t <= 2.0; t += 0.0625) {
      const Eigen::VectorXd scale = Eigen::Vector2d(1.0, 2.0);
      for (int order = 0; order <= 6; ++order) {
        INFO(times.size() << " samples, t = " << t << ", order " << order);
        const double expected = Motion(4, t, order);
        const Eigen::VectorXd derivative = trajectory.Derivative(t, order);
        CHECK(derivative(0) == Approx(expected).margin(1e-9 * std::pow(10.0, order)));
        CHECK(derivative(1) == Approx(scale(1) * expected).margin(2e-9 * std::pow(10.0, order)));
      }
    }
  }
}

TEST_CASE("a sampled motion is at rest before its first sample and after its last", "[solvers]") {
  const SampledTrajectory trajectory = SampleMotion(4, {0.0, 0.5, 1.0, 1.5, 2.0});
  Eigen::MatrixXd derivatives;
  trajectory.Derivatives(-1.0, 5, derivatives);
  CHECK(derivatives(0, 0) == 1.0);
  CHECK(derivatives.block(0, 1, 2, 5).isZero(0.0));
  trajectory.Derivatives(3.0, 5, derivatives);
  CHECK(derivatives(0, 0) == -2.0);
  CHECK(derivatives(1, 0) == -4.0);
  CHECK(derivatives.block(0, 1, 2, 5).isZero(0.0));
  for (int order = 1; order <= 4; ++order) {  // continuous where it joins the rest
    CHECK(trajectory.Derivative(0.0, order).norm() == Approx(0.0).margin(1e-9));
    CHECK(trajectory.Derivative(2.0, order).norm() == Approx(0.0).margin(1e-9));
  }
  CHECK(trajectory.breakpoints() == std::vector<double>{0.0, 2.0});
}

TEST_CASE("the interpolation error of a smoother motion falls as h^10", "[solvers]") {
  // p_6 (degree 13) rests to order 6 at the ends but is not a spline of degree 9: the error of
  // the value falls as h^10 (degree 2k + 1 = 9 interpolation), so halving h divides it by about
  // 2^10; 2^8 leaves room for the asymptotics not yet being reached.
  const auto max_error = [](int intervals) {
    std::vector<double> times;
    for (int i = 0; i <= intervals; ++i) times.push_back(2.0 * i / intervals);
    const SampledTrajectory trajectory = SampleMotion(6, times);
    double error = 0.0;
    for (double t = 0.0; t <= 2.0; t += 1.0 / 512.0) {
      error = std::max(error, std::abs(trajectory.Derivative(t, 0)(0) - Motion(6, t, 0)));
    }
    return error;
  };
  const double coarse = max_error(8), fine = max_error(16);
  INFO("errors " << coarse << " and " << fine);
  CHECK(coarse > 0.0);
  CHECK(fine < coarse / 256.0);
  CHECK(fine < 1e-7);
}

// The Euler numbers' E_10 = -50521: K = |E_10| / (4^5 10!) is Favard's constant K_10 / pi^10,
// the sharp bound of odd-degree spline interpolation at the knots (periodic; for the complete
// cubic it is Hall's 5/384): |y - s| <= K h^10 max |y^(10)| for degree 9.
constexpr double kFavardDegree9 = 50521.0 / (1024.0 * 3628800.0);

TEST_CASE("the interpolation error of a smoother motion is within K h^10 max |y^(10)|",
          "[solvers]") {
  // p_6 (degree 13) rests to order 6 at the ends, more than the spline's end conditions ask,
  // so the spline is the complete interpolant of y = 1 - 3 p_6(t / 2) and the bound applies.
  double tenth = 0.0;  // max |y^(10)| on [0, 2], from the closed form
  for (double t = 0.0; t <= 2.0; t += 1.0 / 4096.0) {
    tenth = std::max(tenth, std::abs(Motion(6, t, 10)));
  }
  for (const int intervals : {8, 16, 32}) {
    std::vector<double> times;
    for (int i = 0; i <= intervals; ++i) times.push_back(2.0 * i / intervals);
    const SampledTrajectory trajectory = SampleMotion(6, times);
    double error = 0.0;
    for (double t = 0.0; t <= 2.0; t += 1.0 / 2048.0) {
      error = std::max(error, std::abs(trajectory.Derivative(t, 0)(0) - Motion(6, t, 0)));
    }
    const double bound = kFavardDegree9 * std::pow(2.0 / intervals, 10) * tenth;
    INFO(intervals << " intervals: error " << error << ", bound " << bound);
    CHECK(error <= bound);
  }
}

TEST_CASE(
    "10^4 samples of Eq. (65) give it back within their round-off, as amplified by the spline",
    "[solvers][paper]") {
  // Eq. (65) lies in the spline's space, so the interpolation error is zero and what is left is
  // the spline through the samples' rounding delta: its B-spline coefficients are at most
  // ||A^-1|| max |delta| (A: the collocation matrix of degree 9 with its scaled end rows, whose
  // inverse has norm 65.5 on the data for any number of samples, SciPy's BSpline), and each
  // derivative multiplies them by at most 2 p / h (differences of coefficients over knot spans
  // of at least h, p = 9). delta: a few ulps of evaluating y and the solve's backward error, at
  // most 64 eps max |y|. Orders 0..2: what a projected or BDF solve reads.
  constexpr int kSamples = 10000;
  std::vector<double> times;
  for (int i = 0; i < kSamples; ++i) times.push_back(2.0 * i / (kSamples - 1));
  const SampledTrajectory trajectory = SampleMotion(4, times);
  const double spacing = 2.0 / (kSamples - 1);
  const double coefficient_error = 65.5 * 64.0 * std::numeric_limits<double>::epsilon() * 2.0;
  Eigen::MatrixXd derivatives;
  double errors[3] = {0.0, 0.0, 0.0};
  for (int i = 0; i <= 100000; ++i) {
    const double t = 2.0 * i / 100000;
    trajectory.Derivatives(t, 2, derivatives);
    for (int order = 0; order <= 2; ++order) {
      errors[order] =
          std::max(errors[order], std::abs(derivatives(0, order) - Motion(4, t, order)));
    }
  }
  for (int order = 0; order <= 2; ++order) {
    const double bound = coefficient_error * std::pow(2.0 * 9.0 / spacing, order);
    INFO("order " << order << ": error " << errors[order] << ", bound " << bound);
    CHECK(errors[order] <= bound);
  }
}

// Samples rounded to 12 significant digits, as a measurement or a short CSV gives them.
SampledTrajectory SampleRounded(int motion_order, int samples, double tolerance) {
  std::vector<double> times;
  Eigen::MatrixXd values(samples, 1);
  for (int i = 0; i < samples; ++i) {
    times.push_back(2.0 * i / (samples - 1));
    const double exact = Motion(motion_order, times.back(), 0);
    char text[32];
    std::snprintf(text, sizeof text, "%.11e", exact);
    values(i, 0) = std::stod(text);
  }
  return SampledTrajectory(times, values, 4, tolerance);
}

TEST_CASE("rounded samples: the fit keeps the derivatives that interpolation loses",
          "[solvers][paper]") {
  // 10^4 samples of Eq. (65) rounded to 12 digits (5e-12 at most, 1.7e-12 of the range 3):
  // the interpolating spline carries the rounding into y_d'' multiplied by some (2p / h)^2 =
  // 8e9 (h = 2e-4, p = 9), while Eq. (65) itself lies in every spline space the fit tries, so
  // the fit takes no inner knot and gives Eq. (65) back but for its end samples' rounding.
  const SampledTrajectory interpolated = SampleRounded(4, 10000, 0.0);
  const SampledTrajectory fitted = SampleRounded(4, 10000, kSampleTolerance);
  CHECK(interpolated.knot_stride() == 1);
  CHECK(fitted.knot_stride() >= 9999);
  CHECK(fitted.largest_deviation() <= 2e-12);  // the rounding, relative to the range 3
  double interpolation_error = 0.0, fit_error = 0.0;
  for (int i = 0; i <= 20000; ++i) {
    const double t = 2.0 * i / 20000;
    interpolation_error =
        std::max(interpolation_error, std::abs(interpolated.Derivative(t, 2)(0) - Motion(4, t, 2)));
    fit_error = std::max(fit_error, std::abs(fitted.Derivative(t, 2)(0) - Motion(4, t, 2)));
  }
  INFO("y_d'' errors: interpolated " << interpolation_error << ", fitted " << fit_error);
  CHECK(interpolation_error > 1e-5);  // the failure the fit is for (max |y''| is some 6)
  CHECK(fit_error < 1e-9);
}

TEST_CASE("a motion outside the spline's space is fitted within the tolerance on fewer knots",
          "[solvers]") {
  // p_6 (degree 13) is no spline of degree 9: the fit needs inner knots, fewer than samples.
  // Checked here with the closed form, independently of the fit's own residuals: the root mean
  // square of the deviations at the samples within 1e-10 of the range 3, every derivative the
  // inverse reads within what the knot spacing allows.
  constexpr int kSamples = 4001;
  std::vector<double> times;
  for (int i = 0; i < kSamples; ++i) times.push_back(2.0 * i / (kSamples - 1));
  const SampledTrajectory trajectory = SampleMotion(6, times, kSampleTolerance);
  INFO("knot stride " << trajectory.knot_stride());
  CHECK(trajectory.knot_stride() > 1);
  CHECK(trajectory.knot_stride() < kSamples - 1);
  double squares = 0.0, largest = 0.0;
  for (const double t : times) {
    const double deviation = std::abs(trajectory.Derivative(t, 0)(0) - Motion(6, t, 0));
    squares += deviation * deviation;
    largest = std::max(largest, deviation);
  }
  CHECK(std::sqrt(squares / kSamples) <= 1e-10 * 3.0);
  CHECK(trajectory.largest_deviation() == Approx(largest / 3.0).epsilon(1e-6));
  // Jackson: a spline of degree 9 on knots H apart is within C H^(10 - m) of the m-th derivative;
  // with its values within 1e-10 here, the fourth derivative (max some 2e3) keeps 1e-5 of it.
  for (double t = 0.0; t <= 2.0; t += 1.0 / 1024.0) {
    CHECK(trajectory.Derivative(t, 4)(0) == Approx(Motion(6, t, 4)).margin(2e-2));
  }
}

TEST_CASE("the sample tolerance is checked", "[solvers]") {
  const std::vector<double> times{0.0, 1.0, 2.0};
  const Eigen::Vector3d values(0.0, 1.0, 1.0);
  CHECK_THROWS_WITH(SampledTrajectory(times, values, 4, -1e-3),
                    Catch::Contains("relative_tolerance = -0.001: must be >= 0"));
  CHECK_THROWS_WITH(SampledTrajectory(times, values, 4, 1.0), Catch::Contains("and < 1"));
  CHECK_THROWS_AS(SampledTrajectory(times, values, 4, std::nan("")), UsageError);
}

TEST_CASE("samples beyond the limit or too close for their values are refused", "[solvers]") {
  const std::size_t too_many = kMaxTrajectoryPoints + 1;
  std::vector<double> times(too_many);
  for (std::size_t i = 0; i < too_many; ++i) times[i] = double(i);
  CHECK_THROWS_WITH(SampledTrajectory(times, Eigen::MatrixXd::Zero(Eigen::Index(too_many), 1)),
                    "samples: 1000001 samples: at most 1000000");
  // 1e-300 s apart: the first derivative alone would be some 1e300.
  CHECK_THROWS_WITH(SampledTrajectory({0.0, 1e-300, 1.0}, Eigen::Vector3d(0.0, 1.0, 1.0)),
                    "samples: values up to 1, times 0 = 0 and 1 = 1e-300 the closest: the "
                    "spline's derivatives up to order 4 overflow (samples too close, or values "
                    "too large, for doubles)");
  CHECK_THROWS_WITH(
      SampledTrajectory({0.0, 1.0, 2.0, 3.0}, Eigen::Vector4d(0.0, 1e308, -1e308, 0.0)),
      Catch::Contains("samples: values up to 1e+308, times 0 = 0 and 1 = 1 the "
                      "closest: the spline's derivatives up to order 4 overflow"));
}

TEST_CASE("a samples file beyond the limit is refused at its first sample beyond it", "[solvers]") {
  const testing::TemporaryDirectory directory;
  const std::string path = (directory.path() / "many.csv").string();
  {
    std::ofstream file(path);
    file << "t,y\n";
    for (std::size_t i = 0; i <= kMaxTrajectoryPoints; ++i) file << i << ",0\n";
  }
  // Line 1 is the header, so sample 10^6 + 1 is on line 10^6 + 2.
  CHECK_THROWS_WITH(LoadTrajectorySamples(path),
                    path + ":1000002: more than 1000000 samples, the most a trajectory may have");
}

TEST_CASE("more continuous derivatives than the limit are refused by every trajectory kind",
          "[solvers]") {
  const int too_many = kMaxContinuousDerivatives + 1;
  CHECK_THROWS_WITH(SampledTrajectory({0.0, 1.0}, Eigen::Vector2d(0.0, 1.0), too_many),
                    "samples: continuous derivatives = 33: must be from 1 to 32");
  CHECK_THROWS_WITH(SampledTrajectory({0.0, 1.0}, Eigen::Vector2d(0.0, 1.0), 0),
                    "samples: continuous derivatives = 0: must be from 1 to 32");
  CHECK_THROWS_WITH(FunctionTrajectory([](double, int, Eigen::MatrixXd&) {}, 1, 1000000, {0.0}),
                    "trajectory function: continuous derivatives = 1000000: must be from 1 to 32");
  // At the limit: degree 65, and its derivatives still finite and at rest at the ends.
  const SampledTrajectory highest({0.0, 0.5, 1.0}, Eigen::Vector3d(0.0, 0.5, 1.0),
                                  kMaxContinuousDerivatives);
  CHECK(highest.Derivative(0.25, kMaxContinuousDerivatives).allFinite());
  CHECK(highest.Derivative(1.0, kMaxContinuousDerivatives).norm() == 0.0);
}

TEST_CASE("bad samples are refused with the sample named", "[solvers]") {
  const Eigen::MatrixXd one = Eigen::MatrixXd::Zero(1, 1), three = Eigen::MatrixXd::Zero(3, 1);
  CHECK_THROWS_WITH(SampledTrajectory({0.0}, one), Catch::Contains("at least two"));
  CHECK_THROWS_WITH(SampledTrajectory({0.0, 1.0, 1.0}, three),
                    Catch::Contains("time 2 = 1 is not after time 1 = 1"));
  CHECK_THROWS_WITH(SampledTrajectory({0.0, 1.0}, three), Catch::Contains("3 rows of values"));
  Eigen::MatrixXd not_finite = three;
  not_finite(1, 0) = std::nan("");
  CHECK_THROWS_WITH(SampledTrajectory({0.0, 1.0, 2.0}, not_finite),
                    Catch::Contains("sample 1 is not finite"));
}

TEST_CASE("a function trajectory answers with the caller's function", "[solvers]") {
  const FunctionTrajectory trajectory(
      [](double t, int highest, Eigen::MatrixXd& derivatives) {
        for (int order = 0; order <= highest; ++order) {
          derivatives(0, order) = std::pow(2.0, order) * std::exp(2.0 * t);  // e^(2t)
        }
      },
      1, 6, {0.0});
  CHECK(trajectory.Derivative(0.5, 3)(0) == Approx(8.0 * std::exp(1.0)).epsilon(1e-15));
  CHECK(trajectory.breakpoints() == std::vector<double>{0.0});
  const FunctionTrajectory wrong_shape(
      [](double, int, Eigen::MatrixXd& derivatives) { derivatives.resize(3, 1); }, 1, 4, {0.0});
  CHECK(std::isnan(wrong_shape.Derivative(0.0, 2)(0)));  // the solve stops on it
  CHECK_THROWS_AS(FunctionTrajectory(nullptr, 1, 4, {}), UsageError);
}

}  // namespace
}  // namespace servokit

namespace servokit {
namespace {

// Issue #34: samples as users' tools write them. pandas' to_csv puts an unnamed index column
// first; people write "t, y1" with blanks; a solve file has its outputs as y1_d among other
// columns; the time need not come first. Columns are found by name where the header names an
// output, by position otherwise, and a missing output is named.
TEST_CASE("samples files from pandas, with blanks and named columns", "[trajectories]") {
  const testing::TemporaryDirectory directory;
  const auto write = [&](const std::string& name, const std::string& text) {
    const std::string path = (directory.path() / name).string();
    std::ofstream(path) << text;
    return path;
  };
  // pandas: DataFrame({"t": [0, 1], "y2": [5, 6], "y1": [1, 2]}).to_csv(path)
  const TrajectorySamples pandas = SelectOutputColumns(
      LoadTrajectorySamples(write("pandas.csv", ",t,y2,y1\n0,0,5,1\n1,1,6,2\n")), {"y1", "y2"},
      "pandas.csv");
  CHECK(pandas.times == std::vector<double>{0.0, 1.0});
  CHECK(pandas.values(0, 0) == 1.0);
  CHECK(pandas.values(1, 1) == 6.0);
  const TrajectorySamples blanks = SelectOutputColumns(
      LoadTrajectorySamples(write("blanks.csv", "t, y1\n 0, 3 \n1 ,4\n")), {"y1"}, "blanks.csv");
  CHECK(blanks.values(1, 0) == 4.0);
  const TrajectorySamples solve_file = SelectOutputColumns(
      LoadTrajectorySamples(write("solve.csv", "x,t,F,y1_d\n9,0,7,0.5\n9,2,7,1.5\n")), {"y1"},
      "solve.csv");
  CHECK(solve_file.times == std::vector<double>{0.0, 2.0});
  CHECK(solve_file.values(1, 0) == 1.5);
  const TrajectorySamples positional = SelectOutputColumns(
      LoadTrajectorySamples(write("positional.csv", "time,a,b\n0,1,2\n1,3,4\n")), {"y1", "y2"},
      "positional.csv");
  CHECK(positional.times == std::vector<double>{0.0, 1.0});  // the first column
  CHECK(positional.values(1, 1) == 4.0);
  CHECK_THROWS_WITH(
      SelectOutputColumns(LoadTrajectorySamples(write("missing.csv", "t,y1,z\n0,1,2\n1,3,4\n")),
                          {"y1", "y2"}, "missing.csv"),
      "missing.csv: no column y2 (or y2_d) among 'y1, z'");
  CHECK_THROWS_WITH(
      SelectOutputColumns(LoadTrajectorySamples(write("extra.csv", "t,y1,y2\n0,1,2\n1,3,4\n")),
                          {"y1"}, "extra.csv"),
      "extra.csv: column 'y2' names an output the model does not have (it has 1 "
      "output)");
  CHECK_THROWS_WITH(
      SelectOutputColumns(LoadTrajectorySamples(write("count.csv", "t,a,b\n0,1,2\n")), {"y1"},
                          "count.csv"),
      Catch::Contains("count.csv: 2 output columns after t ('a, b'), but the model has 1"));
}

}  // namespace
}  // namespace servokit
