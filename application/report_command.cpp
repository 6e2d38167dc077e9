// servokit report paper --out DIR
// servokit report MODEL --vary p=a:b:n [--vary ...] [--set p=v]... [--y0 v]... [--q0 v]... --out
// DIR
// servokit report --from SWEEP_DIR --out DIR
#include <complex>
#include <filesystem>
#include <fstream>
#include <map>
#include <memory>
#include <ostream>
#include <sstream>
#include <string_view>
#include <system_error>

#include "analysis/parameter_grid.h"
#include "analysis/zero_dynamics.h"
#include "application/commands.h"
#include "application/exit_codes.h"
#include "application/grid_arguments.h"
#include "application/sweep_store.h"
#include "base/errors.h"
#include "base/number_format.h"
#include "files/input_file.h"
#include "modeling/model.h"
#include "studies/class_map.h"
#include "studies/model_report.h"
#include "studies/paper_report.h"

#ifndef SERVOKIT_MODELS_DIR
#error "SERVOKIT_MODELS_DIR must be defined by the build"
#endif

namespace servokit {
namespace {

struct ReportArguments {
  std::string subject;  // "paper" or a model file
  std::string out;
  std::vector<std::string> vary;
  std::vector<std::string> overrides;
  std::vector<std::string> y0;  // the operating point, as for `analyze`
  std::vector<std::string> q0;
  std::string models_directory;
  std::string from;  // a finished sweep's directory
};

// Where the shipped models are: --models, else $SERVOKIT_MODELS, else beside an installed
// executable (<prefix>/bin/servokit -> <prefix>/share/servokit/models, cmake/install.cmake),
// else the source tree's.
std::string ModelsDirectory(const ReportArguments& arguments) {
  if (!arguments.models_directory.empty()) return arguments.models_directory;
  if (const char* environment = std::getenv("SERVOKIT_MODELS")) return environment;
  std::error_code no_executable;
  const std::filesystem::path installed =
      std::filesystem::read_symlink("/proc/self/exe", no_executable).parent_path().parent_path() /
      "share" / "servokit" / "models";
  if (!no_executable && std::filesystem::is_directory(installed)) return installed.string();
  return SERVOKIT_MODELS_DIR;
}

// The fields of one line of a sweep table (RFC 4180 as CsvQuote writes them; no line breaks
// inside a field).
std::vector<std::string> CsvFields(const std::string& line) {
  std::vector<std::string> fields(1);
  bool quoted = false;
  for (std::size_t i = 0; i < line.size(); ++i) {
    const char c = line[i];
    if (quoted) {
      if (c == '"' && i + 1 < line.size() && line[i + 1] == '"') {
        fields.back() += '"';
        ++i;
      } else if (c == '"') {
        quoted = false;
      } else {
        fields.back() += c;
      }
    } else if (c == '"') {
      quoted = true;
    } else if (c == ',') {
      fields.emplace_back();
    } else {
      fields.back() += c;
    }
  }
  return fields;
}

// A table of a sweep: its header's column indices and its rows.
struct CsvTable {
  std::filesystem::path file;
  std::vector<std::string> header;
  std::vector<std::vector<std::string>> rows;

  std::size_t Column(std::string_view name) const {
    for (std::size_t i = 0; i < header.size(); ++i) {
      if (header[i] == name) return i;
    }
    throw UsageError(file.string() + ": no column " + std::string(name));
  }
};

CsvTable ReadCsvTable(const std::filesystem::path& file, const std::vector<std::string>& columns) {
  std::istringstream in(ReadInputFile(file.string(), "the sweep table", kTableFileLimit));
  CsvTable table{file, {}, {}};
  std::string line;
  if (!std::getline(in, line) || (table.header = CsvFields(line)) != columns) {
    throw UsageError(file.string() + ": its header is not that of the sweep's grid");
  }
  while (std::getline(in, line)) {
    table.rows.push_back(CsvFields(line));
    if (table.rows.back().size() != columns.size()) {
      throw UsageError(file.string() + ": line " + std::to_string(table.rows.size() + 1) + " has " +
                       std::to_string(table.rows.back().size()) + " fields, not " +
                       std::to_string(columns.size()));
    }
  }
  return table;
}

double ReadNumber(const CsvTable& table, const std::string& text) {
  try {
    std::size_t used = 0;
    const double value = std::stod(text, &used);
    if (used == text.size()) return value;
  } catch (const std::exception&) {
  }
  throw UsageError(table.file.string() + ": '" + text + "' is not a number");
}

// The points of a finished CSV sweep of `grid`, and each one's class as the map names it
// (oscillatory: a complex pair beyond `options`' imaginary-axis tolerance, as Classify decides).
StoredSweep ReadStoredSweep(const std::filesystem::path& directory,
                            const ParameterGrid& grid,
                            const ClassificationOptions& options) {
  const CsvTable points = ReadCsvTable(directory / "points.csv", PointsColumns(grid));
  const CsvTable eigenvalues =
      ReadCsvTable(directory / "eigenvalues.csv", EigenvaluesColumns(grid));
  if (points.rows.size() != grid.num_points()) {
    throw UsageError(points.file.string() + ": " + std::to_string(points.rows.size()) +
                     " points, the grid of sweep.json has " + std::to_string(grid.num_points()));
  }
  const std::size_t varied = grid.axes().size();
  // A point is found by its varied columns' text (the same FormatExact text in both tables).
  std::map<std::vector<std::string>, std::size_t> point_of;
  StoredSweep stored;
  const std::size_t error = points.Column("error"), realization = points.Column("realization"),
                    stability = points.Column("stability");
  for (std::size_t i = 0; i < points.rows.size(); ++i) {
    const std::vector<std::string>& row = points.rows[i];
    point_of[std::vector<std::string>(row.begin(), row.begin() + long(varied))] = i;
    SweepPoint point;
    point.ok = row[error].empty();
    point.error = row[error];
    stored.points.push_back(point);
  }
  const std::size_t re = eigenvalues.Column("re"), im = eigenvalues.Column("im");
  for (const std::vector<std::string>& row : eigenvalues.rows) {
    const auto found =
        point_of.find(std::vector<std::string>(row.begin(), row.begin() + long(varied)));
    if (found == point_of.end()) {
      throw UsageError(eigenvalues.file.string() + ": an eigenvalue of no point of points.csv");
    }
    stored.points[found->second].eigenvalues.emplace_back(ReadNumber(eigenvalues, row[re]),
                                                          ReadNumber(eigenvalues, row[im]));
  }
  for (std::size_t i = 0; i < points.rows.size(); ++i) {
    const SweepPoint& point = stored.points[i];
    stored.classes.push_back(
        point.ok
            ? MapClassName(
                  points.rows[i][realization], points.rows[i][stability],
                  !OscillatoryModes(point.eigenvalues, options.imaginary_axis_tolerance).empty())
            : "no solution");
  }
  return stored;
}

// `report --from DIR`: the report of a finished sweep, its model loaded from the recorded path.
void ReportFromSweep(const ReportArguments& arguments) {
  const std::filesystem::path directory(arguments.from);
  const SweepRecord record = ReadSweepRecord(directory);
  const std::string file = record.file.string();
  if (record.linear) {
    throw UsageError(file + ": a sweep of a linear model; `report --from` reads multibody sweeps");
  }
  if (record.format != SweepFileFormat::kCsv) {
    throw UsageError(file + ": its tables are in " + SweepTableFileNames(record.format) +
                     "; `report --from` reads CSV sweeps (sweep --format csv)");
  }
  if (!record.completed) {
    throw UsageError(file +
                     ": the sweep is not completed; finish it (run the same `servokit "
                     "sweep` again) first");
  }
  if (!std::filesystem::is_regular_file(record.model_path)) {
    throw UsageError(file + ": its model " + record.model_path + " is missing");
  }
  std::vector<ParameterOverride> fixed;
  for (const auto& [name, value] : record.fixed_parameters)
    fixed.push_back({name, FormatExact(value)});
  const Model model = LoadModel(record.model_path, fixed);
  if (model.content_hash() != record.content_hash) {
    throw UsageError(file + ": its model " + record.model_path + " has changed since the sweep " +
                     "(content hash " + model.content_hash() + ", recorded " + record.content_hash +
                     ")");
  }
  const std::vector<GridAxis> axes = ResolveSweepAxes(record, model.parameter_names());
  const ParameterGrid grid(axes);
  const StoredSweep stored = ReadStoredSweep(directory, grid, record.options);
  MakeOutputDirectory(arguments.out);
  WriteModelReport(arguments.out, model, axes, record.options, &stored);
}

int RunReport(const ReportArguments& arguments, std::ostream& out, std::ostream& err) {
  if (!arguments.from.empty()) {
    if (!arguments.subject.empty() || !arguments.vary.empty() || !arguments.overrides.empty() ||
        !arguments.y0.empty() || !arguments.q0.empty()) {
      throw UsageError(
          "report --from: the sweep gives the model, grid and options; no SUBJECT, "
          "--vary, --set, --y0 or --q0");
    }
    ReportFromSweep(arguments);
  } else if (arguments.subject.empty()) {
    throw UsageError("report: give `paper`, a model file, or --from a finished sweep's directory");
  } else if (arguments.subject == "paper") {
    if (!arguments.vary.empty() || !arguments.overrides.empty() || !arguments.y0.empty() ||
        !arguments.q0.empty()) {
      throw UsageError(
          "report paper: --vary and --set are for `report MODEL` (and so are --y0, --q0)");
    }
    const std::string models = ModelsDirectory(arguments);
    if (!std::filesystem::exists(models + "/mass_on_car.yaml")) {
      throw UsageError("report paper: no mass_on_car.yaml in " + models +
                       " (give the shipped models with --models DIR)");
    }
    MakeOutputDirectory(arguments.out);
    WritePaperReport(arguments.out, models);
  } else {
    const Model model = LoadModel(arguments.subject, ParseOverrides(arguments.overrides));
    std::vector<GridAxis> axes;
    std::vector<std::string> warnings;
    for (const std::string& text : arguments.vary) {
      axes.push_back(ParseGridAxis({model.parameter_names(), model.parameter_display_units()}, text,
                                   &warnings));
    }
    for (const std::string& warning : warnings) err << "servokit: warning: " << warning << "\n";
    ClassificationOptions options;
    if (!arguments.y0.empty()) options.operating_point.y0 = ParseValues("--y0", arguments.y0);
    if (!arguments.q0.empty()) options.operating_point.q_guess = ParseValues("--q0", arguments.q0);
    MakeOutputDirectory(arguments.out);
    WriteModelReport(arguments.out, model, axes, options);
  }
  out << "report written to " << (std::filesystem::path(arguments.out) / "report.md").string()
      << " and report.html\n";
  return static_cast<int>(ExitCode::kSuccess);
}

}  // namespace

Command AddReportCommand(CLI::App& app) {
  auto arguments = std::make_shared<ReportArguments>();
  CLI::App* report = app.add_subcommand(
      "report", "Write a Markdown and HTML report with figures: the paper's, or any model's");
  report->footer(
      "Examples:\n  servokit report paper --out paper-report\n  servokit report "
      "models/rotational_arm.yaml --vary s=0:1:n=201 --out arm-report\n  servokit report --from "
      "sweep-dir --out sweep-report");
  report->add_option("SUBJECT", arguments->subject, "`paper`, or a model file (YAML)");
  report->add_option("--out", arguments->out, "Directory for report.md, report.html, figures")
      ->required();
  report->add_option("--vary", arguments->vary,
                     "A parameter study: name=a:b:n, name=a:b:n=N, name=a:b:step=h or "
                     "name=v1,v2,.. (deg allowed)");
  report->add_option("--set", arguments->overrides,
                     "Override a parameter: name=value (value may end in deg)");
  report->add_option("--y0", arguments->y0,
                     "Output value at the operating point, one per output (default: h(0))");
  report->add_option("--q0", arguments->q0, "Newton's starting point for q (default: 0)");
  report->add_option("--from", arguments->from,
                     "A finished sweep's directory (servokit sweep --out, CSV): report its grid");
  report->add_option("--models", arguments->models_directory,
                     "Directory of the shipped models (for `report paper`)");
  return {report, [arguments](std::ostream& out, std::ostream& err) {
            return RunReport(*arguments, out, err);
          }};
}

}  // namespace servokit
