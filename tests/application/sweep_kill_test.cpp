// `servokit sweep` killed with SIGKILL (issue #7): the real binary (SERVOKIT_BINARY) is killed at
// chosen and at random moments, then the same command is run again, until the sweep finishes.
// The finished directory must hold the same bytes, file for file (points.csv, eigenvalues.csv and
// sweep.json), as an uninterrupted run of the same command in another directory, and nothing
// else. The random delays come from std::mt19937 with a fixed seed (printed), so a failure can be
// replayed; the moments that matter are also forced by watching the files:
//   - very early: at most a few milliseconds after the start, before any point is checkpointed;
//   - while writing: once the partial CSV holds rows past the checkpoint's recorded size (rows
//     that are not durable yet, possibly a torn last row), which the resumed run must cut off;
//   - after progress: a random delay after the checkpoint has recorded new points;
//   - at the end: as soon as every point is checkpointed (during the final renames and the
//     rewrite of sweep.json), which the resumed run must complete without computing again.
#include <signal.h>
#include <sys/wait.h>

#include <algorithm>
#include <catch2/catch.hpp>
#include <chrono>
#include <cstdio>
#include <filesystem>
#include <optional>
#include <random>
#include <string>
#include <thread>
#include <vector>

#include "tests/test_files.h"
#include "tests/test_paths.h"
#include "tests/test_process.h"

namespace servokit {
namespace {

namespace fs = std::filesystem;
using testing::ReadFile;
using testing::StartProcess;
using testing::TemporaryDirectory;
using testing::TestDataPath;
using testing::WaitForProcess;

// The seed of the random kill delays; printed so that a failing run can be told apart.
constexpr std::mt19937::result_type kSeed = 20261121;

// The sweep: the six-mass chain observed at its third mass (six zero-dynamics eigenvalues a
// point) over 200 x 240 = 48 000 points on one thread, 2-4 s on this machine (about 25 000
// points/s; sweep rates: docs/benchmarks.md), in blocks of 500 with a checkpoint every 0.05 s, so
// that there are many checkpoints to be killed before, between and after. The output directory is
// relative ("out") and the model path absolute, so sweep.json (which records the command line)
// is the same bytes in the reference directory and in the killed one.
constexpr std::size_t kPoints = 200 * 240;
std::vector<std::string> SweepCommand() {
  return {SERVOKIT_BINARY,
          "sweep",
          TestDataPath("chain_output_x3.yaml"),
          "--vary",
          "m=0.5:2:200",
          "--vary",
          "k=50:150:240",
          "--out",
          "out",
          "--threads",
          "1",
          "--block-size",
          "500",
          "--checkpoint-interval",
          "0.05"};
}

/// Starts the sweep in `directory`; stdout goes to a file there, and stderr is appended to one
/// across the restarts.
pid_t StartSweep(const fs::path& directory) {
  testing::ProcessOptions options;
  options.append_stderr = true;
  return StartProcess(directory, SweepCommand(), options);
}

/// The child's wait status if it has exited.
std::optional<int> Exited(pid_t child) {
  int status = 0;
  if (::waitpid(child, &status, WNOHANG) == child) return status;
  return std::nullopt;
}

/// A value of the checkpoint file (`key=value` lines), if the file and the key are there.
std::optional<std::uintmax_t> CheckpointValue(const fs::path& out, const std::string& key) {
  const std::string text = ReadFile(out / ".sweep-checkpoint");
  const std::size_t at = text.find("\n" + key + "=");
  if (at == std::string::npos) return std::nullopt;
  return std::stoull(text.substr(at + key.size() + 2));
}

std::uintmax_t SizeOr0(const fs::path& path) {
  std::error_code error;
  const std::uintmax_t size = fs::file_size(path, error);
  return error ? 0 : size;
}

/// Polls every millisecond until `ready()` holds or the child exits (then returns its status).
/// A sweep whose points.csv.partial in `out` does not grow for 60 s is killed and fails the
/// test; a slow one is not (under the sanitizers, with other tests on the same cores, the
/// whole sweep takes minutes).
template <typename Ready>
std::optional<int> WaitUntil(pid_t child, const fs::path& out, Ready ready) {
  constexpr std::chrono::seconds kStalled(60);
  std::uintmax_t size = SizeOr0(out / "points.csv.partial");
  auto deadline = std::chrono::steady_clock::now() + kStalled;
  while (std::chrono::steady_clock::now() < deadline) {
    if (const std::optional<int> status = Exited(child)) return status;
    if (ready()) return std::nullopt;
    if (const std::uintmax_t now = SizeOr0(out / "points.csv.partial"); now != size) {
      size = now;
      deadline = std::chrono::steady_clock::now() + kStalled;
    }
    std::this_thread::sleep_for(std::chrono::milliseconds(1));
  }
  ::kill(child, SIGKILL);
  WaitForProcess(child);
  FAIL("the sweep wrote no row for 60 s");
  return std::nullopt;
}

enum class KillMoment { kVeryEarly, kWhileWriting, kAfterProgress, kAtTheEnd };

const char* Describe(KillMoment moment) {
  switch (moment) {
    case KillMoment::kVeryEarly:
      return "very early";
    case KillMoment::kWhileWriting:
      return "while writing rows past the checkpoint";
    case KillMoment::kAfterProgress:
      return "a random delay after a new checkpoint";
    case KillMoment::kAtTheEnd:
      return "once every point is checkpointed";
  }
  return "";
}

}  // namespace

TEST_CASE(
    "a sweep killed with SIGKILL again and again resumes to the bytes of an uninterrupted run",
    "[reports][slow]") {
  std::printf("sweep_kill_test: random kill delays from std::mt19937 seed %u\n",
              static_cast<unsigned>(kSeed));
  std::mt19937 random(kSeed);
  const TemporaryDirectory reference_work, killed_work;
  const fs::path reference = reference_work / "out", out = killed_work / "out";

  // The uninterrupted run.
  const int reference_status = WaitForProcess(StartSweep(reference_work.path()));
  INFO("reference stderr: " << ReadFile(reference_work / "stderr.txt"));
  REQUIRE(WIFEXITED(reference_status));
  REQUIRE(WEXITSTATUS(reference_status) == 0);

  const std::vector<KillMoment> plan = {KillMoment::kVeryEarly,     KillMoment::kWhileWriting,
                                        KillMoment::kAfterProgress, KillMoment::kVeryEarly,
                                        KillMoment::kAfterProgress, KillMoment::kWhileWriting,
                                        KillMoment::kAfterProgress, KillMoment::kAtTheEnd};
  std::uniform_int_distribution<int> early_delay_us(0, 3000);
  std::uniform_int_distribution<int> progress_delay_ms(0, 120);
  int kills = 0, kills_before_first_point = 0, kills_past_checkpoint = 0, torn_rows = 0;
  bool finished = false;
  for (std::size_t round = 0; round < plan.size() && !finished; ++round) {
    const KillMoment moment = plan[round];
    const std::uintmax_t done_before = CheckpointValue(out, "points_done").value_or(0);
    const pid_t child = StartSweep(killed_work.path());
    std::optional<int> status;
    switch (moment) {
      case KillMoment::kVeryEarly:
        std::this_thread::sleep_for(std::chrono::microseconds(early_delay_us(random)));
        break;
      case KillMoment::kWhileWriting:
        // Rows on disk past what the checkpoint records: not yet durable, perhaps torn.
        status = WaitUntil(child, out, [&] {
          const auto recorded = CheckpointValue(out, "points_bytes");
          const auto done = CheckpointValue(out, "points_done");
          return recorded && done && *done > done_before &&
                 SizeOr0(out / "points.csv.partial") > *recorded;
        });
        break;
      case KillMoment::kAfterProgress:
        status = WaitUntil(child, out, [&] {
          return CheckpointValue(out, "points_done").value_or(0) > done_before;
        });
        if (!status) {
          std::this_thread::sleep_for(std::chrono::milliseconds(progress_delay_ms(random)));
        }
        break;
      case KillMoment::kAtTheEnd:
        status = WaitUntil(
            child, out, [&] { return CheckpointValue(out, "points_done").value_or(0) == kPoints; });
        break;
    }
    if (!status) {
      ::kill(child, SIGKILL);
      status = WaitForProcess(child);
    }
    const std::uintmax_t done_after = CheckpointValue(out, "points_done").value_or(0);
    const std::uintmax_t partial = SizeOr0(out / "points.csv.partial");
    const std::uintmax_t recorded = CheckpointValue(out, "points_bytes").value_or(0);
    const std::string partial_text = ReadFile(out / "points.csv.partial");
    const bool torn = !partial_text.empty() && partial_text.back() != '\n';
    std::printf(
        "sweep_kill_test: round %zu, %s: %s; checkpoint %ju of %zu points, points.csv.partial "
        "%ju bytes (checkpoint %ju)%s\n",
        round, Describe(moment), WIFSIGNALED(*status) ? "killed" : "finished before the kill",
        done_after, kPoints, partial, recorded, torn ? ", last row torn" : "");
    if (WIFEXITED(*status)) {
      INFO("stderr: " << ReadFile(killed_work / "stderr.txt"));
      REQUIRE(WEXITSTATUS(*status) == 0);
      finished = true;
      continue;
    }
    REQUIRE(WTERMSIG(*status) == SIGKILL);
    ++kills;
    if (moment == KillMoment::kVeryEarly && done_after == done_before) ++kills_before_first_point;
    if (partial > recorded) ++kills_past_checkpoint;
    if (torn) ++torn_rows;
    // The final tables appear only once every point is checkpointed (Finish checkpoints before
    // it renames): a finished points.csv of an unfinished sweep would be resumed as finished.
    const bool completed =
        ReadFile(out / "sweep.json").find("\"completed\": true") != std::string::npos;
    if (fs::exists(out / "points.csv") && !completed) CHECK(done_after == kPoints);
  }
  std::printf(
      "sweep_kill_test: %d kills, %d before any new point, %d with rows past the "
      "checkpoint, %d with a torn last row\n",
      kills, kills_before_first_point, kills_past_checkpoint, torn_rows);
  CHECK(kills >= 5);
  // The first round kills within 3 ms of the start, long before the model is even loaded and
  // the first block written (tens of ms); the while-writing rounds wait for rows past the
  // checkpoint before they kill.
  CHECK(kills_before_first_point >= 1);
  CHECK(kills_past_checkpoint >= 1);

  if (!finished) {
    const int status = WaitForProcess(StartSweep(killed_work.path()));
    INFO("stderr: " << ReadFile(killed_work / "stderr.txt"));
    REQUIRE(WIFEXITED(status));
    REQUIRE(WEXITSTATUS(status) == 0);
  }
  const std::string stderr_text = ReadFile(killed_work / "stderr.txt");
  CHECK_THAT(stderr_text, Catch::Contains("servokit: resuming at point "));

  // Byte for byte, every file of the finished sweep; and nothing else left behind.
  std::vector<std::string> names;
  for (const auto& entry : fs::directory_iterator(out)) {
    names.push_back(entry.path().filename().string());
  }
  std::sort(names.begin(), names.end());
  CHECK(names == std::vector<std::string>{"eigenvalues.csv", "points.csv", "sweep.json"});
  for (const char* file : {"points.csv", "eigenvalues.csv", "sweep.json"}) {
    INFO(file);
    const std::string expected = ReadFile(reference / file);
    REQUIRE_FALSE(expected.empty());
    const std::string actual = ReadFile(out / file);
    CHECK(actual.size() == expected.size());
    CHECK((actual == expected));  // not CHECK(actual == expected): Catch would print megabytes
  }
  // The reference itself is the whole grid: a header and one row per point.
  const std::string points = ReadFile(reference / "points.csv");
  CHECK(std::size_t(std::count(points.begin(), points.end(), '\n')) == kPoints + 1);
}

}  // namespace servokit
