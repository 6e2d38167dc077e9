// api::Sweep and api::SweepToFiles: the classification over a grid of parameter values, for
// either kind of model, in memory or as the tables of `servokit sweep`.
#include "analysis/sweep.h"

#include <filesystem>
#include <functional>
#include <span>
#include <variant>

#include "analysis/parameter_grid.h"
#include "analysis/zero_dynamics.h"
#include "base/errors.h"
#include "base/option_check.h"
#include "files/output_file.h"
#include "reports/sweep_tables.h"
#include "servokit/toolkit_bridge.h"
#include "studies/grid_text.h"

namespace servokit::api {
namespace {

SweepAxis FromGridAxis(const GridAxis& axis) {
  SweepAxis result;
  result.parameter = axis.name;
  if (const auto* range = std::get_if<ValueRange>(&axis.values)) {
    result.range = SweepRange{range->first, range->last, range->count};
  } else {
    result.values = std::get<std::vector<double>>(axis.values);
  }
  result.degrees = axis.display_unit == DisplayUnit::kDegree;
  return result;
}

GridParameters ModelGridParameters(const Model& model) {
  const LoadedModel& loaded = ToolkitModel(model);
  return {loaded.parameter_names(), loaded.parameter_display_units()};
}

}  // namespace

GridAxis ToGridAxis(const Model& model, const SweepAxis& axis) {
  GridAxis grid_axis;
  grid_axis.name = axis.parameter;
  grid_axis.parameter = ParameterIndex(model.parameter_names(), axis.parameter);
  if (!axis.values.empty()) {
    grid_axis.values = axis.values;
  } else {
    RequireOption(axis.range.has_value(), "SweepAxis", "values", axis.parameter,
                  "must hold at least one value (or give a range)");
    RequireOption(axis.range->count >= 1, "SweepRange", "count", axis.range->count,
                  "must be at least 1");
    grid_axis.values = ValueRange{axis.range->first, axis.range->last, axis.range->count};
  }
  const DisplayUnit shown = ToolkitModel(model).parameter_display_units()[grid_axis.parameter];
  grid_axis.display_unit =
      axis.degrees ? (*axis.degrees ? DisplayUnit::kDegree : DisplayUnit::kSI) : shown;
  return grid_axis;
}

ParameterGrid ToGrid(const Model& model, const std::vector<SweepAxis>& axes) {
  std::vector<GridAxis> grid_axes;
  for (const SweepAxis& axis : axes) grid_axes.push_back(ToGridAxis(model, axis));
  ParameterGrid grid(std::move(grid_axes));
  CheckSweepColumns(grid);
  return grid;
}

namespace {

// Runs the sweep block by block into `consume`: the toolkit's one sweep engine, either kind.
// Stops after a block when the caller asks to (SweepOptions::stop_requested).
void RunModelSweep(
    const Model& model,
    const ParameterGrid& grid,
    const SweepOptions& options,
    const std::function<void(std::size_t, std::span<const servokit::SweepPoint>)>& consume) {
  RunSweep(ToolkitModel(model), grid, ToSweepOptions(model, options), 0,
           [&](std::size_t first, std::span<const servokit::SweepPoint> block) {
             consume(first, block);
             if (options.progress) options.progress(first + block.size(), grid.num_points());
             return !(options.stop_requested && options.stop_requested());
           });
}

SweepPoint ToSweepPoint(const ParameterGrid& grid,
                        std::size_t index,
                        const servokit::SweepPoint& point) {
  SweepPoint result;
  result.parameter_values.resize(grid.axes().size());
  grid.PointValues(index, result.parameter_values);
  result.parameter_display_values.reserve(grid.axes().size());
  for (std::size_t axis = 0; axis < grid.axes().size(); ++axis) {
    result.parameter_display_values.push_back(
        grid.axes()[axis].DisplayValue(result.parameter_values[axis]));
  }
  result.solved = point.ok;
  result.error = point.error;
  if (!point.ok) return result;
  result.realization = point.realization;
  result.P_rank = int(point.rank);
  result.relative_degree = point.relative_degree;
  result.differentiation_index = point.differentiation_index;
  result.internal_dynamics_order = point.internal_dynamics_order;
  result.stability = point.stability;
  result.eigenvalues = point.eigenvalues;
  result.max_real_part = point.max_real_part;
  result.eigenvalue_modes.reserve(point.eigenvalues.size());
  for (const std::complex<double> eigenvalue : point.eigenvalues) {
    const Mode mode = ModeOf(eigenvalue);
    result.eigenvalue_modes.push_back({mode.frequency_hz, mode.damping_ratio});
  }
  return result;
}

}  // namespace

servokit::SweepOptions ToSweepOptions(const Model& model, const SweepOptions& options) {
  servokit::SweepOptions sweep_options;
  static_cast<AnalysisOptions&>(sweep_options) = ToAnalysisOptions(model, options.analysis);
  sweep_options.threads = options.threads;
  return sweep_options;
}

SweepAxis ParseSweepAxis(const Model& model,
                         const std::string& text,
                         const std::string& label,
                         std::vector<std::string>* warnings) {
  return FromGridAxis(ParseGridAxis(ModelGridParameters(model), label, text, warnings));
}

std::vector<SweepAxis> ParseSweepAxes(const Model& model,
                                      const std::vector<std::string>& texts,
                                      const std::string& label,
                                      std::vector<std::string>* warnings) {
  const ParameterGrid grid = ParseParameterGrid(ModelGridParameters(model), label, texts, warnings);
  std::vector<SweepAxis> axes;
  for (const GridAxis& axis : grid.axes()) axes.push_back(FromGridAxis(axis));
  return axes;
}

std::string AngleSpanWarning(const Model& model,
                             const std::string& parameter,
                             bool has_unit,
                             double low,
                             double high,
                             const std::string& label) {
  const std::size_t index = ParameterIndex(model.parameter_names(), parameter);
  return servokit::AngleSpanWarning(
      label, parameter, ToolkitModel(model).parameter_display_units()[index], has_unit, low, high);
}

std::vector<SweepPoint> Sweep(const Model& model,
                              const std::vector<SweepAxis>& axes,
                              const SweepOptions& options) {
  const ParameterGrid grid = ToGrid(model, axes);
  std::vector<SweepPoint> points;
  points.reserve(grid.num_points());
  RunModelSweep(model, grid, options,
                [&](std::size_t first, std::span<const servokit::SweepPoint> block) {
                  for (std::size_t i = 0; i < block.size(); ++i) {
                    points.push_back(ToSweepPoint(grid, first + i, block[i]));
                  }
                });
  return points;
}

SweepColumns SweepTableColumns(const Model& model, const std::vector<SweepAxis>& axes) {
  const ParameterGrid grid = ToGrid(model, axes);
  return {PointsColumns(grid), EigenvaluesColumns(grid)};
}

std::size_t SweepToFiles(const Model& model,
                         const std::vector<SweepAxis>& axes,
                         const std::string& directory,
                         const SweepOptions& options) {
  const ParameterGrid grid = ToGrid(model, axes);
  const std::filesystem::path folder(directory);
  std::error_code error;
  std::filesystem::create_directories(folder, error);
  if (error) throw Error(directory + ": cannot create the directory: " + error.message());
  OutputFile points_file((folder / "points.csv").string());
  OutputFile eigenvalues_file((folder / "eigenvalues.csv").string());
  points_file.Write(PointsCsvHeader(grid));
  eigenvalues_file.Write(EigenvaluesCsvHeader(grid));
  std::string points_csv, eigenvalues_csv;
  std::size_t count = 0;
  RunModelSweep(model, grid, options,
                [&](std::size_t first, std::span<const servokit::SweepPoint> block) {
                  points_csv.clear();
                  eigenvalues_csv.clear();
                  AppendCsvRows(grid, first, block, points_csv, eigenvalues_csv);
                  points_file.Write(points_csv);
                  eigenvalues_file.Write(eigenvalues_csv);
                  count = first + block.size();
                });
  points_file.Commit();
  eigenvalues_file.Commit();
  return count;
}

}  // namespace servokit::api
