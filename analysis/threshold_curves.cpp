#include "analysis/threshold_curves.h"

#include <algorithm>
#include <cmath>
#include <tuple>

#include "analysis/sweep.h"
#include "base/errors.h"
#include "base/option_check.h"

namespace servokit {
namespace {

// The events located on one line: the held parameter's value and the crossings along it.
struct Line {
  double held = 0.0;
  std::vector<ThresholdCrossing> crossings;
};

bool SameChange(const ThresholdCurve& curve, const ThresholdCrossing& crossing) {
  return curve.from == crossing.from && curve.to == crossing.to && curve.via == crossing.via;
}

// Joins the points of consecutive lines into curves: each open curve (its last point on the
// previous line) takes the nearest point of the same change within `max_step`, nearest pairs
// first; a point left over starts a curve.
std::vector<ThresholdCurve> JoinLines(const std::vector<Line>& lines,
                                      ThresholdEvent event,
                                      int traced_axis,
                                      double max_step) {
  std::vector<ThresholdCurve> curves;
  std::vector<std::size_t> open;  // curves whose last point lies on the previous line
  for (const Line& line : lines) {
    // Candidate pairs (distance along the line, open curve, crossing).
    std::vector<std::tuple<double, std::size_t, std::size_t>> pairs;
    for (std::size_t c = 0; c < open.size(); ++c) {
      const ThresholdCurve& curve = curves[open[c]];
      const CurvePoint& last = curve.points.back();
      const double last_value = traced_axis == 0 ? last.x : last.y;
      for (std::size_t k = 0; k < line.crossings.size(); ++k) {
        const double distance = std::abs(line.crossings[k].value - last_value);
        if (SameChange(curve, line.crossings[k]) && distance <= max_step) {
          pairs.emplace_back(distance, c, k);
        }
      }
    }
    std::sort(pairs.begin(), pairs.end());
    std::vector<bool> curve_taken(open.size(), false), crossing_taken(line.crossings.size(), false);
    std::vector<std::size_t> next_open;
    std::vector<std::size_t> owner(line.crossings.size(), 0);
    for (const auto& [distance, c, k] : pairs) {
      if (curve_taken[c] || crossing_taken[k]) continue;
      curve_taken[c] = crossing_taken[k] = true;
      owner[k] = open[c];
    }
    for (std::size_t k = 0; k < line.crossings.size(); ++k) {
      const ThresholdCrossing& crossing = line.crossings[k];
      if (!crossing_taken[k]) {
        ThresholdCurve curve;
        curve.event = event;
        curve.from = crossing.from;
        curve.to = crossing.to;
        curve.via = crossing.via;
        curve.traced_axis = traced_axis;
        curves.push_back(std::move(curve));
        owner[k] = curves.size() - 1;
      }
      const CurvePoint point = traced_axis == 0
                                   ? CurvePoint{crossing.value, line.held, crossing.bracket_width}
                                   : CurvePoint{line.held, crossing.value, crossing.bracket_width};
      curves[owner[k]].points.push_back(point);
      next_open.push_back(owner[k]);
    }
    open = std::move(next_open);
  }
  return curves;
}

}  // namespace

void ThresholdCurveOptions::Validate(const Model& model) const {
  thresholds.Validate(model);
  constexpr const char* kOwner = "ThresholdCurveOptions";
  RequireOption(lines >= 1, kOwner, "lines", lines, "must be >= 1");
  RequireOption(along_first || along_second, kOwner, "along_first", along_first ? 1 : 0,
                "or along_second must be set");
  RequireOption(max_join_step > 0.0 && max_join_step <= 1.0, kOwner, "max_join_step", max_join_step,
                "must be > 0 and <= 1");
  RequireOption(threads >= 0, kOwner, "threads", threads, "must be >= 0");
  RequireOption(threads <= kMaxSweepThreads, kOwner, "threads", threads,
                "must be <= " + std::to_string(kMaxSweepThreads));
}

std::string CurveLabel(const ThresholdCurve& curve) {
  return std::string(ToString(curve.event)) + ": " + curve.from + " -> " + curve.to +
         (curve.via.empty() ? "" : " via " + curve.via);
}

std::vector<ThresholdCurve> TraceThresholdCurves(const Model& model,
                                                 const CurveAxis& x,
                                                 const CurveAxis& y,
                                                 const std::vector<ThresholdEvent>& events,
                                                 const ThresholdCurveOptions& options) {
  options.Validate(model);
  for (const CurveAxis* axis : {&x, &y}) {
    if (axis->parameter >= model.num_parameters()) throw UsageError("no such parameter index");
    if (!(std::isfinite(axis->low) && std::isfinite(axis->high) && axis->low < axis->high)) {
      throw UsageError("the range " + FormatNumber(axis->low) + ":" + FormatNumber(axis->high) +
                       " of " + model.parameter_names()[axis->parameter] +
                       " must be finite with low < high");
    }
  }
  if (x.parameter == y.parameter) {
    throw UsageError("threshold curves need two different parameters, not " +
                     model.parameter_names()[x.parameter] + " twice");
  }
  const Eigen::VectorXd base =
      options.thresholds.parameters.size() > 0 ? options.thresholds.parameters : model.parameters();
  const std::size_t line_count = static_cast<std::size_t>(options.lines) + 1;
  SweepOptions threading;
  threading.threads = options.threads;
  std::vector<ThresholdCurve> curves;
  for (const int traced_axis : {0, 1}) {
    if (!(traced_axis == 0 ? options.along_first : options.along_second)) continue;
    const CurveAxis& traced = traced_axis == 0 ? x : y;
    const CurveAxis& held = traced_axis == 0 ? y : x;
    // One search per (event, line), in parallel; each writes its own slot.
    std::vector<Line> lines(events.size() * line_count);
    ParallelFor(lines.size(), SweepThreads(threading), 1, [&](std::size_t i, int) {
      const std::size_t j = i % line_count;
      Line& line = lines[i];
      line.held = j + 1 == line_count
                      ? held.high
                      : held.low + (held.high - held.low) * double(j) / double(options.lines);
      ThresholdOptions line_options = options.thresholds;
      line_options.parameters = base;
      line_options.parameters(Eigen::Index(held.parameter)) = line.held;
      line.crossings = FindThresholds(model, traced.parameter, traced.low, traced.high,
                                      events[i / line_count], line_options)
                           .events;
    });
    for (std::size_t e = 0; e < events.size(); ++e) {
      const std::vector<Line> event_lines(lines.begin() + std::ptrdiff_t(e * line_count),
                                          lines.begin() + std::ptrdiff_t((e + 1) * line_count));
      for (ThresholdCurve& curve : JoinLines(event_lines, events[e], traced_axis,
                                             options.max_join_step * (traced.high - traced.low))) {
        curves.push_back(std::move(curve));
      }
    }
  }
  return curves;
}

}  // namespace servokit
