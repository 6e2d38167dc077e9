#include "application/command_line.h"

#include <CLI/CLI.hpp>
#include <algorithm>
#include <filesystem>
#include <new>
#include <ostream>
#include <sstream>
#include <string>
#include <string_view>
#include <system_error>
#include <vector>

#include "application/commands.h"
#include "application/exit_codes.h"
#include "servokit/servokit.h"

#ifndef SERVOKIT_VERSION
#error "SERVOKIT_VERSION must be defined by the build"
#endif

namespace servokit {

void MakeOutputDirectory(const std::string& directory) {
  std::error_code error;
  std::filesystem::create_directories(directory, error);
  if (error || !std::filesystem::is_directory(directory)) {
    throw Error("--out " + directory + ": cannot make the directory (" + error.message() + ")");
  }
}

api::ParameterValues ParseParameterValues(const std::vector<std::string>& texts) {
  api::ParameterValues values;
  for (const std::string& text : texts) {
    const auto equals = text.find('=');
    if (equals == std::string::npos || equals == 0) {
      throw UsageError("--set " + text + ": expected name=value (e.g. --set alpha=\"5 deg\")");
    }
    values.emplace_back(text.substr(0, equals), text.substr(equals + 1));
  }
  return values;
}

namespace {

// The flag that sets an analysis option (analyze, sweep, threshold), or "" if none does: the
// one place where the options' fields meet the command line (`generate` names its own).
std::string_view FlagForOption(std::string_view owner, std::string_view field) {
  struct OptionFlag {
    std::string_view owner, field, flag;
  };
  static constexpr OptionFlag kFlags[] = {
      {"OperatingPointOptions", "y0", "--y0"},
      {"OperatingPointOptions", "q_guess", "--q0"},
      {"ClassificationOptions", "rank_tolerance", "--rank-tolerance"},
      {"ClassificationOptions", "imaginary_axis_tolerance", "--axis-tolerance"},
      {"LinearAnalysisOptions", "rank_tolerance", "--rank-tolerance"},
      {"LinearZeroDynamicsOptions", "imaginary_axis_tolerance", "--axis-tolerance"},
      {"LinearZeroDynamicsOptions", "shift", "--shift"},
      {"ArpackOptions", "eigenvalues", "--eigenvalues"},
      {"ThresholdOptions", "scan_intervals", "--scan"},
      {"ThresholdOptions", "relative_tolerance", "--tolerance"},
  };
  for (const OptionFlag& entry : kFlags) {
    if (entry.owner == owner && entry.field == field) return entry.flag;
  }
  return "";
}

// The message of an error as the command line says it: the toolkit's words, with the user's
// flag where one set the value ("--set k=stiff: not a number" for a parameter override,
// "... must be > 0 and < 1 (--rank-tolerance)" for an option).
std::string CommandLineMessage(const std::exception& error) {
  // Past the loader (which names the file and key), memory can still run out in an analysis
  // or a solve: status 1, in words rather than "std::bad_alloc".
  if (dynamic_cast<const std::bad_alloc*>(&error) != nullptr) {
    return "out of memory (free memory, or raise the process's limit)";
  }
  if (const auto* bad_override = dynamic_cast<const ParameterOverrideError*>(&error)) {
    return "--set " + bad_override->name() + "=" + bad_override->value() + ": " +
           bad_override->problem();
  }
  if (const auto* bad_option = dynamic_cast<const OptionError*>(&error)) {
    const std::string_view flag = FlagForOption(bad_option->owner(), bad_option->field());
    if (!flag.empty()) return std::string(error.what()) + " (" + std::string(flag) + ")";
  }
  return error.what();
}

// An empty --out names no file or directory: `solve --out ""` wrote nothing and exited 0.
// Checked here, once, for every command that has --out (and its subcommands: generate chain).
void RefuseEmptyOut(const CLI::App& command) {
  for (const CLI::App* subcommand : command.get_subcommands()) RefuseEmptyOut(*subcommand);
  const CLI::Option* out = command.get_option_no_throw("--out");
  if (out == nullptr) return;
  for (const std::string& value : out->results()) {
    if (value.empty()) throw UsageError("--out \"\": must name a file or directory");
  }
}

}  // namespace

Eigen::VectorXd ParseValues(const std::string& option, const std::vector<std::string>& texts) {
  std::vector<double> values;
  for (const std::string& text : texts) {
    std::stringstream stream(text);
    std::string item;
    while (std::getline(stream, item, ',')) {
      const std::optional<api::ValueWithUnit> value = api::ParseQuantity(item);
      if (!value) {
        throw UsageError(option + " " + text + ": '" + item +
                         "' is not a number (use e.g. 0.5 or \"5 deg\")");
      }
      values.push_back(value->value);
    }
  }
  return Eigen::Map<const Eigen::VectorXd>(values.data(), Eigen::Index(values.size()));
}

namespace {

// Edits (insertions, deletions, substitutions) between two names, for "did you mean".
std::size_t EditDistance(std::string_view a, std::string_view b) {
  std::vector<std::size_t> row(b.size() + 1);
  for (std::size_t j = 0; j <= b.size(); ++j) row[j] = j;
  for (std::size_t i = 1; i <= a.size(); ++i) {
    std::size_t diagonal = row[0];
    row[0] = i;
    for (std::size_t j = 1; j <= b.size(); ++j) {
      const std::size_t above = row[j];
      row[j] = std::min({row[j] + 1, row[j - 1] + 1, diagonal + (a[i - 1] == b[j - 1] ? 0 : 1)});
      diagonal = above;
    }
  }
  return row[b.size()];
}

// An option the command does not know is the first thing to say: CLI11 would report a required
// option as missing first ("--t-end is required" for a misspelt --tend). Finds the (sub)command
// the words name, then each "--name" it lacks, with the nearest it has.
void RefuseUnknownOptions(const CLI::App& app, int argc, const char* const* argv) {
  const CLI::App* command = &app;
  for (int i = 1; i < argc; ++i) {
    const std::string_view word = argv[i];
    if (word == "--") return;  // positionals only after it
    if (!word.starts_with("--")) {
      // A subcommand's name moves into it; any other word is a value or a positional.
      for (const CLI::App* sub : command->get_subcommands({})) {
        if (sub->check_name(std::string(word))) {
          command = sub;
          break;
        }
      }
      continue;
    }
    const std::string name(word.substr(0, word.find('=')));
    if (name == "--help" || name == "--version") continue;
    if (command->get_option_no_throw(name) != nullptr) continue;
    std::string nearest;
    std::size_t best = 4;  // suggest within three edits only
    for (const CLI::Option* option : command->get_options()) {
      for (const std::string& known : option->get_lnames()) {
        const std::size_t distance = EditDistance(name.substr(2), known);
        if (distance < best) {
          best = distance;
          nearest = "--" + known;
        }
      }
    }
    throw UsageError("unknown option " + name +
                     (command == &app ? std::string() : " for " + command->get_name()) +
                     (nearest.empty() ? "" : " (did you mean " + nearest + "?)"));
  }
}

}  // namespace

int RunCommandLine(int argc, const char* const* argv, std::ostream& out, std::ostream& err) {
  CLI::App app(
      "servokit: analyse and solve servo-constraint problems of underactuated "
      "multibody systems");
  app.require_subcommand(1);
  app.footer(
      "Example:\n  servokit analyze models/mass_on_car.yaml\n"
      "`servokit SUBCOMMAND --help` shows each subcommand's options and an example; the errors\n"
      "and exit statuses are listed in docs/errors.md.");
  app.set_version_flag("--version", std::string("servokit ") + SERVOKIT_VERSION);
  const std::vector<Command> commands = {AddAnalyzeCommand(app), AddThresholdCommand(app),
                                         AddSweepCommand(app),   AddSolveCommand(app),
                                         AddReportCommand(app),  AddGenerateCommand(app)};
  try {
    // CLI11 reports a misspelt command as a missing one ("A subcommand is required").
    if (argc > 1 && argv[1][0] != '-' &&
        std::none_of(commands.begin(), commands.end(),
                     [&](const Command& command) { return command.app->check_name(argv[1]); })) {
      std::string names;
      for (const Command& command : commands) {
        names += (names.empty() ? "" : ", ") + command.app->get_name();
      }
      throw UsageError(std::string("unknown command '") + argv[1] + "' (expected " + names + ")");
    }
    RefuseUnknownOptions(app, argc, argv);
    try {
      app.parse(argc, argv);
    } catch (const CLI::CallForHelp&) {
      out << app.help();
      return 0;
    } catch (const CLI::CallForAllHelp&) {
      out << app.help("", CLI::AppFormatMode::All);
      return 0;
    } catch (const CLI::CallForVersion&) {
      out << app.version() << "\n";
      return 0;
    } catch (const CLI::ParseError& error) {
      throw UsageError(error.what());
    }
    RefuseEmptyOut(app);
    for (const Command& command : commands) {
      if (command.app->parsed()) return command.run(out, err);
    }
    throw UsageError("no command given (try servokit --help)");
  } catch (const std::exception& error) {
    err << "servokit: error: " << CommandLineMessage(error) << "\n";
    return static_cast<int>(ExitCodeFor(error));
  } catch (...) {
    err << "servokit: error: unknown internal error\n";
    return static_cast<int>(ExitCode::kOther);
  }
}

}  // namespace servokit
