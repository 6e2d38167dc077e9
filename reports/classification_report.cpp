#include "reports/classification_report.h"

#include <sstream>

#include "base/number_format.h"
#include "modeling/symbolic_model.h"
#include "modeling/units.h"
#include "reports/escaping.h"

namespace servokit {
namespace {

// Minimum phase follows from the stability verdict: when that is undetermined at the precision of
// the computation (large linear models), so is minimum phase, and neither word is printed.
std::string MinimumPhaseText(Stability stability, bool minimum_phase) {
  if (stability == Stability::kUndetermined) return ", minimum phase undetermined";
  return minimum_phase ? ", minimum phase" : ", non-minimum phase";
}

// The same in JSON: null when undetermined.
nlohmann::ordered_json MinimumPhaseJson(Stability stability, bool minimum_phase) {
  if (stability == Stability::kUndetermined) return nullptr;
  return minimum_phase;
}

nlohmann::ordered_json VectorToJson(const Eigen::VectorXd& values) {
  nlohmann::ordered_json array = nlohmann::ordered_json::array();
  for (Eigen::Index i = 0; i < values.size(); ++i) array.push_back(WithoutNegativeZero(values(i)));
  return array;
}

nlohmann::ordered_json MatrixToJson(const Eigen::MatrixXd& matrix) {
  nlohmann::ordered_json rows = nlohmann::ordered_json::array();
  for (Eigen::Index i = 0; i < matrix.rows(); ++i) rows.push_back(VectorToJson(matrix.row(i)));
  return rows;
}

nlohmann::ordered_json EigenvaluesToJson(const std::vector<std::complex<double>>& eigenvalues) {
  nlohmann::ordered_json array = nlohmann::ordered_json::array();
  for (const auto& eigenvalue : eigenvalues) {
    array.push_back({{"re", WithoutNegativeZero(eigenvalue.real())},
                     {"im", WithoutNegativeZero(eigenvalue.imag())}});
  }
  return array;
}

template <typename Container>
std::string Join(const Container& items, const std::string& separator) {
  std::ostringstream out;
  bool first = true;
  for (const auto& item : items) {
    out << (first ? "" : separator) << item;
    first = false;
  }
  return out.str();
}

std::string VectorToText(const Eigen::VectorXd& values) {
  std::vector<std::string> parts;
  for (Eigen::Index i = 0; i < values.size(); ++i) parts.push_back(FormatShort(values(i)));
  return "[" + Join(parts, ", ") + "]";
}

std::string MatrixToText(const Eigen::MatrixXd& matrix) {
  std::vector<std::string> rows;
  for (Eigen::Index i = 0; i < matrix.rows(); ++i) rows.push_back(VectorToText(matrix.row(i)));
  return "[" + Join(rows, ", ") + "]";
}

std::string EigenvaluesToText(const std::vector<std::complex<double>>& eigenvalues) {
  if (eigenvalues.empty()) return "none";
  std::vector<std::string> parts;
  for (const auto& eigenvalue : eigenvalues) parts.push_back(FormatComplex(eigenvalue));
  return Join(parts, ", ");
}

std::string ModesToText(const std::vector<Mode>& modes) {
  if (modes.empty()) return "none (no complex pair)";
  std::vector<std::string> parts;
  for (const Mode& mode : modes) {
    parts.push_back(FormatShort(mode.frequency_hz) + " Hz, damping ratio " +
                    FormatShort(mode.damping_ratio));
  }
  return Join(parts, "; ");
}

// Each parameter in the unit it is shown in: "alpha = 5 deg" for one given in degrees (degrees
// stay degrees, issue #34); the JSON keeps SI.
std::string ParametersToText(const Model& model) {
  std::vector<std::string> parts;
  for (std::size_t i = 0; i < model.num_parameters(); ++i) {
    const double value = model.parameters()(Eigen::Index(i));
    parts.push_back(model.parameter_names()[i] + " = " +
                    (model.parameter_display_units()[i] == DisplayUnit::kDegree
                         ? FormatShort(DisplayDegrees(value)) + " deg"
                         : FormatShort(value)));
  }
  return Join(parts, ", ");
}

std::string IntsToText(const std::vector<int>& values) { return "[" + Join(values, ", ") + "]"; }

}  // namespace

std::vector<std::pair<std::string, std::string>> ClassificationSummary(const Model& model,
                                                                       const Classification& c) {
  const auto& structure = c.structure;
  std::string relative_degree = IntsToText(structure.relative_degree);
  if (!structure.decoupling_matrix_regular) {
    relative_degree +=
        " (decoupling matrix singular: no vector relative degree; orders of the "
        "infinite zeros " +
        IntsToText(structure.infinite_zero_orders) + ")";
  }
  std::vector<std::pair<std::string, std::string>> rows = {
      {"parameters", ParametersToText(model)},
      {"operating point", "q = " + VectorToText(c.operating_point.q) +
                              ", u = " + VectorToText(c.operating_point.u) +
                              ", y = " + VectorToText(c.operating_point.y) +
                              (model.num_constraints() > 0
                                   ? ", lambda = " + VectorToText(c.operating_point.multipliers)
                                   : std::string())},
      {"P = H M^-1 B", MatrixToText(c.decoupling.decoupling_matrix)},
      {"singular values of P", VectorToText(c.decoupling.singular_values) + " (zero below " +
                                   FormatShort(c.decoupling.rank_threshold) + ")"},
      {"rank P", std::to_string(c.decoupling.rank) + " of " +
                     std::to_string(c.decoupling.decoupling_matrix.rows()) + ", deficiency " +
                     std::to_string(c.decoupling.rank_deficiency)},
      {"realization", std::string(ToString(c.decoupling.realization))},
      {"relative degree", relative_degree},
      {"differentiation index",
       std::to_string(structure.differentiation_index) +
           " (projected DAE: " + std::to_string(structure.projected_index) + ")"},
      {"internal dynamics",
       "order " + std::to_string(structure.internal_dynamics_order) + (c.flat ? " (flat)" : "")},
      {"zero dynamics", EigenvaluesToText(c.zero_dynamics.eigenvalues)},
      {"stability",
       std::string(ToString(c.zero_dynamics.stability)) +
           MinimumPhaseText(c.zero_dynamics.stability, c.zero_dynamics.minimum_phase) +
           (c.zero_dynamics.stability_note.empty() ? ""
                                                   : " (" + c.zero_dynamics.stability_note + ")")},
      {"oscillatory modes", ModesToText(c.zero_dynamics.modes)},
      {"recommended solver", std::string(ToString(c.recommended_solver))},
  };
  if (model.num_constraints() > 0) {
    // After the parameters and the operating point: what the numbers below are about.
    rows.insert(rows.begin() + 2,
                {"constraints", std::to_string(model.num_constraints()) + " (" +
                                    std::to_string(model.dof() - model.num_constraints()) +
                                    " degrees of freedom; P, zeros on the tangent space of "
                                    "c(q) = 0)"});
  }
  if (c.cross_check) {
    rows.push_back({"cross-check (QZ)",
                    std::string(c.cross_check->agrees ? "agrees" : "DISAGREES") +
                        ": invariant zeros " + EigenvaluesToText(c.cross_check->invariant_zeros) +
                        ", largest difference " + FormatShort(c.cross_check->max_difference) +
                        (c.cross_check->note.empty() ? "" : "; " + c.cross_check->note)});
  }
  if (c.nonlinear_structure) {
    const NonlinearStructureSummary& nonlinear = *c.nonlinear_structure;
    std::string text = "not derived";
    if (nonlinear.derived) {
      text = "relative degree " + IntsToText(nonlinear.relative_degree);
      if (nonlinear.extended) {
        text += ", extended to " + IntsToText(nonlinear.extended_relative_degree);
      }
      text += ", internal dynamics order " + std::to_string(nonlinear.internal_order);
    }
    rows.push_back({"nonlinear structure", text});
    if (!nonlinear.note.empty()) rows.push_back({"note", nonlinear.note});
  }
  return rows;
}

namespace {}  // namespace

namespace {

nlohmann::ordered_json NonlinearStructureToJson(const NonlinearStructureSummary& nonlinear) {
  nlohmann::ordered_json json = {{"derived", nonlinear.derived}, {"route", nonlinear.route}};
  if (nonlinear.derived) {
    json["relative_degree"] = nonlinear.relative_degree;
    json["defined_at_operating_point"] = nonlinear.defined_at_operating_point;
    json["dynamic_extension"] = {
        {"needed", nonlinear.extended},
        {"delayed_inputs", nonlinear.delayed_inputs},
        {"integrators", nonlinear.integrators},
        {"relative_degree", nonlinear.extended_relative_degree},
    };
    json["internal_dynamics_order"] = nonlinear.internal_order;
  }
  json["note"] = nonlinear.note;
  return json;
}

}  // namespace

nlohmann::ordered_json ClassificationToJson(const Model& model,
                                            const Classification& c,
                                            const ClassificationOptions& options) {
  nlohmann::ordered_json parameters = nlohmann::ordered_json::object();
  for (std::size_t i = 0; i < model.num_parameters(); ++i) {
    parameters[model.parameter_names()[i]] = model.parameters()(Eigen::Index(i));
  }
  nlohmann::ordered_json modes = nlohmann::ordered_json::array();
  for (const Mode& mode : c.zero_dynamics.modes) {
    modes.push_back({{"frequency_hz", mode.frequency_hz}, {"damping_ratio", mode.damping_ratio}});
  }
  nlohmann::ordered_json zero_dynamics = {
      {"eigenvalues", EigenvaluesToJson(c.zero_dynamics.eigenvalues)},
      {"stability", ToString(c.zero_dynamics.stability)},
      {"minimum_phase", MinimumPhaseJson(c.zero_dynamics.stability, c.zero_dynamics.minimum_phase)},
      {"modes", modes},
  };
  // Only where there is one (a curve of equilibria), so that other objects are unchanged.
  if (!c.zero_dynamics.stability_note.empty()) {
    zero_dynamics["stability_note"] = c.zero_dynamics.stability_note;
  }
  if (c.cross_check) {
    zero_dynamics["cross_check"] = {
        {"method", "invariant zeros of the linearization (QZ of the Rosenbrock pencil)"},
        {"invariant_zeros", EigenvaluesToJson(c.cross_check->invariant_zeros)},
        {"max_difference", c.cross_check->max_difference},
        {"agrees", c.cross_check->agrees},
    };
    // Only when the routes disagree, so that the object of an agreeing check is unchanged.
    if (!c.cross_check->note.empty()) zero_dynamics["cross_check"]["note"] = c.cross_check->note;
  }
  nlohmann::ordered_json json = {
      {"model", model.name()},
      {"parameters", parameters},
      {"dof", model.dof()},
      {"coordinates", model.coordinates()},
      {"inputs", model.inputs()},
      {"outputs", model.output_names()},
      {"operating_point",
       {{"q", VectorToJson(c.operating_point.q)},
        {"u", VectorToJson(c.operating_point.u)},
        {"y", VectorToJson(c.operating_point.y)}}},
      {"P", MatrixToJson(c.decoupling.decoupling_matrix)},
      {"P_singular_values", VectorToJson(c.decoupling.singular_values)},
      {"P_rank_threshold", c.decoupling.rank_threshold},
      {"P_rank", c.decoupling.rank},
      {"P_rank_deficiency", c.decoupling.rank_deficiency},
      {"realization", ToString(c.decoupling.realization)},
      {"relative_degree", c.structure.relative_degree},
      {"decoupling_matrix_regular", c.structure.decoupling_matrix_regular},
      {"infinite_zero_orders", c.structure.infinite_zero_orders},
      {"differentiation_index", c.structure.differentiation_index},
      {"projected_index", c.structure.projected_index},
      {"internal_dynamics_order", c.structure.internal_dynamics_order},
      {"flat", c.flat},
      {"zero_dynamics", zero_dynamics},
      {"recommended_solver", ToString(c.recommended_solver)},
      {"tolerances",
       {{"rank_tolerance", options.rank_tolerance},
        {"imaginary_axis_tolerance", options.imaginary_axis_tolerance}}},
      // How the model's derivatives are taken: the routes its size allowed (docs/model-files.md,
      // "How servokit reads a model").
      {"derivatives",
       {{"jacobians", model.has_program(Quantity::kForcesJacobians) ? "symbolic" : "forward-mode"},
        // The load-time decision (Model::has_zero_dynamics_polynomial would derive it).
        {"zero_dynamics_polynomial", model.symbolic().has_zero_dynamics_polynomial()}}},
  };
  if (model.num_constraints() > 0) {
    json["constraints"] = model.num_constraints();
    json["operating_point"]["multipliers"] = VectorToJson(c.operating_point.multipliers);
  }
  if (c.operating_point.curve_direction) {  // not isolated: the curve through the point
    json["operating_point"]["curve_direction"] = VectorToJson(*c.operating_point.curve_direction);
  }
  if (c.nonlinear_structure) {
    json["nonlinear_structure"] = NonlinearStructureToJson(*c.nonlinear_structure);
  }
  return json;
}

namespace {

using SummaryRows = std::vector<std::pair<std::string, std::string>>;

std::string RowsToText(const std::string& name,
                       const std::string& source,
                       const SummaryRows& rows) {
  std::ostringstream out;
  out << PlainText(name) << " (" << PlainText(source) << ")\n";
  for (const auto& [label, value] : rows) {
    out << "  " << label << std::string(label.size() < 24 ? 24 - label.size() : 1, ' ') << value
        << "\n";
  }
  return out.str();
}

std::string RowsToMarkdown(const std::string& name,
                           const std::string& description,
                           const SummaryRows& rows) {
  std::ostringstream out;
  out << "## " << MarkdownText(name) << "\n\n";
  if (!description.empty()) out << MarkdownText(description) << "\n\n";
  out << "| property | value |\n| --- | --- |\n";
  for (const auto& [label, value] : rows) out << "| " << label << " | " << value << " |\n";
  return out.str();
}

}  // namespace

std::string ClassificationToText(const Model& model, const Classification& c) {
  return RowsToText(model.name(), model.source(), ClassificationSummary(model, c));
}

std::string ClassificationToMarkdown(const Model& model, const Classification& c) {
  return RowsToMarkdown(model.name(), model.description(), ClassificationSummary(model, c));
}

std::string FormatClassification(const Model& model,
                                 const Classification& classification,
                                 const ClassificationOptions& options,
                                 ReportFormat format) {
  switch (format) {
    case ReportFormat::kJson:
      return ClassificationToJson(model, classification, options).dump(2) + "\n";
    case ReportFormat::kMarkdown:
      return ClassificationToMarkdown(model, classification);
    case ReportFormat::kText:
      break;
  }
  return ClassificationToText(model, classification);
}

namespace {

std::string LinearParametersToText(const LinearModel& model) {
  std::vector<std::string> parts;
  for (std::size_t i = 0; i < model.parameter_names().size(); ++i) {
    parts.push_back(model.parameter_names()[i] + " = " +
                    FormatShort(model.parameters()(Eigen::Index(i))));
  }
  return parts.empty() ? "none" : Join(parts, ", ");
}

std::vector<std::string> NumberedNames(const std::string& prefix, std::size_t count) {
  std::vector<std::string> names;
  for (std::size_t i = 1; i <= count; ++i) names.push_back(prefix + std::to_string(i));
  return names;
}

constexpr const char* kLinearOperatingPoint =
    "q = 0, q' = 0, u = 0, y = 0 (a linear model is its own linearization there)";

}  // namespace

std::vector<std::pair<std::string, std::string>> LinearAnalysisSummary(const LinearModel& model,
                                                                       const LinearAnalysis& a) {
  const LinearZeroDynamics& zeros = a.zero_dynamics;
  std::vector<std::pair<std::string, std::string>> rows = {
      {"parameters", LinearParametersToText(model)},
      {"size", std::to_string(model.dof()) + " coordinates, " + std::to_string(model.num_inputs()) +
                   " inputs, " + std::to_string(model.num_outputs()) + " outputs"},
      {"operating point", kLinearOperatingPoint},
      {"P = H M^-1 B", MatrixToText(a.decoupling.decoupling_matrix)},
      {"singular values of P", VectorToText(a.decoupling.singular_values) + " (zero below " +
                                   FormatShort(a.decoupling.rank_threshold) + ")"},
      {"rank P", std::to_string(a.decoupling.rank) + " of " +
                     std::to_string(a.decoupling.decoupling_matrix.rows()) + ", deficiency " +
                     std::to_string(a.decoupling.rank_deficiency)},
      {"realization", std::string(ToString(a.decoupling.realization))},
      {"relative degree", a.relative_degrees.determined
                              ? IntsToText(a.relative_degrees.relative_degree)
                              : "not determined: " + a.relative_degrees.note},
      {"differentiation index", a.relative_degrees.determined
                                    ? std::to_string(a.differentiation_index) +
                                          " (projected DAE: " + std::to_string(a.projected_index) +
                                          ")"
                                    : std::string("not determined (needs the relative degrees)")},
      {"internal dynamics",
       a.relative_degrees.determined
           ? "order " + std::to_string(a.internal_dynamics_order) + (a.flat ? " (flat)" : "")
           : std::string("order not determined")},
      {"zero dynamics", EigenvaluesToText(zeros.eigenvalues)},
      {"eigenvalues computed", zeros.scope},
      {"error bounds of the zeros",
       VectorToText(Eigen::Map<const Eigen::VectorXd>(zeros.error_bounds.data(),
                                                      Eigen::Index(zeros.error_bounds.size())))},
      {"stability", std::string(ToString(zeros.stability)) +
                        MinimumPhaseText(zeros.stability, zeros.minimum_phase) +
                        (zeros.stability_note.empty() ? "" : " (" + zeros.stability_note + ")")},
      {"oscillatory modes", ModesToText(zeros.modes)},
      {"recommended solver", std::string(ToString(a.recommended_solver))},
  };
  if (model.num_constraints() > 0) {  // after the size, as a closed chain's multibody report
    rows.insert(rows.begin() + 2,
                {"constraints",
                 std::to_string(model.num_constraints()) + " (" +
                     std::to_string(model.dof() - model.num_constraints()) +
                     " degrees of freedom; P and the relative degrees of the bordered system: "
                     "inputs [u; lambda], outputs [y; G q])"});
  }
  return rows;
}

nlohmann::ordered_json LinearAnalysisToJson(const LinearModel& model,
                                            const LinearAnalysis& a,
                                            const LinearAnalysisOptions& options) {
  nlohmann::ordered_json parameters = nlohmann::ordered_json::object();
  for (std::size_t i = 0; i < model.parameter_names().size(); ++i) {
    parameters[model.parameter_names()[i]] = model.parameters()(Eigen::Index(i));
  }
  const LinearZeroDynamics& zeros = a.zero_dynamics;
  nlohmann::ordered_json modes = nlohmann::ordered_json::array();
  for (const Mode& mode : zeros.modes) {
    modes.push_back({{"frequency_hz", mode.frequency_hz}, {"damping_ratio", mode.damping_ratio}});
  }
  nlohmann::ordered_json zero_dynamics = {
      {"eigenvalues", EigenvaluesToJson(zeros.eigenvalues)},
      {"error_bounds", zeros.error_bounds},
      {"stability", ToString(zeros.stability)},
      {"stability_note", zeros.stability_note},
      {"minimum_phase", MinimumPhaseJson(zeros.stability, zeros.minimum_phase)},
      {"modes", modes},
      {"complete", zeros.complete},
      {"zero_count", zeros.zero_count},
      {"scope", zeros.scope},
      {"solver", ToString(zeros.solver_used)},
      {"target", ToString(zeros.target)},
      {"shift", zeros.shift},
  };
  if (zeros.solver_used == LinearEigenSolver::kArpack) {
    zero_dynamics["arpack"] = {{"restarts", zeros.arpack.restarts},
                               {"operator_applications", zeros.arpack.operator_applications},
                               {"basis_size", zeros.arpack.basis_size}};
  }
  const Eigen::VectorXd zero_io = Eigen::VectorXd::Zero(Eigen::Index(model.num_inputs()));
  // Not determined numerically (a fine mesh of a continuum): null, with the note saying why.
  const bool determined = a.relative_degrees.determined;
  nlohmann::ordered_json json = {
      {"model", model.name()},
      {"kind", "linear"},
      {"parameters", parameters},
      {"dof", model.dof()},
      {"inputs", NumberedNames("u", model.num_inputs())},
      {"outputs", NumberedNames("y", model.num_outputs())},
      {"operating_point",
       {{"q", nlohmann::ordered_json::array()},
        {"u", VectorToJson(zero_io)},
        {"y", VectorToJson(zero_io)},
        {"note", std::string(kLinearOperatingPoint) + "; q has dof entries, all 0, not listed"}}},
      {"P", MatrixToJson(a.decoupling.decoupling_matrix)},
      {"P_singular_values", VectorToJson(a.decoupling.singular_values)},
      {"P_rank_threshold", a.decoupling.rank_threshold},
      {"P_rank", a.decoupling.rank},
      {"P_rank_deficiency", a.decoupling.rank_deficiency},
      {"realization", ToString(a.decoupling.realization)},
      {"relative_degree", determined ? nlohmann::ordered_json(a.relative_degrees.relative_degree)
                                     : nlohmann::ordered_json(nullptr)},
      {"relative_degree_note", a.relative_degrees.note},
      {"decoupling_matrix_regular", a.relative_degrees.decoupling_matrix_regular},
      {"differentiation_index", determined ? nlohmann::ordered_json(a.differentiation_index)
                                           : nlohmann::ordered_json(nullptr)},
      {"projected_index",
       determined ? nlohmann::ordered_json(a.projected_index) : nlohmann::ordered_json(nullptr)},
      {"internal_dynamics_order", determined ? nlohmann::ordered_json(a.internal_dynamics_order)
                                             : nlohmann::ordered_json(nullptr)},
      {"flat", a.flat},
      {"zero_dynamics", zero_dynamics},
      {"recommended_solver", ToString(a.recommended_solver)},
      {"tolerances",
       {{"rank_tolerance", options.rank_tolerance},
        {"imaginary_axis_tolerance", options.zero_dynamics.imaginary_axis_tolerance},
        {"infinite_tolerance", options.zero_dynamics.infinite_tolerance}}},
  };
  if (model.num_constraints() > 0) json["constraints"] = model.num_constraints();
  return json;
}

std::string FormatLinearAnalysis(const LinearModel& model,
                                 const LinearAnalysis& analysis,
                                 const LinearAnalysisOptions& options,
                                 ReportFormat format) {
  switch (format) {
    case ReportFormat::kJson:
      return LinearAnalysisToJson(model, analysis, options).dump(2) + "\n";
    case ReportFormat::kMarkdown:
      return RowsToMarkdown(model.name(), model.description(),
                            LinearAnalysisSummary(model, analysis));
    case ReportFormat::kText:
      break;
  }
  return RowsToText(model.name(), model.source(), LinearAnalysisSummary(model, analysis));
}

}  // namespace servokit
