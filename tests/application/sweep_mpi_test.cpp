// `mpirun -np K servokit sweep` (issue #6, studies/distributed_sweep.h): the real binary under the
// real launcher (SERVOKIT_MPIEXEC, Open MPI's mpirun) must write the same files, byte for byte, as
// one process: points.csv, eigenvalues.csv and sweep.json, each run started in its own directory
// with the same relative --out, so that even the command line recorded in sweep.json is the
// same. An error on any rank gives one error line and its exit status from the whole job, never
// a hang (every job runs under `timeout`); a stopped MPI sweep resumes, with or without MPI, to
// the same files. Registered only when servokit is built with MPI
// (tests/application/CMakeLists.txt).
#include <signal.h>

#include <algorithm>
#include <catch2/catch.hpp>
#include <chrono>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>
#include <thread>
#include <vector>

#include "tests/test_files.h"
#include "tests/test_paths.h"
#include "tests/test_process.h"

namespace servokit {
namespace {

using testing::Lines;
using testing::ReadFile;
using testing::TemporaryDirectory;

namespace fs = std::filesystem;
using testing::ModelPath;
using testing::TestDataPath;

// Every job is killed after this long: a hang fails the test instead of blocking CTest. The
// slowest job here, the single-process reference run of the SIGINT test, takes about 12 s
// (under a minute under the sanitizers).
constexpr const char* kJobTimeoutSeconds = "120";

// The exit status of a job `timeout` killed.
constexpr int kTimedOut = 124;

using Job = testing::ProcessResult;

/// Starts `command` in `directory` (created if needed) under `timeout`, its stdout and stderr
/// going to files there; returns the pid of `timeout`, which passes signals on to the command.
/// --foreground: a signal reaches the command once, as Ctrl-C in a shell reaches mpirun. Without
/// it `timeout` also signals its process group, mpirun included, and mpirun takes a second
/// SIGINT as "abort now": it exits at once and leaves the ranks running.
pid_t Start(const fs::path& directory, const std::vector<std::string>& command) {
  fs::create_directories(directory);
  std::vector<std::string> all = {"timeout", "--foreground", "-k", "5", kJobTimeoutSeconds};
  all.insert(all.end(), command.begin(), command.end());
  return testing::StartProcess(directory, all);
}

/// Waits for a job Start() began in `directory` and collects what it printed.
Job Finish(pid_t child, const fs::path& directory) {
  Job job = testing::CollectProcess(child, directory);
  // mpirun's event library can warn on shutdown under load ("[warn] Epoll MOD(1) on fd 28
  // failed ..."); those lines are Open MPI's, not servokit's, which never starts a line so.
  std::string servokit_lines;
  for (const std::string& line : Lines(job.err)) {
    if (line.rfind("[warn] ", 0) != 0) servokit_lines += line + "\n";
  }
  job.err = servokit_lines;
  return job;
}

/// Runs `command` in `directory` and waits for it.
Job RunIn(const fs::path& directory, const std::vector<std::string>& command) {
  return Finish(Start(directory, command), directory);
}

/// mpirun with `ranks` processes, quiet (-q: no banner of its own when a rank exits non-zero),
/// allowed to run as root and to put more ranks than cores on this machine.
std::vector<std::string> MpiRun(int ranks) {
  // Open MPI refuses to run as root unless both are set (CI containers run as root).
  ::setenv("OMPI_ALLOW_RUN_AS_ROOT", "1", 1);
  ::setenv("OMPI_ALLOW_RUN_AS_ROOT_CONFIRM", "1", 1);
  return {SERVOKIT_MPIEXEC, "-q", "--oversubscribe", "-np", std::to_string(ranks)};
}

std::vector<std::string> Concatenate(std::vector<std::string> first,
                                     const std::vector<std::string>& second) {
  first.insert(first.end(), second.begin(), second.end());
  return first;
}

// ---- the sweeps ------------------------------------------------------------------------------

// The six-mass chain observed at its third mass (six eigenvalues a point): 2400 points, by default
// in blocks of 150 (16 blocks), a few tenths of a second in all.
constexpr std::size_t kChainPoints = 2400;
constexpr std::size_t kChainBlock = 150;
std::vector<std::string> ChainSweep(const std::vector<std::string>& more = {},
                                    std::size_t block_size = kChainBlock) {
  return Concatenate(
      {SERVOKIT_BINARY, "sweep", TestDataPath("chain_output_x3.yaml"), "--vary", "m=0.5:2:40",
       "--vary", "k=50:150:60", "--out", "out", "--block-size", std::to_string(block_size)},
      more);
}

// The mass on car over alpha x d, with rows of every kind: flat (alpha = 90 deg), stable,
// critical and oscillating points.
std::vector<std::string> CarSweep(const std::vector<std::string>& more = {}) {
  return Concatenate({SERVOKIT_BINARY, "sweep", ModelPath("mass_on_car.yaml"), "--vary",
                      "alpha=0deg:90deg:31", "--vary", "d=0:2:21", "--out", "out"},
                     more);
}

// A closed chain (issue #32): the five-bar over its spring and damper, classified on its loops.
std::vector<std::string> FiveBarSweep() {
  return {SERVOKIT_BINARY, "sweep",     ModelPath("five_bar.yaml"),
          "--vary",        "c=5:20:17", "--vary",
          "d=0.05:0.5:13", "--out",     "out",
          "--block-size",  "16"};
}

/// Every file a finished sweep leaves in `out` (the run's stdout/stderr are elsewhere).
std::vector<std::string> FileNames(const fs::path& out) {
  std::vector<std::string> names;
  for (const auto& entry : fs::directory_iterator(out)) {
    names.push_back(entry.path().filename().string());
  }
  std::sort(names.begin(), names.end());
  return names;
}

/// Both sweeps finished and wrote the same files with the same bytes. No field is excluded:
/// sweep.json records neither timings nor the number of processes or threads.
void CheckSameFiles(const fs::path& a, const fs::path& b) {
  REQUIRE(FileNames(a) == std::vector<std::string>{"eigenvalues.csv", "points.csv", "sweep.json"});
  CHECK(FileNames(b) == FileNames(a));
  for (const std::string& name : FileNames(a)) {
    INFO(name);
    const std::string first = ReadFile(a / name);
    CHECK_FALSE(first.empty());
    CHECK((first == ReadFile(b / name)));  // not CHECK(a == b): Catch would print it all
  }
}

/// The single-process run of `command` in `directory`, which must succeed; its --out is "out".
Job SingleProcess(const fs::path& directory, const std::vector<std::string>& command) {
  const Job job = RunIn(directory, command);
  INFO(job.err);
  REQUIRE(job.status == 0);
  return job;
}

std::string Interrupted(std::size_t done, std::size_t total) {
  return "servokit: error: interrupted at point " + std::to_string(done) + " of " +
         std::to_string(total) + "; run the same command again to resume\n";
}

// ---- same files ------------------------------------------------------------------------------

TEST_CASE("mpirun -np 2 writes the same files as one process, byte for byte", "[reports][mpi]") {
  const TemporaryDirectory work;
  for (const auto& [name, sweep] : {std::pair{"chain", ChainSweep()}, std::pair{"car", CarSweep()},
                                    std::pair{"five-bar", FiveBarSweep()}}) {
    INFO(name);
    const Job single = SingleProcess(work / name / "single", sweep);
    const Job job = RunIn(work / name / "mpi", Concatenate(MpiRun(2), sweep));
    INFO(job.err);
    REQUIRE(job.status == 0);
    CHECK(job.err.empty());
    CHECK(job.out == single.out);  // "swept N points of ... into out (...); 0 without a solution"
    CheckSameFiles(work / name / "single" / "out", work / name / "mpi" / "out");
  }
}

TEST_CASE("mpirun -np 3 with a number of blocks that 3 does not divide writes the same files",
          "[reports][mpi]") {
  const TemporaryDirectory work;
  // 2400 points in blocks of 350: six full blocks and one of 300, seven in all.
  const std::vector<std::string> sweep = ChainSweep({"--threads", "1"}, 350);
  SingleProcess(work / "single", sweep);
  const fs::path single = work / "single" / "out";
  const Job job = RunIn(work / "mpi", Concatenate(MpiRun(3), sweep));
  INFO(job.err);
  REQUIRE(job.status == 0);
  CheckSameFiles(single, work / "mpi" / "out");
}

TEST_CASE("more ranks than blocks: the ranks without a block wait and exit 0", "[reports][mpi]") {
  const TemporaryDirectory work;
  const std::vector<std::string> sweep = ChainSweep({"--threads", "1"}, 1000);
  SingleProcess(work / "single", sweep);
  const fs::path single = work / "single" / "out";
  const Job job = RunIn(work / "mpi", Concatenate(MpiRun(4), sweep));  // three blocks
  INFO(job.err);
  REQUIRE(job.status == 0);
  CheckSameFiles(single, work / "mpi" / "out");
}

TEST_CASE("a grid warning under mpirun is printed once, by rank 0", "[reports][mpi]") {
  const TemporaryDirectory work;
  // d=0:1:2 could be MATLAB's 0, 1, 2 (docs/sweep.md "The grid": Not MATLAB's colon): every
  // rank parses it, rank 0 alone warns.
  const std::vector<std::string> sweep = {
      SERVOKIT_BINARY, "sweep", ModelPath("mass_on_car.yaml"), "--vary", "d=0:1:2", "--out", "out"};
  const Job job = RunIn(work / "warn", Concatenate(MpiRun(2), sweep));
  INFO(job.err);
  REQUIRE(job.status == 0);
  CHECK(job.err ==
        "servokit: warning: --vary d=0:1:2 is read as 2 values from 0 to 1 (servokit's a:b:n), "
        "not as MATLAB's start:step:end (0, 1, ..., 2); write d=0:1:n=2 for the first, "
        "d=0:2:step=1 for the second\n");
  CHECK_THAT(job.out, !Catch::Contains("warning"));
}

TEST_CASE("mpirun -np 2 writes the same sweep.h5 and sweep.mat as one process, byte for byte",
          "[reports][mpi]") {
  // The other ranks send binary records instead of CSV rows (TableEncoding::kRecords); rank 0
  // builds the file from them as a single process does.
  const TemporaryDirectory work;
  for (const auto& [format, file] :
       {std::pair{"hdf5", "sweep.h5"}, std::pair{"mat", "sweep.mat"}}) {
    INFO(format);
    const std::vector<std::string> sweep =
        CarSweep({"--format", format, "--block-size", "100", "--threads", "1"});
    SingleProcess(work / format / "single", sweep);
    const Job job = RunIn(work / format / "mpi", Concatenate(MpiRun(2), sweep));
    INFO(job.err);
    REQUIRE(job.status == 0);
    const fs::path single = work / format / "single" / "out", mpi = work / format / "mpi" / "out";
    std::vector<std::string> expected = {file, "sweep.json"};
    std::sort(expected.begin(), expected.end());  // as FileNames lists them
    CHECK(FileNames(mpi) == expected);
    CHECK((ReadFile(single / file) == ReadFile(mpi / file)));
    CHECK((ReadFile(single / "sweep.json") == ReadFile(mpi / "sweep.json")));
  }
}

// ---- errors ----------------------------------------------------------------------------------

TEST_CASE("a usage error under mpirun is one error line and status 2 from the whole job",
          "[reports][mpi]") {
  const TemporaryDirectory work;
  const std::vector<std::string> sweep = {
      SERVOKIT_BINARY, "sweep", ModelPath("mass_on_car.yaml"), "--vary", "beta=0:1:3",
      "--out",         "out"};
  const Job job = RunIn(work / "quiet", Concatenate(MpiRun(2), sweep));
  CHECK(job.status == 2);
  CHECK(job.err ==
        "servokit: error: --vary beta=0:1:3: unknown parameter 'beta' (the model has m1, m2, k, "
        "d, alpha)\n");
  CHECK_FALSE(fs::exists(work / "quiet" / "out"));
  // Without -q mpirun adds a banner of its own; servokit still prints one line.
  std::vector<std::string> loud = MpiRun(2);
  loud.erase(std::find(loud.begin(), loud.end(), "-q"));
  const Job loud_job = RunIn(work / "loud", Concatenate(loud, sweep));
  CHECK(loud_job.status == 2);
  const std::vector<std::string> lines = Lines(loud_job.err);
  CHECK(std::count_if(lines.begin(), lines.end(), [](const std::string& line) {
          return line.rfind("servokit: error: ", 0) == 0;
        }) == 1);
}

TEST_CASE("an error on rank 0 alone (the directory holds another sweep) ends every rank",
          "[reports][mpi]") {
  const TemporaryDirectory work;
  REQUIRE(RunIn(work / "run", CarSweep()).status == 0);
  const Job job = RunIn(work / "run", Concatenate(MpiRun(2), ChainSweep()));
  CHECK(job.status == 2);
  CHECK(job.err ==
        "servokit: error: --out out holds another sweep (a different model, grid or options); "
        "use another --out or delete that directory\n");
}

TEST_CASE("a rank that computes another sweep than rank 0 is refused, by rank", "[reports][mpi]") {
  const TemporaryDirectory work;
  // Two programs in one job (MPMD): rank 1 is given another stiffness.
  const Job job =
      RunIn(work / "run", Concatenate(Concatenate(MpiRun(1), CarSweep({":"})),
                                      Concatenate({"-np", "1"}, CarSweep({"--set", "k=6"}))));
  CHECK(job.status == 2);
  CHECK_THAT(job.err, Catch::StartsWith("servokit: error: rank 1: this rank computes another "
                                        "sweep than rank 0 ("));
  CHECK(Lines(job.err).size() == 1);
  CHECK_FALSE(fs::exists(work / "run" / "out" / "points.csv"));
}

TEST_CASE("an error on another rank in the middle of the sweep ends every rank with its line",
          "[reports][mpi]") {
  const TemporaryDirectory work;
  // Rank 1 fails after its second block (the test hook throws an Error: status 1).
  const Job job =
      RunIn(work / "run",
            Concatenate(Concatenate(MpiRun(1), ChainSweep({":", "-np", "1", "env",
                                                           "SERVOKIT_TEST_FAIL_AFTER_BLOCKS=2"})),
                        ChainSweep()));
  CHECK(job.status == 1);
  CHECK(job.err ==
        "servokit: error: rank 1: SERVOKIT_TEST_FAIL_AFTER_BLOCKS=2: failing as asked\n");
}

// ---- stop and resume -------------------------------------------------------------------------

TEST_CASE("an MPI sweep stopped on every rank resumes under MPI to the same files",
          "[reports][mpi]") {
  const TemporaryDirectory work;
  SingleProcess(work / "single", ChainSweep());
  const fs::path single = work / "single" / "out";
  // Each rank stops after its third block: rank 0 after writing blocks 0..2 (its own 0 and 2,
  // rank 1's 1), so the checkpoint holds three blocks.
  ::setenv("SERVOKIT_TEST_STOP_AFTER_BLOCKS", "3", 1);
  const Job stopped = RunIn(work / "mpi", Concatenate(MpiRun(2), ChainSweep()));
  ::unsetenv("SERVOKIT_TEST_STOP_AFTER_BLOCKS");
  CHECK(stopped.status == 130);
  CHECK(stopped.err == Interrupted(3 * kChainBlock, kChainPoints));
  CHECK_FALSE(fs::exists(work / "mpi" / "out" / "points.csv"));
  const Job resumed = RunIn(work / "mpi", Concatenate(MpiRun(2), ChainSweep()));
  INFO(resumed.err);
  REQUIRE(resumed.status == 0);
  CHECK(resumed.err == "servokit: resuming at point " + std::to_string(3 * kChainBlock) + " of " +
                           std::to_string(kChainPoints) + "\n");
  CheckSameFiles(single, work / "mpi" / "out");
}

TEST_CASE("an MPI sweep stopped by one rank resumes without MPI to the same files",
          "[reports][mpi]") {
  const TemporaryDirectory work;
  SingleProcess(work / "single", ChainSweep());
  const fs::path single = work / "single" / "out";
  // Rank 1 alone stops after computing its fourth block (block 7): rank 0 writes blocks 0..8
  // (its own 8 included) and then, in place of block 9, learns that rank 1 stopped.
  const Job stopped =
      RunIn(work / "mpi",
            Concatenate(Concatenate(MpiRun(1), ChainSweep({":", "-np", "1", "env",
                                                           "SERVOKIT_TEST_STOP_AFTER_BLOCKS=4"})),
                        ChainSweep()));
  CHECK(stopped.status == 130);
  CHECK(stopped.err == Interrupted(9 * kChainBlock, kChainPoints));
  const Job resumed = RunIn(work / "mpi", ChainSweep());
  INFO(resumed.err);
  REQUIRE(resumed.status == 0);
  CHECK(resumed.err == "servokit: resuming at point " + std::to_string(9 * kChainBlock) + " of " +
                           std::to_string(kChainPoints) + "\n");
  CheckSameFiles(single, work / "mpi" / "out");
}

TEST_CASE("a single-process sweep stopped part way resumes under mpirun -np 3 to the same files",
          "[reports][mpi]") {
  const TemporaryDirectory work;
  SingleProcess(work / "single", ChainSweep());
  const fs::path single = work / "single" / "out";
  ::setenv("SERVOKIT_TEST_STOP_AFTER_BLOCKS", "5", 1);
  const Job stopped = RunIn(work / "mixed", ChainSweep());
  ::unsetenv("SERVOKIT_TEST_STOP_AFTER_BLOCKS");
  CHECK(stopped.status == 130);
  CHECK(stopped.err == Interrupted(5 * kChainBlock, kChainPoints));
  const Job resumed = RunIn(work / "mixed", Concatenate(MpiRun(3), ChainSweep()));
  INFO(resumed.err);
  REQUIRE(resumed.status == 0);
  CheckSameFiles(single, work / "mixed" / "out");
}

// mpirun passes a SIGINT on to the ranks as SIGTERM only after about a second (SIGCONT, a wait,
// then SIGTERM), and kills them with SIGKILL a second later (odls_base_sigkill_timeout). So the
// sweep must still run a second after the interrupt, on one thread a rank (whatever the cores),
// and a block must take well under a second for the ranks to stop at its end. Under the
// sanitizers a point is ~50 times slower (the ranks use the full unwinder there,
// tests/application/CMakeLists.txt), so the sweep and the blocks are smaller. A rank killed
// mid-block is application.sweep_kill's case.
#if defined(__SANITIZE_ADDRESS__)
constexpr std::size_t kInterruptedChainMasses = 60;  // 12 000 points: 18 s on two ranks
constexpr std::size_t kInterruptedBlock = 20;        // 60 ms
#else
constexpr std::size_t kInterruptedChainMasses = 960;  // 192 000 points: 6 s on two ranks
constexpr std::size_t kInterruptedBlock = 100;        // 6 ms
#endif

TEST_CASE("SIGINT to mpirun stops every rank; the same command resumes to the same files",
          "[reports][mpi][slow]") {
  const TemporaryDirectory work;
  const std::size_t total = kInterruptedChainMasses * 200;
  const std::vector<std::string> sweep = {SERVOKIT_BINARY,
                                          "sweep",
                                          TestDataPath("chain_output_x3.yaml"),
                                          "--vary",
                                          "m=0.5:2:" + std::to_string(kInterruptedChainMasses),
                                          "--vary",
                                          "k=50:150:n=200",
                                          "--out",
                                          "out",
                                          "--threads",
                                          "1",
                                          "--block-size",
                                          std::to_string(kInterruptedBlock),
                                          "--checkpoint-interval",
                                          "0.1"};
  SingleProcess(work / "single", sweep);
  const fs::path single = work / "single" / "out";
  const pid_t job = Start(work / "mpi", Concatenate(MpiRun(2), sweep));
  // Interrupt once every rank is computing (a checkpoint records a finished block), not after a
  // fixed time: under the sanitizers the ranks need several seconds to start.
  const fs::path out = work / "mpi" / "out";
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(60);
  while (!fs::exists(out / "points.csv") && std::chrono::steady_clock::now() < deadline) {
    // The checkpoint is replaced by a rename, so a read sees a whole file or none.
    const std::string checkpoint = ReadFile(out / ".sweep-checkpoint");
    const std::size_t key = checkpoint.find("\npoints_done=");
    if (key != std::string::npos && std::stoull(checkpoint.substr(key + 13)) > 0) break;
    std::this_thread::sleep_for(std::chrono::milliseconds(10));
  }
  // `timeout` passes SIGINT on to mpirun, and mpirun to the ranks as SIGTERM.
  ::kill(job, SIGINT);
  const Job stopped = Finish(job, work / "mpi");
  INFO(stopped.err);
  CHECK(stopped.status != kTimedOut);
  // Stopped part way: had the sweep finished first, nothing here would be tested.
  REQUIRE_FALSE(fs::exists(out / "points.csv"));
  // mpirun's own exit status (1) says nothing of the ranks; rank 0's line and the checkpoint do.
  const std::string checkpoint = ReadFile(out / ".sweep-checkpoint");
  const std::size_t key = checkpoint.find("\npoints_done=");
  REQUIRE(key != std::string::npos);
  const std::size_t done = std::stoull(checkpoint.substr(key + 13));
  CHECK(stopped.err == Interrupted(done, total));
  CHECK(done % kInterruptedBlock == 0);  // a block boundary
  CHECK(done < total);
  // The interrupt checkpoints at once: nothing past the recorded sizes.
  CHECK_THAT(checkpoint,
             Catch::Contains("\npoints_bytes=" +
                             std::to_string(fs::file_size(out / "points.csv.partial")) + "\n"));
  const Job resumed = RunIn(work / "mpi", Concatenate(MpiRun(2), sweep));
  INFO(resumed.err);
  REQUIRE(resumed.status == 0);
  CHECK_THAT(resumed.err, Catch::Contains("resuming at point " + std::to_string(done)));
  CheckSameFiles(single, out);
}

}  // namespace
}  // namespace servokit
