#include "studies/study_support.h"

#include "base/errors.h"
#include "base/number_format.h"

namespace servokit {

double AsIs(double value) { return value; }

std::vector<double> Linspace(double low, double high, int count) {
  std::vector<double> values;
  for (int i = 0; i < count; ++i) {
    values.push_back(count == 1 ? low : low + (high - low) * double(i) / double(count - 1));
  }
  return values;
}

std::vector<SweepPoint> SweepParameter(const Model& model,
                                       std::size_t parameter,
                                       const std::vector<double>& values,
                                       const ClassificationOptions& options) {
  Workspace workspace(model);
  options.Validate(model);
  std::vector<SweepPoint> points;
  for (const double value : values) {
    workspace.parameters(Eigen::Index(parameter)) = value;
    points.push_back(AnalyzeSweepPoint(model, workspace, options));
  }
  return points;
}

std::vector<std::pair<double, double>> RootLocus(const std::vector<SweepPoint>& points) {
  std::vector<std::pair<double, double>> locus;
  for (const SweepPoint& point : points) {
    for (const auto& eigenvalue : point.eigenvalues) {
      locus.emplace_back(eigenvalue.real(), eigenvalue.imag());
    }
  }
  return locus;
}

std::vector<std::pair<double, double>> EigenvalueCurve(const std::vector<SweepPoint>& points,
                                                       const std::vector<double>& values,
                                                       bool imaginary) {
  std::vector<std::pair<double, double>> curve;
  for (std::size_t i = 0; i < points.size(); ++i) {
    for (const auto& eigenvalue : points[i].eigenvalues) {
      curve.emplace_back(values[i], imaginary ? eigenvalue.imag() : eigenvalue.real());
    }
  }
  return curve;
}

Table ThresholdTable(const std::vector<ThresholdSearch>& searches,
                     const std::string& unit,
                     double (*to_display)(double)) {
  Table table;
  table.header = {"event", "parameter", "value" + (unit.empty() ? "" : " [" + unit + "]"),
                  "from",  "to",        "located to"};
  for (const ThresholdSearch& search : searches) {
    if (search.events.empty()) {
      table.rows.push_back({std::string(ToString(search.event)), search.parameter,
                            "none in [" + FormatShort(to_display(search.low)) + ", " +
                                FormatShort(to_display(search.high)) + "]",
                            "", "", ""});
    }
    for (const ThresholdCrossing& event : search.events) {
      table.rows.push_back({std::string(ToString(search.event)), search.parameter,
                            FormatPrecise(to_display(event.value)), event.from,
                            event.to + (event.via.empty() ? "" : " (through " + event.via + ")"),
                            FormatShort(event.bracket_width)});
    }
  }
  return table;
}

void AddClosedForm(Document& document,
                   const CharacteristicPolynomial& closed_form,
                   const std::string& parameter) {
  document.Add(
      Paragraph{"Characteristic polynomial of the linearized zero dynamics, det of the "
                "Rosenbrock matrix at rest (roots = zero-dynamics eigenvalues): `" +
                closed_form.polynomial + "`."});
  Table table;
  table.header = {"condition", "Routh-Hurwitz (Stodola): stable iff all > 0",
                  "solved for " + parameter, "sign changes in the range"};
  for (const HurwitzCondition& condition : closed_form.hurwitz) {
    std::string changes;
    for (const double value : condition.sign_changes) {
      changes += (changes.empty() ? "" : ", ") + FormatPrecise(value);
    }
    table.rows.push_back({condition.name, "`" + condition.expression + "`",
                          condition.solved.empty() ? "" : "`" + condition.solved + "`",
                          changes.empty() ? "none" : changes});
  }
  document.Add(table);
  if (!closed_form.discriminant.empty()) {
    std::string changes;
    for (const double value : closed_form.discriminant_sign_changes) {
      changes += (changes.empty() ? "" : ", ") + FormatPrecise(value);
    }
    document.Add(Paragraph{"Discriminant (negative: a complex pair): `" + closed_form.discriminant +
                           "`; sign changes at " + (changes.empty() ? "none" : changes) + "."});
  }
}

}  // namespace servokit
