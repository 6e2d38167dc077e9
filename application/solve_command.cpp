// servokit solve MODEL [--set p=v]... --trajectory rest-to-rest|FILE.yaml|FILE.csv [--y0 A --yf B
// --t0 T0 --tf TF]
//     [--t-start TS] --t-end TE --method
//     auto|algebraic|euler|radau|bdf|normal-form|stable-inversion|linearized|M1,M2,...
//     [--sample-tolerance E] [--force] [--step H] [--rtol R] [--atol A] [--sample-time DT]
//     [--pre-actuation S]
//     [--post-actuation S] [--verify] --out FILE [--format csv|mat|modelica] [--plot DIR]
//     [--summary json|text]
#include <algorithm>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <memory>
#include <optional>
#include <ostream>
#include <sstream>

#include "application/commands.h"
#include "application/exit_codes.h"
#include "servokit/servokit.h"

namespace servokit {
namespace {

struct SolveArguments {
  std::string model_path;
  std::vector<std::string> overrides;
  std::string trajectory;
  std::vector<std::string> y0, yf;
  std::vector<std::string> q0;
  std::optional<double> t0, tf, t_start;
  double t_end = std::numeric_limits<double>::quiet_NaN();
  std::string method = "auto";
  bool force = false;
  std::optional<double> step, rtol, atol, sample_time, pre_actuation, post_actuation;
  std::optional<double> sample_tolerance;
  bool verify = false;
  std::string out;
  std::optional<std::string> format;
  std::string plot;              // --plot DIR, "" for no figures
  std::string summary = "json";  // what stdout gets: json or text
};

// The desired trajectory from --trajectory and, for rest-to-rest, --y0 --yf --t0 --tf; a CSV
// file's columns are matched to the model's outputs by name.
api::OutputTrajectory MakeTrajectory(const SolveArguments& arguments, const api::Model& model) {
  api::OutputTrajectory trajectory;
  if (arguments.sample_tolerance &&
      std::filesystem::path(arguments.trajectory).extension() != ".csv") {
    throw UsageError("--sample-tolerance belongs to a CSV file of samples, not to --trajectory " +
                     arguments.trajectory);
  }
  if (arguments.trajectory == "rest-to-rest") {
    if (arguments.y0.empty() || arguments.yf.empty() || !arguments.t0 || !arguments.tf) {
      throw UsageError("--trajectory rest-to-rest needs --y0, --yf, --t0 and --tf");
    }
    trajectory.y0 = ParseValues("--y0", arguments.y0);
    trajectory.yf = ParseValues("--yf", arguments.yf);
    trajectory.t0 = *arguments.t0;
    trajectory.tf = *arguments.tf;
    return trajectory;
  }
  if (!arguments.y0.empty() || !arguments.yf.empty() || arguments.t0 || arguments.tf) {
    throw UsageError(
        "--y0, --yf, --t0 and --tf belong to --trajectory rest-to-rest; a "
        "trajectory file gives its waypoints or samples itself");
  }
  if (!std::filesystem::exists(arguments.trajectory)) {
    throw UsageError("--trajectory " + arguments.trajectory +
                     ": no such file (expected rest-to-rest, a YAML file of waypoints or a CSV "
                     "file of samples)");
  }
  if (std::filesystem::path(arguments.trajectory).extension() == ".csv") {
    if (arguments.sample_tolerance) {
      const double tolerance = *arguments.sample_tolerance;
      if (!(tolerance >= 0.0 && tolerance < 1.0)) {
        throw UsageError("--sample-tolerance " + api::FormatNumber(tolerance) +
                         ": must be >= 0 (0: through every sample) and < 1");
      }
      trajectory.sample_tolerance = tolerance;
    }
    api::ReadSamplesFile(arguments.trajectory, model, trajectory);
    return trajectory;
  }
  trajectory.waypoint_file = arguments.trajectory;
  return trajectory;
}

// The flag of a solve setting: the one place where the library's words meet the command line.
std::string FlagFor(SolveSetting setting) {
  switch (setting) {
    case SolveSetting::kMethod:
      return "--method";
    case SolveSetting::kForce:
      return "--force";
    case SolveSetting::kStartTime:
      return "--t-start";
    case SolveSetting::kEndTime:
      return "--t-end";
    case SolveSetting::kStep:
      return "--step";
    case SolveSetting::kRelativeTolerance:
      return "--rtol";
    case SolveSetting::kAbsoluteTolerance:
      return "--atol";
    case SolveSetting::kSampleTime:
      return "--sample-time";
    case SolveSetting::kPreActuation:
      return "--pre-actuation";
    case SolveSetting::kPostActuation:
      return "--post-actuation";
  }
  return "--" + std::string(ToString(setting));
}

// The solve, with the library's errors about settings and methods told in flags.
api::Feedforward SolveTellingFlags(const api::Model& model,
                                   const api::OutputTrajectory& trajectory,
                                   const api::SolveOptions& options) {
  try {
    return api::Solve(model, trajectory, options);
  } catch (const SettingError& error) {
    throw UsageError(FlagFor(error.setting()) + ": " + error.what());
  } catch (const MethodRefused& error) {
    std::string hint;
    if (!error.forceable().empty()) {
      hint = "; --force integrates forward anyway";
      if (options.method == SolverMethod::kAuto) {
        hint += " (with " + std::string(ToString(error.forceable().front())) + ")";
      }
    }
    throw NoSolution(std::string(error.what()) + hint);
  }
}

// The format of --out: --format when given, else from the name (.mat: mat, else csv); a name
// that belongs to another format is refused (SolveFileNameProblem).
SolveFileFormat ChooseFormat(const SolveArguments& arguments) {
  if (!arguments.format) return api::SolveFileFormatOfName(arguments.out);
  const std::optional<SolveFileFormat> format = SolveFileFormatFromString(*arguments.format);
  if (!format) {
    throw UsageError("--format " + *arguments.format + ": expected csv, mat or modelica");
  }
  if (const std::optional<std::string> problem =
          api::SolveFileNameProblem(arguments.out, *format)) {
    throw UsageError("--format " + *arguments.format + " --out " + arguments.out + ": " + *problem);
  }
  return *format;
}

// --method: one method (auto included), or a comma-separated list of named methods, each
// solved in turn and overlaid; auto (it picks one) and a method named twice are refused.
std::vector<std::string> ParseMethods(const std::string& text) {
  std::vector<std::string> methods;
  for (std::size_t start = 0;;) {
    const std::size_t comma = text.find(',', start);
    methods.push_back(text.substr(start, comma == std::string::npos ? comma : comma - start));
    if (comma == std::string::npos) break;
    start = comma + 1;
  }
  if (methods.size() == 1) {
    if (!SolverMethodFromString(text)) {
      throw UsageError("--method " + text +
                       ": expected auto, algebraic, euler, radau, bdf, normal-form, "
                       "stable-inversion or linearized");
    }
    return methods;
  }
  for (std::size_t i = 0; i < methods.size(); ++i) {
    const std::string& method = methods[i];
    if (method == "auto") {
      throw UsageError("--method " + text +
                       ": auto picks one method; a list names the methods to overlay");
    }
    if (!SolverMethodFromString(method)) {
      throw UsageError("--method " + text + ": '" + method +
                       "': expected algebraic, euler, radau, bdf, normal-form, "
                       "stable-inversion or linearized");
    }
    if (std::find(methods.begin(), methods.begin() + std::ptrdiff_t(i), method) !=
        methods.begin() + std::ptrdiff_t(i)) {
      throw UsageError("--method " + text + ": " + method + " is listed twice");
    }
  }
  return methods;
}

// The file of the k-th listed method: --out for the first, else --out with ".<method>" before
// its extension (u.csv -> u.radau.csv, u -> u.radau), in the same directory and format.
std::string OutFileOf(const std::string& out,
                      const std::vector<std::string>& methods,
                      std::size_t k) {
  if (k == 0) return out;
  const std::filesystem::path path(out);
  const std::string name = path.stem().string() + "." + methods[k] + path.extension().string();
  return (path.parent_path() / name).string();
}

// How bad a run's status is, for the status of several: a method refused or stopped (3) over
// a failed check (4) over success (0).
int Severity(ExitCode code) {
  switch (code) {
    case ExitCode::kNoSolution:
      return 2;
    case ExitCode::kVerificationFailed:
      return 1;
    default:
      return 0;
  }
}

// The directories a solve makes for its outputs (--out's folder, --plot), made before any work
// so that a long solve's files have somewhere to go, and removed again, while still empty,
// unless the solve got as far as writing (Keep): an error leaves nothing behind. Never removes
// a directory that was there or that holds anything.
class MadeDirectories {
 public:
  MadeDirectories() = default;
  MadeDirectories(const MadeDirectories&) = delete;
  MadeDirectories& operator=(const MadeDirectories&) = delete;
  ~MadeDirectories() {
    if (kept_) return;
    for (auto directory = made_.rbegin(); directory != made_.rend(); ++directory) {
      std::error_code ignored;
      std::filesystem::remove(*directory, ignored);  // fails, harmlessly, on a non-empty one
    }
  }

  // `directory` and its missing parents; UsageError "<flag> <text>: ..." when it cannot be made.
  void Make(const std::filesystem::path& directory,
            const std::string& flag,
            const std::string& text) {
    std::vector<std::filesystem::path> missing;
    std::error_code error;
    for (std::filesystem::path path = directory;
         !path.empty() && !std::filesystem::exists(path, error); path = path.parent_path()) {
      missing.push_back(path);
      if (path == path.parent_path()) break;
    }
    std::filesystem::create_directories(directory, error);
    if (error || !std::filesystem::is_directory(directory)) {
      throw UsageError(flag + " " + text + ": cannot make the directory " + directory.string() +
                       (error ? " (" + error.message() + ")" : std::string()));
    }
    made_.insert(made_.end(), missing.rbegin(), missing.rend());
  }

  void Keep() { kept_ = true; }

 private:
  std::vector<std::filesystem::path> made_;  // outermost first
  bool kept_ = false;
};

// --out names a file; its folder is made when missing.
void PrepareOutArgument(const std::string& out, MadeDirectories& made) {
  if (out == "-") {
    // stdout carries the summary (JSON or text); the table would be mixed into it.
    throw UsageError("--out -: standard output holds the summary; name a file for the table");
  }
  const std::filesystem::path out_directory = std::filesystem::path(out).parent_path();
  if (!out_directory.empty()) made.Make(out_directory, "--out", out);
}

// One value per output, said in flags (the rest-to-rest trajectory itself refuses --y0 and
// --yf of different lengths) or naming the samples file.
void CheckTrajectoryFitsModel(const SolveArguments& arguments,
                              const api::Model& model,
                              const api::OutputTrajectory& trajectory) {
  const std::size_t outputs = model.num_outputs();
  const std::string per_output = ", but the model has " + std::to_string(outputs) +
                                 (outputs == 1 ? " output" : " outputs") + " (one per output)";
  if (arguments.trajectory == "rest-to-rest" && trajectory.y0.size() == trajectory.yf.size() &&
      trajectory.y0.size() != Eigen::Index(outputs)) {
    throw UsageError("--y0 and --yf: " + std::to_string(trajectory.y0.size()) + " values" +
                     per_output);
  }
  if (!trajectory.sample_times.empty() &&
      trajectory.sample_values.cols() != Eigen::Index(outputs)) {
    throw UsageError(arguments.trajectory + ": " + std::to_string(trajectory.sample_values.cols()) +
                     " output columns after t" + per_output);
  }
}

// The options every listed method shares (method and file are set per method).
api::SolveOptions SharedSolveOptions(const SolveArguments& arguments, SolveFileFormat format) {
  api::SolveOptions options;
  options.force = arguments.force;
  options.t_start = arguments.t_start;
  options.t_end = arguments.t_end;
  options.step = arguments.step;
  options.rtol = arguments.rtol;
  options.atol = arguments.atol;
  options.sample_time = arguments.sample_time;
  options.pre_actuation = arguments.pre_actuation;
  options.post_actuation = arguments.post_actuation;
  options.verify = arguments.verify;
  if (!arguments.q0.empty()) options.q_guess = ParseValues("--q0", arguments.q0);
  options.file_format = format;
  return options;
}

// The solves of the listed methods, each with the file it wrote.
struct MethodSolves {
  std::vector<api::Feedforward> solves;
  std::vector<std::string> files;
  ExitCode status = ExitCode::kSuccess;  // kNoSolution when a listed method was refused
};

// Each method in turn on the same model and trajectory, with its notes on `err`. With one
// method a refusal is the command's error as before; in a list it is that method's, and the
// others still run.
MethodSolves SolveEachMethod(const std::vector<std::string>& methods,
                             const std::string& out_file,
                             const api::Model& model,
                             const api::OutputTrajectory& trajectory,
                             api::SolveOptions options,
                             std::ostream& err) {
  const bool several = methods.size() > 1;
  MethodSolves result;
  for (std::size_t k = 0; k < methods.size(); ++k) {
    options.method = *SolverMethodFromString(methods[k]);  // ParseMethods checked each
    options.out_file = OutFileOf(out_file, methods, k);
    if (!several) {
      result.solves.push_back(SolveTellingFlags(model, trajectory, options));
    } else {
      try {
        result.solves.push_back(SolveTellingFlags(model, trajectory, options));
      } catch (const NoSolution& error) {
        err << "servokit: error: --method " << methods[k] << ": " << error.what() << "\n";
        result.status = ExitCode::kNoSolution;
        continue;
      }
    }
    result.files.push_back(options.out_file);
    const std::string label =
        several ? std::string(ToString(result.solves.back().summary.method)) + ": " : "";
    for (const std::string& note : result.solves.back().notes) {
      err << "servokit: note: " << label << note << "\n";
    }
  }
  return result;
}

// stdout: the summaries as text, one JSON object, or a JSON array of several.
void WriteSummaries(const std::vector<api::Feedforward>& solves,
                    const std::string& summary,
                    bool several,
                    std::ostream& out) {
  if (summary == "text") {
    for (std::size_t k = 0; k < solves.size(); ++k) {
      out << (k > 0 ? "\n" : "") << api::SolveSummaryText(solves[k].summary);
    }
  } else if (!several) {
    out << solves.front().summary.json << "\n";
  } else {
    std::vector<api::SolveSummary> summaries;
    for (const api::Feedforward& solve : solves) summaries.push_back(solve.summary);
    out << api::SolveSummariesJson(summaries) << "\n";
  }
}

// Also for a solve that stopped early or failed its check: the figures show where and how.
void DrawSolvesWithRows(const std::string& plot,
                        const api::Model& model,
                        const std::vector<api::Feedforward>& solves) {
  std::vector<const api::Feedforward*> drawn;
  for (const api::Feedforward& solve : solves) {
    if (!solve.t.empty()) drawn.push_back(&solve);
  }
  if (!plot.empty() && !drawn.empty()) api::DrawSolveFigures(plot, model, drawn);
}

// Each solve's warnings and failure on `err`; the worst status of all the listed methods.
ExitCode ReportOutcomes(const MethodSolves& method_solves, bool several, std::ostream& err) {
  ExitCode status = method_solves.status;
  for (std::size_t k = 0; k < method_solves.solves.size(); ++k) {
    const api::Feedforward& feedforward = method_solves.solves[k];
    const api::SolveSummary& summary = feedforward.summary;
    const std::string method(ToString(summary.method));
    const std::string label = several ? method + ": " : "";
    for (const std::string& warning : summary.warnings) {
      err << "servokit: warning: " << label << warning << "\n";
    }
    ExitCode code = ExitCode::kSuccess;
    if (summary.status == SolveStatus::kVerificationFailed) {
      err << "servokit: error: " << label << summary.message << "\n";
      code = ExitCode::kVerificationFailed;
    } else if (!feedforward.usable) {
      err << "servokit: error: " << method << " stopped: " << summary.message
          << " (the rows up to there are in " << method_solves.files[k] << ")\n";
      code = ExitCode::kNoSolution;
    }
    if (Severity(code) > Severity(status)) status = code;
  }
  return status;
}

int RunSolve(const SolveArguments& arguments, std::ostream& out, std::ostream& err) {
  const std::vector<std::string> methods = ParseMethods(arguments.method);
  if (arguments.summary != "json" && arguments.summary != "text") {
    throw UsageError("--summary " + arguments.summary + ": expected json or text");
  }
  // Before any work: a solve whose answer cannot be written is wasted.
  const SolveFileFormat format = ChooseFormat(arguments);
  MadeDirectories made;
  if (!arguments.plot.empty()) made.Make(arguments.plot, "--plot", arguments.plot);
  PrepareOutArgument(arguments.out, made);
  const api::Model model =
      api::Model::FromFile(arguments.model_path, ParseParameterValues(arguments.overrides));
  const api::OutputTrajectory trajectory = MakeTrajectory(arguments, model);
  CheckTrajectoryFitsModel(arguments, model, trajectory);

  // The inputs are read: no output may be one of them, a link, a FIFO or a directory.
  for (std::size_t k = 0; k < methods.size(); ++k)
    api::CheckOutputPath(OutFileOf(arguments.out, methods, k));

  const bool several = methods.size() > 1;
  const MethodSolves method_solves = SolveEachMethod(methods, arguments.out, model, trajectory,
                                                     SharedSolveOptions(arguments, format), err);
  made.Keep();  // the files are written, of a solve that stopped early too
  WriteSummaries(method_solves.solves, arguments.summary, several, out);
  DrawSolvesWithRows(arguments.plot, model, method_solves.solves);
  return static_cast<int>(ReportOutcomes(method_solves, several, err));
}

}  // namespace

Command AddSolveCommand(CLI::App& app) {
  auto arguments = std::make_shared<SolveArguments>();
  CLI::App* solve = app.add_subcommand(
      "solve", "Compute the feedforward u_d(t) and motion q_d(t) for a desired output");
  solve->footer(
      "The CSV has the columns t, each coordinate, each <coordinate>_dot, each input, y1_d, ...;\n"
      "--format mat (the default for an --out ending in .mat) writes them as MAT v5 column\n"
      "vectors of those names plus a struct `solve` of the summary (MATLAB: load u.mat;\n"
      "plot(t, F)); --format modelica writes the CombiTimeTable tables u_d, q_d and y_d.\n"
      "The endings belong to their formats: mat needs .mat, csv and modelica refuse .mat,\n"
      "modelica refuses .csv (use .txt); a contradiction is an error (status 2).\n"
      "stdout gets one JSON object (method, classification, steps, max_servo_residual, and\n"
      "with --verify the largest output error when u_d drives the model from rest, against a\n"
      "bound from the tolerances; a failed check exits with status 4).\n"
      "--method radau,bdf solves with each method in turn: files u.csv, u.bdf.csv, a JSON\n"
      "array of the two objects, and --plot figures with one curve per method.\n\n"
      "Example (paper Sect. 5.1, case 4, u_d every millisecond):\n"
      "  servokit solve models/mass_on_car.yaml --set alpha=0 --set d=0 \\\n"
      "    --trajectory rest-to-rest --y0 0.5 --yf 2.5 --t0 0 --tf 6 --t-end 10 \\\n"
      "    --sample-time 0.001 --verify --out case4.csv");
  solve->add_option("MODEL", arguments->model_path, "Model file (YAML)")->required();
  solve->add_option("--set", arguments->overrides,
                    "Override a parameter: name=value (value may end in deg)");
  solve
      ->add_option("--trajectory", arguments->trajectory,
                   "rest-to-rest (Eq. 65, with --y0 --yf --t0 --tf), a YAML file of waypoints, "
                   "or a CSV file of samples (t,y1,...: joined by a spline at rest before the "
                   "first and after the last, see --sample-tolerance)")
      ->required();
  solve->add_option("--y0", arguments->y0, "Rest-to-rest: output at t0, one per output");
  solve->add_option("--yf", arguments->yf, "Rest-to-rest: output at tf, one per output");
  solve->add_option("--t0", arguments->t0, "Rest-to-rest: start of the motion [s]");
  solve->add_option("--tf", arguments->tf, "Rest-to-rest: end of the motion [s]");
  solve->add_option("--q0", arguments->q0,
                    "Newton's starting point for q at the operating point, the equilibrium "
                    "holding y_d at the motion's start (--t-start, else the trajectory's first "
                    "time), where the solve is classified and linearized (default: the model "
                    "file's q0, else 0)");
  solve->add_option("--t-start", arguments->t_start,
                    "Start of the solve [s] (default: the trajectory's first time; stable "
                    "inversion: the start of its pre-actuation)");
  solve->add_option("--t-end", arguments->t_end, "End of the solve [s]")->required();
  solve
      ->add_option("--method", arguments->method,
                   "auto, algebraic, euler, radau, bdf, normal-form, stable-inversion or "
                   "linearized; or a comma-separated list of named methods (no auto, none "
                   "twice), each solved in turn and overlaid in --plot's figures: the first "
                   "writes --out, each further one --out with .<method> before its extension "
                   "(u.csv, u.radau.csv); stdout gets a JSON array of their objects; the exit "
                   "status is the worst (3 over 4 over 0)")
      ->capture_default_str();
  solve->add_flag("--force", arguments->force,
                  "Integrate unstable internal dynamics forward anyway");
  solve->add_option("--step", arguments->step,
                    "Euler backward's fixed step, the algebraic inverse's own spacing [s] "
                    "(default 1e-3)");
  solve->add_option("--rtol", arguments->rtol,
                    "Relative tolerance (default 1e-8 radau, euler and stable inversion, 1e-10 "
                    "bdf and normal-form)");
  solve->add_option("--atol", arguments->atol,
                    "Absolute tolerance (default 1e-10 radau, euler and stable inversion, 1e-12 "
                    "bdf and normal-form)");
  solve->add_option("--sample-tolerance", arguments->sample_tolerance,
                    "Samples: how far the spline may keep from them, root mean square, relative "
                    "to each output's range (default 1e-10: it takes as few knots as that "
                    "allows; 0: through every sample, whose rounding its derivatives then carry)");
  solve->add_option("--sample-time", arguments->sample_time,
                    "Write rows at t_start + k DT over exactly [t_start, t_end], from the "
                    "method's continuous extension [s] (default: the method's own points)");
  solve->add_option("--pre-actuation", arguments->pre_actuation,
                    "Stable inversion: time before the motion to cover [s] (default: from the "
                    "eigenvalues, widened until the answer settles)");
  solve->add_option("--post-actuation", arguments->post_actuation,
                    "Stable inversion: time after the motion to cover [s] (default: likewise)");
  solve->add_flag("--verify", arguments->verify,
                  "Drive the model with u_d from rest (CVODE) and check the output error "
                  "against a bound from the tolerances (exit status 4 when it fails)");
  solve->add_option("--out", arguments->out, "File to write (CSV unless --format or .mat says)")
      ->required();
  solve->add_option("--format", arguments->format,
                    "csv (default), mat (MAT v5 for MATLAB and scipy; the default for an --out "
                    "ending in .mat) or modelica (CombiTimeTable text: tables u_d, q_d with "
                    "q_dot, and y_d)");
  solve->add_option("--plot", arguments->plot,
                    "Directory (made if missing) for figures of u_d, q_d, dq_d/dt and y against "
                    "y_d (y: the forward simulation's with --verify, else h(q_d)), with the "
                    "motion's start and end and stable inversion's pre- and post-actuation "
                    "marked: u_d-<input>, q_d-<coordinate>, q_d_dot-<coordinate>, "
                    "y-<output>, each .dat .gp .png .svg (needs gnuplot)");
  solve
      ->add_option("--summary", arguments->summary,
                   "What stdout gets: json (the summary object) or text (a few lines for "
                   "people); --format is the format of the --out file")
      ->capture_default_str();
  return {solve, [arguments](std::ostream& out, std::ostream& err) {
            return RunSolve(*arguments, out, err);
          }};
}

}  // namespace servokit
