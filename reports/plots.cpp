#include "reports/plots.h"

#include <fcntl.h>
#include <spawn.h>
#include <sys/wait.h>

#include <algorithm>
#include <array>
#include <cerrno>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <limits>
#include <sstream>

#include "base/errors.h"
#include "base/number_format.h"
#include "files/output_file.h"
#include "reports/escaping.h"

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

// The colour values of series i, or none.
const std::vector<double>& ColoursOf(const PlotColouring& colouring, std::size_t i) {
  static const std::vector<double> kNone;
  return i < colouring.values.size() ? colouring.values[i] : kNone;
}

void WriteData(const std::string& path, const PlotSpec& spec, const PlotColouring& colouring) {
  OutputFile file(path);
  std::ostream& data = file.stream();
  for (std::size_t i = 0; i < spec.series.size(); ++i) {
    const PlotSeries& series = spec.series[i];
    const std::vector<double>& colours = ColoursOf(colouring, i);
    if (!colours.empty() && colours.size() != series.points.size()) {
      throw Error("plot " + spec.name + ": series '" + series.title + "' has " +
                  std::to_string(colours.size()) + " colours for " +
                  std::to_string(series.points.size()) + " points");
    }
    data << "# " << PlainText(series.title) << "\n";
    for (std::size_t k = 0; k < series.points.size(); ++k) {
      data << FormatExact(series.points[k].first) << " " << FormatExact(series.points[k].second);
      if (!colours.empty()) data << " " << FormatExact(colours[k]);
      data << "\n";
    }
    data << "\n\n";  // gnuplot: a new data set (index)
  }
  file.Commit();
}

// Marker labels: markers at (nearly) the same x share one label ("stability, oscillation");
// a label closer than kLabelSpacing of the x span to another one, or whose text would run into
// another's, is put one line lower, so that events at one place stay readable.
constexpr int kTitleLines = 3;          // the top margin (character heights) the title takes
constexpr double kLabelSpacing = 0.15;  // fraction of the x span one label may take
constexpr double kSameMarker = 1e-6;    // fraction of the x span: one place
constexpr int kLabelLevels = 6;         // lines used before starting again at the top
constexpr double kRightAligned = 0.5;   // labels right of this fraction of the span go left
// The width of one character of a label as a fraction of the x span, for the widest output:
// the PDF (12 pt text on a plot about 3.9 in wide: 0.55 x 12 pt / 3.9 in); PNG and SVG text
// takes less, so a label estimated free of another is free in every format.
constexpr double kLabelCharacterWidth = 0.024;

struct MarkerLabel {
  double x = 0.0;
  std::vector<std::string> parts;  // the labels of the markers at x, each once
  int level = 0;
  bool right_aligned = false;  // the text ends at x (else it starts there)

  std::string Text() const {
    std::string text;
    for (const std::string& part : parts) text += (text.empty() ? "" : ", ") + part;
    return text;
  }
};

// The x extent of the figure: the given x range, else the data and the markers.
std::pair<double, double> XExtent(const PlotSpec& spec) {
  double low = 0.0, high = 0.0;
  if (std::sscanf(spec.x_range.c_str(), "[%lf:%lf]", &low, &high) == 2 && high > low) {
    return {low, high};
  }
  low = std::numeric_limits<double>::infinity();
  high = -low;
  for (const PlotSeries& series : spec.series) {
    for (const auto& point : series.points) {
      if (std::isfinite(point.first)) {
        low = std::min(low, point.first);
        high = std::max(high, point.first);
      }
    }
  }
  for (const MarkerLine& marker : spec.markers) {
    low = std::min(low, marker.x);
    high = std::max(high, marker.x);
  }
  if (!(high > low)) return {low - 1.0, low + 1.0};
  return {low, high};
}

// The x interval a label's text covers, from its length (UTF-8 continuation bytes not
// counted) and alignment.
std::pair<double, double> LabelExtent(const MarkerLabel& label, double span) {
  std::size_t characters = 1;  // the offset from the line
  for (const char c : label.Text()) characters += (static_cast<unsigned char>(c) & 0xC0) != 0x80;
  const double width = double(characters) * kLabelCharacterWidth * span;
  return label.right_aligned ? std::pair{label.x - width, label.x}
                             : std::pair{label.x, label.x + width};
}

bool LabelsCollide(const MarkerLabel& a, const MarkerLabel& b, double span) {
  if (std::abs(a.x - b.x) < kLabelSpacing * span) return true;
  const auto [a_low, a_high] = LabelExtent(a, span);
  const auto [b_low, b_high] = LabelExtent(b, span);
  return a_low < b_high && b_low < a_high;
}

std::vector<MarkerLabel> PlaceLabels(const PlotSpec& spec, double x_low, double span) {
  std::vector<MarkerLine> markers = spec.markers;
  std::stable_sort(markers.begin(), markers.end(),
                   [](const MarkerLine& a, const MarkerLine& b) { return a.x < b.x; });
  std::vector<MarkerLabel> labels;
  for (const MarkerLine& marker : markers) {
    if (labels.empty() || std::abs(marker.x - labels.back().x) > kSameMarker * span) {
      labels.push_back({marker.x, {}, 0});
    }
    std::vector<std::string>& parts = labels.back().parts;
    if (std::find(parts.begin(), parts.end(), marker.label) == parts.end()) {
      parts.push_back(marker.label);
    }
  }
  for (MarkerLabel& label : labels) label.right_aligned = label.x > x_low + kRightAligned * span;
  for (std::size_t i = 0; i < labels.size(); ++i) {
    for (int level = 0;; ++level) {
      bool taken = false;
      for (std::size_t j = 0; j < i; ++j) {
        taken = taken || (labels[j].level == level && LabelsCollide(labels[i], labels[j], span));
      }
      if (!taken || level + 1 == kLabelLevels) {
        labels[i].level = level;
        break;
      }
    }
  }
  return labels;
}

// Titles longer than this (in bytes) put the key below the graph.
constexpr std::size_t kLongKeyTitle = 40;

// A palette from dark blue over green to yellow (viridis' ends and middle), readable in grey.
constexpr const char* kPalette =
    "set palette defined (0 '#440154', 1 '#3b528b', 2 '#21918c', 3 '#5ec962', 4 '#fde725')\n";

void WriteScript(const std::string& path,
                 const std::string& stem,
                 const PlotSpec& spec,
                 const PlotColouring& colouring) {
  bool coloured = false;
  for (std::size_t i = 0; i < spec.series.size(); ++i) {
    coloured = coloured || !ColoursOf(colouring, i).empty();
  }
  // Marker labels stand above the graph, one line per level, in a margin made for them between
  // the graph and the title, so that they never hide a curve (issue #34: an opaque "motion
  // end" did).
  const auto [x_low, x_high] = XExtent(spec);
  const double span = x_high - x_low;
  const std::vector<MarkerLabel> labels = PlaceLabels(spec, x_low, span);
  int levels = 0;
  for (const MarkerLabel& label : labels) levels = std::max(levels, label.level + 1);
  OutputFile file(path);
  std::ostream& script = file.stream();
  script << "set encoding utf8\nset title " << GnuplotString(spec.title);
  if (levels > 0) script << " offset 0," << levels << "\nset tmargin " << kTitleLines + levels;
  script << "\nset xlabel " << GnuplotString(spec.x_label) << "\nset ylabel "
         << GnuplotString(spec.y_label) << "\nset grid\n";
  if (coloured) {
    script << kPalette << "set cblabel " << GnuplotString(colouring.label)
           << "\nset colorbox\nset key below\n";
  } else {
    // The key goes below the graph, where it takes the figure's width instead of squeezing the
    // graph from the side, and is never over data (issue #34); long titles (the classes and
    // curves of a map) one per line, short ones side by side.
    std::size_t longest = 0;
    for (const PlotSeries& series : spec.series) longest = std::max(longest, series.title.size());
    script << (longest > kLongKeyTitle ? "set key below left Left reverse\n"
                                       : "set key below horizontal\n");
  }
  if (!spec.x_range.empty()) script << "set xrange " << spec.x_range << "\n";
  if (!spec.y_range.empty()) script << "set yrange " << spec.y_range << "\n";
  for (std::size_t i = 0; i < spec.markers.size(); ++i) {
    const MarkerLine& marker = spec.markers[i];
    script << "set arrow " << i + 1 << " from first " << FormatExact(marker.x)
           << ", graph 0 to first " << FormatExact(marker.x)
           << ", graph 1 nohead dashtype 2 linecolor 'gray40'\n";
  }
  for (const MarkerLabel& label : labels) {
    script << "set label " << GnuplotString(label.Text()) << " at first " << FormatExact(label.x)
           << ", graph 1 " << (label.right_aligned ? "right" : "left") << " offset "
           << (label.right_aligned ? "-0.5," : "0.5,") << label.level + 0.6 << "\n";
  }
  std::string plot = "plot ";
  for (std::size_t i = 0; i < spec.series.size(); ++i) {
    const PlotSeries& series = spec.series[i];
    plot += (i ? ", " : "") + Quoted(stem + ".dat") + " index " + std::to_string(i) +
            (ColoursOf(colouring, i).empty()
                 ? " using 1:2 with " + series.style
                 : " using 1:2:3 with " + series.style + " linecolor palette") +
            (series.title.empty() ? " notitle" : " title " + GnuplotString(series.title));
  }
  // Sizes and fonts for a slide: the PDF at 5 x 3.5 in with 12 pt text; the bitmaps at the
  // same proportions.
  script << "set terminal pngcairo noenhanced size 1000,700 font ',14'\nset output "
         << Quoted(stem + ".png") << "\n"
         << plot << "\nset terminal svg noenhanced size 1000,700 dynamic font ',16'\nset output "
         << Quoted(stem + ".svg")
         << "\nreplot\nset terminal pdfcairo noenhanced size 5in,3.5in font ',12'\nset output "
         << Quoted(stem + ".pdf") << "\nreplot\nunset output\n";
  file.Commit();
}

// The environment for gnuplot: the caller's, with TZ=UTC, so that the date cairo writes into a
// PDF has one form ("D:YYYYMMDDHHMMSSZ"), which FixPdfDate() then replaces.
std::vector<std::string> GnuplotEnvironment() {
  std::vector<std::string> variables;
  for (char** variable = environ; *variable != nullptr; ++variable) {
    if (std::strncmp(*variable, "TZ=", 3) != 0) variables.emplace_back(*variable);
  }
  variables.emplace_back("TZ=UTC");
  return variables;
}

// cairo 1.16 writes the time of the run into every PDF (/CreationDate) and ignores
// SOURCE_DATE_EPOCH; outputs must be the same bytes in every run, so the date is replaced by a
// fixed one of the same length (the cross-reference offsets stay right).
void FixPdfDate(const std::string& path) {
  std::string bytes;
  {
    std::ifstream in(path, std::ios::binary);
    std::ostringstream buffer;
    buffer << in.rdbuf();
    bytes = buffer.str();
  }
  const std::string key = "/CreationDate (D:";
  const std::string fixed = "20000101000000";
  const std::size_t at = bytes.find(key);
  if (at == std::string::npos) return;
  const std::size_t digits = at + key.size();
  std::size_t end = digits;
  while (end < bytes.size() && std::isdigit(static_cast<unsigned char>(bytes[end]))) ++end;
  if (end - digits != fixed.size()) return;
  bytes.replace(digits, fixed.size(), fixed);
  OutputFile out(path);
  out.Write(bytes);
  out.Commit();
}

// Runs gnuplot on the script, in `directory`, with its messages in `log`; messages name the files
// as they will be in `shown_directory`.
void RunGnuplot(const std::string& directory,
                const std::string& script,
                const std::string& log,
                const std::string& shown_directory) {
  posix_spawn_file_actions_t actions;
  posix_spawn_file_actions_init(&actions);
  posix_spawn_file_actions_addchdir_np(&actions, directory.c_str());
  posix_spawn_file_actions_addopen(&actions, STDOUT_FILENO, log.c_str(),
                                   O_WRONLY | O_CREAT | O_TRUNC, 0644);
  posix_spawn_file_actions_adddup2(&actions, STDOUT_FILENO, STDERR_FILENO);
  std::string program = "gnuplot";
  std::string argument = script;
  char* argv[] = {program.data(), argument.data(), nullptr};
  std::vector<std::string> variables = GnuplotEnvironment();
  std::vector<char*> environment;
  for (std::string& variable : variables) environment.push_back(variable.data());
  environment.push_back(nullptr);
  pid_t pid = 0;
  const int spawned = posix_spawnp(&pid, "gnuplot", &actions, nullptr, argv, environment.data());
  posix_spawn_file_actions_destroy(&actions);
  if (spawned != 0) {
    throw Error("cannot run gnuplot (" + std::string(std::strerror(spawned)) +
                "): install gnuplot-nox; the data and scripts are in " + shown_directory);
  }
  int status = 0;
  while (waitpid(pid, &status, 0) < 0 && errno == EINTR) {
  }
  if (!WIFEXITED(status) || WEXITSTATUS(status) != 0) {
    std::ifstream messages(directory + "/" + log);
    std::string first_line;
    std::getline(messages, first_line);
    throw Error("gnuplot failed on " + shown_directory + "/" + script +
                (WIFEXITED(status) && WEXITSTATUS(status) == 127
                     ? ": gnuplot not found (install gnuplot-nox)"
                     : ": " + first_line));
  }
}

// Quantile p of sorted values, interpolating linearly between order statistics (R type 7).
double Quantile(const std::vector<double>& sorted, double p) {
  const double position = p * double(sorted.size() - 1);
  const auto below = std::size_t(std::floor(position));
  const std::size_t above = std::min(below + 1, sorted.size() - 1);
  return sorted[below] + (position - double(below)) * (sorted[above] - sorted[below]);
}

constexpr double kLowQuantile = 0.1;
constexpr double kHighQuantile = 0.9;
constexpr double kPadding = 0.05;

constexpr std::array<std::pair<const char*, const char*>, 48> kGreek = {{
    {"alpha", "α"},  {"beta", "β"},  {"gamma", "γ"}, {"delta", "δ"},   {"epsilon", "ε"},
    {"zeta", "ζ"},   {"eta", "η"},   {"theta", "θ"}, {"iota", "ι"},    {"kappa", "κ"},
    {"lambda", "λ"}, {"mu", "μ"},    {"nu", "ν"},    {"xi", "ξ"},      {"omicron", "ο"},
    {"pi", "π"},     {"rho", "ρ"},   {"sigma", "σ"}, {"tau", "τ"},     {"upsilon", "υ"},
    {"phi", "φ"},    {"chi", "χ"},   {"psi", "ψ"},   {"omega", "ω"},   {"Alpha", "Α"},
    {"Beta", "Β"},   {"Gamma", "Γ"}, {"Delta", "Δ"}, {"Epsilon", "Ε"}, {"Zeta", "Ζ"},
    {"Eta", "Η"},    {"Theta", "Θ"}, {"Iota", "Ι"},  {"Kappa", "Κ"},   {"Lambda", "Λ"},
    {"Mu", "Μ"},     {"Nu", "Ν"},    {"Xi", "Ξ"},    {"Omicron", "Ο"}, {"Pi", "Π"},
    {"Rho", "Ρ"},    {"Sigma", "Σ"}, {"Tau", "Τ"},   {"Upsilon", "Υ"}, {"Phi", "Φ"},
    {"Chi", "Χ"},    {"Psi", "Ψ"},   {"Omega", "Ω"},
}};

}  // namespace

RobustRange RobustLimits(std::vector<double> values) {
  values.erase(std::remove_if(values.begin(), values.end(),
                              [](double value) { return !std::isfinite(value); }),
               values.end());
  RobustRange result;
  if (values.empty()) return result;
  std::sort(values.begin(), values.end());
  result.min = values.front();
  result.max = values.back();
  const double q_low = Quantile(values, kLowQuantile);
  const double q_high = Quantile(values, kHighQuantile);
  const double width = q_high - q_low;
  result.low = std::max(result.min, q_low - width);
  result.high = std::min(result.max, q_high + width);
  for (const double value : values) {
    result.outside += value < result.low || value > result.high ? 1 : 0;
  }
  if (result.high > result.low) {
    const double pad = kPadding * (result.high - result.low);
    result.range = "[" + FormatExact(result.low - pad) + ":" + FormatExact(result.high + pad) + "]";
  }
  return result;
}

std::string PlotSymbol(const std::string& name) {
  std::string base = name, accent;
  for (const auto& [suffix, mark] : {std::pair{"_ddot", "\u0308"}, std::pair{"_dot", "\u0307"}}) {
    const std::string ending(suffix);
    if (base.size() > ending.size() &&
        base.compare(base.size() - ending.size(), ending.size(), ending) == 0) {
      base.erase(base.size() - ending.size());
      accent = mark;
      break;
    }
  }
  // The Greek letter may stand alone or begin the name before an underscore (theta_1 -> θ_1).
  const std::size_t head_end = std::min(base.find('_'), base.size());
  const std::string head = base.substr(0, head_end);
  for (const auto& [word, letter] : kGreek) {
    if (head == word) {
      base = std::string(letter) + base.substr(head_end);
      break;
    }
  }
  if (accent.empty()) return base;
  // The dot goes over the symbol: right after the first character (a UTF-8 sequence).
  std::size_t first = 1;
  while (first < base.size() && (static_cast<unsigned char>(base[first]) & 0xC0) == 0x80) ++first;
  return base.substr(0, first) + accent + base.substr(first);
}

void DrawPlot(const std::string& directory, const PlotSpec& spec, const PlotColouring& colouring) {
  // gnuplot writes its figures by name: into a directory of servokit's own, from where each
  // finished file is moved over its final name (files/output_file.h), so that a link planted
  // in `directory` is never followed and a failed run leaves no half-written figure.
  const ScratchDirectory scratch(directory);
  const auto publish = [&](const std::vector<std::string>& extensions) {
    for (const std::string& extension : extensions) {
      const std::string name = spec.name + extension;
      if (std::filesystem::exists(scratch.path() + "/" + name)) {
        scratch.Publish(name, directory + "/" + name);
      } else {
        throw Error("gnuplot wrote no " + directory + "/" + name);
      }
    }
  };
  WriteData(scratch.path() + "/" + spec.name + ".dat", spec, colouring);
  WriteScript(scratch.path() + "/" + spec.name + ".gp", spec.name, spec, colouring);
  try {
    RunGnuplot(scratch.path(), spec.name + ".gp", spec.name + ".log", directory);
  } catch (const Error&) {
    publish({".dat", ".gp"});  // for the user to look at, as the message says
    if (std::filesystem::exists(scratch.path() + "/" + spec.name + ".log")) publish({".log"});
    throw;
  }
  FixPdfDate(scratch.path() + "/" + spec.name + ".pdf");
  publish({".dat", ".gp", ".log", ".png", ".svg", ".pdf"});
}

}  // namespace servokit
