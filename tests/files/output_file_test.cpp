// Outputs are written whole or not at all, and only where they were asked for
// (files/output_file.h): a temporary file of servokit's own, renamed over the final name on
// Commit; links, FIFOs, devices, directories and inputs refused at the final name.
#include "files/output_file.h"

#include <sys/resource.h>
#include <sys/stat.h>
#include <sys/wait.h>
#include <unistd.h>

#include <catch2/catch.hpp>
#include <climits>
#include <csignal>
#include <cstdlib>
#include <filesystem>
#include <fstream>

#include "files/input_file.h"
#include "tests/test_files.h"

namespace servokit {
namespace {

using testing::ReadFile;
using testing::TemporaryDirectory;

std::size_t Entries(const std::filesystem::path& directory) {
  std::size_t count = 0;
  for ([[maybe_unused]] const auto& entry : std::filesystem::directory_iterator(directory)) {
    ++count;
  }
  return count;
}

std::string UsageMessage(const std::string& path) {
  try {
    CheckOutputPath(path);
  } catch (const UsageError& error) {
    return error.what();
  }
  return "accepted";
}

TEST_CASE("a committed output holds what was written, under its name only", "[files]") {
  const TemporaryDirectory directory;
  const std::string path = (directory / "u.csv").string();
  {
    OutputFile file(path);
    file.stream() << "t,x\n";
    file.Write("0,1\n");
    CHECK(!std::filesystem::exists(path));  // nothing under the final name before Commit
    CHECK(std::filesystem::exists(file.temporary_path()));
    file.Commit();
  }
  CHECK(ReadFile(path) == "t,x\n0,1\n");
  CHECK(Entries(directory.path()) == 1);  // the temporary is gone (renamed)
}

// Found replaying the seeds of the fuzz target output_path: the temporary's name, the final one
// with 8 bytes more, was too long for a file name when the final one had 248 to 255 bytes.
TEST_CASE("an output named as long as a file name may be is written, through a shorter temporary",
          "[files]") {
  const TemporaryDirectory directory;
  const std::string path = (directory / std::string(NAME_MAX, 'n')).string();
  {
    OutputFile file(path);
    CHECK(std::filesystem::path(file.temporary_path()).filename().string().size() <=
          std::size_t{NAME_MAX});
    file.Write("long name");
    file.Commit();
  }
  CHECK(ReadFile(path) == "long name");
  CHECK(Entries(directory.path()) == 1);
}

TEST_CASE("an output not committed leaves nothing, and an old file as it was", "[files]") {
  const TemporaryDirectory directory;
  const std::string path = (directory / "u.csv").string();
  std::ofstream(path) << "old";
  {
    OutputFile file(path);
    file.Write("new, but never finished");
  }
  CHECK(ReadFile(path) == "old");
  CHECK(Entries(directory.path()) == 1);
}

TEST_CASE("a link at the output's name is refused and its target untouched", "[files]") {
  const TemporaryDirectory directory;
  const std::filesystem::path victim = directory / "victim.txt";
  std::ofstream(victim) << "secret";
  std::filesystem::create_symlink(victim, directory / "u.csv");
  const std::string path = (directory / "u.csv").string();
  CHECK(UsageMessage(path) == path + ": is a symbolic link; servokit does not write through links");
  CHECK_THROWS_AS(OutputFile(path), UsageError);
  CHECK(ReadFile(victim) == "secret");
}

TEST_CASE("a FIFO, a device, a directory and an empty name are refused as outputs", "[files]") {
  const TemporaryDirectory directory;
  const std::string fifo = (directory / "u.csv").string();
  REQUIRE(::mkfifo(fifo.c_str(), 0600) == 0);
  CHECK(UsageMessage(fifo) ==
        fifo + ": is not a regular file (a FIFO, socket or device); not replaced");
  CHECK(UsageMessage("/dev/full") ==
        "/dev/full: is not a regular file (a FIFO, socket or device); not replaced");
  CHECK(UsageMessage(directory.path().string()) ==
        directory.path().string() + ": is a directory, not a file");
  CHECK(UsageMessage("") == "an output file name is empty");
}

TEST_CASE("a file read as an input is never overwritten as an output", "[files]") {
  const TemporaryDirectory directory;
  const std::string path = (directory / "model.yaml").string();
  std::ofstream(path) << "name: x\n";
  CHECK(UsageMessage(path) == "accepted");
  ReadInputFile(path, "the model file", kModelFileLimit);
  CHECK(UsageMessage(path) ==
        path + ": is an input of this run (the model, a matrix or a trajectory); not overwritten");
}

TEST_CASE("a write past the file size limit fails with the system's reason, naming the file",
          "[files]") {
  // RLIMIT_FSIZE stands in for a full disk (both fail write(); EFBIG here, ENOSPC there), in a
  // child process, so that the limit does not reach the test runner.
  const TemporaryDirectory directory;
  const std::string path = (directory / "u.csv").string();
  const pid_t child = ::fork();
  REQUIRE(child >= 0);
  if (child == 0) {
    std::signal(SIGXFSZ, SIG_IGN);  // EFBIG instead of the signal
    const rlimit limit{4096, 4096};
    ::setrlimit(RLIMIT_FSIZE, &limit);
    try {
      OutputFile file(path);
      file.Write(std::string(1 << 20, 'x'));
      file.Commit();
    } catch (const Error& error) {
      std::_Exit(std::string(error.what()) == "cannot write " + path + ": File too large" ? 7 : 8);
    }
    std::_Exit(9);
  }
  int status = 0;
  REQUIRE(::waitpid(child, &status, 0) == child);
  CHECK(WIFEXITED(status));
  CHECK(WEXITSTATUS(status) == 7);
  CHECK(!std::filesystem::exists(path));
  CHECK(Entries(directory.path()) == 0);  // the temporary was removed
}

TEST_CASE("a scratch directory publishes finished files and removes the rest", "[files]") {
  const TemporaryDirectory directory;
  std::string scratch_path;
  {
    const ScratchDirectory scratch(directory.path().string());
    scratch_path = scratch.path();
    std::ofstream(scratch_path + "/a.png") << "figure";
    std::ofstream(scratch_path + "/a.log") << "messages";
    std::filesystem::create_symlink(directory / "elsewhere", directory / "a.png.link");
    scratch.Publish("a.png", (directory / "a.png").string());
    CHECK_THROWS_AS(scratch.Publish("a.log", (directory / "a.png.link").string()), UsageError);
  }
  CHECK(ReadFile(directory / "a.png") == "figure");
  CHECK(!std::filesystem::exists(scratch_path));
}

}  // namespace
}  // namespace servokit
