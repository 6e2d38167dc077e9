#pragma once
// Threshold curves in the plane of two parameters (issue #18, two-parameter maps), traced by
// continuation of the one-parameter threshold finder (analysis/thresholds.h), never from the
// edges of a classified grid: on each of a set of lines across the plane (the other parameter
// held at one value) FindThresholds locates every event to its tolerance, and located points of
// the same kind on neighbouring lines are joined into curves. Lines run along each axis in turn:
// a curve nearly parallel to one axis is crossed by the lines along the other, so tracing both
// ways finds curves of any direction (a curve crossed both ways appears as two curves, one per
// direction, on the same place).
#include <cstddef>
#include <string>
#include <vector>

#include "analysis/thresholds.h"
#include "base/vocabulary.h"
#include "modeling/model.h"

namespace servokit {

/// One axis of the plane: a model parameter and its range (SI units).
struct CurveAxis {
  std::size_t parameter = 0;  // index into model.parameter_names()
  double low = 0.0, high = 0.0;
};

struct ThresholdCurveOptions {
  // How each line's events are found and located (its `parameters` are the base values of the
  // parameters on neither axis; empty: nominal).
  ThresholdOptions thresholds;
  // Lines across each axis: lines + 1 values of the held parameter, low to high inclusive.
  // 40 resolves the smooth curves of the paper's models; the cost is one threshold search per
  // line, event and direction.
  int lines = 40;
  // Trace along the first axis (lines at values of the second), along the second, or both.
  bool along_first = true;
  bool along_second = true;
  // Points on neighbouring lines join into one curve only when they are at most this far
  // apart along the line, relative to the span of the traced axis: a curve that runs nearly
  // along the lines leaves them far apart, and is traced by the lines of the other direction.
  double max_join_step = 0.25;
  // Threads for the lines (0: OpenMP's default; at most kMaxSweepThreads); the curves do not
  // depend on it.
  int threads = 0;
  // Throws UsageError naming the field, its value and the rule it breaks.
  void Validate(const Model& model) const;
};

/// A located point of a curve: (x, y) = (first, second axis' parameter) in SI units; the
/// coordinate along the traced axis lies within +- bracket_width / 2 (ThresholdCrossing), the
/// other is the line's value, exactly.
struct CurvePoint {
  double x = 0.0, y = 0.0;
  double bracket_width = 0.0;
};

/// Points of one event kind and one change (from -> to, via) on consecutive lines, joined.
struct ThresholdCurve {
  ThresholdEvent event = ThresholdEvent::kStability;
  std::string from, to, via;       // as ThresholdCrossing, read in the traced parameter's ascent
  int traced_axis = 0;             // 0: lines along the first axis (x located), 1: along the second
  std::vector<CurvePoint> points;  // in the order of the lines (ascending held value)
};

/// "oscillation: oscillatory (1 mode) -> non-oscillatory" (with " via ..." for a thin state).
std::string CurveLabel(const ThresholdCurve& curve);

/// Traces the curves of every event in `events` in the rectangle x × y, the parameters on
/// neither axis at options.thresholds.parameters (default: nominal). Curves are ordered by
/// traced axis, event (in the order given), then their first line and place along it. Throws
/// UsageError for bad options, equal parameters on both axes or a range that is not low < high.
std::vector<ThresholdCurve> TraceThresholdCurves(const Model& model,
                                                 const CurveAxis& x,
                                                 const CurveAxis& y,
                                                 const std::vector<ThresholdEvent>& events,
                                                 const ThresholdCurveOptions& options = {});

}  // namespace servokit
