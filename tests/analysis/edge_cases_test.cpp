// Numerical edge cases of the classification (issue #7): P near singular, M near singular,
// parameters at 0 or huge, NaN or Inf in a parameter or produced by the model. Each case must
// give a correct classification, with the tolerance that decided it stated, or a clear error;
// never a NaN in the output without a message. Expected values are closed forms derived here:
//
// Rotational arm (models/rotational_arm.yaml, paper Eq. 49 with Table 2, output
// y = alpha + s/(s+l) beta) at beta = 0: M = m l^2 [[8/3, 5/6], [5/6, 1/3]], det M = 7/36 m^2 l^4,
// M^-1 B = [12, -30] / (7 m l^2), H = [1, sigma] with sigma = s/(s+l), so
//   P(s) = (12 - 30 sigma) / (7 m l^2) = 6 (2l - 3s) / (7 m l^2 (s + l)),
// linear in s - 2l/3 near s* = 2l/3: P = -54 (s - s*) / (35 m l^3). The rank threshold is
// rank_tolerance |H| |M^-1 B| = 1e-10 sqrt(1 + sigma^2) sqrt(12^2 + 30^2) / (7 m l^2)
// (= 1.446e-10 at s*), so P counts as zero for |s - s*| <= 3.2e-10 l. The zero dynamics are the
// roots of Eq. (56): m l^2 (2l - 3s) lambda^2 + 6 d (s+l) lambda + 6 c (s+l) = 0; where P is
// taken as zero only the linear part remains: lambda = -c/d.
//
// Mass on car (models/mass_on_car.yaml, Eqs. 26-27): det M = m1 m2 + m2^2 sin^2(alpha),
// P = (M22 - cos(alpha) M12) / det M = sin^2(alpha) / (m1 + m2 sin^2(alpha)), and the zero
// dynamics m2 sin^2(alpha) s'' + d s' + k s = 0 (Eq. 36 with y_d = 0).
#include <sys/wait.h>

#include <algorithm>
#include <catch2/catch.hpp>
#include <cmath>
#include <complex>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <limits>
#include <nlohmann/json.hpp>
#include <numbers>
#include <regex>
#include <sstream>
#include <string>
#include <vector>

#include "analysis/sweep_point.h"
#include "analysis/thresholds.h"
#include "base/errors.h"
#include "tests/analysis/classify_helpers.h"
#include "tests/test_files.h"
#include "tests/test_process.h"

namespace servokit {
namespace {

namespace fs = std::filesystem;
using Catch::Matchers::Contains;
using Catch::Matchers::StartsWith;
using testing::ClassifyFile;
using testing::ModelPath;
using testing::ReadFile;
using testing::StartProcess;
using testing::TemporaryDirectory;
using testing::TestDataPath;
using testing::WaitForProcess;

// Table 2 (the arm) and the mass on car's parameters (docs/model-files.md "Shipped models").
constexpr double kL = 1.0, kArmMass = 3.438, kC = 50.0, kArmDamping = 0.25;
constexpr double kM1 = 1.0, kM2 = 2.0, kK = 5.0;
const double kAlpha = 5.0 * std::numbers::pi / 180.0;
const double kSin2 = std::sin(kAlpha) * std::sin(kAlpha);

std::string Exact(double value) {
  char text[32];
  std::snprintf(text, sizeof text, "%.17g", value);
  return text;
}

// ---- closed forms --------------------------------------------------------------------------

// In long double: near s* the factor 2l - 3s cancels to a few bits of a double.
long double ArmP(double s) {
  const long double ls = s;
  return 6.0L * (2.0L * kL - 3.0L * ls) / (7.0L * kArmMass * kL * kL * (ls + kL));
}

double ArmRankThreshold(double s, double rank_tolerance) {
  const double sigma = s / (s + kL);
  return rank_tolerance * std::sqrt(1.0 + sigma * sigma) * std::sqrt(12.0 * 12.0 + 30.0 * 30.0) /
         (7.0 * kArmMass * kL * kL);
}

// The two real roots of Eq. (56), by the cancellation-free quadratic formula in long double,
// sorted as SortEigenvalues does (real part descending).
std::vector<double> ArmZeroDynamics(double s) {
  const long double ls = s;
  const long double a2 = kArmMass * kL * kL * (2.0L * kL - 3.0L * ls);
  const long double a1 = 6.0L * kArmDamping * (ls + kL);
  const long double a0 = 6.0L * kC * (ls + kL);
  const long double discriminant = a1 * a1 - 4.0L * a2 * a0;
  REQUIRE(discriminant > 0.0L);
  const long double q = -0.5L * (a1 + std::sqrt(discriminant));
  std::vector<double> roots = {double(q / a2), double(a0 / q)};
  std::sort(roots.rbegin(), roots.rend());
  return roots;
}

// ---- sweep files ---------------------------------------------------------------------------

// The comma-separated fields of a CSV row that has no quoted field.
std::vector<std::string> Fields(const std::string& row) {
  std::vector<std::string> fields;
  for (std::size_t start = 0;;) {
    const std::size_t comma = row.find(',', start);
    fields.push_back(row.substr(start, comma - start));
    if (comma == std::string::npos) return fields;
    start = comma + 1;
  }
}

// Checks a points.csv row of a sweep of the mass on car (alpha = 5 deg) over one parameter
// (docs/sweep.md "The files", points.csv: the parameter, realization, P_rank, relative_degree,
// differentiation_index, internal_dynamics_order, stability, max_real_part, error). The class
// columns follow from the model's matrices (file comment), whatever k and d:
//  - P = sin^2(alpha) / (m1 + m2 sin^2(alpha)) != 0: rank 1 = m, and F first appears in y''
//    (relative degree 2);
//  - ker H, H = [1, cos(alpha)], is spanned by D = [-cos(alpha), 1] / |.|, and
//    D^T B = -cos(alpha) / |.| != 0: non-ideal orthogonal (docs/analyze.md "How it is computed",
//    Realization);
//  - index = relative degree + 1 = 3; internal dynamics order 2 n - r = 4 - 2 = 2.
// `max_real_part` is compared with the closed form within round-off (1e-12) relative to
// `magnitude`, the largest |lambda|; the error column is empty.
void CheckMassOnCarRow(const std::string& row,
                       double parameter,
                       const std::string& stability,
                       double max_real_part,
                       double magnitude) {
  INFO(row);
  const std::vector<std::string> fields = Fields(row);
  REQUIRE(fields.size() == 9);
  CHECK(std::stod(fields[0]) == parameter);  // written exactly: reads back to the same double
  CHECK(fields[1] == "non-ideal-orthogonal");
  CHECK(fields[2] == "1");
  CHECK(fields[3] == "2");
  CHECK(fields[4] == "3");
  CHECK(fields[5] == "2");
  CHECK(fields[6] == stability);
  CHECK(std::abs(std::stod(fields[7]) - max_real_part) <= 1e-12 * magnitude);
  CHECK(fields[8].empty());
}

// ---- the servokit binary -------------------------------------------------------------------

struct Run {
  int status = -1;
  std::string out, err;
};

// Runs SERVOKIT_BINARY with `arguments` in `work`, which keeps its stdout and stderr.
Run RunBinary(const TemporaryDirectory& work, std::vector<std::string> arguments) {
  REQUIRE(fs::exists(SERVOKIT_BINARY));
  arguments.insert(arguments.begin(), SERVOKIT_BINARY);
  const int status = WaitForProcess(StartProcess(work.path(), arguments));
  REQUIRE(WIFEXITED(status));
  return {WEXITSTATUS(status), ReadFile(work / "stdout.txt"), ReadFile(work / "stderr.txt")};
}

// The message of the NoSolution that `classify` throws (any other exception fails the test).
template <typename Classify>
std::string NoSolutionMessage(Classify classify) {
  try {
    classify();
  } catch (const NoSolution& error) {
    return error.what();
  }
  return "(no NoSolution was thrown)";
}

// "nan", "inf" or "infinity" as a word, as printf and CSV writers spell non-finite numbers
// (not "infinite_zero_orders").
bool HasNonFiniteNumber(const std::string& text) {
  static const std::regex non_finite(R"(\b(nan|inf|infinity)\b)", std::regex::icase);
  return std::regex_search(text, non_finite);
}

// ---- P near singular: the arm around s* = 2l/3 ---------------------------------------------

TEST_CASE("the arm near s = 2l/3: P, the rank band and the zero dynamics follow the closed form",
          "[analysis][paper]") {
  const double s_star = 2.0 * kL / 3.0;
  for (const double offset : {0.0, 1e-10, -1e-10, 1e-9, -1e-9, 1e-6, -1e-6}) {
    const double s = s_star + offset;
    INFO("s = 2l/3 + " << offset);
    const Classification c = ClassifyFile(ModelPath("rotational_arm.yaml"), {{"s", Exact(s)}});
    const double expected_p = double(ArmP(s));
    const double threshold = ArmRankThreshold(s, 1e-10);
    // Round-off of H M^-1 B: a few epsilon of |H| |M^-1 B| = 1.4 (absolute).
    CHECK(c.decoupling.decoupling_matrix(0, 0) == Approx(expected_p).margin(1e-15));
    CHECK(c.decoupling.rank_threshold == Approx(threshold).epsilon(1e-12));
    // Every case is at least a factor 3 from the edge of the band (|s - s*| = 3.2e-10), so
    // round-off cannot decide it.
    const double ratio = std::abs(expected_p) / threshold;
    REQUIRE((ratio < 1.0 / 3.0 || ratio > 3.0));
    const bool rank_one = ratio > 1.0;
    CHECK(c.decoupling.rank == (rank_one ? 1 : 0));
    REQUIRE(c.cross_check.has_value());
    CHECK(c.cross_check->agrees);
    if (!rank_one) {
      CHECK(c.decoupling.realization == Realization::kTangential);
      CHECK(c.structure.relative_degree == std::vector<int>{3});
      CHECK(c.structure.differentiation_index == 4);
      REQUIRE(c.zero_dynamics.eigenvalues.size() == 1);
      CHECK(c.zero_dynamics.eigenvalues[0].real() == Approx(-kC / kArmDamping).epsilon(1e-6));
      CHECK(c.zero_dynamics.stability == Stability::kAsymptoticallyStable);
      continue;
    }
    CHECK(c.decoupling.realization == Realization::kNonIdealOrthogonal);
    CHECK(c.structure.relative_degree == std::vector<int>{2});
    CHECK(c.structure.differentiation_index == 3);
    const std::vector<double> roots = ArmZeroDynamics(s);
    REQUIRE(c.zero_dynamics.eigenvalues.size() == 2);
    // The far root is -a1/a2 ~ 1/P: P carries a relative round-off of up to 1e-16 * 1.4 / |P|
    // (7e-7 at |s - s*| = 1e-9).
    for (std::size_t i = 0; i < 2; ++i) {
      CHECK(c.zero_dynamics.eigenvalues[i].real() == Approx(roots[i]).epsilon(1e-5));
      CHECK(c.zero_dynamics.eigenvalues[i].imag() == 0.0);
    }
    // Past s* the leading coefficient m l^2 (2l - 3s) is negative: one root in the right half
    // plane (Fig. 8).
    CHECK(c.zero_dynamics.stability ==
          (offset > 0 ? Stability::kUnstable : Stability::kAsymptoticallyStable));
  }
}

TEST_CASE("analyze states the rank threshold next to P, and the tolerance moves the verdict",
          "[analysis]") {
  const TemporaryDirectory work;
  const double s = 2.0 * kL / 3.0 + 1e-10;  // |P| = 4.5e-11: zero at 1e-10, not at 1e-11
  for (const double tolerance : {1e-10, 1e-11}) {
    INFO("--rank-tolerance " << tolerance);
    const Run run =
        RunBinary(work, {"analyze", ModelPath("rotational_arm.yaml"), "--set", "s=" + Exact(s),
                         "--rank-tolerance", Exact(tolerance), "--format", "json"});
    INFO(run.err);
    REQUIRE(run.status == 0);
    const nlohmann::json json = nlohmann::json::parse(run.out);
    const double threshold = ArmRankThreshold(s, tolerance);
    CHECK(json["tolerances"]["rank_tolerance"].get<double>() == tolerance);
    CHECK(json["P_rank_threshold"].get<double>() == Approx(threshold).epsilon(1e-12));
    CHECK(json["P"][0][0].get<double>() == Approx(double(ArmP(s))).margin(1e-15));
    const bool rank_one = std::abs(double(ArmP(s))) > threshold;
    CHECK(rank_one == (tolerance < 1e-10));
    CHECK(json["P_rank"].get<int>() == (rank_one ? 1 : 0));
    CHECK(json["realization"].get<std::string>() ==
          (rank_one ? "non-ideal-orthogonal" : "tangential"));
    CHECK_FALSE(HasNonFiniteNumber(run.out));
    // nlohmann::json writes NaN and Inf as null.
    for (const char* key : {"P", "P_singular_values", "P_rank_threshold"}) {
      INFO(key);
      CHECK(json[key].dump().find("null") == std::string::npos);
    }
  }
  // The text form says the same: "(zero below <threshold>)", with the default tolerance 1e-10.
  const Run text =
      RunBinary(work, {"analyze", ModelPath("rotational_arm.yaml"), "--set", "s=" + Exact(s)});
  REQUIRE(text.status == 0);
  static const std::regex zero_below(R"(\(zero below ([^)]+)\))");
  std::smatch printed;
  REQUIRE(std::regex_search(text.out, printed, zero_below));
  // The closed form 1e-10 |H| |M^-1 B| (file comment; 1.446e-10 here). The text report prints
  // six significant digits, so the printed number is within half a unit of the sixth digit
  // (5e-6 relative) of the threshold.
  CHECK(std::stod(printed[1].str()) == Approx(ArmRankThreshold(s, 1e-10)).epsilon(5e-6));
}

// ---- M near singular ------------------------------------------------------------------------

TEST_CASE("a mass matrix singular to working precision is an error that names it", "[analysis]") {
  // det M = m1 m2 + m2^2 sin^2(alpha): exactly 0 for m1 = 0 at alpha = 0; 1e-300 against entries
  // of order 1 for m2 = 1e-300; entries 1e308 against 2 for m1 = 1e308 (condition ~ 1e308).
  // Before: "the output does not determine the inputs" and "infinite relative degree".
  const std::vector<std::vector<ParameterOverride>> cases = {
      {{"m1", "0"}, {"alpha", "0"}}, {{"m2", "1e-300"}}, {{"m1", "1e308"}}};
  for (const auto& overrides : cases) {
    INFO(overrides.front().name << " = " << overrides.front().value);
    CHECK_THAT(NoSolutionMessage([&] { ClassifyFile(ModelPath("mass_on_car.yaml"), overrides); }),
               Contains("the mass matrix is singular to working precision"));
  }
  // m2 = 0 makes M semidefinite: det M = 0 and the Cholesky factor fails.
  CHECK_THAT(NoSolutionMessage([&] {
               ClassifyFile(ModelPath("mass_on_car.yaml"), {{"m2", "0"}});
             }),
             Contains("mass matrix is not positive definite"));
  // Through the command line: one line, exit status 3 (no solution of the kind asked).
  const TemporaryDirectory work;
  const Run run = RunBinary(
      work, {"analyze", ModelPath("mass_on_car.yaml"), "--set", "m1=0", "--set", "alpha=0"});
  CHECK(run.status == 3);
  CHECK_THAT(run.err, Contains("servokit: error: the mass matrix is singular to working "
                               "precision at the operating point"));
  CHECK(run.out.empty());
}

TEST_CASE("the singular-mass decision is LLT's rcond estimate against 1e3 epsilon", "[analysis]") {
  // Linearize skips the estimate when the exact reciprocal condition (from M^-1) clears the
  // limit twice over. The rule itself is unchanged: at alpha = 0, M = [[m1 + m2, m2], [m2, m2]]
  // (det m1 m2), and m1 steps through the limit; each verdict must be the one LLT's rcond()
  // of that M gives, computed here directly.
  const double m2 = 2.0, limit = 1e3 * std::numeric_limits<double>::epsilon();
  int refused = 0, accepted = 0;
  for (double m1 = 1e-14; m1 < 1e-10; m1 *= 1.25) {
    Eigen::Matrix2d mass;
    mass << m1 + m2, m2, m2, m2;
    const bool singular = !(Eigen::LLT<Eigen::MatrixXd>(Eigen::MatrixXd(mass)).rcond() > limit);
    std::ostringstream value;
    value.precision(17);
    value << m1;
    INFO("m1 = " << value.str());
    const std::string message = NoSolutionMessage([&] {
      ClassifyFile(ModelPath("mass_on_car.yaml"), {{"m1", value.str()}, {"alpha", "0"}});
    });
    CHECK((message.find("the mass matrix is singular to working precision") != std::string::npos) ==
          singular);
    (singular ? refused : accepted) += 1;
  }
  CHECK(refused > 0);
  CHECK(accepted > 0);
}

TEST_CASE("a massless car is regular away from alpha = 0: P = 1/m2", "[analysis]") {
  // m1 = 0 at alpha = 5 deg: det M = m2^2 sin^2(alpha) > 0; P = sin^2 / (0 + m2 sin^2) = 1/m2.
  for (const char* m1 : {"0", "1e-300"}) {
    INFO("m1 = " << m1);
    const Classification c = ClassifyFile(ModelPath("mass_on_car.yaml"), {{"m1", m1}, {"d", "1"}});
    CHECK(c.decoupling.decoupling_matrix(0, 0) == Approx(1.0 / kM2).epsilon(1e-12));
    const std::vector<std::complex<double>> roots = testing::QuadraticRoots(kM2 * kSin2, 1.0, kK);
    REQUIRE(c.zero_dynamics.eigenvalues.size() == 2);
    for (std::size_t i = 0; i < 2; ++i) {
      CHECK(c.zero_dynamics.eigenvalues[i].real() == Approx(roots[i].real()).epsilon(1e-9));
    }
  }
}

// ---- parameters at 0 or huge ----------------------------------------------------------------

TEST_CASE("huge stiffness: exact zero dynamics up to k = 1e300, a clear overflow error at 1e308",
          "[analysis]") {
  // d = 0: the zero dynamics are +-i sqrt(k / (m2 sin^2 alpha)) (critical).
  // Before: k = 1e200 gave "infinite relative degree" (the squares in norm() overflowed) and
  // k = 1e300 "equilibrium not isolated" (FullPivLU's threshold set by the entry 1e300).
  for (const double k : {1e20, 1e150, 1e200, 1e300}) {
    INFO("k = " << k);
    const Classification c =
        ClassifyFile(ModelPath("mass_on_car.yaml"), {{"k", Exact(k)}, {"d", "0"}});
    const double frequency = std::sqrt(k) / std::sqrt(kM2 * kSin2);
    REQUIRE(c.zero_dynamics.eigenvalues.size() == 2);
    CHECK(c.zero_dynamics.eigenvalues[0].imag() == Approx(frequency).epsilon(1e-9));
    CHECK(c.zero_dynamics.eigenvalues[1].imag() == Approx(-frequency).epsilon(1e-9));
    CHECK(c.zero_dynamics.stability == Stability::kCritical);
    CHECK(c.decoupling.decoupling_matrix(0, 0) ==
          Approx(kSin2 / (kM1 + kM2 * kSin2)).epsilon(1e-12));
  }
  // k = 1e308: M^-1 K is finite but the first-order zero dynamics overflow; before, "the
  // equilibrium is not isolated", which is false (k > 0 fixes s).
  CHECK_THAT(NoSolutionMessage([&] {
               ClassifyFile(ModelPath("mass_on_car.yaml"), {{"k", "1e308"}, {"d", "0"}});
             }),
             Contains("overflows the range of double"));
  // A sweep decides as analyze does (issue #29): its polynomial route never forms k / m2 and
  // would have roots here, but the point records analyze's overflow, not a verdict analyze
  // refuses.
  const Model model = LoadModel(ModelPath("mass_on_car.yaml"), {{"k", "1e308"}, {"d", "0"}});
  Workspace workspace(model);
  const SweepPoint point = AnalyzeSweepPoint(model, workspace, ClassificationOptions{});
  CHECK_FALSE(point.ok);
  CHECK_THAT(point.error, Contains("overflows the range of double"));
}

TEST_CASE("a mass matrix beyond the largest double is an overflow error, not a singular one",
          "[analysis]") {
  // m2 = 1e308: the first column of M sums to m1 + m2 + m2 cos(alpha) = 1.996e308 > 1.797e308,
  // so M's norm (and its condition estimate) overflows; before: "infinite relative degree".
  CHECK_THAT(NoSolutionMessage([&] {
               ClassifyFile(ModelPath("mass_on_car.yaml"), {{"m2", "1e308"}});
             }),
             Contains("the mass matrix overflows the range of double") && Contains("m2 = 1e+308"));
}

TEST_CASE("far output values are reached; one so large that Newton's step overflows is named",
          "[analysis]") {
  // The mass on the car: y = x + s cos(alpha), and k s = 0, F = 0 at rest, so the equilibrium
  // for y0 is x = y0, s = 0, u = 0 exactly. KINSOL caps a step from q = 0 at length 1 and gave
  // up after five (KIN_MXNEWT_5X_EXCEEDED) for y0 = 10 before servokit continued from there.
  const TemporaryDirectory work;
  for (const double y0 : {10.0, 1e3, 1e6}) {
    INFO("y0 = " << y0);
    const Run run = RunBinary(
        work, {"analyze", ModelPath("mass_on_car.yaml"), "--y0", Exact(y0), "--format", "json"});
    REQUIRE(run.status == 0);
    const nlohmann::json point = nlohmann::json::parse(run.out)["operating_point"];
    CHECK(point["q"][0].get<double>() == Approx(y0).epsilon(1e-12));
    CHECK(std::abs(point["q"][1].get<double>()) <= 1e-12 * y0);
    CHECK(std::abs(point["u"][0].get<double>()) <= 1e-12 * y0);
  }
  // Past about 1e154 KINSOL's 0.5 |F|^2 overflows; then its step does. It used to give up with
  // a flag SUNDIALS 6.4 names "NONE"; the message must say what happened instead.
  const Run run = RunBinary(work, {"analyze", ModelPath("mass_on_car.yaml"), "--y0", "1e308"});
  CHECK(run.status == 3);
  CHECK(run.out.empty());
  CHECK(run.err ==
        "servokit: error: no equilibrium found for y0 = [1e+308]: the equilibrium equations "
        "became NaN or Inf after a Newton step overflowed q (is y0 within the model's range?); "
        "give a starting point near the equilibrium (--q0, or q0: in the model file)\n");
}

TEST_CASE("k = 0 leaves s free: the equilibrium is not isolated", "[analysis]") {
  // With k = 0, f(q, 0) = 0 for every s: (y0 - s cos(alpha), s) is an equilibrium for all s.
  CHECK_THAT(NoSolutionMessage([&] {
               ClassifyFile(ModelPath("mass_on_car.yaml"), {{"k", "0"}});
             }),
             Contains("is not isolated"));
}

TEST_CASE("huge damping overflows with a message, not 'did not converge'", "[analysis]") {
  // d = 1e308: the roots of m2 sin^2 lambda^2 + d lambda + k are -k/d = -5e-308 and
  // -d/(m2 sin^2 alpha) = -6.6e309, beyond the largest double.
  CHECK_THAT(NoSolutionMessage([&] {
               ClassifyFile(ModelPath("mass_on_car.yaml"), {{"d", "1e308"}});
             }),
             Contains("overflows the range of double"));
}

// ---- the two routes to the zero dynamics disagree (issue #29) -------------------------------

TEST_CASE(
    "a cross-check that disagrees is stated with its reason; the verdict is the normal form's",
    "[analysis]") {
  // tests/data/edge_tan_pole.yaml: the spring force k tan(s + pi/2), at s = 0 where double's
  // tan(pi/2) = t = 1.633e16 (pi/2 rounded below the pole). The linearization's stiffness is
  // k (1 + t^2) = 1.33e33, and the zero dynamics (Eq. 36 with that stiffness) are
  // m2 sin^2(alpha) lambda^2 + d lambda + k (1 + t^2) = 0: lambda = -d / (2 m2 sin^2 alpha)
  // +- i omega, omega = sqrt(k (1 + t^2) / (m2 sin^2 alpha) - (d / (2 m2 sin^2 alpha))^2)
  // = 2.96e17, damping ratio 1.1e-16: on the imaginary axis by the axis tolerance (critical).
  // QZ of the unscaled pencil finds four finite zeros instead of two.
  const double t = std::tan(std::numbers::pi / 2);
  const double mass = kM2 * kSin2;
  const double omega = std::sqrt(kK * (1.0 + t * t) / mass - std::pow(1.0 / (2.0 * mass), 2));
  const Classification c = ClassifyFile(TestDataPath("edge_tan_pole.yaml"));
  REQUIRE(c.zero_dynamics.eigenvalues.size() == 2);
  // The normal form's eigenvalues: round-off of a 2 x 2 eigenproblem, relative to |lambda|.
  CHECK(c.zero_dynamics.eigenvalues[0].imag() == Approx(omega).epsilon(1e-9));
  CHECK(std::abs(c.zero_dynamics.eigenvalues[0].real()) <= 1e-9 * omega);
  CHECK(c.zero_dynamics.stability == Stability::kCritical);
  REQUIRE(c.cross_check.has_value());
  CHECK_FALSE(c.cross_check->agrees);
  CHECK(c.cross_check->invariant_zeros.size() != 2);
  CHECK_THAT(c.cross_check->note,
             Contains("QZ counts " + std::to_string(c.cross_check->invariant_zeros.size()) +
                      " finite invariant zeros where the orders of the infinite zeros give 2") &&
                 Contains("the zero dynamics and stability shown are the normal form's"));
  // A sweep (no QZ) gives the same verdict.
  const Model model = LoadModel(TestDataPath("edge_tan_pole.yaml"));
  Workspace workspace(model);
  const SweepPoint point = AnalyzeSweepPoint(model, workspace, ClassificationOptions{});
  REQUIRE(point.ok);
  CHECK(point.stability == Stability::kCritical);
  // Through the command line: the row and the JSON say which route decided, on one line.
  const TemporaryDirectory work;
  const Run text = RunBinary(work, {"analyze", TestDataPath("edge_tan_pole.yaml")});
  CHECK(text.status == 0);
  static const std::regex row(R"(\n  cross-check \(QZ\) +DISAGREES: [^\n]*normal form's[^\n]*\n)");
  CHECK(std::regex_search(text.out, row));
  const Run json =
      RunBinary(work, {"analyze", TestDataPath("edge_tan_pole.yaml"), "--format", "json"});
  REQUIRE(json.status == 0);
  const nlohmann::json check = nlohmann::json::parse(json.out)["zero_dynamics"]["cross_check"];
  CHECK(check["agrees"] == false);
  CHECK(check["note"].get<std::string>() == c.cross_check->note);
}

TEST_CASE("QZ that does not converge fails the cross-check, not the analysis", "[analysis]") {
  // m2 = k = 1e300, d = 0: the zero dynamics m2 sin^2(alpha) lambda^2 + k = 0 are
  // +-i sqrt(k / m2) / sin(alpha) = +-i / sin(5 deg) = +-11.47i, which the normal form finds;
  // QZ of the pencil with entries 1 and 1e300 does not converge. Before: exit status 3.
  const Classification c =
      ClassifyFile(ModelPath("mass_on_car.yaml"), {{"m2", "1e300"}, {"k", "1e300"}, {"d", "0"}});
  REQUIRE(c.zero_dynamics.eigenvalues.size() == 2);
  CHECK(c.zero_dynamics.eigenvalues[0].imag() == Approx(1.0 / std::sin(kAlpha)).epsilon(1e-9));
  REQUIRE(c.cross_check.has_value());
  CHECK_FALSE(c.cross_check->agrees);
  CHECK(c.cross_check->invariant_zeros.empty());
  CHECK_THAT(c.cross_check->note, StartsWith("QZ of the Rosenbrock pencil did not converge; ") &&
                                      Contains("normal form's"));
}

// ---- NaN and Inf ----------------------------------------------------------------------------

TEST_CASE("a force that is NaN or infinite at the operating point is an error naming it",
          "[analysis]") {
  const std::string path = TestDataPath("edge_nan_stiffness.yaml");
  // Nominal: sqrt(25) = 5 = k and log(e) = 1 = d: the mass on car's zero dynamics.
  const Classification c = ClassifyFile(path);
  const auto roots = testing::QuadraticRoots(kM2 * kSin2, 1.0, kK);
  REQUIRE(c.zero_dynamics.eigenvalues.size() == 2);
  for (std::size_t i = 0; i < 2; ++i) {
    CHECK(c.zero_dynamics.eigenvalues[i].real() == Approx(roots[i].real()).epsilon(1e-9));
  }
  // sqrt(-1) and log(0), log(-1): NaN or -Inf in the forces at q = 0.
  for (const ParameterOverride& bad :
       std::vector<ParameterOverride>{{"c", "-1"}, {"g", "0"}, {"g", "-1"}}) {
    const std::string& name = bad.name;
    const std::string& value = bad.value;
    INFO(name << " = " << value);
    CHECK_THAT(NoSolutionMessage([&] { ClassifyFile(path, {bad}); }),
               Contains("the model is not finite at q0 = [0, 0]: NaN or Inf") &&
                   Contains(name + " = " + value));
  }
}

TEST_CASE("Inf, NaN and numbers beyond double on the command line are usage errors", "[analysis]") {
  const TemporaryDirectory work;
  for (const char* value : {"inf", "-inf", "nan", "1e400", "-1e400"}) {
    INFO("--set k=" << value);
    const Run run = RunBinary(
        work, {"analyze", ModelPath("mass_on_car.yaml"), "--set", std::string("k=") + value});
    CHECK(run.status == 2);
    CHECK_THAT(run.err, Contains(std::string("--set k=") + value + ": not a number"));
  }
  for (const char* vary : {"k=0:inf:3", "k=1e400:1:3", "k=1,nan", "k=-inf,1"}) {
    INFO("--vary " << vary);
    const fs::path out = work / "sweep";
    const Run run = RunBinary(
        work, {"sweep", ModelPath("mass_on_car.yaml"), "--vary", vary, "--out", out.string()});
    CHECK(run.status == 2);
    CHECK_THAT(run.err, Contains(std::string("--vary ") + vary + ": '"));
    CHECK_FALSE(fs::exists(out));
  }
}

TEST_CASE("NaN and Inf in a trajectory are usage errors, and no CSV is written", "[analysis]") {
  const TemporaryDirectory work;
  const fs::path csv = work / "u.csv";
  const std::vector<std::string> solve = {
      "solve", ModelPath("mass_on_car.yaml"), "--t-end", "3", "--out", csv.string()};
  const auto with = [&](std::vector<std::string> trajectory) {
    std::vector<std::string> arguments = solve;
    arguments.insert(arguments.end(), trajectory.begin(), trajectory.end());
    return arguments;
  };
  const std::vector<std::string> rest_to_rest = {
      "--trajectory", "rest-to-rest", "--t0", "0", "--tf", "1"};
  for (const char* value : {"nan", "inf", "-inf"}) {
    std::vector<std::string> arguments = with(rest_to_rest);
    arguments.insert(arguments.end(), {"--y0", "0", "--yf", value});
    INFO("--yf " << value);
    const Run run = RunBinary(work, arguments);
    CHECK(run.status == 2);
    CHECK_THAT(run.err,
               Contains(std::string("--yf ") + value + ": '" + value + "' is not a number"));
    CHECK_FALSE(fs::exists(csv));
  }
  // YAML spells them .nan and .inf; a waypoint file names the entry.
  for (const auto& [entry, waypoints] :
       {std::pair{"waypoints[1].y[0]", "waypoints:\n- {t: 0, y: [0]}\n- {t: 1, y: [.nan]}\n"},
        std::pair{"waypoints[1].t", "waypoints:\n- {t: 0, y: [0]}\n- {t: .inf, y: [1]}\n"},
        std::pair{"waypoints[0].y[0]", "waypoints:\n- {t: 0, y: [-.inf]}\n- {t: 1, y: [1]}\n"}}) {
    const fs::path file = work / "waypoints.yaml";
    std::ofstream(file) << waypoints;
    INFO(waypoints);
    const Run run = RunBinary(work, with({"--trajectory", file.string()}));
    CHECK(run.status == 2);
    CHECK_THAT(run.err, Contains(file.string() + ": " + entry + ": not a number"));
    CHECK(std::count(run.err.begin(), run.err.end(), '\n') == 1);
    CHECK_FALSE(fs::exists(csv));
  }
}

TEST_CASE("a sweep records edge points that fail with their message and writes no NaN",
          "[analysis]") {
  const TemporaryDirectory work;
  const fs::path out = work / "sweep";
  const Run run =
      RunBinary(work, {"sweep", ModelPath("mass_on_car.yaml"), "--vary", "k=0,5,1e300,1e308",
                       "--set", "d=0", "--out", out.string(), "--threads", "1"});
  INFO(run.err);
  REQUIRE(run.status == 0);
  const std::vector<std::string> rows = testing::Lines(ReadFile(out / "points.csv"));
  REQUIRE(rows.size() == 5);
  CHECK_THAT(rows[1], Contains("0,,,,,,,,\"the equilibrium at q = [0, 0] is not isolated"));
  // k = 1e308: the error analyze gives (the zero dynamics overflow), not a verdict.
  CHECK_THAT(rows[4], Contains("1e+308,,,,,,,,\"") && Contains("overflows the range of double"));
  const std::string eigenvalues = ReadFile(out / "eigenvalues.csv");
  CHECK_FALSE(HasNonFiniteNumber(ReadFile(out / "points.csv")));
  CHECK_FALSE(HasNonFiniteNumber(eigenvalues));
  const std::vector<std::string> eigenvalue_rows = testing::Lines(eigenvalues);
  // Two eigenvalues for each of the two points with a solution, after the header.
  REQUIRE(eigenvalue_rows.size() == 5);
  const std::vector<double> stiffnesses = {5.0, 1e300};
  for (std::size_t i = 0; i < stiffnesses.size(); ++i) {
    const double k = stiffnesses[i];
    INFO("k = " << k);
    // d = 0: the roots of m2 sin^2(alpha) lambda^2 + k are +-i omega, omega =
    // sqrt(k / (m2 sin^2 alpha)) (18.14 for k = 5: 2.887 Hz, paper Sect. 3): max real part 0,
    // critical.
    const double omega = std::sqrt(k) / std::sqrt(kM2 * kSin2);
    CheckMassOnCarRow(rows[2 + i], k, "critical", 0.0, omega);
    // Rows k, eigenvalue_index, re, im, frequency_hz = |lambda| / 2 pi, damping_ratio = -re /
    // |lambda| (docs/sweep.md "The files", eigenvalues.csv): the pair +-i omega, the positive
    // imaginary part first (real parts equal, imaginary parts descending). Tolerance: round-off of
    // the eigenvalue solver, relative to |lambda| = omega.
    for (std::size_t j = 0; j < 2; ++j) {
      const std::vector<std::string> fields = Fields(eigenvalue_rows[1 + 2 * i + j]);
      INFO(eigenvalue_rows[1 + 2 * i + j]);
      REQUIRE(fields.size() == 6);
      CHECK(std::stod(fields[0]) == k);
      CHECK(fields[1] == std::to_string(j));
      const double sign = j == 0 ? 1.0 : -1.0;
      CHECK(std::abs(std::stod(fields[2])) <= 1e-12 * omega);
      CHECK(std::stod(fields[3]) == Approx(sign * omega).epsilon(1e-12));
      CHECK(std::stod(fields[4]) == Approx(omega / (2.0 * std::numbers::pi)).epsilon(1e-12));
      CHECK(std::abs(std::stod(fields[5])) <= 1e-12);
    }
  }

  // The NaN-producing model: the row names the problem, the sweep goes on.
  const fs::path out2 = work / "sweep2";
  const Run nan_run = RunBinary(work, {"sweep", TestDataPath("edge_nan_stiffness.yaml"), "--vary",
                                       "c=-1,25", "--out", out2.string()});
  REQUIRE(nan_run.status == 0);
  const std::vector<std::string> nan_rows = testing::Lines(ReadFile(out2 / "points.csv"));
  REQUIRE(nan_rows.size() == 3);
  CHECK_THAT(nan_rows[1], Contains("-1,,,,,,,,\"the model is not finite at q0 = [0, 0]"));
  // c = 25, g = e: the mass on car with k = 5, d = 1, whose zero dynamics
  // m2 sin^2(alpha) lambda^2 + d lambda + k = 0 (Eq. 36) has two negative real roots
  // (over-damped below 9.1 deg, Fig. 6): asymptotically stable, max real part the larger root.
  const auto roots = testing::QuadraticRoots(kM2 * kSin2, 1.0, kK);
  CheckMassOnCarRow(nan_rows[2], 25.0, "asymptotically-stable", roots[0].real(),
                    std::abs(roots[1]));
}

TEST_CASE("a sweep row is an error exactly where analyze exits with status 3", "[analysis]") {
  // The reproductions of issue #29 through the program. alpha = 0, d = 1: det M = m1 m2 is 0
  // at m1 = 0, and m1 + m2 rounds to m2 at m1 = 1e-20 (singular to working precision); at
  // m1 = 1, M is regular, P = sin^2(alpha) / det M = 0 (tangential), the zero dynamics
  // d s' + k s = 0 have the one root -k/d = -5 (relative degree 2 dof - 1 = 3, index 4).
  // Before, all three rows were "tangential, asymptotically-stable".
  const TemporaryDirectory work;
  const std::vector<std::string> fixed = {"--set", "alpha=0", "--set", "d=1"};
  const auto with = [](std::vector<std::string> first, const std::vector<std::string>& rest) {
    first.insert(first.end(), rest.begin(), rest.end());
    return first;
  };
  const Run sweep =
      RunBinary(work, with({"sweep", ModelPath("mass_on_car.yaml"), "--vary", "m1=0,1e-20,1",
                            "--out", (work / "masses").string(), "--threads", "1"},
                           fixed));
  REQUIRE(sweep.status == 0);
  const std::vector<std::string> rows = testing::Lines(ReadFile(work / "masses" / "points.csv"));
  REQUIRE(rows.size() == 4);
  for (const std::string m1 : {"0", "1e-20", "1"}) {
    INFO("m1 = " << m1);
    const Run analyze = RunBinary(
        work, with({"analyze", ModelPath("mass_on_car.yaml"), "--set", "m1=" + m1}, fixed));
    CHECK(analyze.status == (m1 == "1" ? 0 : 3));
  }
  CHECK_THAT(rows[1], StartsWith("0,,,,,,,,\"the mass matrix is singular to working precision"));
  CHECK_THAT(rows[2],
             StartsWith("1e-20,,,,,,,,\"the mass matrix is singular to working precision"));
  CHECK(rows[3] == "1,tangential,0,3,4,1,asymptotically-stable,-5,");
  // d = +-1e308 at alpha = 5 deg: the root -d / (m2 sin^2 alpha) is beyond the largest double
  // (analyze: status 3); before, the rows said "critical".
  const Run damped =
      RunBinary(work, {"sweep", ModelPath("mass_on_car.yaml"), "--vary", "d=1e308,-1e308,1",
                       "--out", (work / "dampers").string(), "--threads", "1"});
  REQUIRE(damped.status == 0);
  const std::vector<std::string> damped_rows =
      testing::Lines(ReadFile(work / "dampers" / "points.csv"));
  REQUIRE(damped_rows.size() == 4);
  for (std::size_t i = 1; i <= 2; ++i) {
    const std::string d = i == 1 ? "1e308" : "-1e308";
    INFO("d = " << d);
    CHECK(RunBinary(work, {"analyze", ModelPath("mass_on_car.yaml"), "--set", "d=" + d}).status ==
          3);
    CHECK_THAT(damped_rows[i], Contains(",,,,,,,,\"") && Contains("overflows the range of double"));
  }
  CHECK_THAT(damped_rows[3], StartsWith("1,non-ideal-orthogonal,1,2,3,2,asymptotically-stable,"));
}

TEST_CASE("threshold refuses a range whose midpoints overflow and finds k = 0 exactly",
          "[analysis]") {
  const TemporaryDirectory work;
  // Before: "value": null (a NaN) for 0:1e308 and "floating point overflow" (status 1) for
  // 1e300:1e308.
  for (const char* range : {"k=0:1e308", "k=1e300:1e308"}) {
    INFO(range);
    const Run run = RunBinary(work, {"threshold", ModelPath("mass_on_car.yaml"), "--vary", range,
                                     "--event", "stability", "--set", "d=0"});
    CHECK(run.status == 2);
    CHECK_THAT(run.err, Contains("so that its midpoints do not overflow"));
    CHECK(run.out.empty());
  }
  // k = 0 has no isolated equilibrium, every k > 0 is critical (d = 0): the one event is at 0.
  const Model model = LoadModel(ModelPath("mass_on_car.yaml"), {{"d", "0"}});
  const ThresholdSearch search = FindThresholds(model, 2, 0.0, 10.0, ThresholdEvent::kStability);
  REQUIRE(search.events.size() == 1);
  const ThresholdCrossing& event = search.events[0];
  CHECK(event.from == "no-solution");
  CHECK(event.to == "critical");
  // The final bracket (1e-12 wide, the default tolerance) holds 0, so 0 is reported; the width
  // is that of the interval centred at 0 that holds the bracket: at most twice its width.
  CHECK(event.value == 0.0);
  CHECK(event.bracket_width <= 2e-12);
}

}  // namespace
}  // namespace servokit
