// Replays every input of the fuzz corpus (tests/fuzz/corpus/<target>/: the seeds) and every
// input the fuzzer found (tests/fuzz/regressions/<target>/: crashes, hangs and sanitizer reports,
// each fixed) through the functions of tests/fuzz/fuzz_inputs.h, with any compiler. Each must
// load (or write) or fail with a servokit::Error whose message is one line naming the file, as a
// user would see it; the properties a function checks itself (finite derivatives, the output
// sandbox) abort the test when broken. `make test-sanitize` replays them under ASan and UBSan as
// well.
#include <algorithm>
#include <catch2/catch.hpp>
#include <filesystem>
#include <functional>
#include <string>
#include <vector>

#include "base/errors.h"
#include "tests/fuzz/fuzz_inputs.h"
#include "tests/test_files.h"

namespace {

namespace fs = std::filesystem;
using servokit::testing::ReadFile;

struct Reader {
  const char* folder;  // corpus and regressions sub-folder
  std::function<void(std::string_view)> read;
  // What its messages name: the file, or (for a sampled trajectory's spline) what it describes.
  std::vector<std::string> sources;
  // Messages quote the input itself (an output's name): one line where it is.
  bool quotes_input = false;
};

// All files of `folder` (none if it does not exist), in a stable order.
std::vector<fs::path> Inputs(const fs::path& folder) {
  std::vector<fs::path> files;
  if (!fs::is_directory(folder)) return files;
  for (const auto& entry : fs::directory_iterator(folder)) {
    if (entry.is_regular_file()) files.push_back(entry.path());
  }
  std::sort(files.begin(), files.end());
  return files;
}

// Reads one input; returns the error message, or "" when it loaded.
std::string ErrorOf(const Reader& reader, const std::string& bytes) {
  try {
    reader.read(bytes);
  } catch (const servokit::Error& error) {
    return error.what();
  }
  return "";
}

}  // namespace

TEST_CASE("Every fuzz input loads or gives a one-line error naming the file", "[fuzz]") {
  const fs::path fuzz_folder = fs::path(SERVOKIT_TEST_DATA_DIR).parent_path() / "fuzz";
  const std::vector<Reader> readers = {
      {"model_file", servokit::fuzz::ReadModelFile, {"model.yaml"}},
      {"expression", servokit::fuzz::ReadExpression, {"fuzz.yaml"}},
      {"matrix_market", servokit::fuzz::ReadMatrixMarket, {"fuzz.mtx"}},
      // The spline's own checks (too few samples, times not increasing, derivatives that would
      // overflow) speak of "samples:", as `servokit solve` reports them.
      {"trajectory_file", servokit::fuzz::ReadTrajectoryFile, {"samples.csv", "samples: "}},
      {"waypoint_file", servokit::fuzz::ReadWaypointFile, {"waypoints.yaml"}},
      // Every output is named inside the sandbox, whose name every message holds.
      {"output_path", servokit::fuzz::WriteOutputPath, {"servokit-fuzz-output-"}, true},
  };
  for (const Reader& reader : readers) {
    std::size_t seeds = 0;
    for (const char* kind : {"corpus", "regressions"}) {
      for (const fs::path& input : Inputs(fuzz_folder / kind / reader.folder)) {
        if (std::string(kind) == "corpus") ++seeds;
        INFO(input.string());
        const std::string bytes = ReadFile(input);
        std::string message;
        REQUIRE_NOTHROW(message = ErrorOf(reader, bytes));
        if (!message.empty()) {
          if (!reader.quotes_input || bytes.find('\n') == std::string::npos) {
            CHECK(message.find('\n') == std::string::npos);
          }
          CHECK(std::any_of(reader.sources.begin(), reader.sources.end(),
                            [&](const std::string& source) {
                              return message.find(source) != std::string::npos;
                            }));
        }
      }
    }
    INFO(reader.folder);
    CHECK(seeds >= 5);  // the corpus is there
  }
}
