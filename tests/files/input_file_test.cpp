// Inputs are read only when they are regular files of bounded size (files/input_file.h): a FIFO
// would block forever, /dev/zero never ends, a directory is no file. Each gives one message
// naming the file, at once.
#include "files/input_file.h"

#include <sys/stat.h>

#include <catch2/catch.hpp>
#include <chrono>
#include <filesystem>
#include <fstream>
#include <thread>

#include "tests/test_files.h"

namespace servokit {
namespace {

using testing::TemporaryDirectory;

std::string ReadError(const std::string& path, std::uintmax_t limit = kModelFileLimit) {
  try {
    ReadInputFile(path, "the model file", limit, ErrorKind::kModel);
  } catch (const ModelError& error) {
    return error.what();
  }
  return "no error";
}

TEST_CASE("a regular file is read whole and remembered as an input, under any name", "[files]") {
  const TemporaryDirectory directory;
  const std::string path = (directory / "model.yaml").string();
  std::ofstream(path) << "name: x\n";
  std::filesystem::create_hard_link(path, directory / "other.yaml");
  CHECK(!IsInputFile(path));
  CHECK(ReadInputFile(path, "the model file", kModelFileLimit) == "name: x\n");
  CHECK(IsInputFile(path));
  CHECK(IsInputFile((directory / "other.yaml").string()));
}

TEST_CASE("a file made anew where an input was is not that input", "[files]") {
  // Its inode may be the one the deleted input had; its change time is not (file systems keep
  // it to a clock tick, a few milliseconds at worst: the pause is longer).
  const TemporaryDirectory directory;
  const std::string path = (directory / "model.yaml").string();
  std::ofstream(path) << "name: x\n";
  ReadInputFile(path, "the model file", kModelFileLimit);
  std::filesystem::remove(path);
  std::this_thread::sleep_for(std::chrono::milliseconds(50));
  std::ofstream(path) << "name: y\n";
  CHECK(!IsInputFile(path));
}

TEST_CASE("an input edited and read again is an input as it is now, not as it was", "[files]") {
  // The registry keeps one entry per file, the last read (the fuzz targets rewrite and read one
  // file per input). The pauses let the change time move on (see the test above).
  const TemporaryDirectory directory;
  const std::string path = (directory / "samples.csv").string();
  std::ofstream(path) << "t,y\n0,0\n";
  ReadInputFile(path, "the samples file", kTrajectoryFileLimit);
  for (const char* edit : {"t,y\n0,1\n", "t,y\n0,2\n"}) {
    std::this_thread::sleep_for(std::chrono::milliseconds(50));
    std::ofstream(path) << edit;
    CHECK(!IsInputFile(path));  // changed since it was read
    ReadInputFile(path, "the samples file", kTrajectoryFileLimit);
    CHECK(IsInputFile(path));
  }
}

TEST_CASE("a FIFO is refused at once instead of blocking the read", "[files]") {
  const TemporaryDirectory directory;
  const std::string path = (directory / "fifo.yaml").string();
  REQUIRE(::mkfifo(path.c_str(), 0600) == 0);
  CHECK(ReadError(path) == path +
                               ": cannot read the model file (not a regular file: a FIFO, socket "
                               "or device)");
}

TEST_CASE("a device and a directory are refused, naming the file", "[files]") {
  CHECK(ReadError("/dev/zero") ==
        "/dev/zero: cannot read the model file (not a regular file: a FIFO, socket or device)");
  const TemporaryDirectory directory;
  CHECK(ReadError(directory.path().string()) ==
        directory.path().string() + ": cannot read the model file (a directory, not a file)");
}

TEST_CASE("a file over the limit is refused before it is read", "[files]") {
  const TemporaryDirectory directory;
  const std::string path = (directory / "big.yaml").string();
  // A sparse file: 1 GiB long without taking the disk; only its size is looked at.
  std::ofstream(path).close();
  std::filesystem::resize_file(path, std::uintmax_t{1} << 30);
  CHECK(ReadError(path, std::uintmax_t{1} << 20) ==
        path +
            ": cannot read the model file (1073741824 bytes, over the limit of 1048576 bytes "
            "for such a file)");
}

TEST_CASE("a missing file gives the system's reason, as a usage error by default", "[files]") {
  CHECK_THROWS_AS(ReadInputFile("/no/such/file.csv", "the samples file", kTrajectoryFileLimit),
                  UsageError);
  std::string reason;
  CHECK(!TryReadInputFile("/no/such/file.csv", kTrajectoryFileLimit, reason));
  CHECK(reason == "No such file or directory");
}

}  // namespace
}  // namespace servokit
