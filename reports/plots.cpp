#include "reports/plots.h"

#include <fcntl.h>
#include <spawn.h>
#include <sys/wait.h>

#include <cerrno>
#include <cstring>
#include <fstream>

#include "models/errors.h"
#include "reports/number_format.h"

extern char** environ;

namespace servokit {
namespace {

// gnuplot strings are single-quoted; a quote in a path would end them early.
std::string Quoted(const std::string& text) {
  if (text.find('\'') != std::string::npos) {
    throw UsageError("'" + text + "': a path for gnuplot may not contain a single quote");
  }
  return "'" + text + "'";
}

void WriteData(const std::string& path, const PlotSpec& spec) {
  std::ofstream data(path);
  for (std::size_t i = 0; i < spec.series.size(); ++i) {
    data << "# " << spec.series[i].title << "\n";
    for (const auto& [x, y] : spec.series[i].points) {
      data << FormatExact(x) << " " << FormatExact(y) << "\n";
    }
    data << "\n\n";  // gnuplot: a new data set (index)
  }
  if (!data) throw Error("cannot write " + path);
}

// Marker labels are staggered downwards, so that events at one place stay readable.
constexpr double kLabelTop = 0.96;
constexpr double kLabelStep = 0.05;

void WriteScript(const std::string& path, const std::string& stem, const PlotSpec& spec) {
  std::ofstream script(path);
  script << "set title " << Quoted(spec.title) << "\nset xlabel " << Quoted(spec.x_label)
         << "\nset ylabel " << Quoted(spec.y_label) << "\nset grid\nset key outside right\n";
  if (!spec.x_range.empty()) script << "set xrange " << spec.x_range << "\n";
  if (!spec.y_range.empty()) script << "set yrange " << spec.y_range << "\n";
  for (std::size_t i = 0; i < spec.markers.size(); ++i) {
    const MarkerLine& marker = spec.markers[i];
    script << "set arrow " << i + 1 << " from first " << FormatExact(marker.x)
           << ", graph 0 to first " << FormatExact(marker.x)
           << ", graph 1 nohead dashtype 2 linecolor 'gray40'\n"
           << "set label " << Quoted(marker.label) << " at first " << FormatExact(marker.x)
           << ", graph " << FormatExact(kLabelTop - kLabelStep * double(i % 4))
           << " offset 0.5,0 font ',9'\n";
  }
  std::string plot = "plot ";
  for (std::size_t i = 0; i < spec.series.size(); ++i) {
    plot += (i ? ", " : "") + Quoted(stem + ".dat") + " index " + std::to_string(i) + " with " +
            spec.series[i].style + " title " + Quoted(spec.series[i].title);
  }
  script << "set terminal pngcairo size 900,600\nset output " << Quoted(stem + ".png") << "\n"
         << plot << "\nset terminal svg size 900,600 dynamic\nset output " << Quoted(stem + ".svg")
         << "\nreplot\nunset output\n";
  if (!script) throw Error("cannot write " + path);
}

// Runs gnuplot on the script, in `directory`, with its messages in `log`.
void RunGnuplot(const std::string& directory, const std::string& script, const std::string& log) {
  posix_spawn_file_actions_t actions;
  posix_spawn_file_actions_init(&actions);
  posix_spawn_file_actions_addchdir_np(&actions, directory.c_str());
  posix_spawn_file_actions_addopen(&actions, STDOUT_FILENO, log.c_str(),
                                   O_WRONLY | O_CREAT | O_TRUNC, 0644);
  posix_spawn_file_actions_adddup2(&actions, STDOUT_FILENO, STDERR_FILENO);
  std::string program = "gnuplot";
  std::string argument = script;
  char* argv[] = {program.data(), argument.data(), nullptr};
  pid_t pid = 0;
  const int spawned = posix_spawnp(&pid, "gnuplot", &actions, nullptr, argv, environ);
  posix_spawn_file_actions_destroy(&actions);
  if (spawned != 0) {
    throw Error("cannot run gnuplot (" + std::string(std::strerror(spawned)) +
                "): install gnuplot-nox; the data and scripts are in " + directory);
  }
  int status = 0;
  while (waitpid(pid, &status, 0) < 0 && errno == EINTR) {
  }
  if (!WIFEXITED(status) || WEXITSTATUS(status) != 0) {
    std::ifstream messages(directory + "/" + log);
    std::string first_line;
    std::getline(messages, first_line);
    throw Error("gnuplot failed on " + directory + "/" + script +
                (WIFEXITED(status) && WEXITSTATUS(status) == 127
                     ? ": gnuplot not found (install gnuplot-nox)"
                     : ": " + first_line));
  }
}

}  // namespace

void DrawPlot(const std::string& directory, const PlotSpec& spec) {
  WriteData(directory + "/" + spec.name + ".dat", spec);
  WriteScript(directory + "/" + spec.name + ".gp", spec.name, spec);
  RunGnuplot(directory, spec.name + ".gp", spec.name + ".log");
}

}  // namespace servokit
