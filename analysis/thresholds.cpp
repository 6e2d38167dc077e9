#include "analysis/thresholds.h"

#include <gsl/gsl_errno.h>
#include <gsl/gsl_min.h>
#include <gsl/gsl_roots.h>

#include <algorithm>
#include <cmath>
#include <complex>
#include <functional>
#include <limits>
#include <memory>
#include <optional>
#include <sstream>
#include <string>

#include "analysis/classification.h"
#include "analysis/zero_dynamics.h"
#include "base/errors.h"
#include "base/option_check.h"
#include "numerics/gsl_support.h"

namespace servokit {
namespace {

// The state an event watches at one parameter value: `key` decides equality, `label` is what
// the user reads. Between two values of equal state the continuous indicators tell where a
// state may hold at one point only (an isolated point: P passing through or touching zero,
// B orthogonal to the constraint manifold at one angle, a Markov parameter vanishing):
//  - `crossing`: quantities that vanish with sign change at such a point (entries of P, of the
//    part of B in the tangent space, of the leading Markov parameters);
//  - `touching`: quantities >= 0 that reach 0 there (singular values of P, |D^T B| / |B|, the
//    smallest damping ratio), in units of the tolerance that decides the state: at most 1
//    means that the classification counts it as zero.
// Both are compared only between values of equal key, where they mean the same.
struct State {
  std::string key;
  std::string label;
  std::vector<double> crossing;
  std::vector<double> touching;
};

State NoSolutionState() { return {"no-solution", "no-solution", {}, {}}; }

// The smallest of |part of lambda| / (the size at which SideOfImaginaryAxis counts it as 0)
// over `eigenvalues` (the real part for stability, the imaginary part of the upper members of
// complex pairs for oscillation); empty when there is none.
std::vector<double> SmallestPartInTolerances(const std::vector<std::complex<double>>& eigenvalues,
                                             double tolerance,
                                             bool imaginary) {
  const double scale = SpectrumScale(eigenvalues);
  std::optional<double> smallest;
  for (const auto& eigenvalue : eigenvalues) {
    if (imaginary && eigenvalue.imag() <= 0.0) continue;
    const double part = imaginary ? eigenvalue.imag() : eigenvalue.real();
    const double zero_size =
        std::max(tolerance * std::abs(eigenvalue), kZeroEigenvalueFloor * scale);
    const double ratio = zero_size > 0.0 ? std::abs(part) / zero_size : 0.0;
    smallest = smallest ? std::min(*smallest, ratio) : ratio;
  }
  return smallest ? std::vector<double>{*smallest} : std::vector<double>{};
}

State StabilityState(const Classification& c, double axis_tolerance) {
  const auto& eigenvalues = c.zero_dynamics.eigenvalues;
  const int right_half_plane = CountRightHalfPlane(eigenvalues, axis_tolerance);
  const double scale = SpectrumScale(eigenvalues);
  int on_axis = 0;
  for (const auto& eigenvalue : eigenvalues) {
    if (SideOfImaginaryAxis(eigenvalue, scale, axis_tolerance) == AxisSide::kOn) ++on_axis;
  }
  std::string label(ToString(c.zero_dynamics.stability));
  // An unstable spectrum with eigenvalues on the axis is a state of its own: it is what an
  // eigenvalue passes through on its way from one half plane to the other.
  if (right_half_plane > 1 || (right_half_plane > 0 && on_axis > 0)) {
    label += " (" + std::to_string(right_half_plane) + " unstable";
    if (on_axis > 0) label += ", " + std::to_string(on_axis) + " on the imaginary axis";
    label += ")";
  }
  return {label, label, {}, SmallestPartInTolerances(eigenvalues, axis_tolerance, false)};
}

State OscillationState(const Classification& c, double axis_tolerance) {
  const std::size_t pairs = c.zero_dynamics.modes.size();
  const std::string label = pairs == 0   ? "non-oscillatory"
                            : pairs == 1 ? "oscillatory (1 mode)"
                                         : "oscillatory (" + std::to_string(pairs) + " modes)";
  return {label,
          label,
          {},
          SmallestPartInTolerances(c.zero_dynamics.eigenvalues, axis_tolerance, true)};
}

void AppendEntries(const Eigen::MatrixXd& matrix, double scale, std::vector<double>& out) {
  for (Eigen::Index j = 0; j < matrix.cols(); ++j) {
    for (Eigen::Index i = 0; i < matrix.rows(); ++i) {
      out.push_back(scale > 0.0 ? matrix(i, j) / scale : 0.0);
    }
  }
}

State RealizationState(const Classification& c, double rank_tolerance) {
  const DecouplingAnalysis& decoupling = c.decoupling;
  std::string label(ToString(decoupling.realization));
  std::string key = label + " rank " + std::to_string(decoupling.rank);
  if (decoupling.rank == decoupling.decoupling_matrix.rows()) {
    // The sign of det P tells the two sides of a place where P passes through zero apart.
    key += decoupling.decoupling_matrix.determinant() > 0 ? " +" : " -";
  } else if (decoupling.rank > 0) {
    label += " (rank " + std::to_string(decoupling.rank) + ")";
  }
  State state{key, label, {}, {}};
  // P relative to |H| |M^-1 B| (its rank test's scale), and the part of B in the tangent space
  // of the constraint manifold, D D^T B / |B| (zero exactly where the realization is ideal).
  const double p_scale = decoupling.rank_threshold / rank_tolerance;
  AppendEntries(decoupling.decoupling_matrix, p_scale, state.crossing);
  const Eigen::MatrixXd& input_matrix = c.linearization.input_matrix;
  AppendEntries(decoupling.tangent_basis * (decoupling.tangent_basis.transpose() * input_matrix),
                input_matrix.norm(), state.crossing);
  for (Eigen::Index i = 0; i < decoupling.singular_values.size(); ++i) {
    state.touching.push_back(decoupling.rank_threshold > 0.0
                                 ? decoupling.singular_values(i) / decoupling.rank_threshold
                                 : 0.0);
  }
  state.touching.push_back(decoupling.tangential_input_share / rank_tolerance);
  return state;
}

std::string JoinNumbers(const std::vector<int>& numbers) {
  std::string text;
  for (const int number : numbers) text += (text.empty() ? "" : ", ") + std::to_string(number);
  return numbers.size() == 1 ? text : "(" + text + ")";
}

State StructureState(const Classification& c) {
  const OutputStructure& structure = c.structure;
  std::string label =
      (structure.relative_degree.size() == 1 ? "relative degree " : "relative degrees ") +
      JoinNumbers(structure.relative_degree) + ", index " +
      std::to_string(structure.differentiation_index);
  std::vector<int> orders = structure.infinite_zero_orders;
  std::vector<int> sorted_degrees = structure.relative_degree;
  std::sort(sorted_degrees.begin(), sorted_degrees.end());
  if (orders != sorted_degrees) label += ", infinite zeros " + JoinNumbers(orders);
  State state{label, label, {}, {}};
  // The rows C_i A^(r_i - 1) B: where one vanishes at a point, r_i grows there.
  AppendEntries(structure.decoupling_matrix, structure.decoupling_matrix.norm(), state.crossing);
  return state;
}

class StateProbe {
 public:
  StateProbe(const Model& model,
             std::size_t parameter,
             ThresholdEvent event,
             const ThresholdOptions& options)
      : model_(model), workspace_(model), parameter_(parameter), event_(event), options_(options) {
    options_.classification.cross_check = false;
    if (options_.parameters.size() > 0) workspace_.parameters = options_.parameters;
  }

  State At(double value) {
    ++classifications_;
    workspace_.parameters(Eigen::Index(parameter_)) = value;
    // A point without a solution is a state of its own (e.g. no equilibrium).
    try {
      return StateOf(Classify(model_, workspace_, options_.classification));
    } catch (const NoSolution&) {
      return NoSolutionState();
    }
  }

  // det P at `value`, or NaN where there is no solution.
  double DecouplingDeterminant(double value) {
    ++classifications_;
    workspace_.parameters(Eigen::Index(parameter_)) = value;
    try {
      return Classify(model_, workspace_, options_.classification)
          .decoupling.decoupling_matrix.determinant();
    } catch (const NoSolution&) {
      return std::numeric_limits<double>::quiet_NaN();
    }
  }

  int classifications() const { return classifications_; }

 private:
  State StateOf(const Classification& c) const {
    const ClassificationOptions& options = options_.classification;
    switch (event_) {
      case ThresholdEvent::kStability:
        return StabilityState(c, options.imaginary_axis_tolerance);
      case ThresholdEvent::kOscillation:
        return OscillationState(c, options.imaginary_axis_tolerance);
      case ThresholdEvent::kRealization:
        return RealizationState(c, options.rank_tolerance);
      case ThresholdEvent::kStructure:
        return StructureState(c);
    }
    return NoSolutionState();
  }

  const Model& model_;
  Workspace workspace_;
  std::size_t parameter_;
  ThresholdEvent event_;
  ThresholdOptions options_;
  int classifications_ = 0;
};

// An event's final bracket: the change happens in [lower, upper].
struct Located {
  double lower = 0.0, upper = 0.0;
  std::string from, to, via;
};

// The boundary in [left, right] where `holds` stops being true (true at left, false at
// right), by GSL's bisection solver, to `tolerance` relative to max(1, |x|).
std::pair<double, double> Bisect(const std::function<bool(double)>& holds,
                                 double left,
                                 double right,
                                 double tolerance) {
  const auto bracket = NarrowBracket(
      gsl_root_fsolver_bisection, [&](double x) { return holds(x) ? -1.0 : 1.0; }, left, right,
      tolerance, tolerance);
  if (!bracket) throw std::runtime_error("bisection: the states at the bracket's ends agree");
  return {bracket->lower, bracket->upper};
}

// Every change of state between `left` and `right`, whose states differ.
void LocateChanges(StateProbe& probe,
                   double left,
                   double right,
                   State left_state,
                   const State& right_state,
                   double tolerance,
                   std::vector<Located>& events) {
  while (left_state.key != right_state.key) {
    const std::string key = left_state.key;
    const auto [lower, upper] =
        Bisect([&](double x) { return probe.At(x).key == key; }, left, right, tolerance);
    const State after = probe.At(upper);
    events.push_back({lower, upper, left_state.label, after.label, ""});
    left = upper;
    left_state = after;
  }
}

// A point of [left, right] where touching indicator `index` is smallest, by GSL's Brent
// minimizer, given f(left) <= f(right): a middle point below both ends is looked for by
// halving towards `left` first (the minimum may lie between the left end and the first
// midpoint). nullopt when there is none (the indicator grows from `left`).
std::optional<double> SmallestNear(
    StateProbe& probe, std::size_t index, double left, double right, double tolerance) {
  auto indicator = [&](double x) {
    const State state = probe.At(x);
    return index < state.touching.size() ? state.touching[index]
                                         : std::numeric_limits<double>::quiet_NaN();
  };
  const double at_left = indicator(left), at_right = indicator(right);
  double middle = right, at_middle = at_right;
  constexpr int kMaxHalvings = 60;
  for (int i = 0; i < kMaxHalvings && !(at_middle < at_left && at_middle < at_right); ++i) {
    middle = left + 0.5 * (middle - left);
    if (std::abs(middle - left) <= tolerance * std::max(1.0, std::abs(left))) return std::nullopt;
    at_middle = indicator(middle);
    if (!std::isfinite(at_middle)) return std::nullopt;
  }
  if (!(at_middle < at_left && at_middle < at_right)) return std::nullopt;
  using Function = std::function<double(double)>;
  Function function = indicator;
  gsl_function adapter{
      [](double x, void* data) { return (*static_cast<const Function*>(data))(x); }, &function};
  std::unique_ptr<gsl_min_fminimizer, void (*)(gsl_min_fminimizer*)> minimizer(
      gsl_min_fminimizer_alloc(gsl_min_fminimizer_brent), gsl_min_fminimizer_free);
  const double lower = std::min(left, right), upper = std::max(left, right);
  if (!minimizer ||
      gsl_min_fminimizer_set_with_values(minimizer.get(), &adapter, middle, at_middle, lower,
                                         left < right ? at_left : at_right, upper,
                                         left < right ? at_right : at_left) != GSL_SUCCESS) {
    return std::nullopt;
  }
  // The minimizer only needs to land inside the band where the indicator is at most 1 (the
  // band's edges are then found by bisection on the state): it stops there, or at sqrt(eps),
  // the best a minimizer can locate a minimum to.
  constexpr int kMaxIterations = 100;
  constexpr double kMinimizerTolerance = 1.5e-8;
  for (int i = 0; i < kMaxIterations; ++i) {
    if (gsl_min_fminimizer_f_minimum(minimizer.get()) <= 1.0) break;
    if (gsl_min_fminimizer_iterate(minimizer.get()) != GSL_SUCCESS) break;
    if (gsl_min_test_interval(gsl_min_fminimizer_x_lower(minimizer.get()),
                              gsl_min_fminimizer_x_upper(minimizer.get()), 0.0,
                              kMinimizerTolerance) == GSL_SUCCESS) {
      break;
    }
  }
  return gsl_min_fminimizer_x_minimum(minimizer.get());
}

// The band around `inside` (whose state differs from `state`, the state at both `left` and
// `right`) where the state is not `state`: one event that passes through it.
Located IsolatedBand(StateProbe& probe,
                     double left,
                     double inside,
                     double right,
                     const State& state,
                     const State& thin,
                     double tolerance) {
  // The band's outer ends: the lower end of the bracket of its first edge, the upper end of
  // the bracket of its last.
  auto differs = [&](double x) { return probe.At(x).key != state.key; };
  const double lower = Bisect([&](double x) { return !differs(x); }, left, inside, tolerance).first;
  const double upper = Bisect(differs, inside, right, tolerance).second;
  return {lower, upper, state.label, state.label, thin.label};
}

// An isolated point between two scan values of equal state, from a crossing indicator that
// changes sign there: its zero by GSL's Brent solver. The state at the zero must differ.
std::optional<Located> FindCrossing(StateProbe& probe,
                                    double left,
                                    double right,
                                    const State& state,
                                    std::size_t index,
                                    double tolerance) {
  // Where the state differs, the point sought is found: 0 ends the search there.
  auto indicator = [&](double x) {
    const State at = probe.At(x);
    if (at.key != state.key) return 0.0;
    return index < at.crossing.size() ? at.crossing[index]
                                      : std::numeric_limits<double>::quiet_NaN();
  };
  const auto bracket =
      NarrowBracket(gsl_root_fsolver_brent, indicator, left, right, tolerance, tolerance);
  if (!bracket) return std::nullopt;
  const State at_root = probe.At(bracket->root);
  if (at_root.key == state.key) return std::nullopt;
  // The state holds in a band around the zero (the classification's tolerance): the event is
  // the band, which contains the zero.
  return IsolatedBand(probe, left, bracket->root, right, state, at_root, tolerance);
}

// An isolated point near `node` (a local minimum of touching indicator `index` among scan
// values of one state): the indicator's minimum by GSL's Brent minimizer; an event if the
// state differs there.
std::optional<Located> FindTouch(StateProbe& probe,
                                 double left,
                                 double node,
                                 double right,
                                 const State& state,
                                 std::size_t index,
                                 double tolerance) {
  // The minimum lies on one side of the node: the first side with a point below the node.
  for (const double far : {left, right}) {
    if (far == node) continue;
    const std::optional<double> smallest = SmallestNear(probe, index, node, far, tolerance);
    if (!smallest) continue;
    const State thin = probe.At(*smallest);
    if (thin.key == state.key) return std::nullopt;
    return IsolatedBand(probe, std::min(left, *smallest), *smallest, std::max(right, *smallest),
                        state, thin, tolerance);
  }
  return std::nullopt;
}

// Looks between scan values of equal state for isolated points (see State).
void LocateIsolatedPoints(StateProbe& probe,
                          const std::vector<double>& values,
                          const std::vector<State>& states,
                          double tolerance,
                          std::vector<Located>& events) {
  const std::size_t n = values.size();
  auto same = [&](std::size_t i, std::size_t j) {
    return states[i].key == states[j].key &&
           states[i].crossing.size() == states[j].crossing.size() &&
           states[i].touching.size() == states[j].touching.size();
  };
  std::vector<bool> found(n, false);  // an isolated point already found next to node i
  for (std::size_t i = 0; i + 1 < n; ++i) {
    if (!same(i, i + 1)) continue;
    for (std::size_t j = 0; j < states[i].crossing.size(); ++j) {
      const double a = states[i].crossing[j], b = states[i + 1].crossing[j];
      if (!(a * b < 0.0)) continue;
      if (auto event = FindCrossing(probe, values[i], values[i + 1], states[i], j, tolerance)) {
        events.push_back(*event);
        found[i] = found[i + 1] = true;
        break;
      }
    }
  }
  for (std::size_t i = 0; i < n; ++i) {
    if (found[i]) continue;
    const bool has_left = i > 0 && same(i - 1, i);
    const bool has_right = i + 1 < n && same(i, i + 1);
    if (!has_left && !has_right) continue;
    for (std::size_t j = 0; j < states[i].touching.size(); ++j) {
      const double here = states[i].touching[j];
      // At most 1: the state already counts it as zero at this value, so nothing is hidden.
      if (!(here > 1.0)) continue;
      const double before = has_left ? states[i - 1].touching[j] : HUGE_VAL;
      const double after = has_right ? states[i + 1].touching[j] : HUGE_VAL;
      // A local minimum of the sampled indicator, by more than round-off on the right (ties
      // to the left count, so that a minimum halfway between two values is seen once; a
      // plateau with round-off ripples, such as the damping ratio 1 of real eigenvalues, is
      // none).
      constexpr double kSignificantDrop = 1e-9;
      if (!(here <= before * (1.0 + kSignificantDrop) && here < after * (1.0 - kSignificantDrop))) {
        continue;
      }
      const double left = has_left ? values[i - 1] : values[i];
      const double right = has_right ? values[i + 1] : values[i];
      if (auto event = FindTouch(probe, left, values[i], right, states[i], j, tolerance)) {
        events.push_back(*event);
        break;
      }
    }
  }
}

// Whether the state on (start, end) holds at one point only, widened to a band by the
// tolerances: a touching indicator that the band's middle counts as zero (at most 1) rises
// towards the band's edges (above kRiseFraction at a quarter of its width; a state that holds
// on an interval keeps it at round-off, 1e-6 or less, throughout).
bool IsPointBand(StateProbe& probe, double start, double end) {
  constexpr double kRiseFraction = 0.05;
  const State middle = probe.At(0.5 * (start + end));
  const State quarter = probe.At(start + 0.25 * (end - start));
  const State three_quarters = probe.At(start + 0.75 * (end - start));
  if (quarter.key != middle.key || three_quarters.key != middle.key) return false;
  for (std::size_t j = 0; j < middle.touching.size(); ++j) {
    if (j >= quarter.touching.size() || j >= three_quarters.touching.size()) break;
    if (middle.touching[j] <= 1.0 &&
        std::max(quarter.touching[j], three_quarters.touching[j]) >= kRiseFraction) {
      return true;
    }
  }
  return false;
}

// Two events A -> T -> B are one passing through T when T holds at one point only: when they
// are closer than `merge_tolerance` (relative), or when T's interval is a point band.
bool PassesThroughPoint(StateProbe& probe,
                        const Located& into,
                        const Located& out_of,
                        double merge_tolerance) {
  if (out_of.lower - into.upper <=
      merge_tolerance * std::max(1.0, std::max(std::abs(into.upper), std::abs(out_of.lower)))) {
    return true;
  }
  return IsPointBand(probe, into.upper, out_of.lower);
}

// A point band at an end of the range (the arm's ideal realization at s = 0 only, on s = 0:1)
// holds the event's true place anywhere in it, not only at its edge: the event's bracket
// takes the band in.
void TakeInEndBands(StateProbe& probe, double low, double high, std::vector<Located>& events) {
  if (events.empty()) return;
  Located& first = events.front();
  if (first.lower > low && IsPointBand(probe, low, first.lower)) first.lower = low;
  Located& last = events.back();
  if (last.upper < high && IsPointBand(probe, last.upper, high)) last.upper = high;
}

// Events that pass through a point become one whose `via` names the states passed through.
std::vector<Located> MergeThroughPoints(StateProbe& probe,
                                        const std::vector<Located>& events,
                                        double merge_tolerance) {
  std::vector<Located> merged;
  for (const Located& event : events) {
    if (!merged.empty() && merged.back().to == event.from &&
        PassesThroughPoint(probe, merged.back(), event, merge_tolerance)) {
      Located& last = merged.back();
      last.via += (last.via.empty() ? "" : ", ") + event.from;
      last.to = event.to;
      last.upper = event.upper;
      continue;
    }
    merged.push_back(event);
  }
  return merged;
}

// An event located by bisection on the state is only as sharp as the classification's rank
// band (P counts as zero within rank_tolerance of its scale). Where det P changes sign across
// the event, the exact place is the zero of det P: a realization change through P = 0, or a
// zero-dynamics eigenvalue leaving through infinity (the rotational arm at s/l = 2/3, where
// the leading coefficient of Eq. (56) vanishes with P). GSL's Brent solver finds it.
void RefineThroughSingularDecoupling(StateProbe& probe,
                                     double tolerance,
                                     double search_width,
                                     Located& event) {
  const double middle = 0.5 * (event.lower + event.upper);
  const double width =
      std::max(event.upper - event.lower, search_width * std::max(1.0, std::abs(middle)));
  const double left = middle - width, right = middle + width;
  const double at_left = probe.DecouplingDeterminant(left);
  const double at_right = probe.DecouplingDeterminant(right);
  if (!(std::isfinite(at_left) && std::isfinite(at_right)) || at_left * at_right >= 0.0) return;
  const auto bracket = NarrowBracket(
      gsl_root_fsolver_brent, [&](double x) { return probe.DecouplingDeterminant(x); }, left, right,
      tolerance, tolerance);
  if (bracket && bracket->converged) {
    event.lower = bracket->lower;
    event.upper = bracket->upper;
  }
}

// The reported value and precision of a bracket: its middle, or 0 when it contains 0 (a
// threshold at exactly 0 is reported as 0, not as round-off beside it); the width of the
// interval centred at the value that holds the bracket, so that value +- width / 2 contains
// the event, and never less than the requested tolerance (a solver that hits a zero of its
// function exactly returns an empty bracket, but that zero carries the function's round-off).
ThresholdCrossing Report(const Located& event, double tolerance) {
  const double value = event.lower <= 0.0 && event.upper >= 0.0
                           ? 0.0
                           : event.lower + 0.5 * (event.upper - event.lower);
  const double width = std::max(2.0 * std::max(value - event.lower, event.upper - value),
                                tolerance * std::max(1.0, std::abs(value)));
  return {value, width, event.from, event.to, event.via};
}

}  // namespace

void ThresholdOptions::Validate(const Model& model) const {
  classification.Validate(model);
  constexpr const char* kOwner = "ThresholdOptions";
  RequireOption(scan_intervals >= 1, kOwner, "scan_intervals", scan_intervals, "must be >= 1");
  RequireOption(scan_intervals <= kMaxScanIntervals, kOwner, "scan_intervals", scan_intervals,
                "must be <= " + std::to_string(kMaxScanIntervals));
  RequireOption(relative_tolerance > 0.0 && relative_tolerance < 1.0, kOwner, "relative_tolerance",
                relative_tolerance, "must be > 0 and < 1");
  RequireOption(merge_tolerance >= 0.0, kOwner, "merge_tolerance", merge_tolerance, "must be >= 0");
  const auto count = static_cast<Eigen::Index>(model.num_parameters());
  RequireOption(parameters.size() == 0 || (parameters.size() == count && parameters.allFinite()),
                kOwner, "parameters", parameters,
                "must be empty or hold " + std::to_string(count) + " finite values");
}

ThresholdSearch FindThresholds(const Model& model,
                               std::size_t parameter,
                               double low,
                               double high,
                               ThresholdEvent event,
                               const ThresholdOptions& options) {
  options.Validate(model);
  if (parameter >= model.num_parameters()) throw UsageError("no such parameter index");
  if (!(std::isfinite(low) && std::isfinite(high) && low < high)) {
    throw UsageError("the range " + FormatNumber(low) + ":" + FormatNumber(high) + " of " +
                     model.parameter_names()[parameter] + " must be finite with low < high");
  }
  // Bisection and the merging of events add two values of the range: beyond half the largest
  // double that sum overflows (a null "value" in JSON, or GSL's "floating point overflow").
  constexpr double kLargestEndpoint = 0.5 * std::numeric_limits<double>::max();
  if (std::abs(low) > kLargestEndpoint || std::abs(high) > kLargestEndpoint) {
    std::ostringstream message;
    message << "the range " << low << ":" << high << " of " << model.parameter_names()[parameter]
            << " must lie within +-" << kLargestEndpoint
            << " (half the largest double), so that its midpoints do not overflow";
    throw UsageError(message.str());
  }
  UseGslStatusCodes();  // for the minimizer of FindTouch

  ThresholdSearch search;
  search.parameter = model.parameter_names()[parameter];
  search.event = event;
  search.low = low;
  search.high = high;
  StateProbe probe(model, parameter, event, options);
  const double tolerance = options.relative_tolerance;
  std::vector<double> values;
  std::vector<State> states;
  for (int i = 0; i <= options.scan_intervals; ++i) {
    values.push_back(i == options.scan_intervals
                         ? high
                         : low + (high - low) * double(i) / double(options.scan_intervals));
    states.push_back(probe.At(values.back()));
  }
  std::vector<Located> events;
  for (std::size_t i = 0; i + 1 < values.size(); ++i) {
    LocateChanges(probe, values[i], values[i + 1], states[i], states[i + 1], tolerance, events);
  }
  LocateIsolatedPoints(probe, values, states, tolerance, events);
  std::sort(events.begin(), events.end(),
            [](const Located& a, const Located& b) { return a.lower < b.lower; });
  std::vector<Located> merged = MergeThroughPoints(probe, events, options.merge_tolerance);
  TakeInEndBands(probe, low, high, merged);
  for (Located& located : merged) {
    RefineThroughSingularDecoupling(probe, tolerance, options.merge_tolerance, located);
  }
  for (const Located& located : merged) search.events.push_back(Report(located, tolerance));
  for (const ThresholdCrossing& crossing : search.events) {
    if (!std::isfinite(crossing.value) || !std::isfinite(crossing.bracket_width)) {
      throw NoSolution("the " + std::string(ToString(event)) + " event between " + crossing.from +
                       " and " + crossing.to + " of " + search.parameter +
                       " could not be located to a finite value");
    }
  }
  search.classifications = probe.classifications();
  return search;
}

}  // namespace servokit
