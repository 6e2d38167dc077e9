// The public C++ API from several threads at once (issue #29; servokit/servokit.h promises it).
// GiNaC, which loads the models and derives their nonlinear structure and algebraic inverses,
// is not thread-safe: 8 threads calling Analyze on acrobot.yaml, or Solve with the algebraic
// method, crashed inside GiNaC::power::eval in 4 of 5 runs before its work went under one lock
// (modeling/symbolic_lock.h). Each case makes every call once on one thread for the reference,
// then makes the calls again from kThreads threads at once, each thread starting at another
// call, and requires every answer to equal its reference exactly: the numbers are
// deterministic (modeling/canonical_expression.h), so any difference is a race. Assertions run on
// the main thread only (Catch2's are not thread-safe). Under ThreadSanitizer: make test-thread.
#include <algorithm>
#include <catch2/catch.hpp>
#include <chrono>
#include <complex>
#include <cstddef>
#include <exception>
#include <functional>
#include <sstream>
#include <string>
#include <thread>
#include <utility>
#include <vector>

#include "servokit/servokit.h"
#include "tests/test_paths.h"

namespace sk = servokit::api;
using servokit::testing::ModelPath;

namespace {

constexpr int kThreads = 8;
// Each thread makes each call up to kMaxCallsPerThread times, fewer when the call is slow: as
// often as fits in kSecondsPerCall of the reference call's time (kThreads x calls x its time),
// but at least kMinCallsPerThread times. A symbolic call (Analyze's nonlinear structure, a
// model's first algebraic solve) runs one thread at a time, 10 to 100 ms each, so this keeps
// the suite's run short on 2 cores, and as short under ThreadSanitizer (make test-thread).
constexpr int kMaxCallsPerThread = 50;
constexpr int kMinCallsPerThread = 2;
constexpr double kSecondsPerCall = 0.4;

// One call; returns its answer as bytes to compare.
struct Call {
  std::string name;
  std::function<std::string()> run;
};

// How often each thread makes a call whose reference took `seconds`.
int CallsPerThread(double seconds) {
  const double fitting = kSecondsPerCall / (kThreads * seconds);
  return fitting >= kMaxCallsPerThread ? kMaxCallsPerThread
                                       : std::max(kMinCallsPerThread, static_cast<int>(fitting));
}

void AppendBytes(std::string& out, const double* data, Eigen::Index size) {
  out.append(reinterpret_cast<const char*>(data), static_cast<std::size_t>(size) * sizeof(double));
  out += '|';
}
void AppendBytes(std::string& out, const Eigen::MatrixXd& matrix) {
  AppendBytes(out, matrix.data(), matrix.size());
}
void AppendBytes(std::string& out, const Eigen::VectorXd& vector) {
  AppendBytes(out, vector.data(), vector.size());
}

// Everything an analysis gives: its three reports (numbers as %.17g) and the numbers' bits.
std::string Fingerprint(const sk::Analysis& analysis) {
  std::string out = analysis.json + analysis.text + analysis.markdown;
  AppendBytes(out, analysis.q);
  AppendBytes(out, analysis.u);
  AppendBytes(out, analysis.y);
  AppendBytes(out, analysis.P);
  for (const std::complex<double>& eigenvalue : analysis.zero_dynamics.eigenvalues) {
    AppendBytes(out, reinterpret_cast<const double*>(&eigenvalue), 2);
  }
  return out;
}

// Everything a solve gives: its summary, messages and every row's bits.
std::string Fingerprint(const sk::Feedforward& feedforward) {
  const sk::SolveSummary& summary = feedforward.summary;
  std::string out =
      summary.json + std::string(sk::ToString(summary.status)) + "|" + summary.message + "|";
  for (const std::string& line : summary.warnings) out += line + "|";
  for (const std::string& line : feedforward.notes) out += line + "|";
  AppendBytes(out, feedforward.t.data(), static_cast<Eigen::Index>(feedforward.t.size()));
  for (const Eigen::MatrixXd* rows :
       {&feedforward.q, &feedforward.q_dot, &feedforward.u, &feedforward.y_d, &feedforward.y}) {
    AppendBytes(out, *rows);
  }
  return out;
}

// An exception is an answer too: its message.
std::string Answer(const std::function<std::string()>& run) {
  try {
    return run();
  } catch (const std::exception& error) {
    return std::string("exception: ") + error.what();
  }
}

// Makes every call once on this thread, then from kThreads threads at once (thread t starts at
// call t and goes round), and checks each answer against the first.
void CheckThreadedAnswersEqualSingleThreaded(const std::vector<Call>& calls) {
  std::vector<std::string> reference;
  std::vector<int> calls_per_thread;
  for (const Call& call : calls) {
    const auto start = std::chrono::steady_clock::now();
    reference.push_back(Answer(call.run));
    const std::chrono::duration<double> seconds = std::chrono::steady_clock::now() - start;
    calls_per_thread.push_back(CallsPerThread(seconds.count()));
    INFO(call.name << ": " << reference.back().substr(0, 300));
    REQUIRE(reference.back().rfind("exception: ", 0) != 0);  // the reference must be an answer
  }
  struct Mismatch {
    std::size_t call;
    std::string answer;
  };
  std::vector<std::vector<Mismatch>> mismatches(kThreads);
  std::vector<int> made(kThreads, 0);
  std::vector<std::thread> threads;
  for (int t = 0; t < kThreads; ++t) {
    threads.emplace_back([&, t] {
      const auto thread = static_cast<std::size_t>(t);
      std::vector<int> left = calls_per_thread;
      for (std::size_t k = thread % calls.size(), idle = 0; idle < calls.size();
           k = (k + 1) % calls.size()) {
        if (left[k] == 0) {
          ++idle;
          continue;
        }
        idle = 0;
        --left[k];
        ++made[thread];
        std::string answer = Answer(calls[k].run);
        if (answer != reference[k]) mismatches[thread].push_back({k, std::move(answer)});
      }
    });
  }
  for (std::thread& thread : threads) thread.join();
  int expected_per_thread = 0;
  for (const int count : calls_per_thread) expected_per_thread += count;
  for (std::size_t t = 0; t < kThreads; ++t) {
    CHECK(made[t] == expected_per_thread);
    for (const Mismatch& mismatch : mismatches[t]) {
      INFO("thread " << t << ", " << calls[mismatch.call].name << ": "
                     << mismatch.answer.substr(0, 300));
      CHECK(mismatch.answer == reference[mismatch.call]);
    }
  }
}

const std::vector<std::string> kShippedModels = {"acrobot.yaml",
                                                 "cart_pendulum.yaml",
                                                 "gantry_crane.yaml",
                                                 "mass_on_car.yaml",
                                                 "mass_spring_chain.yaml",
                                                 "rotational_arm.yaml",
                                                 "rotational_arm_tip.yaml",
                                                 "three_link_arm.yaml"};

sk::OutputTrajectory RestToRest(std::vector<double> y0,
                                std::vector<double> yf,
                                double t0,
                                double tf) {
  sk::OutputTrajectory trajectory;
  trajectory.y0 = Eigen::Map<const Eigen::VectorXd>(y0.data(), Eigen::Index(y0.size()));
  trajectory.yf = Eigen::Map<const Eigen::VectorXd>(yf.data(), Eigen::Index(yf.size()));
  trajectory.t0 = t0;
  trajectory.tf = tf;
  return trajectory;
}

sk::SolveOptions Method(sk::SolverMethod method, double t_end) {
  sk::SolveOptions options;
  options.method = method;
  options.t_end = t_end;
  return options;
}

// A solve of `model` (shared by the threads) by `options.method`.
Call SolveCall(const std::string& name,
               const sk::Model& model,
               const sk::OutputTrajectory& trajectory,
               const sk::SolveOptions& options) {
  return {name + " by " + std::string(sk::ToString(options.method)), [model, trajectory, options] {
            return Fingerprint(sk::Solve(model, trajectory, options));
          }};
}

// A sweep's polynomial path reads the zero-dynamics polynomial, which a model derives and
// compiles on first use (Model::polynomial_programs, once, whichever thread asks first): each
// call loads the model afresh and sweeps it from 4 std::threads at once, so that the first use
// is a race. One OpenMP thread per sweep: ThreadSanitizer cannot see libgomp's barriers (its
// OpenMP runtime is not instrumented) and would report the sweep's own workspaces.
std::string SweepFingerprint(const sk::Model& model, const std::string& parameter) {
  sk::SweepOptions options;
  options.threads = 1;
  std::ostringstream bytes;
  bytes << std::hexfloat;  // every bit, so that any difference is seen
  for (const sk::SweepPoint& point :
       sk::Sweep(model, {sk::SweepAxis(parameter, {0.1, 0.3, 0.5, 0.7, 0.9})}, options)) {
    bytes << point.solved << sk::ToString(point.stability);
    for (const std::complex<double>& zero : point.eigenvalues) bytes << zero;
    bytes << "\n";
  }
  return bytes.str();
}

}  // namespace

TEST_CASE("analyze from 8 threads at once gives the single-threaded answer on every shipped model",
          "[servokit]") {
  // Each model twice: one copy shared by all threads, and a fresh load in every call (loading
  // and dropping models while others analyze: the symbolic model's expressions are destroyed
  // by whichever thread lets go of them last).
  std::vector<Call> calls;
  for (const std::string& file : kShippedModels) {
    const sk::Model shared = sk::Model::FromFile(ModelPath(file));
    calls.push_back({file + " (shared)", [shared] { return Fingerprint(sk::Analyze(shared)); }});
    calls.push_back({file + " (loaded per call)", [file] {
                       return Fingerprint(sk::Analyze(sk::Model::FromFile(ModelPath(file))));
                     }});
  }
  CheckThreadedAnswersEqualSingleThreaded(calls);
}

TEST_CASE("sweep fresh models from 8 threads at once, each from 4 threads", "[servokit]") {
  constexpr int kSweepers = 4;
  std::vector<Call> calls;
  for (const auto& [file, parameter] : std::vector<std::pair<std::string, std::string>>{
           {"mass_on_car.yaml", "d"}, {"rotational_arm.yaml", "s"}}) {
    calls.push_back({file + " swept", [file, parameter] {
                       const sk::Model model = sk::Model::FromFile(ModelPath(file));
                       std::vector<std::string> answers(kSweepers);
                       std::vector<std::thread> sweepers;
                       for (int t = 0; t < kSweepers; ++t) {
                         sweepers.emplace_back([&, t] {
                           answers[std::size_t(t)] = SweepFingerprint(model, parameter);
                         });
                       }
                       for (std::thread& sweeper : sweepers) sweeper.join();
                       std::string all;
                       for (const std::string& answer : answers) all += answer;
                       return all;
                     }});
  }
  CheckThreadedAnswersEqualSingleThreaded(calls);
}

TEST_CASE("solve from 8 threads at once gives the single-threaded feedforward for every method",
          "[servokit]") {
  const sk::Model crane = sk::Model::FromFile(ModelPath("gantry_crane.yaml"));
  const sk::Model car = sk::Model::FromFile(ModelPath("mass_on_car.yaml"));
  const sk::Model arm_minimum_phase =
      sk::Model::FromFile(ModelPath("rotational_arm.yaml"), {{"s", "0.5"}});
  const sk::Model arm = sk::Model::FromFile(ModelPath("rotational_arm.yaml"), {{"s", "0.9"}});
  const sk::OutputTrajectory crane_move = RestToRest({0.0, 2.0}, {1.0, 2.0}, 0.0, 3.0);
  const sk::OutputTrajectory car_move = RestToRest({0.0}, {1.0}, 0.0, 2.0);
  const sk::OutputTrajectory arm_move = RestToRest({0.0}, {0.1}, 1.0, 3.0);

  sk::SolveOptions algebraic = Method(sk::SolverMethod::kAlgebraic, 4.0);
  algebraic.step = 0.01;
  algebraic.verify = true;
  std::vector<Call> calls = {
      SolveCall("gantry_crane", crane, crane_move, algebraic),
      SolveCall("mass_on_car", car, car_move, Method(sk::SolverMethod::kBdf, 3.0)),
      SolveCall("mass_on_car", car, car_move, Method(sk::SolverMethod::kRadau, 3.0)),
      SolveCall("mass_on_car", car, car_move, Method(sk::SolverMethod::kEuler, 3.0)),
      SolveCall("rotational_arm s = 0.5", arm_minimum_phase, arm_move,
                Method(sk::SolverMethod::kNormalForm, 3.5)),
      SolveCall("rotational_arm s = 0.9", arm, arm_move,
                Method(sk::SolverMethod::kStableInversion, 3.5)),
      // The linearized model is loaded from text in every solve and dropped after it.
      SolveCall("gantry_crane", crane, crane_move, Method(sk::SolverMethod::kLinearized, 4.0)),
  };
  // The algebraic inverse is derived once per model, parameters and options, and the last 8
  // are kept: 10 car masses make the threads derive, share and evict inverses at once. The flat
  // mass on car (alpha = 0, d = 0), whose derivation takes 2 ms: the crane's takes 100 ms, and
  // as many derivations of it took minutes under ThreadSanitizer.
  sk::SolveOptions flat = Method(sk::SolverMethod::kAlgebraic, 3.0);
  flat.step = 0.01;
  for (int k = 0; k < 10; ++k) {
    const std::string mass = std::to_string(1 + k);
    const sk::Model flat_car = sk::Model::FromFile(ModelPath("mass_on_car.yaml"),
                                                   {{"alpha", "0"}, {"d", "0"}, {"m1", mass}});
    calls.push_back(SolveCall("flat mass_on_car m1 = " + mass, flat_car, car_move, flat));
  }
  CheckThreadedAnswersEqualSingleThreaded(calls);
}
