#pragma once
// servokit's C++ API: the one header a program includes to use servokit as a library.
//
//   #include <servokit/servokit.h>
//   namespace sk = servokit::api;
//   const sk::Model model = sk::Model::FromFile("mass_on_car.yaml", {{"alpha", "5 deg"}});
//   const sk::Analysis analysis = sk::Analyze(model);
//   // analysis.realization == sk::Realization::kNonIdealOrthogonal,
//   // analysis.zero_dynamics.eigenvalues ...
//
// Everything the `servokit` command does is here, in the toolkit's own words: load a model (a
// file or a string, either kind), analyze it at an operating point, sweep parameters (in memory,
// or into a directory as `servokit sweep` does: durable, resumable, over MPI ranks), locate
// thresholds, solve for the feedforward, write reports, and generate large linear models. Options
// are structs whose defaults are servokit's; results are plain values. Errors are the exceptions of
// base/errors.h, each with a kind (usage, model, no solution). The header needs only Eigen and the
// standard library: GiNaC, SUNDIALS and the rest stay inside the compiled library.
//
// Every function may be called from several threads at once, on one model or on several (a
// DirectorySweep object from one thread at a time, and an MPI job's collective steps from the
// thread that started MPI). The
// symbolic steps (loading a model, Analyze's nonlinear structure, the inverse a solve derives
// once per model and options) use GiNaC, which is not thread-safe, and run one thread at a time
// under one process-wide lock; the numeric work (operating points, zero dynamics, sweeps,
// integration) runs in parallel.
#include <Eigen/Dense>
#include <complex>
#include <cstddef>
#include <functional>
#include <limits>
#include <memory>
#include <optional>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

#include "base/errors.h"
#include "base/process_group.h"
#include "base/vocabulary.h"

namespace servokit::api {

// ---- the toolkit's named classes (base/vocabulary.h) ----------------------------------------
// Each is an enum with one table of its words: ToString(value) gives the word the docs and the
// files use ("non-ideal-orthogonal", "radau", "converged"), <Enum>FromString(word) the value
// (nullopt for a word that names none).
using servokit::ChainOutputWeights;
using servokit::ChainOutputWeightsFromString;
using servokit::EigenvalueTarget;
using servokit::EigenvalueTargetFromString;
using servokit::LinearEigenSolver;
using servokit::LinearEigenSolverFromString;
using servokit::ModelKind;
using servokit::ModelKindFromString;
using servokit::ProcessGroup;
using servokit::Realization;
using servokit::RealizationFromString;
using servokit::ReportFormat;
using servokit::ReportFormatFromString;
using servokit::SolveFileFormat;
using servokit::SolveFileFormatFromString;
using servokit::SolverMethod;
using servokit::SolverMethodFromString;
using servokit::SolveStatus;
using servokit::SolveStatusFromString;
using servokit::Stability;
using servokit::StabilityFromString;
using servokit::SweepFileFormat;
using servokit::SweepFileFormatFromString;
using servokit::ThresholdEvent;
using servokit::ThresholdEventFromString;
using servokit::ToString;

// ---- models ---------------------------------------------------------------------------------

/// Parameter values that replace a model file's own: (name, value), where the value is a number
/// in SI units or "<number> deg" (converted to radians), as in the model file.
using ParameterValues = std::vector<std::pair<std::string, std::string>>;

/// A value as model files and parameter overrides write it: "<number>" in SI units,
/// "<number> deg" (a blank before deg optional), converted to radians, or "<number> rad".
struct ValueWithUnit {
  double value = 0.0;         // SI (radians for degrees)
  bool degrees = false;       // in degrees
  bool unit_written = false;  // "deg" or "rad" written: not a bare number
};
/// The value of `text`, nullopt when it is not such a number.
std::optional<ValueWithUnit> ParseQuantity(std::string_view text);
/// A number as servokit writes it in messages: the shortest text that reads back to the same
/// double ("nan", "inf" for those).
std::string FormatNumber(double value);

class Model;
/// `value` for `parameter` of `model` read in the unit the model declares it in: a bare number
/// for a parameter given in degrees ("alpha: 5 deg") is in degrees (45 is 45 deg, never 45
/// rad); one that names its unit keeps it. Throws UsageError for an unknown parameter.
ValueWithUnit InParameterUnit(const Model& model,
                              const std::string& parameter,
                              ValueWithUnit value);

/// A loaded model, either kind: immutable, cheap to copy (copies share it) and safe to use from
/// several threads at once.
class Model {
 public:
  /// Reads a model file (YAML; docs/model-files.md, `kind: linear` included). Throws ModelError
  /// naming the file, key and entry of a bad file, UsageError for a bad override.
  static Model FromFile(const std::string& path, const ParameterValues& overrides = {});
  /// The same for a command that takes multibody models only: a linear model file is a
  /// ModelError naming the file (before its matrices are read).
  static Model MultibodyFromFile(const std::string& path, const ParameterValues& overrides = {});
  /// The same from YAML text; `source` names it in error messages, and a linear model's matrix
  /// files are found relative to its directory.
  static Model FromString(const std::string& yaml,
                          const std::string& source = "<string>",
                          const ParameterValues& overrides = {});

  ModelKind kind() const;
  const std::string& name() const;
  /// The file path as given, or FromString's `source`.
  const std::string& source() const;
  /// Parameter names, and their values in SI units after overrides (same order).
  const std::vector<std::string>& parameter_names() const;
  const Eigen::VectorXd& parameters() const;
  /// The unit each parameter is shown in (same order): "deg" for one the model file or an
  /// override gave in degrees ("5 deg"), "SI" otherwise. Values are SI whatever it says.
  std::vector<std::string> parameter_display_units() const;
  /// Generalized coordinates q and inputs u; a linear model's are numbered q1.., u1...
  std::size_t dof() const;
  std::size_t num_inputs() const;
  std::size_t num_outputs() const;
  /// Names of the coordinates, the inputs and the outputs (y1, y2, ...), in the order of q, u
  /// and y: the columns of a solve's CSV. A linear model's are numbered q1.., u1...
  std::vector<std::string> coordinate_names() const;
  std::vector<std::string> input_names() const;
  std::vector<std::string> output_names() const;
  /// A closed chain's multipliers lambda1, lambda2, ... (one per loop-closing constraint), the
  /// columns of Feedforward::multipliers and of a solve's file after y_d; empty for an open chain.
  std::vector<std::string> multiplier_names() const;

  struct Loaded;  // the toolkit's model, inside the library

 private:
  explicit Model(std::shared_ptr<const Loaded> loaded) : loaded_(std::move(loaded)) {}
  friend const Loaded& Unwrap(const Model& model);
  std::shared_ptr<const Loaded> loaded_;
};

// ---- analysis -------------------------------------------------------------------------------

/// The linearization at the operating point as a state-space model x' = A x + B u, y = C x + D u
/// with x = (dq, dq'), in SI units and unscaled: A = [0 I; -M^-1 K -M^-1 D], B = [0; M^-1 B],
/// C = [H 0], D = 0 (what python-control's ss() and MATLAB's ss() take). For a closed chain dq is
/// in the coordinates of the loops' tangent space, dq = tangent_basis dz.
struct StateSpaceModel {
  Eigen::MatrixXd A, B, C, D;
  Eigen::MatrixXd tangent_basis;  // a closed chain's T (dof x dof - constraints); else empty
};

struct AnalyzeOptions;
struct ChainModel;
struct BeamModel;
/// The toolkit's defaults, written once inside it (its classification, linear zero dynamics and
/// generator options): AnalyzeOptions, ChainModel and BeamModel start from them. Each is built
/// once, with every field set.
const AnalyzeOptions& DefaultAnalyzeOptions();
const ChainModel& DefaultChainModel();
const BeamModel& DefaultBeamModel();

/// How Analyze classifies (defaults: the toolkit's, as `servokit analyze` uses them).
struct AnalyzeOptions {
  // The operating point: the output there, one value per output (default: h(q = 0)), and
  // Newton's start for q (default: 0). Multibody models only; a linear model is analysed at 0.
  std::optional<Eigen::VectorXd> y0;
  std::optional<Eigen::VectorXd> q_guess;
  // A singular value (or Markov row) counts as zero at most rank_tolerance times the norms of
  // its factors: relative, so the verdict does not change with units.
  double rank_tolerance = DefaultAnalyzeOptions().rank_tolerance;
  // An eigenvalue with damping ratio |Re lambda| / |lambda| at most this (or below 1e-12 max
  // |lambda|, the zero floor) counts as on the imaginary axis ("critical").
  double imaginary_axis_tolerance = DefaultAnalyzeOptions().imaginary_axis_tolerance;
  // Multibody models: also run the structure algorithm on the nonlinear model (relative degree
  // along the motion, dynamic extension), as `servokit analyze` does; it costs a symbolic
  // derivation per call, which sweeps skip (and which runs one thread at a time).
  bool nonlinear_structure = DefaultAnalyzeOptions().nonlinear_structure;
  // Linear models: the eigensolver (auto: dense up to 200 coordinates, ARPACK above); how many
  // zeros ARPACK computes; its real shift (1/s); which zeros, those nearest the shift or the
  // rightmost.
  LinearEigenSolver eigen_solver = DefaultAnalyzeOptions().eigen_solver;
  int eigenvalues = DefaultAnalyzeOptions().eigenvalues;
  double shift = DefaultAnalyzeOptions().shift;
  EigenvalueTarget which = DefaultAnalyzeOptions().which;
};

/// One lightly damped or undamped mode of the zero dynamics.
struct OscillatoryMode {
  double frequency_hz = 0.0;
  double damping_ratio = 0.0;
};

/// The zero dynamics at the operating point (paper Eq. 48).
struct ZeroDynamics {
  std::vector<std::complex<double>> eigenvalues;
  // kNone: no zero dynamics; kUndetermined (a large linear model only): the precision does not
  // decide an eigenvalue's side.
  Stability stability = Stability::kNone;
  bool minimum_phase = false;
  std::vector<OscillatoryMode> modes;
  // Why the stability is what it is where the numbers alone do not say (a curve of equilibria
  // through the operating point, an undetermined side); else empty.
  std::string stability_note;
};

/// The linearization of a multibody model at its operating point (AnalyzeOptions: y0, q_guess
/// and the tolerances), as StateSpaceModel. Throws as Analyze; UsageError for a linear model
/// (whose matrices are its file's).
StateSpaceModel LinearizeAt(const Model& model, const AnalyzeOptions& options);

/// The classification of a servo-constraint problem at its operating point (docs/analyze.md,
/// the keys of `analyze --format json`), and the three reports `servokit analyze` prints.
struct Analysis {
  Eigen::VectorXd q, u, y;  // the operating point
  // Where that equilibrium is not isolated (named by q_guess on a curve of equilibria): the
  // curve's direction in q, unit length; it is a zero at 0 (zero_dynamics.stability_note).
  std::optional<Eigen::VectorXd> curve_direction;
  // A closed chain's Lagrange multipliers there: C(q)^T lambda hold its loops closed
  // (docs/model-files.md, "Closed kinematic chains"); empty for an open chain.
  Eigen::VectorXd multipliers;
  Eigen::MatrixXd P;  // H M^-1 B (paper Eq. 10); C M^-1 B for a linear model
  int P_rank = 0;
  Realization realization = Realization::kIdealOrthogonal;
  std::vector<int> relative_degree;  // one per output; empty when not determined
  int differentiation_index = 0;     // of the DAE (8)-(9); -1 when not determined
  int projected_index = 0;           // of the projected DAE (15)-(18); -1 when not determined
  int internal_dynamics_order = 0;   // first-order dimension; -1 when not determined
  bool flat = false;
  ZeroDynamics zero_dynamics;
  SolverMethod recommended_solver = SolverMethod::kAuto;
  // The same bytes as `servokit analyze --format text|json|md`.
  std::string text, json, markdown;
};

/// Classifies `model` at its operating point. Throws UsageError for bad options, NoSolution when
/// there is no operating point or no classification (singular M, Newton does not converge).
Analysis Analyze(const Model& model, const AnalyzeOptions& options = {});

// ---- sweeps ---------------------------------------------------------------------------------

/// `count` values evenly spaced from `first` to `last` (SI), both included, as numpy.linspace;
/// on an axis shown in degrees, evenly spaced in degrees (0deg:90deg:91 takes exactly the values
/// 0 deg, 1 deg, ..., 90 deg).
struct SweepRange {
  double first = 0.0, last = 0.0;
  std::size_t count = 1;
};

/// One varied parameter and its values, in SI units: a list, or a range.
struct SweepAxis {
  SweepAxis() = default;
  /// A list: {"d", {0.0, 0.5, 1.0}}.
  SweepAxis(std::string parameter_name, std::vector<double> parameter_values)
      : parameter(std::move(parameter_name)), values(std::move(parameter_values)) {}

  std::string parameter;
  std::vector<double> values;       // the values in their order; or, when empty, `range`
  std::optional<SweepRange> range;  // used when `values` is empty
  // Shown in degrees (its table column "<name>_deg", its values in degrees); unset: as the model
  // shows the parameter (Model::parameter_display_units()).
  std::optional<bool> degrees;
};

/// One axis written in servokit's grid text (docs/sweep.md, "The grid"): "name=a:b:n" (n values
/// from a to b), "name=a:b:n=N", "name=a:b:step=h" or "name=v1,v2,...", each value a number in
/// SI units or "<number> deg" (an axis with a value in degrees is shown in degrees). `label` is
/// the caller's name for the text and starts every message (the command line: "--vary"): throws
/// UsageError "<label> <text>: <problem>" for a bad text or an unknown parameter. Appends to
/// `warnings` a line for a text that is probably not what was meant: a bare a:b:n that MATLAB
/// would read as start:step:end, or an angle's values without a unit spanning more than a turn.
SweepAxis ParseSweepAxis(const Model& model,
                         const std::string& text,
                         const std::string& label,
                         std::vector<std::string>* warnings = nullptr);
/// ParseSweepAxis for each text, and the checks of the grid over them: a parameter varied twice,
/// more points than a size_t counts, a table column that would clash with another.
std::vector<SweepAxis> ParseSweepAxes(const Model& model,
                                      const std::vector<std::string>& texts,
                                      const std::string& label,
                                      std::vector<std::string>* warnings = nullptr);

/// The warning for the values `low`..`high` (SI) of an angle-like parameter of `model` (shown in
/// degrees, or named alpha, beta, gamma, theta, phi, psi or with "angle" in its name) written
/// without a unit (`has_unit` false) that span more than a full turn (2 pi): radians, maybe meant
/// as degrees. "" when there is none. `label` starts it (the command line: "--vary alpha=0:90").
std::string AngleSpanWarning(const Model& model,
                             const std::string& parameter,
                             bool has_unit,
                             double low,
                             double high,
                             const std::string& label);

struct SweepOptions {
  AnalyzeOptions analysis;  // nonlinear_structure is not used: a sweep classifies only
  int threads = 0;          // 0: all cores; the results do not depend on it
  // Asked on the calling thread after each block of points (4096, or the grid's rest): true
  // stops the sweep there, so that a caller can honour an interrupt (Ctrl-C) within a block.
  // Sweep then returns the points done so far and SweepToFiles writes them. Empty: never stops.
  std::function<bool()> stop_requested;
  // Called on the calling thread after each block with the points done and the grid's total,
  // for a progress bar (Sweep and SweepToFiles). Empty: not called.
  std::function<void(std::size_t done, std::size_t total)> progress;
};

/// One point of a sweep: the class columns of `servokit sweep`'s points.csv.
struct SweepPoint {
  std::vector<double> parameter_values;  // one per axis, in the order of the axes (SI)
  // The same in the unit each parameter is shown in (SweepTableColumns): degrees for a parameter
  // given in degrees (the shortest value that converts back exactly, so "5 deg" gives 5).
  std::vector<double> parameter_display_values;
  bool solved = false;  // false: `error` says why this point has no answer, and the class
  std::string error;    // fields below are their defaults
  Realization realization = Realization::kIdealOrthogonal;
  int P_rank = 0;
  std::vector<int> relative_degree;
  int differentiation_index = 0;
  int internal_dynamics_order = 0;
  Stability stability = Stability::kNone;
  std::vector<std::complex<double>> eigenvalues;
  // The largest real part of `eigenvalues`, NaN when there are none (points.csv's
  // max_real_part), and the frequency and damping ratio of each eigenvalue, in their order
  // (eigenvalues.csv's frequency_hz, damping_ratio; 0 Hz and ratio 1 for a zero eigenvalue).
  double max_real_part = std::numeric_limits<double>::quiet_NaN();
  std::vector<OscillatoryMode> eigenvalue_modes;
};

/// Classifies every point of the full grid over `axes` (the first axis varies slowest), the
/// other parameters at the model's values. A point without an answer is recorded, not thrown.
std::vector<SweepPoint> Sweep(const Model& model,
                              const std::vector<SweepAxis>& axes,
                              const SweepOptions& options = {});

/// The column names of points.csv and eigenvalues.csv for a sweep of `model` over `axes`, as
/// every table format names them: the varied parameters ("<name>_deg" for a parameter shown in
/// degrees), then the fixed columns (eigenvalues.csv's eigenvalue index is "eigenvalue_index").
/// Throws UsageError when a parameter's column would clash with another column.
struct SweepColumns {
  std::vector<std::string> points, eigenvalues;
};
SweepColumns SweepTableColumns(const Model& model, const std::vector<SweepAxis>& axes);

/// The same sweep written to `directory` as points.csv and eigenvalues.csv, byte for byte the
/// tables `servokit sweep --out` writes. Returns the number of points. Throws Error when the
/// files cannot be written. (The command's checkpoints, resumption and sweep.json are the
/// application's: use the command for sweeps that must survive an interruption.)
std::size_t SweepToFiles(const Model& model,
                         const std::vector<SweepAxis>& axes,
                         const std::string& directory,
                         const SweepOptions& options = {});

// ---- sweeps into a directory: durable, resumable, distributed -------------------------------

/// The toolkit's sweep settings: DirectorySweepOptions' defaults, and the most a sweep takes (the
/// one place these numbers are written is the toolkit's sweep engine).
struct SweepSettings {
  int max_threads = 0;         // SweepOptions::threads
  std::size_t block_size = 0;  // points per block
  std::size_t max_block_size = 0;
  double checkpoint_interval = 0.0;  // seconds
};
SweepSettings DefaultSweepSettings();

/// How a DirectorySweep writes (defaults: those of `servokit sweep --out`). None of it changes the
/// bytes of the files.
struct DirectorySweepOptions {
  SweepFileFormat format = SweepFileFormat::kCsv;
  // Points computed in parallel, then written; under MPI block b goes to rank b mod K.
  std::size_t block_size = DefaultSweepSettings().block_size;
  // Seconds between checkpoints (fsync): the most work a crash can lose.
  double checkpoint_interval = DefaultSweepSettings().checkpoint_interval;
  // How the sweep was asked for (the command line), recorded in sweep.json.
  std::vector<std::string> command_line;
  // The caller's names for the directory and the format in messages (the command line: "--out",
  // "--format"), so that an error says what to change where it was written.
  std::string directory_label = "directory";
  std::string format_label = "format";
};

/// A sweep into a directory, as `servokit sweep --out DIR` runs it (docs/sweep.md, "The files"
/// and "Interruption and resume"): points.csv and eigenvalues.csv (or sweep.h5, sweep.mat) with
/// sweep.json, written durably as the points are computed, so that a sweep stopped at any moment
/// (SweepOptions::stop_requested, a crash, SIGKILL) is resumed by the same sweep and its files
/// are the same bytes as those of an uninterrupted one, for any thread or process count.
///
/// In a process started by an MPI launcher with an MpiSession alive, every process of the job
/// constructs, opens and runs the same DirectorySweep (each step is collective: a failure on any
/// process throws on all of them): the blocks are shared out over the processes and rank 0
/// alone writes the directory.
///
///   sk::DirectorySweep sweep(model, sk::ParseSweepAxes(model, {"alpha=0deg:90deg:91"}, "axis"));
///   sweep.Open("alpha-sweep");
///   if (sweep.Run() != sk::DirectorySweep::End::kFinished) ...  // stopped: run it again
class DirectorySweep {
 public:
  /// Checks everything that can be checked before the directory is touched: the axes, the
  /// options (threads 0 on a process of an MPI job: the cores of its machine shared among its
  /// ranks there), the format's column names, and that every process sweeps the same. Throws
  /// UsageError. options.stop_requested is not used: Run takes its own.
  DirectorySweep(const Model& model,
                 const std::vector<SweepAxis>& axes,
                 const SweepOptions& options = {},
                 const DirectorySweepOptions& directory_options = {});
  ~DirectorySweep();
  DirectorySweep(const DirectorySweep&) = delete;
  DirectorySweep& operator=(const DirectorySweep&) = delete;

  /// Opens `directory` (made if missing; locked against another sweep) and finds what it holds:
  /// nothing of this sweep, an unfinished run of it (resumed where its checkpoint says), or all
  /// of it. Throws UsageError when it holds another sweep or another process writes it, Error
  /// when it cannot be written.
  void Open(const std::string& directory);

  std::size_t num_points() const;
  /// After Open: the directory holds this sweep, finished; Run has nothing to do.
  bool already_complete() const;
  /// After Open: the first point Run computes (0, or where an interrupted sweep stopped).
  std::size_t first_point() const;

  enum class End {
    kFinished,         // every point written, the tables finished
    kStopped,          // stopped on request at a block; the checkpoint holds points_done()
    kStoppedInTables,  // every point done, stopped while the table file was built; resumable
  };
  /// Computes the points still missing and finishes the files. Asks `stop_requested` (when
  /// given; on every process of an MPI job, and true on any stops all) after each block and
  /// while it builds a table file; tells `progress` the points done in all after each block
  /// written (rank 0).
  End Run(const std::function<bool()>& stop_requested = {},
          const std::function<void(std::size_t done)>& progress = {});

  /// After Run: the points written (num_points(), or fewer when stopped).
  std::size_t points_done() const;
  /// After Run, on rank 0: the points without a solution (their row holds the error).
  std::size_t points_without_solution() const;
  /// The files of the tables: "points.csv, eigenvalues.csv", "sweep.h5" or "sweep.mat".
  std::string table_file_names() const;

 private:
  struct State;
  std::unique_ptr<State> state_;
};

// ---- processes of an MPI job ----------------------------------------------------------------

/// While alive (constructed at the top of main()), a process started by an MPI launcher (mpirun,
/// srun) is one rank of the job, with MPI initialised through servokit's MPI plugin; started any
/// other way, or in a build without MPI, nothing happens and no MPI library is loaded.
class MpiSession {
 public:
  MpiSession(int& argc, char**& argv);
  ~MpiSession();
  MpiSession(const MpiSession&) = delete;
  MpiSession& operator=(const MpiSession&) = delete;

 private:
  struct State;
  std::unique_ptr<State> state_;
};

/// This process's group (ProcessGroup, base/process_group.h); in a build without MPI started by
/// mpirun, the launcher's numbers, so that only rank 0 prints and DirectorySweep refuses to run.
ProcessGroup Processes();

/// Collective (every process of the group calls it): runs `step`; when it throws on any
/// process, throws on every process an error of the kind of the lowest failing rank's, with its
/// message on rank 0.
void OnEveryProcess(const std::function<void()>& step);

// ---- reports --------------------------------------------------------------------------------

/// The paper's report (docs/report.md) into `directory` (which must exist): report.md and
/// report.html with their figures, from the shipped models in `models_directory`.
void WritePaperReport(const std::string& directory, const std::string& models_directory);

/// A report of `model` (multibody) into `directory` (which must exist): its classification at
/// the operating point of `options`, and the study over `axes` (one axis: the zero dynamics
/// along it; two: the map of the plane). Each axis is classified on its own (no grid checks).
void WriteModelReport(const std::string& directory,
                      const Model& model,
                      const std::vector<SweepAxis>& axes,
                      const AnalyzeOptions& options = {});

/// A finished CSV sweep read back from its directory for its report: sweep.json, the model it
/// names (which must be unchanged: same content hash) and its tables.
class FinishedSweep {
 public:
  /// Throws UsageError naming the file and the problem: no sweep.json ("<label> DIR: no
  /// sweep.json there"; `label` is the caller's name for DIR), not a sweep's record, a sweep not
  /// completed, of a linear model or in HDF5/MAT, its model missing or changed, its tables not
  /// those of its grid.
  static FinishedSweep Read(const std::string& directory,
                            const std::string& label = "sweep directory");
  struct Data;  // inside the library

 private:
  explicit FinishedSweep(std::shared_ptr<const Data> data) : data_(std::move(data)) {}
  friend const Data& Unwrap(const FinishedSweep& sweep);
  std::shared_ptr<const Data> data_;
};

/// The report of `sweep` into `directory` (which must exist), as WriteModelReport of its model,
/// grid and options, with the map coloured from its points.
void WriteSweepReport(const std::string& directory, const FinishedSweep& sweep);

// ---- thresholds -----------------------------------------------------------------------------

/// Where to look for a threshold, and for which change.
struct ThresholdQuery {
  std::string parameter;
  double low = 0.0, high = 0.0;  // SI units
  ThresholdEvent event = ThresholdEvent::kStability;
  AnalyzeOptions analysis;  // the tolerances of each classification
  // How finely [low, high] is scanned before each change is bisected, and the relative width
  // each change is located to; unset: the toolkit's (docs/threshold.md).
  std::optional<int> scan_intervals;
  std::optional<double> relative_tolerance;
  // Also derive the zero dynamics' characteristic polynomial in closed form, with its
  // Routh-Hurwitz conditions (a symbolic derivation at q = 0; skipped when analysis moves the
  // operating point with y0 or q_guess).
  bool closed_form = false;
  // Give each value in degrees too, even for a parameter the model shows in SI units (e.g. a
  // range the caller wrote in degrees).
  bool show_degrees = false;
};

/// One located change: the class goes from `from` to `to` at `value` (SI units).
struct Threshold {
  double value = 0.0;
  std::string from, to;
  std::string via;  // a thin state passed through (e.g. "tangential"), or empty
  // `value` * 180 / pi when the parameter is shown in degrees (Model::parameter_display_units()
  // says "deg": the model file or an override gave it in degrees, or show_degrees), else empty.
  std::optional<double> value_deg;
  double bracket_width = 0.0;  // the change lies within value +- bracket_width / 2
};

/// The toolkit's search settings: what ThresholdQuery's unset fields mean, and the largest scan
/// it takes (the one place these numbers are written is the toolkit's ThresholdOptions).
struct ThresholdSettings {
  int scan_intervals = 0;
  double relative_tolerance = 0.0;
  int max_scan_intervals = 0;
};
ThresholdSettings DefaultThresholdSettings();

/// A threshold search: its changes, its cost and the report `servokit threshold` prints.
struct ThresholdReport {
  std::vector<Threshold> thresholds;  // ascending
  int classifications = 0;            // the points classified (scan and bisection)
  std::string json, text;             // --format json and --format text
};

/// Every threshold in [low, high] with the report of the search. Multibody models only; throws
/// UsageError for a bad query (naming ThresholdQuery's or the search options' field).
ThresholdReport SearchThresholds(const Model& model, const ThresholdQuery& query);

/// Every threshold in [low, high], ascending, each to 1e-12 relative: SearchThresholds'
/// thresholds. Multibody models only.
std::vector<Threshold> LocateThresholds(const Model& model, const ThresholdQuery& query);

// ---- solving --------------------------------------------------------------------------------

/// The desired output y_d(t), one of four kinds (the inverse reads y_d up to order r =
/// differentiation index - 1, and each kind is made smooth enough for it):
///   - rest-to-rest (the default): paper Eq. 65, raised in order when the problem needs more
///     derivatives, from y0 at t0 to yf at tf;
///   - waypoints: the YAML file `waypoint_file`;
///   - samples: y_d at `sample_times` (one row of `sample_values` per time, one column per
///     output), joined by a spline of degree 2k + 1, k = max(4, r), at rest before the first
///     sample and after the last, that keeps within `sample_tolerance` times each output's
///     range of the samples (root mean square) on as few knots as that allows; 0 interpolates
///     (trajectories/sampled_trajectory.h);
///   - a function of the caller's: `function(t, highest, d)` fills d (outputs x (highest + 1))
///     with y_d and its derivatives up to `highest` at t.
/// y0, yf, t0 and tf belong to rest-to-rest only.
struct OutputTrajectory {
  Eigen::VectorXd y0, yf;  // one value per output
  double t0 = 0.0, tf = 1.0;
  std::string waypoint_file;  // when set, the trajectory is this file
  std::vector<double> sample_times;
  Eigen::MatrixXd sample_values;
  double sample_tolerance = 1e-10;        // relative to each output's range; 0: interpolate
  std::string sample_source = "samples";  // names the samples in messages (e.g. their file)
  std::function<void(double t, int highest, Eigen::MatrixXd& derivatives)> function;
  int function_outputs = 1;
  // How many derivatives of `function` are continuous; 0 means as many as the inverse reads.
  int function_continuous_derivatives = 0;
  // Where a derivative of `function` above those jumps, increasing; the first is where the
  // solve starts by default (the start of the motion). Must not be empty.
  std::vector<double> function_breakpoints;
};

/// How to solve (defaults: those of `servokit solve`; an unset value is the method's default).
struct SolveOptions {
  SolverMethod method = SolverMethod::kAuto;
  bool force = false;  // integrate unstable internal dynamics forward anyway
  std::optional<double> t_start;
  double t_end = 0.0;
  std::optional<double> step, rtol, atol, sample_time, pre_actuation, post_actuation;
  // Newton's start for q at the operating point the solve is classified (and, for the
  // linearized inverse, linearized) at: the equilibrium holding y_d at the motion's start
  // (default start: the model file's q0, else q = 0), one value per coordinate. A closed chain
  // in absolute coordinates may need one on its loops (a crane's load below its trolley).
  std::optional<Eigen::VectorXd> q_guess;
  // Drive the model with u_d from rest and compare its output with y_d (the forward check).
  bool verify = false;
  // When set, the feedforward is written to this file as `servokit solve --out` writes it, in
  // file_format (CSV by default: t, each coordinate, each <coordinate>_dot, each input, y1_d,
  // ...), and `json` names it. Written also when the solve stops early or
  // fails its check, with the rows up to where it stopped.
  std::string out_file;
  // The format of out_file: CSV, MAT (v5, for MATLAB and scipy.io.loadmat: a column vector per
  // CSV column and the struct `solve` of the summary) or Modelica (the CombiTimeTable `u_d` of
  // t and the inputs). Unset: from the name, MAT for a name ending in .mat, else CSV. A name of
  // the other format's ending (.mat for CSV or Modelica, .csv for Modelica, anything but .mat
  // for MAT) is a UsageError, as is a model whose columns are not MATLAB names for MAT; both
  // are checked before solving.
  std::optional<SolveFileFormat> file_format;
};

/// The forward check of a solve (docs/solve.md, "--verify"): u_d drives the model from the
/// solution's start, and its output must stay within `bound` of y_d.
struct Verification {
  bool passed = false;
  double max_tracking_error = 0.0;
  double time_of_max_error = std::numeric_limits<double>::quiet_NaN();
  // A closed chain's max |c(q)| along the forward runs (held to the bound too); unset for an
  // open chain.
  std::optional<double> max_constraint_violation;
  // Where the solve stopped when it stopped before t_end: the check covers the span up to there
  // only and does not pass. Unset when the solve reached t_end.
  std::optional<double> solve_stopped_at;
  // The method `linearized` on a plant whose check restarts: the error of the restarted
  // (segmented) runs, beside max_tracking_error, which is then one open-loop run's over the
  // whole span and decides. Unset otherwise.
  std::optional<double> segmented_tracking_error;
  double bound = 0.0;
  std::string bound_rule;  // how the bound follows from the solve's tolerances
  // How the forward runs went: one run, or restarts from the solution's state at the start of
  // each of `segments` segments (an unstable plant).
  int segments = 1;
  SolveStatus status = SolveStatus::kConverged;
  std::string message;
  long steps = 0;
  // The forward runs' output h(q) at each of their steps (rows of y: times; columns: outputs);
  // where the check restarts on an unstable plant, a segment's first time repeats the last.
  std::vector<double> t;
  Eigen::MatrixXd y;
};

/// Stable inversion's window (paper Sect. 5.3): where the feedforward starts before the motion
/// (pre-actuation) and ends after it (post-actuation).
struct ActuationWindow {
  double start = 0.0, end = 0.0;  // the span the boundary value problem was solved on
  double pre_actuation_start = 0.0, post_actuation_end = 0.0;
  int widenings = 0;                     // how often the window was widened to converge
  double boundary_value_residual = 0.0;  // of the collocation solution
  long mesh_points = 0;
};

/// How a solve went (style: Ceres' Solver::Summary): what `servokit solve` prints, as values.
struct SolveSummary {
  SolverMethod method = SolverMethod::kAuto;  // the method that ran
  std::string method_reason;                  // why it was chosen
  // kConverged, or why the solve stopped (kVerificationFailed: it converged but failed its
  // forward check, so its answer is not within its tolerances).
  SolveStatus status = SolveStatus::kIntegratorFailure;
  std::string message;
  double stop_time = std::numeric_limits<double>::quiet_NaN();
  double t_start = std::numeric_limits<double>::quiet_NaN();
  double t_end = std::numeric_limits<double>::quiet_NaN();
  std::optional<double> sample_time;
  double rtol = std::numeric_limits<double>::quiet_NaN();
  double atol = std::numeric_limits<double>::quiet_NaN();
  std::optional<double> step;
  long steps = 0, rejected_steps = 0, newton_iterations = 0, function_evaluations = 0;
  std::size_t samples = 0;
  double max_servo_residual = std::numeric_limits<double>::quiet_NaN();
  std::optional<ActuationWindow> window;  // stable inversion only
  std::string trajectory_note;            // how y_d was made smooth enough, when it was
  Analysis classification;                // at the operating point the solve started from
  // The time whose y_d that operating point holds: the solve's start (t_start, else the first
  // breakpoint of y_d).
  double operating_point_time = std::numeric_limits<double>::quiet_NaN();
  std::optional<Verification> verification;
  std::vector<std::string> warnings;
  std::string out_file;  // the feedforward's file, empty when none was written
  // These values (and a few more: each tolerance's source, the verification's start state) as
  // the JSON object `servokit solve` prints (docs/solve.md).
  std::string json;
};

/// The feedforward u_d(t) and motion q_d(t): one row per time.
struct Feedforward {
  SolveSummary summary;
  bool usable = false;  // converged, and passed the check when one was asked for
  std::vector<double> t;
  Eigen::MatrixXd q, q_dot, u, y_d;  // rows: times; columns: coordinates, inputs, outputs
  // A closed chain's multipliers lambda_d (columns: constraints; C^T lambda_d hold its loops
  // closed along the motion); no columns for an open chain.
  Eigen::MatrixXd multipliers;
  Eigen::MatrixXd y;  // h(q_d(t)), the output of the motion, like y_d
  // Where the desired output's motion starts and ends (the trajectory's breakpoints: t0 and tf
  // of rest-to-rest, each waypoint, the first and last sample), increasing.
  std::vector<double> breakpoints;
  std::vector<std::string> notes;
};

/// The JSON array `servokit solve --method a,b` prints: each summary's object, in order.
std::string SolveSummariesJson(const std::vector<SolveSummary>& summaries);

/// The summary told in a few lines (`servokit solve --summary text`): method, status, steps,
/// residual, the forward check, pre- and post-actuation, warnings and the file.
std::string SolveSummaryText(const SolveSummary& summary);

/// Draws the figures of `solves` of `model` (one curve per solve; each must have rows) into
/// `directory` as `servokit solve --plot` does: u_d, q_d, y_d against the motion's output (the
/// forward check's where it ran), as PNG and PDF with their gnuplot scripts and data.
void DrawSolveFigures(const std::string& directory,
                      const Model& model,
                      const std::vector<const Feedforward*>& solves);

// ---- files ----------------------------------------------------------------------------------

/// The samples of a desired output read from a CSV file (t, then one column per output) into
/// `trajectory` (sample_times, sample_values, sample_source). Throws ModelError "file:line:
/// problem".
void ReadSamplesFile(const std::string& path, OutputTrajectory& trajectory);

/// The same, its columns matched to `model`'s outputs: by name where the header names any of
/// them (y1, or y1_d as a solve file writes it; other columns are left out), else by position.
/// Blanks around fields, a pandas index column and a time column named t anywhere are read as
/// such. Throws ModelError naming the file and the output without a column.
void ReadSamplesFile(const std::string& path, const Model& model, OutputTrajectory& trajectory);

/// The format a solve file's name asks for when none is given: MAT for a name ending in .mat
/// (any case), else CSV.
SolveFileFormat SolveFileFormatOfName(const std::string& path);
/// Why `path` cannot hold a solve file of `format` (a name of another format's ending), or
/// nullopt.
std::optional<std::string> SolveFileNameProblem(const std::string& path, SolveFileFormat format);

/// Refuses `path` as the name of an output before any work is done: throws UsageError naming it
/// when it is empty, a link, a directory, a FIFO, socket or device, or a file read as an input.
void CheckOutputPath(const std::string& path);

/// Solves the inverse model of `model` (multibody) for `trajectory`. Throws UsageError for bad
/// options, NoSolution when the method refuses the problem; a solve that stops early returns
/// with usable false and the rows up to there.
Feedforward Solve(const Model& model,
                  const OutputTrajectory& trajectory,
                  const SolveOptions& options);

// ---- large linear models --------------------------------------------------------------------

/// A chain of point masses joined by springs and dampers, a force on one mass, the position of
/// one mass as output.
struct ChainModel {
  long masses = DefaultChainModel().masses;
  double mass = DefaultChainModel().mass;            // kg
  double stiffness = DefaultChainModel().stiffness;  // N/m
  double damping = DefaultChainModel().damping;      // N s/m
  long input_mass = DefaultChainModel().input_mass;  // 1..masses
  // 1..masses (only with output_weights kMass)
  long output_mass = DefaultChainModel().output_mass;
  // The output y: the position of output_mass, sum of (i/N) q_i over every mass (kLinear) or
  // the mean position, sum of q_i / N (kUniform).
  ChainOutputWeights output_weights = DefaultChainModel().output_weights;
  // Close the chain into a ring, mass N rigidly joined back to mass 1 (q_N = q_1: a closed
  // chain with one loop constraint); the file is then ring_N.
  bool closed = DefaultChainModel().closed;
  /// Throws OptionError naming the field, its value and the rule it breaks (Generate checks
  /// the same before it writes anything).
  void Validate() const;
};

/// A hub-driven Euler-Bernoulli beam in finite elements, tip position as output.
struct BeamModel {
  long elements = DefaultBeamModel().elements;
  double length = DefaultBeamModel().length;                        // m
  double hub_inertia = DefaultBeamModel().hub_inertia;              // kg m^2
  double mass_per_length = DefaultBeamModel().mass_per_length;      // kg/m
  double bending_stiffness = DefaultBeamModel().bending_stiffness;  // N m^2
  double damping_factor = DefaultBeamModel().damping_factor;        // beta in D = beta K, s
  void Validate() const;                                            // as ChainModel::Validate
};

/// Writes the model (YAML and its Matrix Market files) into `directory` (made if missing) and
/// returns the YAML file's path, as `servokit generate chain|beam` does. `name` is the model's
/// name and file stem (default chain_N, beam_N). Throws UsageError for a bad size or name.
std::string Generate(const ChainModel& chain,
                     const std::string& directory,
                     const std::string& name = "");
std::string Generate(const BeamModel& beam,
                     const std::string& directory,
                     const std::string& name = "");

}  // namespace servokit::api
