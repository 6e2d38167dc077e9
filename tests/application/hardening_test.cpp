// Hostile files, paths and disks (issue #29), through the real program: a model file cannot
// make servokit run a command or forge an output, only --out is written, a link or special file
// is refused, a full disk loses nothing and leaves nothing under a final name, and a resume
// after space is freed gives the bytes of an uninterrupted run. And memory running out while a
// model is derived (issue #31) is one line naming the file and key, status 1, not a model error.
#include <sys/mount.h>
#include <sys/stat.h>

#include <algorithm>
#include <catch2/catch.hpp>
#include <chrono>
#include <filesystem>
#include <fstream>
#include <string>
#include <vector>

#include "reports/escaping.h"
#include "tests/test_files.h"
#include "tests/test_paths.h"
#include "tests/test_process.h"

namespace servokit {
namespace {

using testing::Lines;
using testing::ModelPath;
using testing::ProcessResult;
using testing::ReadFile;
using testing::RunProcess;
using testing::TemporaryDirectory;

const std::vector<std::string> kRestToRest = {"--trajectory", "rest-to-rest",
                                              "--y0",         "0",
                                              "--yf",         "1",
                                              "--t0",         "0",
                                              "--tf",         "1",
                                              "--t-end",      "2"};

ProcessResult Servokit(const std::filesystem::path& directory,
                       std::vector<std::string> arguments,
                       const testing::ProcessOptions& options = {}) {
  arguments.insert(arguments.begin(), SERVOKIT_BINARY);
  return RunProcess(directory, arguments, options);
}

std::vector<std::string> Solve(const std::string& model, const std::string& out) {
  std::vector<std::string> command = {"solve", model};
  command.insert(command.end(), kRestToRest.begin(), kRestToRest.end());
  command.insert(command.end(), {"--out", out});
  return command;
}

// `text` with the line that starts with `key` replaced by `key` and `value`. (No std::regex:
// GCC warns falsely inside it under the sanitizers, tests/CMakeLists.txt.)
std::string WithLine(const std::string& text, const std::string& key, const std::string& value) {
  std::string result;
  for (const std::string& line : Lines(text)) {
    result += (line.rfind(key, 0) == 0 ? key + value : line) + "\n";
  }
  return result;
}

// The shipped mass on car with its name (and description) replaced by YAML text.
std::string CarModel(const std::filesystem::path& directory,
                     const std::string& name_yaml,
                     const std::string& description_yaml = "") {
  std::string text = WithLine(ReadFile(ModelPath("mass_on_car.yaml")), "name: ", name_yaml);
  if (!description_yaml.empty()) text = WithLine(text, "description: ", description_yaml);
  const std::filesystem::path path = directory / "model.yaml";
  std::ofstream(path) << text;
  return path.string();
}

// Every file under `directory`, as paths relative to it.
std::vector<std::string> Files(const std::filesystem::path& directory) {
  std::vector<std::string> files;
  for (const auto& entry : std::filesystem::recursive_directory_iterator(directory)) {
    files.push_back(std::filesystem::relative(entry.path(), directory).string());
  }
  std::sort(files.begin(), files.end());
  return files;
}

// AddressSanitizer reserves terabytes of address space at start, which RLIMIT_AS refuses.
#if !defined(__SANITIZE_ADDRESS__)
TEST_CASE("memory running out while a model is derived is status 1, naming the file and key",
          "[application]") {
  // 150 coordinates, T = 1/2 (sum q_i'^2) (1 + sum cos(q_i)/150): 9 KB of text, whose
  // Lagrange equations hold 150^2 terms and take some 60 MB to derive and compile (1.1 s), so
  // 40 MB of address space suffice to parse it but not to derive it.
  const TemporaryDirectory directory;
  std::string rates, cosines, springs, input_matrix, coordinates;
  for (int i = 1; i <= 150; ++i) {
    const std::string q = "q" + std::to_string(i);
    coordinates += (i > 1 ? ", " : "") + q;
    rates += (i > 1 ? " + " : "") + q + "_dot^2";
    cosines += " + cos(" + q + ")/150";
    springs += (i > 1 ? " + " : "") + std::string("k/2*") + q + "^2";
    input_matrix += std::string("  - [") + (i == 1 ? "1" : "0") + "]\n";
  }
  std::ofstream(directory.path() / "wide.yaml")
      << "kind: lagrangian\nname: wide\nparameters:\n  k: 1.0\ncoordinates: [" << coordinates
      << "]\ninputs: [u]\nkinetic_energy: \"(" << rates << ")*(1" << cosines
      << ")/2\"\npotential_energy: \"" << springs << "\"\ninput_matrix:\n"
      << input_matrix << "outputs: [q1]\n";
  testing::ProcessOptions limited;
  limited.address_space_limit = rlim_t{40} << 20;
  const ProcessResult result = Servokit(directory.path(), {"analyze", "wide.yaml"}, limited);
  CHECK(result.status == 1);
  CHECK(Lines(result.err).size() == 1);
  CHECK(result.err.rfind("servokit: error: wide.yaml: ", 0) == 0);
  CHECK(result.err.find(": out of memory while ") != std::string::npos);
  // Unlimited, the same file loads: the limit, not the file, stopped it.
  CHECK(Servokit(directory.path(), {"analyze", "wide.yaml"}).status == 0);
}
#endif

TEST_CASE("a name with a line break is refused at load, naming the key", "[application]") {
  const TemporaryDirectory directory;
  const std::string model = CarModel(directory.path(), R"("car\nsystem \"touch INJECTED\"\n#")");
  const ProcessResult run = Servokit(directory.path(), Solve(model, "u.csv"));
  CHECK(run.status == 2);
  CHECK(run.err == "servokit: error: " + model +
                       ": name: holds the control character 0x0a at character 4 (a name is one "
                       "line)\n");
  CHECK(!std::filesystem::exists(directory / "INJECTED"));
}

TEST_CASE("a hostile name and description reach figures, Modelica and reports as text",
          "[application]") {
  const TemporaryDirectory directory;
  const std::string name =
      "car'q\\ `touch BACKQUOTE` system(\"touch SYSTEM\") "
      "<script>alert(1)</script> #1 double u_d(2,2)";
  std::string quoted_name = "\"";
  for (const char c : name)
    quoted_name += (c == '"' || c == '\\') ? std::string("\\") + c : std::string(1, c);
  quoted_name += "\"";
  const std::string model = CarModel(directory.path(), quoted_name, quoted_name);

  std::vector<std::string> plotted = Solve(model, "u.txt");
  plotted.insert(plotted.end(), {"--format", "modelica", "--plot", "figures"});
  const ProcessResult solve = Servokit(directory.path(), plotted);
  REQUIRE(solve.status == 0);
  // The figures were drawn; gnuplot reads the title back with the name as written (its words
  // kept apart: underscores are shown as spaces, reports/solve_figures.cpp).
  CHECK(std::filesystem::exists(directory / "figures" / "u_d-F.png"));
  std::string title;
  for (const std::string& line : Lines(ReadFile(directory / "figures" / "u_d-F.gp"))) {
    if (line.rfind("set title ", 0) == 0) title = line.substr(std::string("set title ").size());
  }
  // The title's string alone: a figure with marker labels moves it up ("... offset 0,2").
  if (const std::size_t offset = title.rfind(" offset "); offset != std::string::npos) {
    title.resize(offset);
  }
  std::ofstream(directory / "title.gp") << "print " << title << "\n";
  const ProcessResult shown = RunProcess(directory.path(), {"gnuplot", "title.gp"});
  std::string readable = name;
  std::replace(readable.begin(), readable.end(), '_', ' ');
  CHECK(shown.err.find(readable) != std::string::npos);
  // The Modelica file's three tables (u_d, q_d, y_d) and no more: the name stays inside its
  // comment line.
  std::vector<std::string> tables;
  for (const std::string& line : Lines(ReadFile(directory / "u.txt"))) {
    if (line.rfind("double ", 0) == 0) tables.push_back(line.substr(7, 3));
  }
  CHECK(tables == std::vector<std::string>{"u_d", "q_d", "y_d"});

  const ProcessResult report =
      Servokit(directory.path(), {"report", model, "--vary", "d=0.5:1:n=3", "--out", "report"});
  REQUIRE(report.status == 0);
  const std::string markdown = ReadFile(directory / "report" / "report.md");
  CHECK(markdown.find(MarkdownText(name)) != std::string::npos);
  CHECK(markdown.find("<script>") == std::string::npos);
  const std::string html = ReadFile(directory / "report" / "report.html");
  CHECK(html.find(HtmlText(name)) != std::string::npos);
  CHECK(html.find("<script>") == std::string::npos);

  const ProcessResult analyze = Servokit(directory.path(), {"analyze", model, "--format", "md"});
  REQUIRE(analyze.status == 0);
  CHECK(analyze.out.find("## " + MarkdownText(name) + "\n") != std::string::npos);

  for (const char* planted : {"BACKQUOTE", "SYSTEM"}) {
    for (const std::string& file : Files(directory.path()))
      CHECK(file.find(planted) == std::string::npos);
  }
}

TEST_CASE("a link planted at an output is refused and its target left as it was", "[application]") {
  const TemporaryDirectory directory;
  const std::filesystem::path victim = directory / "victim.txt";
  std::ofstream(victim) << "secret";
  const std::string model = ModelPath("mass_on_car.yaml");

  std::filesystem::create_symlink(victim, directory / "u.csv");
  ProcessResult run = Servokit(directory.path(), Solve(model, "u.csv"));
  CHECK(run.status == 2);
  CHECK(run.err ==
        "servokit: error: u.csv: is a symbolic link; servokit does not write through "
        "links\n");

  for (const char* partial : {"points.csv.partial", "points.csv", "sweep.json"}) {
    const TemporaryDirectory sweep;
    std::filesystem::create_symlink(victim, sweep / partial);
    run = Servokit(directory.path(),
                   {"sweep", model, "--vary", "d=0:1:n=3", "--out", sweep.path().string()});
    CHECK(run.status == 2);
    CHECK(run.err.find((sweep / partial).string() + ": is a symbolic link") != std::string::npos);
  }

  std::filesystem::create_directories(directory / "figures");
  std::filesystem::create_symlink(victim, directory / "figures" / "u_d-F.png");
  std::vector<std::string> plotted = Solve(model, "v.csv");
  plotted.insert(plotted.end(), {"--plot", "figures"});
  run = Servokit(directory.path(), plotted);
  CHECK(run.status == 2);
  CHECK(run.err.find("figures/u_d-F.png: is a symbolic link") != std::string::npos);
  CHECK(ReadFile(victim) == "secret");
}

TEST_CASE("a FIFO as a model, a trajectory file or an output fails at once, naming it",
          "[application]") {
  const TemporaryDirectory directory;
  REQUIRE(::mkfifo((directory / "fifo").c_str(), 0600) == 0);
  const auto started = std::chrono::steady_clock::now();
  ProcessResult run = Servokit(directory.path(), {"analyze", "fifo"});
  CHECK(run.status == 2);
  CHECK(run.err ==
        "servokit: error: fifo: cannot read the model file (not a regular file: a FIFO, "
        "socket or device)\n");
  run = Servokit(directory.path(), {"solve", ModelPath("mass_on_car.yaml"), "--trajectory", "fifo",
                                    "--t-end", "1", "--out", "u.csv"});
  CHECK(run.status == 2);
  CHECK(run.err.find("fifo: cannot read the trajectory file (not a regular file") !=
        std::string::npos);
  run = Servokit(directory.path(), Solve(ModelPath("mass_on_car.yaml"), "fifo"));
  CHECK(run.status == 2);
  CHECK(run.err ==
        "servokit: error: fifo: is not a regular file (a FIFO, socket or device); not "
        "replaced\n");
  // Three runs that would each block forever on the FIFO before.
  CHECK(std::chrono::steady_clock::now() - started < std::chrono::seconds(30));
}

TEST_CASE("an output naming the model is refused and the model kept", "[application]") {
  const TemporaryDirectory directory;
  const std::string model = CarModel(directory.path(), "car");
  const std::string before = ReadFile(model);
  const ProcessResult run = Servokit(directory.path(), Solve(model, model));
  CHECK(run.status == 2);
  CHECK(run.err.find(model + ": is an input of this run") != std::string::npos);
  CHECK(ReadFile(model) == before);
}

TEST_CASE("sweep.json is the same bytes for any thread count", "[application]") {
  const TemporaryDirectory directory;
  const std::string model = ModelPath("mass_on_car.yaml");
  for (const char* threads : {"1", "2"}) {
    REQUIRE(Servokit(directory / threads, {"sweep", model, "--vary", "d=0:1:n=5", "--threads",
                                           threads, "--out", "sweep"})
                .status == 0);
  }
  CHECK(ReadFile(directory / "1" / "sweep" / "sweep.json") ==
        ReadFile(directory / "2" / "sweep" / "sweep.json"));
}

TEST_CASE("a stop while sweep.mat is built is status 130, and the same command finishes it",
          "[application]") {
  const TemporaryDirectory directory;
  const std::vector<std::string> sweep = {
      SERVOKIT_BINARY, "sweep", ModelPath("mass_on_car.yaml"), "--vary", "d=0:1:n=3", "--format",
      "mat",           "--out"};
  std::vector<std::string> stopped = sweep, reference = sweep;
  stopped.push_back("stopped");
  reference.push_back("reference");
  // Three points are one block; the hook's second request comes while the tables are built,
  // where Ctrl-C's would (application/sweep_command.cpp, StopRequest).
  testing::ProcessOptions stop;
  stop.environment["SERVOKIT_TEST_STOP_AFTER_BLOCKS"] = "2";
  const ProcessResult interrupted = RunProcess(directory.path(), stopped, stop);
  CHECK(interrupted.status == 130);
  CHECK(interrupted.err.find("interrupted while writing the tables (every point is done)") !=
        std::string::npos);
  CHECK(!std::filesystem::exists(directory / "stopped" / "sweep.mat"));
  REQUIRE(RunProcess(directory.path(), stopped).status == 0);
  REQUIRE(RunProcess(directory.path(), reference).status == 0);
  CHECK(ReadFile(directory / "stopped" / "sweep.mat") ==
        ReadFile(directory / "reference" / "sweep.mat"));
}

// A tmpfs of `kilobytes` at `path`, unmounted at the end; mounting needs root (CI is root).
class SmallFileSystem {
 public:
  SmallFileSystem(const std::filesystem::path& path, int kilobytes) : path_(path) {
    std::filesystem::create_directories(path_);
    mounted_ = ::mount("tmpfs", path_.c_str(), "tmpfs", 0,
                       ("size=" + std::to_string(kilobytes) + "k").c_str()) == 0;
  }
  ~SmallFileSystem() {
    if (mounted_) ::umount2(path_.c_str(), MNT_DETACH);
  }
  bool mounted() const { return mounted_; }
  void Grow(int kilobytes) const {
    REQUIRE(::mount("tmpfs", path_.c_str(), "tmpfs", MS_REMOUNT,
                    ("size=" + std::to_string(kilobytes) + "k").c_str()) == 0);
  }

 private:
  std::filesystem::path path_;
  bool mounted_ = false;
};

TEST_CASE("a full disk loses nothing: one message, no final file, the same bytes on resume",
          "[application]") {
  const TemporaryDirectory directory;
  const SmallFileSystem disk(directory / "disk", 64);
  if (!disk.mounted()) {
    WARN("skipped: mounting a tmpfs needs root (CI runs as root)");
    return;
  }
  const std::string model = ModelPath("mass_on_car.yaml");
  for (const char* file : {"u.csv", "u.mat"}) {
    const ProcessResult run =
        Servokit(directory.path(), Solve(model, (directory / "disk" / file).string()));
    CHECK(run.status == 1);
    CHECK(run.err == "servokit: error: cannot write " + (directory / "disk" / file).string() +
                         ": No space left on device\n");
  }
  CHECK(Files(directory / "disk").empty());

  for (const char* format : {"csv", "mat", "hdf5"}) {
    INFO(format);
    const std::vector<std::string> sweep = {"sweep",    model,  "--vary", "d=0:1:n=4000",
                                            "--format", format, "--out"};
    std::vector<std::string> full = sweep, reference = sweep;
    full.push_back((directory / "disk" / format).string());
    reference.push_back((directory / (std::string("reference-") + format)).string());
    const ProcessResult failed = Servokit(directory.path(), full);
    CHECK(failed.status == 1);  // not a crash (139), not a success
    CHECK(failed.err.find("No space left on device") != std::string::npos);
    CHECK(Lines(failed.err).size() <= 2);  // a warning about a:b:n at most, then the error
    for (const char* final_name : {"points.csv", "eigenvalues.csv", "sweep.mat", "sweep.h5"}) {
      CHECK(!std::filesystem::exists(directory / "disk" / format / final_name));
    }
    disk.Grow(16384);
    REQUIRE(Servokit(directory.path(), full).status == 0);
    REQUIRE(Servokit(directory.path(), reference).status == 0);
    for (const std::string& file : Files(directory / (std::string("reference-") + format))) {
      if (file == "sweep.json") continue;  // names its own --out
      CHECK(ReadFile(directory / "disk" / format / file) ==
            ReadFile(directory / (std::string("reference-") + format) / file));
    }
    std::filesystem::remove_all(directory / "disk" / format);
    disk.Grow(64);
  }
}

}  // namespace
}  // namespace servokit
