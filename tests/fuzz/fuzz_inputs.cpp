#include "tests/fuzz/fuzz_inputs.h"

#include <fcntl.h>
#include <sys/stat.h>
#include <sys/sysmacros.h>
#include <unistd.h>

#include <Eigen/Dense>
#include <algorithm>
#include <cerrno>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <exception>
#include <filesystem>
#include <fstream>
#include <limits>
#include <optional>
#include <set>
#include <sstream>
#include <string>
#include <utility>
#include <vector>

#include "base/errors.h"
#include "files/input_file.h"
#include "files/output_file.h"
#include "modeling/linear_model.h"
#include "modeling/loaded_model.h"
#include "modeling/matrix_market.h"
#include "modeling/model.h"
#include "trajectories/sampled_trajectory.h"
#include "trajectories/trajectory.h"
#include "trajectories/waypoint_trajectory.h"

namespace servokit::fuzz {
namespace {

namespace fs = std::filesystem;

// Every quantity a multibody model compiles (modeling/model.h).
constexpr unsigned kAllQuantities = (1u << kNumQuantities) - 1;

// A private directory for the model file under test and the matrices beside it, made once per
// process and removed at exit.
class WorkDirectory {
 public:
  WorkDirectory() {
    path_ = fs::temp_directory_path() / ("servokit-fuzz-" + std::to_string(::getpid()));
    fs::create_directories(path_);
    // The Matrix Market files a fuzzed linear model may name: those of tests/data/linear.
    for (const auto& entry : fs::directory_iterator(fs::path(SERVOKIT_TEST_DATA_DIR) / "linear")) {
      if (entry.path().extension() == ".mtx") {
        fs::copy_file(entry.path(), path_ / entry.path().filename(),
                      fs::copy_options::overwrite_existing);
      }
    }
  }
  ~WorkDirectory() {
    std::error_code ignored;
    fs::remove_all(path_, ignored);
  }
  // Writes `bytes` to the file `name` of the directory; returns its path.
  std::string Write(const std::string& name, std::string_view bytes) const {
    const fs::path file = path_ / name;
    std::ofstream(file, std::ios::binary | std::ios::trunc)
        .write(bytes.data(), static_cast<std::streamsize>(bytes.size()));
    return file.string();
  }

 private:
  fs::path path_;
};

const WorkDirectory& Work() {
  static const WorkDirectory directory;
  return directory;
}

// Stops the process with `problem` on stderr: libFuzzer reports the abort as a crash and saves
// the input.
[[noreturn]] void Abort(const std::string& problem) {
  std::fprintf(stderr, "servokit fuzz: %s\n", problem.c_str());
  std::abort();
}

[[noreturn]] void Violated(const std::string& property) { Abort("property violated: " + property); }

// Evaluates everything the model compiled at one state away from zero, as the analysis would.
void EvaluateOnce(const Model& model) {
  Workspace workspace(model);
  const Eigen::VectorXd q = Eigen::VectorXd::Constant(static_cast<Eigen::Index>(model.dof()), 0.3);
  const Eigen::VectorXd q_dot =
      Eigen::VectorXd::Constant(static_cast<Eigen::Index>(model.dof()), -0.2);
  Evaluate(model, workspace, q, q_dot, kAllQuantities);
}

}  // namespace

void ReadModelFile(std::string_view bytes) {
  const std::string path = Work().Write("model.yaml", bytes);
  // The same reader as `servokit analyze` (application/analyze_command.cpp).
  const LoadedModel model = LoadModelFile(path);
  if (const LinearModel* linear = model.linear()) {
    AssembleLinearMatrices(*linear, linear->parameters());
    return;
  }
  EvaluateOnce(*model.multibody());
}

void ReadExpression(std::string_view bytes) {
  std::string quoted;  // a YAML single-quoted scalar: ' is written ''
  for (const char c : bytes) {
    if (c < 0x20 || c > 0x7e) return;
    quoted += c;
    if (c == '\'') quoted += '\'';
  }
  const std::string text =
      "name: fuzz\n"
      "parameters: {m: 1, k: 5, alpha: 5 deg}\n"
      "coordinates: [x, s]\n"
      "inputs: [F]\n"
      "mass_matrix: [[m + 1, m*cos(alpha)], [m*cos(alpha), m]]\n"
      "forces: [0, '" +
      quoted +
      "']\n"
      "input_matrix: [[1], [0]]\n"
      "outputs: ['x + " +
      quoted + "']\n";
  EvaluateOnce(LoadModelFromString(text, "fuzz.yaml"));
}

void ReadMatrixMarket(std::string_view bytes) { ParseMatrixMarket(bytes, "fuzz.mtx"); }

namespace {

// The derivatives of y_d evaluated: Eq. (65)'s order, what a solve of the paper's examples reads.
constexpr int kEvaluatedOrder = 4;
// Samples or waypoints evaluated at each end (with the midpoints after them): where the spline or
// the segments meet the rest, and where the end conditions act; the middle in between.
constexpr std::size_t kEvaluatedPointsAtEachEnd = 3;

// Just before the first time and just after the last, the first and last few times and the
// midpoints after them, and the middle of the whole motion. Midpoints add halves, so that no
// difference of two huge times overflows here.
std::vector<double> EvaluationTimes(const std::vector<double>& times) {
  const double infinity = std::numeric_limits<double>::infinity();
  std::vector<double> at = {std::nextafter(times.front(), -infinity),
                            times.front() / 2 + times.back() / 2,
                            std::nextafter(times.back(), infinity)};
  for (std::size_t i = 0; i < times.size(); ++i) {
    if (i >= kEvaluatedPointsAtEachEnd && i + kEvaluatedPointsAtEachEnd < times.size()) continue;
    at.push_back(times[i]);
    if (i + 1 < times.size()) at.push_back(times[i] / 2 + times[i + 1] / 2);
  }
  return at;
}

// y_d and its derivatives up to kEvaluatedOrder at EvaluationTimes(times), as an integrator reads
// them. Those up to the trajectory's continuous derivatives are promised finite (each constructor
// refuses what would overflow them): a NaN there would reach a solve without a message.
void EvaluateTrajectory(const OutputTrajectory& trajectory,
                        const std::vector<double>& times,
                        const std::string& source) {
  const int finite_orders = std::min(kEvaluatedOrder, trajectory.continuous_derivatives());
  Eigen::MatrixXd derivatives;
  for (const double t : EvaluationTimes(times)) {
    trajectory.Derivatives(t, kEvaluatedOrder, derivatives);
    if (derivatives.rows() != trajectory.outputs() || derivatives.cols() != kEvaluatedOrder + 1) {
      Violated(source + ": Derivatives() gave a matrix of the wrong shape");
    }
    if (!derivatives.leftCols(finite_orders + 1).allFinite()) {
      std::ostringstream problem;
      problem.precision(17);
      problem << source << ": y_d or a derivative up to order " << finite_orders
              << " is not finite at t = " << t << ":\n"
              << derivatives;
      Violated(problem.str());
    }
  }
}

// The bytes of the file at `path` (followed if a link), or nullopt when it cannot be read.
std::optional<std::string> ReadBytes(const fs::path& path) {
  std::ifstream file(path, std::ios::binary);
  if (!file) return std::nullopt;
  std::ostringstream bytes;
  bytes << file.rdbuf();
  return bytes.str();
}

// lstat(), or nullopt when `path` names nothing.
std::optional<struct stat> StatusOf(const fs::path& path) {
  struct stat status {};
  if (::lstat(path.c_str(), &status) != 0) return std::nullopt;
  return status;
}

// The same file: device, inode and type.
bool SameFile(const struct stat& a, const struct stat& b) {
  return a.st_dev == b.st_dev && a.st_ino == b.st_ino &&
         (a.st_mode & S_IFMT) == (b.st_mode & S_IFMT);
}

// One entry planted in the sandbox, as planted.
struct PlantedEntry {
  std::string name;  // relative to the sandbox
  struct stat status {};
  std::string link_target;   // a link's
  std::string bytes;         // a regular file's
  bool replaceable = false;  // a plain file of no input: an output may be renamed over it
};

// The private directories of WriteOutputPath (see fuzz_inputs.h), made once per process and
// removed at exit:
//   <root>/outside/sentinel  what a followed link would change
//   <root>/sandbox/          where every output is named, with the entries of Plant()
class OutputSandbox {
 public:
  OutputSandbox() {
    std::string pattern = (fs::temp_directory_path() / "servokit-fuzz-output-XXXXXX").string();
    if (::mkdtemp(pattern.data()) == nullptr) {
      Abort("cannot create the sandbox " + pattern + ": " + std::strerror(errno));
    }
    root_ = pattern;
    sandbox_ = root_ / "sandbox";
    outside_ = root_ / "outside";
    fs::create_directory(sandbox_);
    fs::create_directory(outside_);
    std::ofstream(outside_ / "sentinel", std::ios::binary) << kSentinelBytes;
    sentinel_ = *StatusOf(outside_ / "sentinel");
    Plant();
  }
  ~OutputSandbox() {
    std::error_code ignored;
    fs::remove_all(root_, ignored);
  }
  OutputSandbox(const OutputSandbox&) = delete;
  OutputSandbox& operator=(const OutputSandbox&) = delete;

  const fs::path& directory() const { return sandbox_; }

  // Aborts unless the sentinel and every planted entry are as they were and the only thing new
  // is the output `path` holding `written` (nothing new when nullopt: the write failed).
  void Check(const fs::path& path, const std::optional<std::string>& written) const {
    CheckOutside();
    std::optional<struct stat> output;
    if (written) {
      output = StatusOf(path);
      if (!output || !S_ISREG(output->st_mode)) {
        Violated(path.string() + ": committed, but no regular file is there");
      }
      if (ReadBytes(path) != *written) {
        Violated(path.string() + ": does not hold exactly the bytes written");
      }
    }
    for (const PlantedEntry& entry : planted_) CheckPlanted(entry, output);
    if (!IsInputFile((sandbox_ / "input.csv").string())) {
      Violated("input.csv: no longer known as an input (changed)");
    }
    for (const std::string& name : NewEntries()) {
      const std::optional<struct stat> status = StatusOf(sandbox_ / name);
      if (output && status && SameFile(*status, *output)) continue;
      Violated(name + ": left in the sandbox by " +
               (written ? "an output written as " : "an output refused as ") + path.string());
    }
  }

  // Removes what an input created and restores the file an output may replace.
  void Reset() {
    std::error_code ignored;
    for (const std::string& name : NewEntries()) fs::remove_all(sandbox_ / name, ignored);
    for (PlantedEntry& entry : planted_) {
      if (!entry.replaceable) continue;
      const std::optional<struct stat> status = StatusOf(sandbox_ / entry.name);
      if (status && SameFile(*status, entry.status)) continue;
      fs::remove(sandbox_ / entry.name, ignored);
      entry = PlantFile(entry.name, true);
    }
  }

 private:
  static constexpr const char* kSentinelBytes = "outside the sandbox: no output may change this\n";

  // The hostile entries, and one file an output may replace.
  void Plant() {
    Record("link_to_outside",
           ::symlink((outside_ / "sentinel").c_str(), Name("link_to_outside").c_str()));
    Record("dangling", ::symlink((outside_ / "missing").c_str(), Name("dangling").c_str()));
    Record("link_to_null", ::symlink("/dev/null", Name("link_to_null").c_str()));
    Record("fifo", ::mkfifo(Name("fifo").c_str(), 0600));
    Record("dir", ::mkdir(Name("dir").c_str(), 0700));
    Record("link_to_dir", ::symlink("dir", Name("link_to_dir").c_str()));
    // A device: a hard link to /dev/null, else a node of its own, where the system allows either.
    if (::link("/dev/null", Name("null").c_str()) == 0 ||
        ::mknod(Name("null").c_str(), S_IFCHR | 0666, ::makedev(1, 3)) == 0) {
      Record("null", 0);
    }
    planted_.push_back(PlantFile("input.csv", false));
    // Another name of the input, linked before the read (a new link changes the file's ctime,
    // which is part of how an input is recognised).
    Record("input_link.csv", ::link(Name("input.csv").c_str(), Name("input_link.csv").c_str()));
    ReadInputFile(Name("input.csv"), "the samples file", kTrajectoryFileLimit);
    planted_.push_back(PlantFile("existing.csv", true));
  }

  // The entry's path, for the C calls (a temporary that lives through the call).
  std::string Name(const std::string& name) const { return (sandbox_ / name).string(); }

  // Records the entry `name` that a call returning `result` made.
  void Record(const std::string& name, int result) {
    if (result != 0) Abort("cannot plant " + name + " in the sandbox: " + std::strerror(errno));
    PlantedEntry entry{name, *StatusOf(sandbox_ / name), "", "", false};
    if (S_ISLNK(entry.status.st_mode)) entry.link_target = fs::read_symlink(sandbox_ / name);
    if (S_ISREG(entry.status.st_mode)) entry.bytes = *ReadBytes(sandbox_ / name);
    planted_.push_back(entry);
  }

  PlantedEntry PlantFile(const std::string& name, bool replaceable) const {
    const std::string bytes = "t,y\n0," + name + "\n";
    std::ofstream(sandbox_ / name, std::ios::binary) << bytes;
    return {name, *StatusOf(sandbox_ / name), "", bytes, replaceable};
  }

  void CheckOutside() const {
    const std::optional<struct stat> sentinel = StatusOf(outside_ / "sentinel");
    if (!sentinel || !SameFile(*sentinel, sentinel_) ||
        sentinel->st_mtim.tv_sec != sentinel_.st_mtim.tv_sec ||
        sentinel->st_mtim.tv_nsec != sentinel_.st_mtim.tv_nsec ||
        ReadBytes(outside_ / "sentinel") != kSentinelBytes) {
      Violated("the sentinel outside the sandbox changed");
    }
    std::error_code error;
    for (const auto& entry : fs::directory_iterator(outside_, error)) {
      if (entry.path().filename() != "sentinel") {
        Violated(entry.path().string() + ": written outside the sandbox");
      }
    }
    struct stat null {};
    if (::stat("/dev/null", &null) != 0 || !S_ISCHR(null.st_mode)) {
      Violated("/dev/null is no longer a device");
    }
  }

  void CheckPlanted(const PlantedEntry& entry, const std::optional<struct stat>& output) const {
    const fs::path path = sandbox_ / entry.name;
    const std::optional<struct stat> status = StatusOf(path);
    if (entry.replaceable && output && status && SameFile(*status, *output)) return;
    if (!status || !SameFile(*status, entry.status)) {
      Violated(entry.name + ": replaced or removed by an output");
    }
    if (S_ISLNK(status->st_mode) && fs::read_symlink(path) != entry.link_target) {
      Violated(entry.name + ": the link was changed");
    }
    if (S_ISREG(status->st_mode) && ReadBytes(path) != entry.bytes) {
      Violated(entry.name + ": written through");
    }
  }

  // What the sandbox holds that was not planted, relative to it, parents before children.
  std::vector<std::string> NewEntries() const {
    std::set<std::string> planted;
    for (const PlantedEntry& entry : planted_) planted.insert(entry.name);
    std::vector<std::string> found;
    std::error_code error;
    for (auto it = fs::recursive_directory_iterator(sandbox_, error);
         it != fs::recursive_directory_iterator(); it.increment(error)) {
      if (error) Abort("cannot list the sandbox: " + error.message());
      const std::string name = fs::path(it->path()).lexically_relative(sandbox_).string();
      if (planted.count(name) == 0) found.push_back(name);
    }
    std::sort(found.begin(), found.end());
    return found;
  }

  fs::path root_, sandbox_, outside_;
  struct stat sentinel_ {};
  std::vector<PlantedEntry> planted_;
};

// servokit's way of writing one output (application/, reports/): the name checked before any
// work, then an OutputFile, written through both of its ways, committed over it.
void WriteThroughOutputFile(const std::string& path, const std::string& bytes) {
  CheckOutputPath(path);
  OutputFile output(path);
  const std::size_t half = bytes.size() / 2;
  output.Write(std::string_view(bytes).substr(0, half));
  output.stream() << bytes.substr(half);
  output.Commit();
}

// The figures' way (reports/plots.cpp): a program writes a plain name into a ScratchDirectory
// beside the output, which publishes it over the output. Names that are no file's ("", ".",
// "..") are not written; returns whether it was.
bool PublishFromScratchDirectory(const fs::path& path, const std::string& bytes) {
  const std::string name = path.filename().string();
  if (name.empty() || name == "." || name == "..") return false;
  const ScratchDirectory scratch(path.parent_path().string());
  std::ofstream(scratch.path() + "/" + name, std::ios::binary) << bytes;
  scratch.Publish(name, path.string());
  return true;
}

}  // namespace

void ReadTrajectoryFile(std::string_view bytes) {
  // As `servokit solve --trajectory samples.csv` reads it (application/solve_command.cpp), then
  // builds it (servokit/solve.cpp) with the paper's Eq. (65) order.
  const std::string path = Work().Write("samples.csv", bytes);
  TrajectorySamples samples = LoadTrajectorySamples(path);
  const std::vector<double> times = samples.times;
  const SampledTrajectory trajectory(std::move(samples.times), std::move(samples.values));
  EvaluateTrajectory(trajectory, times, path);
}

void ReadWaypointFile(std::string_view bytes) {
  const std::string path = Work().Write("waypoints.yaml", bytes);
  const WaypointTrajectory trajectory = LoadWaypointTrajectory(path);
  EvaluateTrajectory(trajectory, trajectory.breakpoints(), path);
}

void WriteOutputPath(std::string_view bytes) {
  static OutputSandbox sandbox;
  static std::size_t writes = 0;
  if (bytes.find('\0') != std::string_view::npos) return;
  const fs::path relative{std::string(bytes)};
  const fs::path normal = relative.lexically_normal();
  // Only names inside the sandbox, by their words: it holds no link to a directory outside.
  if (relative.has_root_path() || (!normal.empty() && *normal.begin() == "..")) return;
  const fs::path path = sandbox.directory() / relative;
  // Different bytes each time, so that a stale file never passes for the new one.
  const std::string written = "t,y\n" + std::to_string(++writes) + ",0\n";
  std::exception_ptr error;
  const auto attempt = [&](const auto& write) {
    std::optional<std::string> done;
    try {
      if (write()) done = written;
    } catch (const Error&) {
      if (!error) error = std::current_exception();
    }
    sandbox.Check(path, done);
    sandbox.Reset();
  };
  attempt([&] {
    WriteThroughOutputFile(path.string(), written);
    return true;
  });
  attempt([&] { return PublishFromScratchDirectory(path, written); });
  if (error) std::rethrow_exception(error);
}

}  // namespace servokit::fuzz
