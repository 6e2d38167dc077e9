#include "analysis/thresholds.h"

#include <gsl/gsl_errno.h>
#include <gsl/gsl_min.h>
#include <gsl/gsl_roots.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <memory>
#include <optional>
#include <sstream>
#include <string>

#include "analysis/classification.h"
#include "models/errors.h"
#include "models/option_check.h"
#include "numerics/gsl_support.h"

namespace servokit {
namespace {

// The state an event watches at one parameter value: `key` decides equality, `label` is what
// the user reads.
struct State {
  std::string key;
  std::string label;
  // sigma_min(P) / (|H| |M^-1 B|), from the same classification: the scan watches it for
  // places where P touches zero (FindTouch). NaN where there is no solution.
  double relative_sigma_min = std::numeric_limits<double>::quiet_NaN();
};

State StabilityState(const Classification& c, double axis_tolerance) {
  double largest = 0.0;
  for (const auto& eigenvalue : c.zero_dynamics.eigenvalues) {
    largest = std::max(largest, std::abs(eigenvalue));
  }
  int right_half_plane = 0;
  for (const auto& eigenvalue : c.zero_dynamics.eigenvalues) {
    if (eigenvalue.real() > axis_tolerance * largest) ++right_half_plane;
  }
  std::string label(ToString(c.zero_dynamics.stability));
  if (right_half_plane > 1) label += " (" + std::to_string(right_half_plane) + " unstable)";
  return {label, label};
}

State OscillationState(const Classification& c) {
  const std::size_t pairs = c.zero_dynamics.modes.size();
  const std::string label = pairs == 0   ? "non-oscillatory"
                            : pairs == 1 ? "oscillatory (1 mode)"
                                         : "oscillatory (" + std::to_string(pairs) + " modes)";
  return {label, label};
}

State RealizationState(const Classification& c) {
  std::string label(ToString(c.decoupling.realization));
  std::string key = label + " rank " + std::to_string(c.decoupling.rank);
  if (c.decoupling.rank == c.decoupling.decoupling_matrix.rows()) {
    // The sign of det P tells the two sides of a place where P passes through zero apart.
    key += c.decoupling.decoupling_matrix.determinant() > 0 ? " +" : " -";
  } else if (c.decoupling.rank > 0) {
    label += " (rank " + std::to_string(c.decoupling.rank) + ")";
  }
  return {key, label};
}

class StateProbe {
 public:
  StateProbe(const Model& model,
             std::size_t parameter,
             ThresholdEvent event,
             const ThresholdOptions& options)
      : model_(model), workspace_(model), parameter_(parameter), event_(event), options_(options) {
    options_.classification.cross_check = false;
  }

  State At(double value) {
    const std::optional<Classification> c = ClassifyAt(value);
    // A point without a solution is a state of its own (e.g. no equilibrium).
    if (!c) return {"no-solution", "no-solution"};
    State state;
    switch (event_) {
      case ThresholdEvent::kStability:
        state = StabilityState(*c, options_.classification.imaginary_axis_tolerance);
        break;
      case ThresholdEvent::kOscillation:
        state = OscillationState(*c);
        break;
      case ThresholdEvent::kRealization:
        state = RealizationState(*c);
        break;
    }
    state.relative_sigma_min = RelativeSigmaMin(*c);
    return state;
  }

  // sigma_min(P) / (|H| |M^-1 B|) at `value` (State::relative_sigma_min), for the minimizer.
  double RelativeSmallestSingularValue(double value) { return At(value).relative_sigma_min; }

  double rank_tolerance() const { return options_.classification.rank_tolerance; }

  // det P at `value`, or NaN where there is no solution.
  double DecouplingDeterminant(double value) {
    const std::optional<Classification> c = ClassifyAt(value);
    return c ? c->decoupling.decoupling_matrix.determinant()
             : std::numeric_limits<double>::quiet_NaN();
  }

  int classifications() const { return classifications_; }

 private:
  double RelativeSigmaMin(const Classification& c) const {
    const double scale = c.decoupling.rank_threshold / options_.classification.rank_tolerance;
    return scale > 0.0 ? c.decoupling.singular_values.tail(1)(0) / scale : 0.0;
  }

  // The classification at `value` of the parameter, or nullopt where it has no solution.
  std::optional<Classification> ClassifyAt(double value) {
    ++classifications_;
    workspace_.parameters(Eigen::Index(parameter_)) = value;
    try {
      return Classify(model_, workspace_, options_.classification);
    } catch (const NoSolution&) {
      return std::nullopt;
    }
  }

  const Model& model_;
  Workspace workspace_;
  std::size_t parameter_;
  ThresholdEvent event_;
  ThresholdOptions options_;
  int classifications_ = 0;
};

// The boundary in [left, right] where the state stops being `left_state`, by GSL's bisection
// solver on the sign function "-1 while the state is left_state, +1 after". Returns the final
// bracket.
std::pair<double, double> Bisect(StateProbe& probe,
                                 double left,
                                 double right,
                                 const State& left_state,
                                 double relative_tolerance) {
  const auto bracket = NarrowBracket(
      gsl_root_fsolver_bisection,
      [&](double x) { return probe.At(x).key == left_state.key ? -1.0 : 1.0; }, left, right,
      relative_tolerance);
  if (!bracket) throw std::runtime_error("bisection: the states at the bracket's ends agree");
  return {bracket->lower, bracket->upper};
}

// Every change of state between `left` and `right`, whose states differ.
void LocateChanges(StateProbe& probe,
                   double left,
                   double right,
                   State left_state,
                   const State& right_state,
                   double relative_tolerance,
                   std::vector<ThresholdCrossing>& events) {
  while (left_state.key != right_state.key) {
    const auto [lower, upper] = Bisect(probe, left, right, left_state, relative_tolerance);
    const State after = probe.At(upper);
    events.push_back({0.5 * (lower + upper), upper - lower, left_state.label, after.label, ""});
    left = upper;
    left_state = after;
  }
}

// Events closer than `merge_tolerance` become one that passes through the states between.
std::vector<ThresholdCrossing> MergeClose(const std::vector<ThresholdCrossing>& events,
                                          double merge_tolerance) {
  std::vector<ThresholdCrossing> merged;
  for (const ThresholdCrossing& event : events) {
    if (!merged.empty()) {
      ThresholdCrossing& last = merged.back();
      const double first_value = last.value - 0.5 * last.bracket_width;
      if (event.value - first_value <= merge_tolerance * std::max(1.0, std::abs(event.value))) {
        last.via += (last.via.empty() ? "" : ", ") + event.from;
        last.to = event.to;
        const double end = event.value + 0.5 * event.bracket_width;
        last.value = 0.5 * (first_value + end);
        last.bracket_width = end - first_value;
        continue;
      }
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
                                     double relative_tolerance,
                                     double search_width,
                                     ThresholdCrossing& event) {
  const double width =
      std::max(event.bracket_width, search_width * std::max(1.0, std::abs(event.value)));
  const double left = event.value - width, right = event.value + width;
  const double at_left = probe.DecouplingDeterminant(left);
  const double at_right = probe.DecouplingDeterminant(right);
  if (!(std::isfinite(at_left) && std::isfinite(at_right)) || at_left * at_right >= 0.0) return;
  const auto bracket = NarrowBracket(
      gsl_root_fsolver_brent, [&](double x) { return probe.DecouplingDeterminant(x); }, left, right,
      relative_tolerance);
  if (bracket && bracket->converged) {
    event.value = bracket->root;
    event.bracket_width = bracket->upper - bracket->lower;
  }
}

// P can touch zero without changing sign (the mass on car at alpha = 0: P ~ sin^2(alpha)); the
// realization is then tangential at one point only, which a scan finds only by luck. A local
// minimum of the relative sigma_min(P) between scan points of one state is refined by GSL's
// Brent minimizer; if the minimum is within the rank tolerance, P touches zero there.
// (A minimizer locates a double root to about sqrt(epsilon) relative, not 1e-12.)
std::optional<ThresholdCrossing> FindTouch(
    StateProbe& probe, double left, double middle, double right, const State& state) {
  gsl_function function{[](double x, void* p) {
                          return static_cast<StateProbe*>(p)->RelativeSmallestSingularValue(x);
                        },
                        &probe};
  std::unique_ptr<gsl_min_fminimizer, void (*)(gsl_min_fminimizer*)> minimizer(
      gsl_min_fminimizer_alloc(gsl_min_fminimizer_brent), gsl_min_fminimizer_free);
  if (!minimizer ||
      gsl_min_fminimizer_set(minimizer.get(), &function, middle, left, right) != GSL_SUCCESS) {
    return std::nullopt;
  }
  constexpr int kMaxIterations = 100;
  // sqrt(epsilon): the best a minimizer can locate a minimum to.
  constexpr double kMinimizerTolerance = 1.5e-8;
  for (int i = 0; i < kMaxIterations; ++i) {
    if (gsl_min_fminimizer_iterate(minimizer.get()) != GSL_SUCCESS) break;
    if (gsl_min_test_interval(gsl_min_fminimizer_x_lower(minimizer.get()),
                              gsl_min_fminimizer_x_upper(minimizer.get()), kMinimizerTolerance,
                              0.0) == GSL_SUCCESS) {
      break;
    }
  }
  if (!(gsl_min_fminimizer_f_minimum(minimizer.get()) <= probe.rank_tolerance())) {
    return std::nullopt;
  }
  const double value = gsl_min_fminimizer_x_minimum(minimizer.get());
  const State touched = probe.At(value);
  ThresholdCrossing crossing;
  crossing.value = value;
  crossing.bracket_width =
      gsl_min_fminimizer_x_upper(minimizer.get()) - gsl_min_fminimizer_x_lower(minimizer.get());
  crossing.from = state.label;
  crossing.to = state.label;
  crossing.via = touched.key == state.key ? "P = 0" : touched.label;
  return crossing;
}

}  // namespace

void ThresholdOptions::Validate(const Model& model) const {
  classification.Validate(model);
  constexpr const char* kOwner = "ThresholdOptions";
  RequireOption(scan_intervals >= 1, kOwner, "scan_intervals", scan_intervals, "must be >= 1");
  RequireOption(relative_tolerance > 0.0 && relative_tolerance < 1.0, kOwner, "relative_tolerance",
                relative_tolerance, "must be > 0 and < 1");
  RequireOption(merge_tolerance >= 0.0, kOwner, "merge_tolerance", merge_tolerance, "must be >= 0");
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
  std::vector<ThresholdCrossing> events;
  double left = low;
  State left_state = probe.At(low);
  // For touches of P = 0: the scan's last two points and their relative sigma_min(P).
  const bool watch_touches = event == ThresholdEvent::kRealization;
  double before = low, before_sigma = std::numeric_limits<double>::quiet_NaN();
  State before_state = left_state;
  double left_sigma = left_state.relative_sigma_min;
  for (int i = 1; i <= options.scan_intervals; ++i) {
    const double right = i == options.scan_intervals
                             ? high
                             : low + (high - low) * double(i) / double(options.scan_intervals);
    const State right_state = probe.At(right);
    LocateChanges(probe, left, right, left_state, right_state, options.relative_tolerance, events);
    if (watch_touches) {
      const double right_sigma = right_state.relative_sigma_min;
      if (left_sigma < before_sigma && left_sigma < right_sigma &&
          before_state.key == left_state.key && left_state.key == right_state.key) {
        if (auto touch = FindTouch(probe, before, left, right, left_state)) {
          events.push_back(*touch);
        }
      }
      before = left;
      before_sigma = left_sigma;
      left_sigma = right_sigma;
    }
    before_state = left_state;
    left = right;
    left_state = right_state;
  }
  std::sort(
      events.begin(), events.end(),
      [](const ThresholdCrossing& a, const ThresholdCrossing& b) { return a.value < b.value; });
  search.events = MergeClose(events, options.merge_tolerance);
  if (event != ThresholdEvent::kOscillation) {
    for (ThresholdCrossing& crossing : search.events) {
      RefineThroughSingularDecoupling(probe, options.relative_tolerance, options.merge_tolerance,
                                      crossing);
    }
  }
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
