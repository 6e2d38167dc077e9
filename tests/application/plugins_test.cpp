// The libraries few commands need are plugins loaded on first use (reports/plugins.h, issue
// #19): a command that writes no HDF5 or MAT file and is not started by mpirun loads neither
// HDF5, matio nor MPI. The dynamic loader lists what it loads when LD_DEBUG=libs; the check is
// shown to be able to fail by a sweep that writes sweep.h5 and a solve that writes a MAT file,
// whose lists must hold HDF5 and matio.
#include <algorithm>
#include <catch2/catch.hpp>
#include <fstream>
#include <string>
#include <vector>

#include "tests/test_files.h"
#include "tests/test_paths.h"
#include "tests/test_process.h"

namespace servokit {
namespace {

using testing::ModelPath;
using testing::ProcessResult;
using testing::TemporaryDirectory;

// What the dynamic loader says it loads while `servokit <arguments>` runs.
ProcessResult RunListingLibraries(const std::filesystem::path& directory,
                                  std::vector<std::string> arguments) {
  arguments.insert(arguments.begin(), SERVOKIT_BINARY);
  const ProcessResult result = testing::RunProcess(directory, arguments, {{{"LD_DEBUG", "libs"}}});
  INFO(result.err.substr(result.err.size() > 4000 ? result.err.size() - 4000 : 0));
  REQUIRE(result.status == 0);
  return result;
}

bool Loads(const ProcessResult& run, const std::string& library) {
  return run.err.find("find library=" + library) != std::string::npos;
}

TEST_CASE("analyze, a CSV sweep and a CSV solve load neither HDF5, matio nor MPI",
          "[application]") {
  const TemporaryDirectory directory;
  const std::string model = ModelPath("mass_on_car.yaml");
  for (const std::vector<std::string>& arguments :
       {std::vector<std::string>{"analyze", model},
        {"sweep", model, "--vary", "d=0:1:n=3", "--out", "csv-sweep"},
        {"solve", model, "--trajectory", "rest-to-rest", "--y0", "0", "--yf", "1", "--t0", "0",
         "--tf", "2", "--t-end", "3", "--out", "u.csv"}}) {
    const ProcessResult run = RunListingLibraries(directory.path(), arguments);
    INFO(arguments.front());
    CHECK_FALSE(Loads(run, "libhdf5"));
    CHECK_FALSE(Loads(run, "libmatio"));
    CHECK_FALSE(Loads(run, "libmpi"));
  }
}

TEST_CASE("the data-files plugin loads HDF5 and matio when a file needs them", "[application]") {
  const TemporaryDirectory directory;
  const std::string model = ModelPath("mass_on_car.yaml");
  const ProcessResult hdf5 = RunListingLibraries(
      directory.path(), {"sweep", model, "--vary", "d=0:1:n=3", "--format", "hdf5", "--out", "h5"});
  CHECK(Loads(hdf5, "libhdf5"));
  CHECK_FALSE(Loads(hdf5, "libmpi"));
  CHECK(std::filesystem::exists(directory.path() / "h5" / "sweep.h5"));
  const ProcessResult mat = RunListingLibraries(
      directory.path(), {"solve", model, "--trajectory", "rest-to-rest", "--y0", "0", "--yf", "1",
                         "--t0", "0", "--tf", "2", "--t-end", "3", "--out", "u.mat"});
  CHECK(Loads(mat, "libmatio"));
  CHECK(std::filesystem::exists(directory.path() / "u.mat"));
}

// SERVOKIT_PLUGIN_DIR is looked in first (programs of other projects name the installed
// plugins' directory with it); a file there that is not a plugin is a one-line error naming it,
// not a crash.
TEST_CASE("SERVOKIT_PLUGIN_DIR is searched first, and a broken plugin is a clear error",
          "[application]") {
  const TemporaryDirectory directory;
  const std::filesystem::path plugins = directory.path() / "plugins";
  std::filesystem::create_directories(plugins);
  std::ofstream(plugins / "libservokit_data_files.so") << "not a shared library\n";
  const ProcessResult run =
      testing::RunProcess(directory.path(),
                          {SERVOKIT_BINARY, "sweep", ModelPath("mass_on_car.yaml"), "--vary",
                           "d=0:1:n=3", "--format", "hdf5", "--out", "h5"},
                          {{{"SERVOKIT_PLUGIN_DIR", plugins.string()}}});
  CHECK(run.status != 0);
  CHECK(run.err.rfind(
            "servokit: error: cannot load " + (plugins / "libservokit_data_files.so").string(),
            0) == 0);
  CHECK(std::count(run.err.begin(), run.err.end(), '\n') == 1);
}

}  // namespace
}  // namespace servokit
