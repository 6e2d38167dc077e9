// servokit solve MODEL [--set p=v]... --trajectory rest-to-rest|FILE [--y0 A --yf B --t0 T0 --tf TF]
//     [--t-start TS] --t-end TE --method auto|algebraic|euler|radau|bdf|normal-form|stable-inversion
//     [--force] [--step H] [--rtol R] [--atol A] [--pre-actuation S] [--post-actuation S]
//     [--verify] --out FILE.csv
#include <cmath>
#include <filesystem>
#include <fstream>
#include <memory>
#include <optional>
#include <ostream>

#include "analysis/classification.h"
#include "models/errors.h"
#include "reports/classification_report.h"
#include "reports/commands.h"
#include "reports/exit_codes.h"
#include "reports/number_format.h"
#include "reports/solve_files.h"
#include "solvers/inverse_model.h"
#include "solvers/trajectory.h"
#include "solvers/waypoint_trajectory.h"

namespace servokit {
namespace {

struct SolveArguments {
  std::string model_path;
  std::vector<std::string> overrides;
  std::string trajectory;
  std::vector<std::string> y0, yf;
  std::optional<double> t0, tf, t_start;
  double t_end = std::numeric_limits<double>::quiet_NaN();
  std::string method = "auto";
  bool force = false;
  std::optional<double> step, rtol, atol, pre_actuation, post_actuation;
  bool verify = false;
  std::string out;
};

// The desired trajectory, raised in order when the problem needs more continuous derivatives
// of y_d than asked for (the inverse reads y_d up to order differentiation index - 1).
std::unique_ptr<OutputTrajectory> MakeTrajectory(const SolveArguments& arguments,
                                                 int needed_derivatives,
                                                 std::string& note) {
  if (arguments.trajectory == "rest-to-rest") {
    if (arguments.y0.empty() || arguments.yf.empty() || !arguments.t0 || !arguments.tf) {
      throw UsageError("--trajectory rest-to-rest needs --y0, --yf, --t0 and --tf");
    }
    const int order = RestToRestOrderFor(needed_derivatives);
    if (order > 4) {
      note = "rest-to-rest raised from Eq. (65) (4 continuous derivatives) to " +
             std::to_string(order) + ": the inverse reads y_d up to order " +
             std::to_string(needed_derivatives);
    }
    return std::make_unique<RestToRestTrajectory>(ParseValues("--y0", arguments.y0),
                                                  ParseValues("--yf", arguments.yf),
                                                  *arguments.t0, *arguments.tf, order);
  }
  if (!arguments.y0.empty() || !arguments.yf.empty() || arguments.t0 || arguments.tf) {
    throw UsageError("--y0, --yf, --t0 and --tf belong to --trajectory rest-to-rest; a "
                     "trajectory file gives its waypoints itself");
  }
  if (!std::filesystem::exists(arguments.trajectory)) {
    throw UsageError("--trajectory " + arguments.trajectory +
                     ": no such file (expected rest-to-rest or a YAML file of waypoints)");
  }
  WaypointTrajectory file = LoadWaypointTrajectory(arguments.trajectory);
  if (file.continuous_derivatives() < needed_derivatives) {
    note = arguments.trajectory + ": raised from " +
           std::to_string(file.continuous_derivatives()) + " to " +
           std::to_string(needed_derivatives) +
           " continuous derivatives: the inverse reads y_d up to that order";
    file = file.WithContinuousDerivatives(needed_derivatives);
  }
  return std::make_unique<WaypointTrajectory>(std::move(file));
}

double TrajectoryStart(const SolveArguments& arguments, const OutputTrajectory& trajectory) {
  if (arguments.t_start) return *arguments.t_start;
  return trajectory.breakpoints().front();
}

int RunSolve(const SolveArguments& arguments, std::ostream& out, std::ostream& err) {
  const std::optional<SolverMethod> method = SolverMethodFromString(arguments.method);
  if (!method) {
    throw UsageError("--method " + arguments.method +
                     ": expected auto, algebraic, euler, radau, bdf, normal-form or "
                     "stable-inversion");
  }
  // Before any work: a solve whose answer cannot be written is wasted.
  const std::filesystem::path out_directory = std::filesystem::path(arguments.out).parent_path();
  if (!out_directory.empty() && !std::filesystem::is_directory(out_directory)) {
    throw UsageError("--out " + arguments.out + ": no directory " + out_directory.string());
  }
  const Model model = LoadModel(arguments.model_path, ParseOverrides(arguments.overrides));
  Workspace workspace(model);
  const ClassificationOptions classification_options;
  const Classification classification = Classify(model, workspace, classification_options);

  std::string trajectory_note;
  const int needed_derivatives = classification.structure.differentiation_index - 1;
  const std::unique_ptr<OutputTrajectory> trajectory =
      MakeTrajectory(arguments, needed_derivatives, trajectory_note);
  if (trajectory->outputs() != Eigen::Index(model.num_outputs())) {
    const std::string given = arguments.trajectory == "rest-to-rest"
                                  ? std::string("--y0 and --yf")
                                  : arguments.trajectory + ": waypoints[0].y";
    const std::size_t outputs = model.num_outputs();
    throw UsageError(given + ": " + std::to_string(trajectory->outputs()) +
                     " values, but the model has " + std::to_string(outputs) +
                     (outputs == 1 ? " output" : " outputs") + " (one value per output)");
  }
  if (!trajectory_note.empty()) err << "servokit: note: " << trajectory_note << "\n";

  InverseModelOptions options;
  options.method = *method;
  options.force = arguments.force;
  options.t_start = TrajectoryStart(arguments, *trajectory);
  options.t_end = arguments.t_end;
  if (arguments.step) options.step = *arguments.step;
  options.rtol = arguments.rtol;
  options.pre_actuation = arguments.pre_actuation;
  options.post_actuation = arguments.post_actuation;
  options.atol = arguments.atol;
  const FeedforwardSolution solution =
      SolveInverseModel(model, *trajectory, classification, options);
  WriteFeedforwardCsv(arguments.out, model, *trajectory, solution);

  nlohmann::ordered_json report = SolveToJson(model, classification, classification_options,
                                              solution, trajectory_note);
  std::optional<Verification> verification;
  if (arguments.verify && !solution.times.empty()) {
    verification = VerifyFeedforward(model, *trajectory, solution);
    report["verification"] = VerificationToJson(*verification);
  }
  report["out"] = arguments.out;
  out << report.dump(2) << "\n";
  if (!solution.summary.IsUsable()) {
    err << "servokit: error: " << ToString(solution.method) << " stopped: "
        << solution.summary.message << " (the rows up to there are in " << arguments.out
        << ")\n";
    return static_cast<int>(ExitCode::kNoSolution);
  }
  return static_cast<int>(ExitCode::kSuccess);
}

}  // namespace

Command AddSolveCommand(CLI::App& app) {
  auto arguments = std::make_shared<SolveArguments>();
  CLI::App* solve = app.add_subcommand(
      "solve", "Compute the feedforward u_d(t) and motion q_d(t) for a desired output");
  solve->footer(
      "The CSV has the columns t, each coordinate, each <coordinate>_dot, each input, y1_d, ...;\n"
      "stdout gets one JSON object (method, classification, steps, max_servo_residual, and\n"
      "with --verify the largest output error of a forward simulation driven by u_d).\n\n"
      "Example (paper Sect. 5.1, case 4):\n"
      "  servokit solve models/mass_on_car.yaml --set alpha=0 --set d=0 \\\n"
      "    --trajectory rest-to-rest --y0 0.5 --yf 2.5 --t0 0 --tf 6 --t-end 10 \\\n"
      "    --method radau --verify --out case4.csv");
  solve->add_option("MODEL", arguments->model_path, "Model file (YAML)")->required();
  solve->add_option("--set", arguments->overrides,
                    "Override a parameter: name=value (value may end in deg)");
  solve
      ->add_option("--trajectory", arguments->trajectory,
                   "rest-to-rest (Eq. 65, with --y0 --yf --t0 --tf) or a YAML file of waypoints")
      ->required();
  solve->add_option("--y0", arguments->y0, "Rest-to-rest: output at t0, one per output");
  solve->add_option("--yf", arguments->yf, "Rest-to-rest: output at tf, one per output");
  solve->add_option("--t0", arguments->t0, "Rest-to-rest: start of the motion [s]");
  solve->add_option("--tf", arguments->tf, "Rest-to-rest: end of the motion [s]");
  solve->add_option("--t-start", arguments->t_start,
                    "Start of the solve [s] (default: the trajectory's first time)");
  solve->add_option("--t-end", arguments->t_end, "End of the solve [s]")->required();
  solve
      ->add_option("--method", arguments->method,
                   "auto, algebraic, euler, radau, bdf, normal-form or stable-inversion")
      ->capture_default_str();
  solve->add_flag("--force", arguments->force,
                  "Integrate unstable internal dynamics forward anyway");
  solve->add_option("--step", arguments->step,
                    "Euler backward step, algebraic sample spacing [s] (default 1e-3)");
  solve->add_option("--rtol", arguments->rtol,
                    "Relative tolerance (default 1e-8 Radau and stable inversion, 1e-10 BDF and "
                    "Dormand-Prince)");
  solve->add_option("--atol", arguments->atol,
                    "Absolute tolerance (default 1e-10 Radau, 1e-12 BDF and Dormand-Prince)");
  solve->add_option("--pre-actuation", arguments->pre_actuation,
                    "Stable inversion: time before the motion to cover [s] (default: from the "
                    "eigenvalues, widened until the answer settles)");
  solve->add_option("--post-actuation", arguments->post_actuation,
                    "Stable inversion: time after the motion to cover [s] (default: likewise)");
  solve->add_flag("--verify", arguments->verify,
                  "Drive the model with u_d (CVODE) and report the largest output error");
  solve->add_option("--out", arguments->out, "CSV file to write")->required();
  return {solve, [arguments](std::ostream& out, std::ostream& err) {
            return RunSolve(*arguments, out, err);
          }};
}

}  // namespace servokit
