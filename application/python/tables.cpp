#include "application/python/tables.h"

#include <pybind11/numpy.h>
#include <pybind11/stl.h>

#include <algorithm>
#include <cstdint>
#include <optional>
#include <utility>

#include "application/python/conversions.h"

namespace servokit::python {
namespace {

// One column of a table: numbers, integers (possibly missing: an empty CSV field) or text.
struct Column {
  enum class Type { kFloat, kInteger, kText };
  std::string name;
  Type type = Type::kFloat;
  bool nullable = false;  // integers only: pandas' Int64 with <NA>, -1 in a structured array
  std::vector<double> numbers;
  std::vector<std::int64_t> integers;
  std::vector<bool> missing;
  std::vector<std::string> texts;

  static Column Of(std::string name, Type type) {
    Column column;
    column.name = std::move(name);
    column.type = type;
    return column;
  }
  static Column Float(std::string name) { return Of(std::move(name), Type::kFloat); }
  static Column Integer(std::string name, bool nullable) {
    Column column = Of(std::move(name), Type::kInteger);
    column.nullable = nullable;
    return column;
  }
  static Column Text(std::string name) { return Of(std::move(name), Type::kText); }
  void AddInteger(std::optional<std::int64_t> value) {
    integers.push_back(value.value_or(-1));
    missing.push_back(!value.has_value());
  }
  std::size_t size() const {
    return type == Type::kFloat ? numbers.size()
                                : (type == Type::kInteger ? integers.size() : texts.size());
  }
};

py::object PandasColumn(const Column& column) {
  switch (column.type) {
    case Column::Type::kFloat:
      return DoubleArray(column.numbers);
    case Column::Type::kInteger: {
      py::array_t<std::int64_t> values(py::ssize_t(column.integers.size()), column.integers.data());
      if (!column.nullable) return values;
      py::array_t<bool> mask(py::ssize_t(column.missing.size()));
      for (std::size_t i = 0; i < column.missing.size(); ++i) {
        mask.mutable_data()[i] = column.missing[i];
      }
      return py::module_::import("pandas").attr("arrays").attr("IntegerArray")(values, mask);
    }
    case Column::Type::kText:
      return py::module_::import("numpy").attr("array")(py::cast(column.texts), "object");
  }
  return py::none();
}

py::object PandasTable(const std::vector<Column>& columns) {
  // Built by position, then named: a parameter may share its name with a column (`k`).
  py::dict data;
  py::list names;
  for (std::size_t i = 0; i < columns.size(); ++i) {
    data[py::int_(i)] = PandasColumn(columns[i]);
    names.append(columns[i].name);
  }
  py::object frame = py::module_::import("pandas").attr("DataFrame")(data);
  frame.attr("columns") = names;
  return frame;
}

// The numpy dtype of a structured array of `columns`: f8, i8 or U<longest text> each.
py::list StructuredFields(const std::vector<Column>& columns) {
  py::list fields;
  py::set seen;
  for (const Column& column : columns) {
    if (seen.contains(py::str(column.name))) {
      throw servokit::UsageError("table = \"numpy\": two columns are named " + column.name +
                                 " (a parameter and a column of the table); use pandas");
    }
    seen.add(py::str(column.name));
    std::string type = "f8";
    if (column.type == Column::Type::kInteger) type = "i8";
    if (column.type == Column::Type::kText) {
      std::size_t width = 1;
      for (const std::string& text : column.texts) width = std::max(width, text.size());
      type = "U" + std::to_string(width);
    }
    fields.append(py::make_tuple(column.name, type));
  }
  return fields;
}

py::object StructuredArray(const std::vector<Column>& columns) {
  const py::module_ numpy = py::module_::import("numpy");
  const py::list fields = StructuredFields(columns);
  const std::size_t rows = columns.empty() ? 0 : columns.front().size();
  py::object array = numpy.attr("zeros")(rows, numpy.attr("dtype")(fields));
  for (const Column& column : columns) {
    py::object values;
    if (column.type == Column::Type::kFloat) {
      values = py::array_t<double>(py::ssize_t(rows), column.numbers.data());
    } else if (column.type == Column::Type::kInteger) {
      values = py::array_t<std::int64_t>(py::ssize_t(rows), column.integers.data());
    } else {
      values = py::cast(column.texts);
    }
    array[py::str(column.name)] = values;
  }
  return array;
}

py::object MakeTable(const std::vector<Column>& columns, const std::string& table) {
  return UsePandas(table) ? PandasTable(columns) : StructuredArray(columns);
}

std::optional<std::int64_t> Determined(const sk::SweepPoint& point, int value) {
  if (!point.solved || point.internal_dynamics_order < 0) return std::nullopt;
  return value;
}

// The columns of points.csv and eigenvalues.csv, filled point by point.
class SweepColumnsBuilder {
 public:
  SweepColumnsBuilder(const sk::Model& model, const std::vector<sk::SweepAxis>& axes)
      : names_(sk::SweepTableColumns(model, axes)),  // "alpha_deg" for a parameter in degrees
        axes_(axes.size()),
        joined_degrees_(model.num_outputs() != 1),  // "1;2", as the CSV writes it
        relative_degree_(joined_degrees_ ? Column::Text("relative_degree")
                                         : Column::Integer("relative_degree", true)),
        k_(Column::Integer(names_.eigenvalues[axes_], false)) {
    for (std::size_t axis = 0; axis < axes_; ++axis) {
      point_axes_.push_back(Column::Float(names_.points[axis]));
      eigenvalue_axes_.push_back(Column::Float(names_.eigenvalues[axis]));
    }
  }

  void Add(const sk::SweepPoint& point) {
    for (std::size_t axis = 0; axis < axes_; ++axis) {
      point_axes_[axis].numbers.push_back(point.parameter_display_values[axis]);
    }
    realization_.texts.push_back(Word(point.realization));
    P_rank_.AddInteger(point.solved ? std::optional<std::int64_t>(point.P_rank) : std::nullopt);
    AddRelativeDegree(point);
    differentiation_index_.AddInteger(Determined(point, point.differentiation_index));
    internal_order_.AddInteger(Determined(point, point.internal_dynamics_order));
    stability_.texts.push_back(Word(point.stability));
    max_real_part_.numbers.push_back(point.max_real_part);
    error_.texts.push_back(point.error);
    for (std::size_t i = 0; i < point.eigenvalues.size(); ++i) {
      for (std::size_t axis = 0; axis < axes_; ++axis) {
        eigenvalue_axes_[axis].numbers.push_back(point.parameter_display_values[axis]);
      }
      k_.AddInteger(std::int64_t(i));
      re_.numbers.push_back(point.eigenvalues[i].real());
      im_.numbers.push_back(point.eigenvalues[i].imag());
      frequency_.numbers.push_back(point.eigenvalue_modes[i].frequency_hz);
      damping_.numbers.push_back(point.eigenvalue_modes[i].damping_ratio);
    }
  }

  // The two tables' columns, in the CSV's order (once: the columns are moved).
  std::vector<Column> TakePoints() {
    std::vector<Column> columns = std::move(point_axes_);
    for (Column* column : {&realization_, &P_rank_, &relative_degree_, &differentiation_index_,
                           &internal_order_, &stability_, &max_real_part_, &error_}) {
      columns.push_back(std::move(*column));
    }
    return columns;
  }
  std::vector<Column> TakeEigenvalues() {
    std::vector<Column> columns = std::move(eigenvalue_axes_);
    for (Column* column : {&k_, &re_, &im_, &frequency_, &damping_}) {
      columns.push_back(std::move(*column));
    }
    return columns;
  }

 private:
  void AddRelativeDegree(const sk::SweepPoint& point) {
    const bool determined = point.solved && point.internal_dynamics_order >= 0;
    if (joined_degrees_) {
      std::string joined;
      for (std::size_t i = 0; determined && i < point.relative_degree.size(); ++i) {
        joined += (i > 0 ? ";" : "") + std::to_string(point.relative_degree[i]);
      }
      relative_degree_.texts.push_back(joined);
    } else {
      relative_degree_.AddInteger(determined && !point.relative_degree.empty()
                                      ? std::optional<std::int64_t>(point.relative_degree[0])
                                      : std::nullopt);
    }
  }

  sk::SweepColumns names_;
  std::size_t axes_;
  bool joined_degrees_;
  std::vector<Column> point_axes_, eigenvalue_axes_;
  Column realization_ = Column::Text("realization"), P_rank_ = Column::Integer("P_rank", true),
         relative_degree_, differentiation_index_ = Column::Integer("differentiation_index", true),
         internal_order_ = Column::Integer("internal_dynamics_order", true),
         stability_ = Column::Text("stability"), max_real_part_ = Column::Float("max_real_part"),
         error_ = Column::Text("error");
  Column k_, re_ = Column::Float("re"), im_ = Column::Float("im"),
             frequency_ = Column::Float("frequency_hz"), damping_ = Column::Float("damping_ratio");
};

}  // namespace

bool UsePandas(const std::string& table) {
  if (table == "pandas") return true;
  if (table == "numpy") return false;
  if (table != "auto") {
    throw servokit::UsageError("table = \"" + table + "\": expected auto, pandas or numpy");
  }
  try {
    py::module_::import("pandas");
    return true;
  } catch (const py::error_already_set& error) {
    if (!error.matches(PyExc_ImportError)) throw;
    return false;
  }
}

py::tuple SweepTables(const sk::Model& model,
                      const std::vector<sk::SweepAxis>& axes,
                      const std::vector<sk::SweepPoint>& points,
                      const std::string& table) {
  SweepColumnsBuilder columns(model, axes);
  for (const sk::SweepPoint& point : points) columns.Add(point);
  return py::make_tuple(MakeTable(columns.TakePoints(), table),
                        MakeTable(columns.TakeEigenvalues(), table));
}

py::object SolveTable(const sk::Model& model,
                      const sk::Feedforward& feedforward,
                      const std::string& table) {
  std::vector<Column> columns;
  Column t = Column::Float("t");
  t.numbers = feedforward.t;
  columns.push_back(std::move(t));
  const auto add = [&](const Eigen::MatrixXd& values, const std::vector<std::string>& names,
                       const std::string& suffix) {
    for (std::size_t j = 0; j < names.size(); ++j) {
      Column column = Column::Float(names[j] + suffix);
      for (Eigen::Index i = 0; i < values.rows(); ++i) {
        column.numbers.push_back(values(i, Eigen::Index(j)));
      }
      columns.push_back(std::move(column));
    }
  };
  add(feedforward.q, model.coordinate_names(), "");
  add(feedforward.q_dot, model.coordinate_names(), "_dot");
  add(feedforward.u, model.input_names(), "");
  add(feedforward.y_d, model.output_names(), "_d");
  add(feedforward.multipliers, model.multiplier_names(), "");  // a closed chain's
  return MakeTable(columns, table);
}

}  // namespace servokit::python
