// `servokit sweep` on a large linear model (`kind: linear`, analysis/sweep.h): the real
// binary on a chain written by `servokit generate chain`, its eigenvalues.csv against the closed
// form at every swept damping, and the same bytes whatever the threads, with or without mpirun,
// interrupted and resumed.
//
// Chain: N masses, force and output at mass 1, M = m I, K = k T, D = d T. The zeros are the roots
// of m λ² + d μ_i λ + k μ_i = 0, μ_i = 4 sin²((2i − 1)π / (2(2N' + 1))), N' = N − 1
// (docs/generate.md, "Synopsis"): 2N' of them; with ARPACK the `--eigenvalues K` nearest 0 are the
// K/2 slowest pairs (μ_1, μ_2, ...).
#include <algorithm>
#include <catch2/catch.hpp>
#include <chrono>
#include <cmath>
#include <complex>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <map>
#include <numbers>
#include <sstream>
#include <string>
#include <vector>

#include "tests/chain_closed_form.h"
#include "tests/test_files.h"
#include "tests/test_process.h"

namespace servokit {
namespace {

using testing::Lines;
using testing::ReadFile;
using testing::TemporaryDirectory;

namespace fs = std::filesystem;

constexpr const char* kJobTimeoutSeconds = "300";
constexpr double kMass = 2.0, kStiffness = 3.0;

std::vector<std::string> Split(const std::string& line, char separator) {
  std::vector<std::string> parts;
  std::stringstream stream(line);
  for (std::string part; std::getline(stream, part, separator);) parts.push_back(part);
  if (!line.empty() && line.back() == separator) parts.emplace_back();
  return parts;
}

using Job = testing::ProcessResult;

/// Runs `command` in `directory` (created if needed) under `timeout`, with `environment` added.
Job RunIn(const fs::path& directory,
          const std::vector<std::string>& command,
          const std::map<std::string, std::string>& environment = {}) {
  std::vector<std::string> all = {"timeout", "-k", "5", kJobTimeoutSeconds};
  all.insert(all.end(), command.begin(), command.end());
  testing::ProcessOptions options;
  options.environment = environment;
  return testing::RunProcess(directory, all, options);
}

/// `servokit generate chain` of `masses` masses into `directory`; returns the YAML's path.
std::string GenerateChain(const fs::path& directory, long masses) {
  const Job job =
      RunIn(directory, {SERVOKIT_BINARY, "generate", "chain", "--masses", std::to_string(masses),
                        "--mass", "2", "--stiffness", "3", "--out", directory.string()});
  INFO(job.err);
  REQUIRE(job.status == 0);
  return Lines(job.out).at(0);
}

std::vector<std::string> Sweep(const std::string& model,
                               const std::vector<std::string>& more = {}) {
  std::vector<std::string> command = {SERVOKIT_BINARY, "sweep",        model,
                                      "--vary",        "d=0.01:0.1:5", "--out",
                                      "out",           "--block-size", "2"};
  command.insert(command.end(), more.begin(), more.end());
  return command;
}

double Damping(std::size_t i) {
  return i == 4 ? 0.1 : 0.01 + static_cast<double>(i) * ((0.1 - 0.01) / 4.0);  // numpy.linspace
}

/// The eigenvalues.csv of `out`, by damping value (as written, exactly).
std::map<double, std::vector<std::complex<double>>> ReadEigenvalues(const fs::path& out) {
  const std::vector<std::string> lines = Lines(ReadFile(out / "eigenvalues.csv"));
  REQUIRE(!lines.empty());
  CHECK(lines[0] == "d,eigenvalue_index,re,im,frequency_hz,damping_ratio");
  std::map<double, std::vector<std::complex<double>>> zeros;
  for (std::size_t row = 1; row < lines.size(); ++row) {
    const std::vector<std::string> fields = Split(lines[row], ',');
    REQUIRE(fields.size() == 6);
    auto& list = zeros[std::stod(fields[0])];
    CHECK(std::stoul(fields[1]) == list.size());
    list.emplace_back(std::stod(fields[2]), std::stod(fields[3]));
  }
  return zeros;
}

/// Every closed-form zero expected at each damping is in the file, to `tolerance` relative.
void CheckZeros(const fs::path& out, long masses, std::size_t per_point, double tolerance) {
  const auto zeros = ReadEigenvalues(out);
  REQUIRE(zeros.size() == 5);
  for (std::size_t i = 0; i < 5; ++i) {
    const double d = Damping(i);
    INFO("d = " << d);
    REQUIRE(zeros.count(d) == 1);
    const auto& computed = zeros.at(d);
    REQUIRE(computed.size() == per_point);
    auto expected = testing::ChainZeros(masses, 1, kMass, kStiffness, d);
    expected.resize(per_point);  // the slowest pairs first: the ones nearest 0
    double worst = 0.0;
    for (const auto& zero : expected) {
      double nearest = INFINITY;
      for (const auto& value : computed) nearest = std::min(nearest, std::abs(zero - value));
      worst = std::max(worst, nearest / std::abs(zero));
    }
    CHECK(worst < tolerance);
  }
}

void CheckSameFiles(const fs::path& a, const fs::path& b) {
  for (const std::string name : {"points.csv", "eigenvalues.csv", "sweep.json"}) {
    INFO(name);
    REQUIRE(fs::exists(a / name));
    REQUIRE(fs::exists(b / name));
    const std::string first = ReadFile(a / name);
    CHECK_FALSE(first.empty());
    CHECK((first == ReadFile(b / name)));
  }
}

}  // namespace

TEST_CASE("servokit sweep on a 30-mass linear chain: every zero, the closed form at each d",
          "[reports][linear_sweep]") {
  const TemporaryDirectory work;
  const std::string model = GenerateChain(work / "model", 30);
  const Job one = RunIn(work / "one", Sweep(model), {{"OMP_NUM_THREADS", "1"}});
  INFO(one.err);
  REQUIRE(one.status == 0);
  CHECK(one.out ==
        "swept 5 points of chain_30 into out (points.csv, eigenvalues.csv, "
        "sweep.json); 0 without a solution\n");
  const fs::path out = work / "one" / "out";
  CheckZeros(out, 30, 58, 1e-9);

  const std::vector<std::string> points = Lines(ReadFile(out / "points.csv"));
  REQUIRE(points.size() == 6);
  CHECK(points[0] ==
        "d,realization,P_rank,relative_degree,differentiation_index,internal_dynamics_order,"
        "stability,max_real_part,error");
  for (std::size_t i = 1; i < points.size(); ++i) {
    const std::vector<std::string> fields = Split(points[i], ',');
    REQUIRE(fields.size() == 9);
    CHECK(std::stod(fields[0]) == Damping(i - 1));
    CHECK(fields[2] == "1");  // P = 1/m
    CHECK(fields[3] == "2");  // force and output at mass 1
    CHECK(fields[4] == "3");
    CHECK(fields[5] == "58");  // 2N - 2
    CHECK(fields[8].empty());
    // The largest real part: the slowest pair, -d μ_1 / (2m) (underdamped).
    const double s = std::sin(std::numbers::pi / (2.0 * 59.0));
    const double mu1 = 4.0 * s * s;
    CHECK(std::stod(fields[7]) == Approx(-Damping(i - 1) * mu1 / (2.0 * kMass)).epsilon(1e-8));
  }
  const std::string record = ReadFile(out / "sweep.json");
  CHECK(record.find("\"kind\": \"linear\"") != std::string::npos);
  CHECK(record.find("\"eigen_solver\": \"auto\"") != std::string::npos);
  CHECK(record.find("\"content_hash\"") != std::string::npos);
  CHECK(record.find("\"completed\": true") != std::string::npos);

  // Two threads: the same bytes (OMP_NUM_THREADS, so that the recorded command line is the same).
  const Job two = RunIn(work / "two", Sweep(model), {{"OMP_NUM_THREADS", "2"}});
  INFO(two.err);
  REQUIRE(two.status == 0);
  CheckSameFiles(out, work / "two" / "out");

  // Interrupted after the first block (2 points), then resumed: the same bytes.
  const Job stopped =
      RunIn(work / "resumed", Sweep(model), {{"SERVOKIT_TEST_STOP_AFTER_BLOCKS", "1"}});
  CHECK(stopped.status == 130);
  CHECK(stopped.err.find("interrupted at point 2 of 5") != std::string::npos);
  const Job resumed = RunIn(work / "resumed", Sweep(model));
  INFO(resumed.err);
  REQUIRE(resumed.status == 0);
  CHECK(resumed.err.find("resuming at point 2 of 5") != std::string::npos);
  CheckSameFiles(out, work / "resumed" / "out");

  // Options of linear models only, and options that do not apply to them, are usage errors.
  const Job y0 = RunIn(work / "y0", Sweep(model, {"--y0", "0"}));
  CHECK(y0.status == 2);
  CHECK(y0.err.find("--y0") != std::string::npos);
  CHECK_FALSE(fs::exists(work / "y0" / "out"));
}

TEST_CASE("servokit sweep on a 1000-mass linear chain: ARPACK's zeros nearest 0",
          "[reports][linear_sweep]") {
  const TemporaryDirectory work;
  const std::string model = GenerateChain(work / "model", 1000);
  const auto start = std::chrono::steady_clock::now();
  const Job one = RunIn(work / "one", Sweep(model, {"--eigenvalues", "6"}));
  const double seconds =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  INFO(one.err);
  REQUIRE(one.status == 0);
  WARN("1000-mass chain, 5 points, ARPACK k = 6: " << seconds << " s");
  CheckZeros(work / "one" / "out", 1000, 6, 1e-8);
  CHECK(ReadFile(work / "one" / "out" / "sweep.json").find("\"eigenvalues\": 6") !=
        std::string::npos);

#ifdef SERVOKIT_MPIEXEC
  // mpirun -np 2: the blocks (2 points each) shared over two ranks; the same bytes.
  ::setenv("OMPI_ALLOW_RUN_AS_ROOT", "1", 1);
  ::setenv("OMPI_ALLOW_RUN_AS_ROOT_CONFIRM", "1", 1);
  std::vector<std::string> command = {SERVOKIT_MPIEXEC, "-q", "--oversubscribe", "-np", "2"};
  const std::vector<std::string> sweep = Sweep(model, {"--eigenvalues", "6"});
  command.insert(command.end(), sweep.begin(), sweep.end());
  const Job mpi = RunIn(work / "mpi", command);
  INFO(mpi.err);
  REQUIRE(mpi.status == 0);
  CheckSameFiles(work / "one" / "out", work / "mpi" / "out");

  // Stopped under mpirun after one block, resumed without it: the same bytes.
  const Job stopped =
      RunIn(work / "mpi-resumed", command, {{"SERVOKIT_TEST_STOP_AFTER_BLOCKS", "1"}});
  CHECK(stopped.status == 130);
  const Job resumed = RunIn(work / "mpi-resumed", sweep);
  INFO(resumed.err);
  REQUIRE(resumed.status == 0);
  CheckSameFiles(work / "one" / "out", work / "mpi-resumed" / "out");
#endif
}

TEST_CASE("servokit sweep on a fine beam: undetermined relative degrees are empty columns",
          "[reports][linear_sweep]") {
  // The beam's tip is observed far from the hub's torque: its Markov rows are round-off at 100
  // elements (docs/analyze.md, "Large linear models"), so the structure at infinity is not
  // determined.
  const TemporaryDirectory work;
  const Job generated = RunIn(work / "model", {SERVOKIT_BINARY, "generate", "beam", "--elements",
                                               "100", "--out", (work / "model").string()});
  REQUIRE(generated.status == 0);
  const std::string model = Lines(generated.out).at(0);
  const Job job = RunIn(work / "one", {SERVOKIT_BINARY, "sweep", model, "--vary", "J=0.1,0.2",
                                       "--out", "out", "--eigenvalues", "4"});
  INFO(job.err);
  REQUIRE(job.status == 0);
  const std::vector<std::string> points = Lines(ReadFile(work / "one" / "out" / "points.csv"));
  REQUIRE(points.size() == 3);
  for (std::size_t i = 1; i < points.size(); ++i) {
    const std::vector<std::string> fields = Split(points[i], ',');
    REQUIRE(fields.size() == 9);
    CHECK(fields[1] == "tangential");
    CHECK(fields[3].empty());
    CHECK(fields[4].empty());
    CHECK(fields[5].empty());
    CHECK(fields[6] == "unstable");  // the non-minimum-phase zero s_1 = 35.4 /s
    CHECK(fields[8].empty());
  }
}

}  // namespace servokit
