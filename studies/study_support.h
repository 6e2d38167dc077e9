#pragma once
// Pieces shared by the studies: the paper's report and the report of any model.
#include <string>
#include <vector>

#include "analysis/characteristic_polynomial.h"
#include "analysis/sweep_point.h"
#include "analysis/thresholds.h"
#include "modeling/model.h"
#include "reports/document.h"
#include "reports/plots.h"

namespace servokit {

/// SweepPoints along one parameter, the others at their nominal values, each classified with
/// `options` (its operating point: --y0, --q0).
std::vector<SweepPoint> SweepParameter(const Model& model,
                                       std::size_t parameter,
                                       const std::vector<double>& values,
                                       const ClassificationOptions& options = {});

/// n values from low to high inclusive.
std::vector<double> Linspace(double low, double high, int count);

/// The eigenvalues of `points` as (Re, Im) pairs (a root locus).
std::vector<std::pair<double, double>> RootLocus(const std::vector<SweepPoint>& points);

/// (value, f(eigenvalue k)) pairs for every point that has at least k + 1 eigenvalues.
std::vector<std::pair<double, double>> EigenvalueCurve(const std::vector<SweepPoint>& points,
                                                       const std::vector<double>& values,
                                                       bool imaginary);

/// A table of located events; values printed through `to_display` (e.g. radians to degrees).
Table ThresholdTable(const std::vector<ThresholdSearch>& searches,
                     const std::string& unit,
                     double (*to_display)(double));

/// The closed form as paragraphs and a table of Routh-Hurwitz conditions.
void AddClosedForm(Document& document,
                   const CharacteristicPolynomial& closed_form,
                   const std::string& parameter);

/// Identity, for tables in SI units.
double AsIs(double value);

}  // namespace servokit
