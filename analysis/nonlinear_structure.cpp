#include "analysis/nonlinear_structure.h"

#include <algorithm>
#include <cmath>
#include <exception>
#include <optional>
#include <set>
#include <string>
#include <utility>
#include <vector>

#include "analysis/numeric_structure.h"
#include "base/errors.h"
#include "modeling/canonical_expression.h"
#include "modeling/expansion_bound.h"
#include "modeling/symbolic_lock.h"
#include "modeling/symbolic_model.h"

namespace servokit {
namespace {

using GiNaC::ex;

std::string OutputName(std::size_t output) { return "y" + std::to_string(output + 1); }

// The value of a GiNaC expression at `point` (every symbol in it replaced by a number), or
// nullopt when it is not a finite real number there (a pole, the root of a negative number).
std::optional<double> ValueAt(const ex& expression, const GiNaC::exmap& point) {
  try {
    const ex value = expression.subs(point).evalf();
    if (!GiNaC::is_a<GiNaC::numeric>(value)) return std::nullopt;
    const GiNaC::numeric number = GiNaC::ex_to<GiNaC::numeric>(value);
    if (!number.is_real()) return std::nullopt;
    const double result = number.to_double();
    if (!std::isfinite(result)) return std::nullopt;
    return result;
  } catch (const std::exception&) {
    return std::nullopt;
  }
}

// The model's equations ready for differentiation: q'' = drift + sum_k u_k acceleration_input[k]
// (q'' = M^-1 (B u - f), paper Eq. 1), with the parameters whose nominal value is 0
// substituted exactly, so that sin(alpha) and d s_dot vanish identically in mass on car case 4.
struct Dynamics {
  std::vector<GiNaC::realsymbol> parameters, coordinates, velocities;
  std::vector<std::vector<GiNaC::realsymbol>> output_derivatives;  // [output][0..2 dof + 1]
  std::vector<ex> outputs;                                         // h_i(q)
  std::vector<ex> acceleration_drift;                              // -M^-1 f
  std::vector<std::vector<ex>> acceleration_input;                 // [input][coordinate]: M^-1 B
  std::vector<std::size_t> zero_parameters;                        // substituted by 0
};

// The most terms BoundExpandedTerms may promise for a derivative's numerator and denominator
// before it is kept as derived instead of brought onto one denominator: normal() cancels common
// factors by multivariate gcds, whose cost grows much faster than the result (issue #31: a
// two-link arm with an elastic joint, relative degrees {2, 4} after a dynamic extension, spent
// 5 s there; its fourth derivative promises 1.8e15). The decisions are numeric at the decision
// points either way; normalised forms are only smaller. The gantry crane's largest derivative
// (3.1e5) is kept as derived, which moves its algebraic solve by 1.5e-13 relative. The
// accelerations M^-1 (B u - f) are bounded the same way: a force that is a product of ten sums
// of five terms would expand to 5^10 terms (solve ran past 120 s).
constexpr double kMaxNormalTerms = 1e5;

Dynamics BuildDynamics(const Model& model) {
  const SymbolicModel& symbolic = model.symbolic();
  Dynamics dynamics;
  dynamics.parameters = symbolic.parameters();
  dynamics.coordinates = symbolic.coordinates();
  dynamics.velocities = symbolic.velocities();
  GiNaC::exmap zero;
  for (std::size_t p = 0; p < dynamics.parameters.size(); ++p) {
    if (model.parameters()[static_cast<Eigen::Index>(p)] == 0.0) {
      zero[dynamics.parameters[p]] = 0;
      dynamics.zero_parameters.push_back(p);
    }
  }
  const auto substitute = [&zero](const GiNaC::matrix& matrix) {
    return GiNaC::ex_to<GiNaC::matrix>(matrix.subs(zero));
  };
  const GiNaC::matrix mass_inverse = substitute(symbolic.mass_matrix()).inverse();
  const GiNaC::matrix drift = mass_inverse.mul(substitute(symbolic.forces())).mul_scalar(-1);
  const GiNaC::matrix input = mass_inverse.mul(substitute(symbolic.input_matrix()));
  const GiNaC::matrix output = substitute(symbolic.output());
  const unsigned dof = static_cast<unsigned>(symbolic.dof());
  for (unsigned j = 0; j < dof; ++j) {
    dynamics.acceleration_drift.push_back(NormalWithinBudget(drift(j, 0), kMaxNormalTerms));
  }
  for (unsigned k = 0; k < input.cols(); ++k) {
    std::vector<ex> column;
    for (unsigned j = 0; j < dof; ++j) {
      column.push_back(NormalWithinBudget(input(j, k), kMaxNormalTerms));
    }
    dynamics.acceleration_input.push_back(std::move(column));
  }
  for (unsigned i = 0; i < output.rows(); ++i) {
    dynamics.outputs.push_back(output(i, 0));
    std::vector<GiNaC::realsymbol> symbols;
    std::string name = OutputName(i) + "_d";
    for (unsigned k = 0; k <= 2 * dof + 1; ++k, name += "'") symbols.emplace_back(name);
    dynamics.output_derivatives.push_back(std::move(symbols));
  }
  return dynamics;
}

// The time derivative of a u-free function phi(q, q', Y) along the motion:
// drift + sum_k u_k input_coefficients[k].
struct TimeDerivative {
  ex drift;
  std::vector<ex> input_coefficients;
};

TimeDerivative Differentiate(const ex& function, const Dynamics& dynamics) {
  TimeDerivative derivative;
  derivative.input_coefficients.assign(dynamics.acceleration_input.size(), 0);
  ex drift = 0;
  for (std::size_t j = 0; j < dynamics.coordinates.size(); ++j) {
    drift += function.diff(dynamics.coordinates[j]) * dynamics.velocities[j];
    const ex by_velocity = function.diff(dynamics.velocities[j]);
    if (by_velocity.is_zero()) continue;
    drift += by_velocity * dynamics.acceleration_drift[j];
    for (std::size_t k = 0; k < dynamics.acceleration_input.size(); ++k) {
      derivative.input_coefficients[k] += by_velocity * dynamics.acceleration_input[k][j];
    }
  }
  for (const auto& symbols : dynamics.output_derivatives) {
    for (std::size_t k = 0; k + 1 < symbols.size(); ++k) {
      if (function.has(symbols[k])) drift += function.diff(symbols[k]) * symbols[k + 1];
    }
  }
  derivative.drift = NormalWithinBudget(drift, kMaxNormalTerms);
  for (ex& coefficient : derivative.input_coefficients) {
    coefficient = NormalWithinBudget(coefficient, kMaxNormalTerms);
  }
  return derivative;
}

// A state where rank decisions are made, with |M^-1 B| there (Frobenius; nullopt when M^-1 B
// is not finite there).
struct DecisionPoint {
  GiNaC::exmap values;
  std::optional<double> input_size;
};

// The reference state (q as given, q' = 0, y_d at rest: Y_i0 = h_i(q), higher derivatives 0)
// and two generic states. Generic, because a coefficient that vanishes at the reference only
// (the gantry crane's y1'' has one proportional to sin(theta)) still puts u into that
// derivative everywhere else.
std::vector<DecisionPoint> DecisionPoints(const Dynamics& dynamics,
                                          const Eigen::VectorXd& parameter_values,
                                          const Eigen::VectorXd& reference_q) {
  GiNaC::exmap nominal;
  for (std::size_t p = 0; p < dynamics.parameters.size(); ++p) {
    nominal[dynamics.parameters[p]] =
        GiNaC::numeric(parameter_values[static_cast<Eigen::Index>(p)]);
  }
  std::vector<DecisionPoint> points(3, DecisionPoint{nominal, std::nullopt});
  for (std::size_t j = 0; j < dynamics.coordinates.size(); ++j) {
    const auto index = static_cast<Eigen::Index>(j);
    points[0].values[dynamics.coordinates[j]] =
        GiNaC::numeric(reference_q.size() == 0 ? 0.0 : reference_q[index]);
    points[0].values[dynamics.velocities[j]] = 0;
    for (std::size_t p = 1; p < points.size(); ++p) {
      points[p].values[dynamics.coordinates[j]] = GiNaC::numeric(GenericCoordinate(p, j));
      points[p].values[dynamics.velocities[j]] = GiNaC::numeric(GenericVelocity(p, j));
    }
  }
  for (std::size_t i = 0; i < dynamics.output_derivatives.size(); ++i) {
    const auto& symbols = dynamics.output_derivatives[i];
    const std::optional<double> rest = ValueAt(dynamics.outputs[i], points[0].values);
    for (std::size_t k = 0; k < symbols.size(); ++k) {
      points[0].values[symbols[k]] = GiNaC::numeric(k == 0 && rest ? *rest : 0.0);
      for (std::size_t p = 1; p < points.size(); ++p) {
        points[p].values[symbols[k]] = GiNaC::numeric(GenericDesiredDerivative(p, i, k));
      }
    }
  }
  for (DecisionPoint& point : points) {
    double sum = 0;
    bool finite = true;
    for (const auto& column : dynamics.acceleration_input) {
      for (const ex& entry : column) {
        const std::optional<double> value = ValueAt(entry, point.values);
        if (!value) finite = false;
        if (value) sum += *value * *value;
      }
    }
    if (finite) point.input_size = std::sqrt(sum);
  }
  return points;
}

// |grad_(q, q') phi| at a point, nullopt when not finite there.
std::optional<double> GradientSize(const ex& function,
                                   const Dynamics& dynamics,
                                   const DecisionPoint& point) {
  double sum = 0;
  for (const auto* symbols : {&dynamics.coordinates, &dynamics.velocities}) {
    for (const auto& symbol : *symbols) {
      const ex partial = function.diff(symbol);
      if (partial.is_zero()) continue;
      const std::optional<double> value = ValueAt(partial, point.values);
      if (!value) return std::nullopt;
      sum += *value * *value;
    }
  }
  return std::sqrt(sum);
}

// The u-coefficients at a point, nullopt when one is not finite there.
std::optional<Eigen::VectorXd> CoefficientsAt(const std::vector<ex>& coefficients,
                                              const DecisionPoint& point) {
  Eigen::VectorXd values(static_cast<Eigen::Index>(coefficients.size()));
  for (std::size_t k = 0; k < coefficients.size(); ++k) {
    const std::optional<double> value = ValueAt(coefficients[k], point.values);
    if (!value) return std::nullopt;
    values[static_cast<Eigen::Index>(k)] = *value;
  }
  return values;
}

// True when the coefficients of u in the derivative of `function` count as zero at every
// decision point where that can be decided: |a| <= tolerance |grad phi| |M^-1 B| (analyze's
// rule for a Markov row). Undecidable everywhere counts as non-zero.
bool CoefficientsVanish(const std::vector<ex>& coefficients,
                        const ex& function,
                        const Dynamics& dynamics,
                        const std::vector<DecisionPoint>& points,
                        double tolerance) {
  if (std::all_of(coefficients.begin(), coefficients.end(),
                  [](const ex& coefficient) { return coefficient.is_zero(); })) {
    return true;
  }
  bool decided = false;
  for (const DecisionPoint& point : points) {
    const std::optional<Eigen::VectorXd> values = CoefficientsAt(coefficients, point);
    const std::optional<double> gradient = GradientSize(function, dynamics, point);
    if (!values || !gradient || !point.input_size) continue;
    decided = true;
    if (values->norm() > tolerance * *gradient * *point.input_size) return false;
  }
  return decided;
}

// The parameters that occur in `expressions`: the derivation relies on their nominal values
// when those expressions are dropped as numerically zero.
void AddParametersOf(const std::vector<ex>& expressions,
                     const Dynamics& dynamics,
                     std::set<std::size_t>& pinned) {
  for (const ex& expression : expressions) {
    for (std::size_t p = 0; p < dynamics.parameters.size(); ++p) {
      if (expression.has(dynamics.parameters[p])) pinned.insert(p);
    }
  }
}

// One output's equation as the algorithm carries it: a u-free function, differentiated until
// u appears in its derivative.
struct Row {
  ex function;  // u-free, of order `order`
  int order = 0;
  bool finished = false;  // u appeared: drift + coefficients u is its input equation
  ex drift;
  std::vector<ex> coefficients;
};

// The rank of the rows' u-coefficient matrix at a point by analyze's rule (singular values
// above tolerance max_i |grad phi_i| |M^-1 B|), nullopt when undecidable there.
std::optional<std::size_t> RankAt(const std::vector<Row>& rows,
                                  const Dynamics& dynamics,
                                  const DecisionPoint& point,
                                  double tolerance,
                                  Eigen::MatrixXd* matrix_out = nullptr) {
  if (!point.input_size) return std::nullopt;
  const auto m = static_cast<Eigen::Index>(rows.size());
  Eigen::MatrixXd matrix(m, m);
  double gradient = 0;
  for (Eigen::Index i = 0; i < m; ++i) {
    const Row& row = rows[static_cast<std::size_t>(i)];
    const std::optional<Eigen::VectorXd> values = CoefficientsAt(row.coefficients, point);
    const std::optional<double> size = GradientSize(row.function, dynamics, point);
    if (!values || !size) return std::nullopt;
    matrix.row(i) = values->transpose();
    gradient = std::max(gradient, *size);
  }
  if (matrix_out != nullptr) *matrix_out = matrix;
  const Eigen::JacobiSVD<Eigen::MatrixXd> svd(matrix);
  const double threshold = tolerance * gradient * *point.input_size;
  return static_cast<std::size_t>((svd.singularValues().array() > threshold).count());
}

}  // namespace

int NonlinearStructure::integrators() const {
  int sum = 0;
  for (int order : highest_derivative) sum += order;
  return sum - static_cast<int>(constraints.size());
}

std::vector<GiNaC::ex> NonlinearStructure::ProgramInputs() const {
  const SymbolicLock lock;
  std::vector<ex> inputs(parameters.begin(), parameters.end());
  inputs.insert(inputs.end(), coordinates.begin(), coordinates.end());
  inputs.insert(inputs.end(), velocities.begin(), velocities.end());
  for (const auto& symbols : output_derivatives)
    inputs.insert(inputs.end(), symbols.begin(), symbols.end());
  return inputs;
}

namespace {

// The structure algorithm's state: the rows being differentiated and what they have given.
class StructureAlgorithm {
 public:
  StructureAlgorithm(const Model& model, const NonlinearStructureOptions& options)
      : dynamics_(BuildDynamics(model)),
        points_(DecisionPoints(dynamics_, model.parameters(), options.reference_q)),
        tolerance_(options.rank_tolerance),
        states_(2 * model.dof()),
        rows_(model.num_outputs()),
        pinned_(dynamics_.zero_parameters.begin(), dynamics_.zero_parameters.end()) {
    structure_.relative_degree.assign(rows_.size(), 0);
    for (std::size_t i = 0; i < rows_.size(); ++i) {
      rows_[i].function = dynamics_.outputs[i] - dynamics_.output_derivatives[i][0];
    }
  }

  NonlinearStructure Run() {
    for (;;) {
      for (std::size_t i = 0; i < rows_.size(); ++i) DifferentiateUntilInputsAppear(i);
      const std::size_t rank = RankNearby();
      if (rank == rows_.size()) break;
      structure_.extension_steps.push_back(ExtendDynamically(rank));
    }
    return Finish();
  }

 private:
  NoSolution NotIndependent(std::size_t row) const { return OutputsNotIndependent(row, states_); }

  // Row i's u-free functions become constraints until u appears in a derivative.
  void DifferentiateUntilInputsAppear(std::size_t i) {
    Row& row = rows_[i];
    const int max_order = static_cast<int>(states_);
    while (!row.finished) {
      if (structure_.constraints.size() == states_) throw NotIndependent(i);
      structure_.constraints.push_back(row.function);
      structure_.constraint_row.push_back(i);
      structure_.constraint_order.push_back(row.order);
      TimeDerivative derivative = Differentiate(row.function, dynamics_);
      ++row.order;
      if (!CoefficientsVanish(derivative.input_coefficients, row.function, dynamics_, points_,
                              tolerance_)) {
        row.finished = true;
        row.drift = derivative.drift;
        row.coefficients = std::move(derivative.input_coefficients);
        if (structure_.relative_degree[i] == 0) structure_.relative_degree[i] = row.order;
        return;
      }
      // Coefficients zero only numerically are dropped: the derivation then holds for the
      // nominal values of the parameters in them.
      AddParametersOf(derivative.input_coefficients, dynamics_, pinned_);
      row.function = derivative.drift;
      if (row.order >= max_order && structure_.relative_degree[i] == 0) {
        throw OutputNeverDependsOnInputs(i, std::size_t(max_order));
      }
    }
  }

  // The rank of the input equations' matrix on a neighbourhood: the largest at the generic
  // points.
  std::size_t RankNearby() const {
    std::size_t rank = 0;
    for (std::size_t p = 1; p < points_.size(); ++p) {
      rank = std::max(rank, RankAt(rows_, dynamics_, points_[p], tolerance_).value_or(0));
    }
    return rank;
  }

  // One step of the dynamic extension: keep `rank` rows whose block is regular at the
  // reference state, replace every other row d by g_d = drift_d - A_dC A_RC^-1 drift_R.
  StructureStep ExtendDynamically(std::size_t rank) {
    const std::size_t m = rows_.size();
    Eigen::MatrixXd reference;
    const std::optional<std::size_t> reference_rank =
        RankAt(rows_, dynamics_, points_[0], tolerance_, &reference);
    StructureStep step = KeptRowsAndColumns(reference, reference_rank.value_or(0), rank);
    const auto rho = static_cast<unsigned>(rank);
    GiNaC::matrix kept_block(rho, rho);
    for (unsigned a = 0; a < rho; ++a) {
      for (unsigned b = 0; b < rho; ++b) {
        kept_block(a, b) = rows_[step.kept_rows[a]].coefficients[step.delayed_inputs[b]];
      }
    }
    const GiNaC::matrix kept_inverse = kept_block.inverse();
    for (std::size_t d = 0; d < m; ++d) {
      if (std::find(step.kept_rows.begin(), step.kept_rows.end(), d) != step.kept_rows.end()) {
        continue;
      }
      CombineWithKeptRows(d, step, kept_inverse);
      step.combined_rows.push_back(d);
    }
    return step;
  }

  // kappa = A_dC A_RC^-1, then g_d = drift_d - kappa drift_R, whose u-coefficients
  // a_d - kappa A_R vanish on a neighbourhood (rank rho): row d is u-free again.
  void CombineWithKeptRows(std::size_t d,
                           const StructureStep& step,
                           const GiNaC::matrix& kept_inverse) {
    Row& row = rows_[d];
    const unsigned rho = kept_inverse.rows();
    std::vector<ex> kappa(rho, 0);
    for (unsigned b = 0; b < rho; ++b) {
      for (unsigned a = 0; a < rho; ++a) {
        kappa[b] += row.coefficients[step.delayed_inputs[a]] * kept_inverse(a, b);
      }
    }
    ex combined = row.drift;
    std::vector<ex> remainder = row.coefficients;
    for (unsigned b = 0; b < rho; ++b) {
      const Row& kept_row = rows_[step.kept_rows[b]];
      combined -= kappa[b] * kept_row.drift;
      for (std::size_t k = 0; k < remainder.size(); ++k) {
        remainder[k] -= kappa[b] * kept_row.coefficients[k];
      }
    }
    for (ex& entry : remainder) entry = NormalWithinBudget(entry, kMaxNormalTerms);
    if (!CoefficientsVanish(remainder, row.function, dynamics_, points_, tolerance_)) {
      throw InputsNotRemoved(d);
    }
    AddParametersOf(remainder, dynamics_, pinned_);
    row.function = NormalWithinBudget(combined, kMaxNormalTerms);
    if (row.function.is_zero()) throw NotIndependent(d);
    row.finished = false;
  }

  // The input equations, the derivatives of y_d read, the symbols.
  NonlinearStructure Finish() {
    const std::size_t m = rows_.size();
    structure_.reference_rank = RankAt(rows_, dynamics_, points_[0], tolerance_).value_or(0);
    for (const Row& row : rows_) {
      structure_.input_drift.push_back(row.drift);
      structure_.input_coefficients.push_back(row.coefficients);
    }
    structure_.highest_derivative.assign(m, 0);
    const auto reads = [&](const ex& expression) {
      for (std::size_t i = 0; i < m; ++i) {
        const auto& symbols = dynamics_.output_derivatives[i];
        for (std::size_t k = symbols.size(); k-- > 0;) {
          if (expression.has(symbols[k])) {
            structure_.highest_derivative[i] =
                std::max(structure_.highest_derivative[i], static_cast<int>(k));
            break;
          }
        }
      }
    };
    for (const ex& constraint : structure_.constraints) reads(constraint);
    for (std::size_t i = 0; i < m; ++i) {
      reads(structure_.input_drift[i]);
      for (const ex& coefficient : structure_.input_coefficients[i]) reads(coefficient);
    }
    structure_.parameters = dynamics_.parameters;
    structure_.coordinates = dynamics_.coordinates;
    structure_.velocities = dynamics_.velocities;
    for (std::size_t i = 0; i < m; ++i) {
      const auto& symbols = dynamics_.output_derivatives[i];
      structure_.output_derivatives.emplace_back(
          symbols.begin(), symbols.begin() + structure_.highest_derivative[i] + 1);
    }
    structure_.pinned_parameters.assign(pinned_.begin(), pinned_.end());
    return std::move(structure_);
  }

  const Dynamics dynamics_;
  const std::vector<DecisionPoint> points_;
  const double tolerance_;
  const std::size_t states_;
  std::vector<Row> rows_;
  std::set<std::size_t> pinned_;
  NonlinearStructure structure_;
};

}  // namespace

NonlinearStructure DeriveNonlinearStructure(const Model& model,
                                            const NonlinearStructureOptions& options) {
  const SymbolicLock lock;
  return StructureAlgorithm(model, options).Run();
}

namespace {

// The summary's note from its other fields: the rank of A at the operating point when it is
// lower there than nearby, else the dynamic extension (its first step's rank).
std::string StructureNote(const NonlinearStructureSummary& summary,
                          std::size_t reference_rank,
                          std::size_t extension_rank,
                          std::size_t m) {
  if (!summary.defined_at_operating_point) {
    const bool scalar_p = m == 1 && summary.relative_degree[0] == 2 && !summary.extended;
    return std::string(scalar_p ? "P" : "the inputs' coefficient matrix") +
           " vanishes at the operating point only (rank " + std::to_string(reference_rank) +
           " of " + std::to_string(m) + " there, " + std::to_string(m) +
           " nearby): the relative degree is not defined there, and the structure of "
           "the linearization (flat or tangential) holds for the linearization only";
  }
  if (!summary.extended) return "";
  std::string names;
  for (std::size_t i = 0; i < summary.delayed_inputs.size(); ++i) {
    names += (i ? ", " : "") + summary.delayed_inputs[i];
  }
  return "the inputs' coefficient matrix is singular on a neighbourhood (rank " +
         std::to_string(extension_rank) + " of " + std::to_string(m) +
         "); a dynamic extension delays " + names + " through " +
         std::to_string(summary.integrators) + " integrator" +
         (summary.integrators == 1 ? "" : "s");
}

// The summary of the numeric route: A regular nearby, or one step of a dynamic extension.
NonlinearStructureSummary NumericSummary(const Model& model, const NumericStructure& numeric) {
  NonlinearStructureSummary summary;
  summary.route = kNumericRoute;
  summary.derived = true;
  summary.relative_degree = numeric.relative_degree;
  summary.extended_relative_degree = numeric.relative_degree;
  int constraints = 0;
  for (int order : numeric.relative_degree) constraints += order;
  std::size_t reference_rank = numeric.reference_rank, extension_rank = 0;
  if (numeric.extension) {
    const NumericExtension& extension = *numeric.extension;
    summary.extended = true;
    for (std::size_t input : extension.step.delayed_inputs)
      summary.delayed_inputs.push_back(model.inputs()[input]);
    summary.extended_relative_degree = extension.highest_derivative;
    constraints = int(extension.constraints);
    int highest = 0;
    for (int order : extension.highest_derivative) highest += order;
    summary.integrators = highest - constraints;
    reference_rank = extension.reference_rank;
    extension_rank = extension.step.rank;
  }
  summary.internal_order = 2 * model.dof() - std::size_t(constraints);
  const std::size_t m = model.num_outputs();
  summary.defined_at_operating_point = reference_rank == m;
  summary.note = StructureNote(summary, reference_rank, extension_rank, m);
  return summary;
}

// The summary of the symbolic route.
NonlinearStructureSummary SymbolicSummary(const Model& model,
                                          const NonlinearStructureOptions& options) {
  // The structure's expressions live in this scope: they are made and destroyed under the lock.
  const SymbolicLock lock;
  NonlinearStructureSummary summary;
  summary.route = kSymbolicRoute;
  NonlinearStructure structure;
  try {
    structure = DeriveNonlinearStructure(model, options);
  } catch (const NoSolution& error) {
    summary.note = error.what();
    return summary;
  }
  summary.derived = true;
  summary.relative_degree = structure.relative_degree;
  summary.extended = structure.extended();
  std::set<std::size_t> delayed;
  for (const StructureStep& step : structure.extension_steps) {
    delayed.insert(step.delayed_inputs.begin(), step.delayed_inputs.end());
  }
  for (std::size_t input : delayed) summary.delayed_inputs.push_back(model.inputs()[input]);
  summary.integrators = structure.integrators();
  summary.extended_relative_degree = structure.highest_derivative;
  summary.internal_order = structure.internal_order();
  const std::size_t m = model.num_outputs();
  summary.defined_at_operating_point = structure.reference_rank == m;
  summary.note = StructureNote(summary, structure.reference_rank,
                               summary.extended ? structure.extension_steps.front().rank : 0, m);
  return summary;
}

}  // namespace

NonlinearStructureSummary SummarizeNonlinearStructure(const Model& model,
                                                      const NonlinearStructureOptions& options) {
  try {
    const NumericStructure numeric = DeriveNumericStructure(model, options);
    if (numeric.rank_nearby == model.num_outputs() || numeric.extension) {
      return NumericSummary(model, numeric);
    }
  } catch (const NoSolution& error) {
    NonlinearStructureSummary summary;
    summary.route = kNumericRoute;
    summary.note = error.what();
    return summary;
  }
  return SymbolicSummary(model, options);
}

}  // namespace servokit
