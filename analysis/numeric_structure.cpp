#include "analysis/numeric_structure.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <memory>
#include <optional>
#include <sstream>
#include <string>
#include <utility>

#include "modeling/motion_series.h"

namespace servokit {
namespace {

// A decision point and the motions from it under u = 0: motions[j] carries the derivatives along
// input j, shifted[s] along state coordinate s (made when a gradient is first needed), tracked[s]
// likewise for the tracking motions of a dynamic extension.
struct DecisionPoint {
  MotionStart start;
  Eigen::MatrixXd input_acceleration;  // M^-1 B
  std::optional<double> input_size;    // |M^-1 B| (Frobenius), nullopt when not finite
  std::vector<MotionSeries> motions, shifted, tracked;
};

class NumericAlgorithm {
 public:
  NumericAlgorithm(const Model& model, const NonlinearStructureOptions& options)
      : model_(model),
        tolerance_(options.rank_tolerance),
        max_work_(options.max_work),
        states_(2 * model.dof()),
        outputs_(model.num_outputs()) {
    const auto n = Eigen::Index(model.dof());
    const auto m = Eigen::Index(model.num_inputs());
    points_.resize(3);
    for (DecisionPoint& point : points_) {
      point.start = {Eigen::VectorXd(n), Eigen::VectorXd(n), Eigen::VectorXd::Zero(m)};
    }
    points_[0].start.q = options.reference_q.size() == 0 ? Eigen::VectorXd::Zero(n)
                                                         : Eigen::VectorXd(options.reference_q);
    points_[0].start.q_dot.setZero();
    for (std::size_t p = 1; p < points_.size(); ++p) {
      for (Eigen::Index j = 0; j < n; ++j) {
        points_[p].start.q[j] = GenericCoordinate(p, std::size_t(j));
        points_[p].start.q_dot[j] = GenericVelocity(p, std::size_t(j));
      }
    }
    for (DecisionPoint& point : points_) Prepare(point);
  }

  NumericStructure Run() {
    NumericStructure structure;
    for (std::size_t i = 0; i < outputs_; ++i) {
      for (int order = 1;; ++order) {
        if (constraints_ == states_) throw OutputsNotIndependent(i, states_);
        ++constraints_;
        if (!CoefficientsVanish(i, order)) {
          structure.relative_degree.push_back(order);
          break;
        }
        if (std::size_t(order) >= states_) throw OutputNeverDependsOnInputs(i, states_);
      }
    }
    for (std::size_t p = 1; p < points_.size(); ++p) {
      structure.rank_nearby = std::max(structure.rank_nearby,
                                       RankAt(points_[p], structure.relative_degree).value_or(0));
    }
    Eigen::MatrixXd reference;
    const std::optional<std::size_t> reference_rank =
        RankAt(points_[0], structure.relative_degree, {}, &reference);
    structure.reference_rank = reference_rank.value_or(0);
    if (structure.rank_nearby < outputs_) {
      structure.extension =
          Extend(structure,
                 KeptRowsAndColumns(reference, structure.reference_rank, structure.rank_nearby));
    }
    return structure;
  }

 private:
  // A direction of zeros but for `entry` of `part`.
  MotionStart Direction(Eigen::VectorXd MotionStart::*part, Eigen::Index entry) const {
    const auto n = Eigen::Index(model_.dof());
    MotionStart direction{Eigen::VectorXd::Zero(n), Eigen::VectorXd::Zero(n),
                          Eigen::VectorXd::Zero(Eigen::Index(model_.num_inputs()))};
    (direction.*part)[entry] = 1.0;
    return direction;
  }

  // A direction along state coordinate s of (q, q').
  MotionStart StateDirection(Eigen::Index s) const {
    const auto n = Eigen::Index(model_.dof());
    return s < n ? Direction(&MotionStart::q, s) : Direction(&MotionStart::q_dot, s - n);
  }

  // The motions along the inputs, and M^-1 B and |M^-1 B| from them: column j is the derivative
  // of q''(0) along u_j.
  void Prepare(DecisionPoint& point) const {
    double sum = 0.0;
    point.motions.reserve(model_.num_inputs());  // front() is read while the others are made
    point.input_acceleration.resize(Eigen::Index(model_.dof()), Eigen::Index(model_.num_inputs()));
    for (Eigen::Index j = 0; j < Eigen::Index(model_.num_inputs()); ++j) {
      if (point.motions.empty()) {
        point.motions.emplace_back(model_, model_.parameters(), point.start,
                                   Direction(&MotionStart::u, j), scratch_);
      } else {  // the same start: M(q(0)) factorised once
        point.motions.emplace_back(point.motions.front(), Direction(&MotionStart::u, j));
      }
      point.input_acceleration.col(j) = point.motions.back().Acceleration().tangent;
      sum += point.input_acceleration.col(j).squaredNorm();
    }
    if (std::isfinite(sum)) point.input_size = std::sqrt(sum);
  }

  // The u-coefficients of y_i^(order) at a point: its derivatives along the inputs (nullopt
  // when not finite).
  std::optional<Eigen::VectorXd> CoefficientsAt(DecisionPoint& point,
                                                std::size_t i,
                                                int order) const {
    Eigen::VectorXd coefficients(Eigen::Index(point.motions.size()));
    for (std::size_t j = 0; j < point.motions.size(); ++j) {
      const MotionSeries::Derivative derivative = point.motions[j].OutputDerivative(order);
      if (!std::isfinite(derivative.value[Eigen::Index(i)])) return std::nullopt;
      coefficients[Eigen::Index(j)] = derivative.tangent[Eigen::Index(i)];
    }
    if (!coefficients.allFinite()) return std::nullopt;
    return coefficients;
  }

  // |grad_(q, q') y_i^(order)| at u = 0; nullopt when not finite.
  std::optional<double> GradientSize(DecisionPoint& point, std::size_t i, int order) const {
    const auto n = Eigen::Index(model_.dof());
    if (point.shifted.empty()) {
      for (Eigen::Index s = 0; s < 2 * n; ++s) {
        point.shifted.emplace_back(point.motions.front(), StateDirection(s));
      }
    }
    double sum = 0.0;
    for (MotionSeries& motion : point.shifted) {
      const double partial = motion.OutputDerivative(order).tangent[Eigen::Index(i)];
      if (!std::isfinite(partial)) return std::nullopt;
      sum += partial * partial;
    }
    return std::sqrt(sum);
  }

  // As the symbolic route: the coefficients of u in y_i^(order) count as zero when at most
  // tolerance |grad phi| |M^-1 B| at every decision point where that can be decided, phi being
  // y_i^(order - 1) less its desired value; undecidable everywhere counts as non-zero. Exact
  // zeros need no gradient.
  bool CoefficientsVanish(std::size_t i, int order) {
    bool decided = false;
    for (DecisionPoint& point : points_) {
      if (scratch_.work > max_work_) throw PastWorkBudget(i, order);
      const std::optional<Eigen::VectorXd> values = CoefficientsAt(point, i, order);
      if (!values || !point.input_size) continue;
      if (values->isZero(0.0)) {
        decided = true;
        continue;
      }
      const std::optional<double> gradient = GradientSize(point, i, order - 1);
      if (!gradient) continue;
      decided = true;
      if (values->norm() > tolerance_ * *gradient * *point.input_size) return false;
    }
    return decided;
  }

  // The rank of the input equations' matrix at a point by the rule of the symbolic route's
  // RankAt (singular values above tolerance max_i |grad phi_i| |M^-1 B|), nullopt when
  // undecidable there: row i at orders[i], from the tracking motions for the combined rows of a
  // dynamic extension's step. `matrix_out` receives the matrix with the rows that count as zero
  // by the rule set to zero, for the choice of the kept rows: the rounding residue of a
  // coefficient that vanishes there (the crane's y1'' ~ sin(theta) at theta = 0), scaled to unit
  // size, must not be chosen.
  std::optional<std::size_t> RankAt(DecisionPoint& point,
                                    const std::vector<int>& orders,
                                    const std::vector<std::size_t>& combined_rows = {},
                                    Eigen::MatrixXd* matrix_out = nullptr) const {
    if (!point.input_size) return std::nullopt;
    Eigen::MatrixXd matrix(Eigen::Index(outputs_), Eigen::Index(model_.num_inputs()));
    double gradient = 0.0;
    std::vector<Eigen::Index> zero_rows;
    for (std::size_t i = 0; i < outputs_; ++i) {
      std::optional<Eigen::VectorXd> values;
      std::optional<double> size;
      if (std::find(combined_rows.begin(), combined_rows.end(), i) != combined_rows.end()) {
        if (auto combined = CombinedCoefficientsAt(point, i, orders[i])) {
          values = std::move(combined->first);
          size = combined->second;
        }
      } else {
        values = CoefficientsAt(point, i, orders[i]);
        size = GradientSize(point, i, orders[i] - 1);
      }
      if (!values || !size) return std::nullopt;
      matrix.row(Eigen::Index(i)) = values->transpose();
      gradient = std::max(gradient, *size);
      if (values->norm() <= tolerance_ * *size * *point.input_size) {
        zero_rows.push_back(Eigen::Index(i));
      }
    }
    if (matrix_out != nullptr) {
      *matrix_out = matrix;
      for (Eigen::Index row : zero_rows) matrix_out->row(row).setZero();
    }
    const Eigen::JacobiSVD<Eigen::MatrixXd> svd(matrix);
    const double threshold = tolerance_ * gradient * *point.input_size;
    return std::size_t((svd.singularValues().array() > threshold).count());
  }

  // The step's combined rows, differentiated until u appears; nullopt where the numeric route
  // cannot take the step (a kept row of relative degree above 2, or a second step needed).
  std::optional<NumericExtension> Extend(const NumericStructure& first, StructureStep step) {
    for (std::size_t row : step.kept_rows) {
      if (first.relative_degree[row] != 2) return std::nullopt;
    }
    const auto is_kept = [&step](std::size_t row) {
      return std::find(step.kept_rows.begin(), step.kept_rows.end(), row) != step.kept_rows.end();
    };
    std::vector<Eigen::MatrixXd> kappa(points_.size());  // rows: outputs; columns: kept rows
    for (std::size_t p = 0; p < points_.size(); ++p) {
      kappa[p] = Combination(points_[p], first.relative_degree, step);
    }
    for (std::size_t d = 0; d < outputs_; ++d) {
      if (is_kept(d)) continue;
      if (!RemainderVanishes(d, first.relative_degree, step, kappa)) throw InputsNotRemoved(d);
      step.combined_rows.push_back(d);
    }
    for (DecisionPoint& point : points_) PrepareTracking(point, step);
    NumericExtension extension;
    extension.final_order = first.relative_degree;
    for (std::size_t d : step.combined_rows) {
      for (int order = first.relative_degree[d] + 1;; ++order) {
        if (constraints_ == states_) throw OutputsNotIndependent(d, states_);
        ++constraints_;
        if (!CombinedCoefficientsVanish(d, order)) {
          extension.final_order[d] = order;
          break;
        }
      }
    }
    std::size_t rank_nearby = 0;
    for (std::size_t p = 1; p < points_.size(); ++p) {
      rank_nearby = std::max(
          rank_nearby, RankAt(points_[p], extension.final_order, step.combined_rows).value_or(0));
    }
    if (rank_nearby < outputs_) return std::nullopt;  // a second step
    extension.reference_rank =
        RankAt(points_[0], extension.final_order, step.combined_rows).value_or(0);
    extension.constraints = constraints_;
    // Row d's equations read y_d_d to its final order, and each kept row's y_R_d to 2 plus as
    // many orders as g_d was differentiated, where kappa_dR is not zero.
    extension.highest_derivative = extension.final_order;
    for (std::size_t d : step.combined_rows) {
      for (std::size_t b = 0; b < step.kept_rows.size(); ++b) {
        const std::size_t kept = step.kept_rows[b];
        if (!CombinationReads(kappa, d, b)) continue;
        extension.highest_derivative[kept] =
            std::max(extension.highest_derivative[kept],
                     2 + extension.final_order[d] - first.relative_degree[d]);
      }
    }
    extension.step = std::move(step);
    return extension;
  }

  // kappa = A_dC A_RC^-1 at a point, for every row d (rows of the kept ones are unit rows); empty
  // where A or A_RC^-1 is not defined there.
  Eigen::MatrixXd Combination(DecisionPoint& point,
                              const std::vector<int>& relative_degree,
                              const StructureStep& step) const {
    const auto kept = Eigen::Index(step.kept_rows.size());
    Eigen::MatrixXd rows_c(Eigen::Index(outputs_), kept);
    for (std::size_t i = 0; i < outputs_; ++i) {
      const std::optional<Eigen::VectorXd> values = CoefficientsAt(point, i, relative_degree[i]);
      if (!values) return {};
      for (Eigen::Index c = 0; c < kept; ++c)
        rows_c(Eigen::Index(i), c) = (*values)[Eigen::Index(step.delayed_inputs[std::size_t(c)])];
    }
    Eigen::MatrixXd block(kept, kept);
    for (Eigen::Index b = 0; b < kept; ++b)
      block.row(b) = rows_c.row(Eigen::Index(step.kept_rows[std::size_t(b)]));
    // kappa block = rows_c, so kappa^T = block^-T rows_c^T.
    const Eigen::PartialPivLU<Eigen::MatrixXd> lu(block.transpose());
    if (!(lu.rcond() > std::numeric_limits<double>::epsilon())) return {};
    return lu.solve(rows_c.transpose()).transpose();
  }

  // a_d - kappa_d A_R vanishes by the rule at every point where that can be decided (the
  // symbolic route's check of the combined row), phi being row d's last u-free function.
  bool RemainderVanishes(std::size_t d,
                         const std::vector<int>& relative_degree,
                         const StructureStep& step,
                         const std::vector<Eigen::MatrixXd>& kappa) {
    bool decided = false;
    for (std::size_t p = 0; p < points_.size(); ++p) {
      DecisionPoint& point = points_[p];
      if (kappa[p].size() == 0 || !point.input_size) continue;
      std::optional<Eigen::VectorXd> remainder = CoefficientsAt(point, d, relative_degree[d]);
      if (!remainder) continue;
      for (std::size_t b = 0; b < step.kept_rows.size(); ++b) {
        const std::size_t kept = step.kept_rows[b];
        const std::optional<Eigen::VectorXd> row =
            CoefficientsAt(point, kept, relative_degree[kept]);
        if (!row) return false;
        *remainder -= kappa[p](Eigen::Index(d), Eigen::Index(b)) * *row;
      }
      const std::optional<double> gradient = GradientSize(point, d, relative_degree[d] - 1);
      if (!gradient || !remainder->allFinite()) continue;
      decided = true;
      if (remainder->norm() > tolerance_ * *gradient * *point.input_size) return false;
    }
    return decided;
  }

  // Whether g_d reads kept row b (kappa_db is not zero at a generic point).
  bool CombinationReads(const std::vector<Eigen::MatrixXd>& kappa,
                        std::size_t d,
                        std::size_t b) const {
    for (std::size_t p = 1; p < points_.size(); ++p) {
      if (kappa[p].size() == 0) continue;
      const double size = kappa[p].row(Eigen::Index(d)).norm();
      if (std::abs(kappa[p](Eigen::Index(d), Eigen::Index(b))) > tolerance_ * size) return true;
    }
    return false;
  }

  // y_row_d^(k) at decision point p, k = 0 .. 2 dof + 1, as the symbolic route's decision
  // points: at rest at the reference state, small unrelated values elsewhere.
  std::vector<double> Desired(std::size_t p, std::size_t row) {
    std::vector<double> desired(states_ + 2, 0.0);
    if (p == 0) {
      desired[0] = points_[0].motions.front().OutputDerivative(0).value[Eigen::Index(row)];
      return desired;
    }
    for (std::size_t k = 0; k < desired.size(); ++k) {
      desired[k] = GenericDesiredDerivative(p, row, k);
    }
    return desired;
  }

  // One tracking motion per state coordinate: the kept outputs follow the point's desired
  // derivatives through the delayed inputs.
  void PrepareTracking(DecisionPoint& point, const StructureStep& step) {
    auto tracking = std::make_shared<MotionSeries::Tracking>();
    tracking->outputs = step.kept_rows;
    tracking->inputs = step.delayed_inputs;
    const auto p = std::size_t(&point - points_.data());
    for (std::size_t row : step.kept_rows) tracking->desired.push_back(Desired(p, row));
    point.tracked.reserve(states_);
    for (Eigen::Index s = 0; s < Eigen::Index(states_); ++s) {
      point.tracked.emplace_back(point.motions.front(), StateDirection(s), tracking);
    }
  }

  // grad_(q, q') g_d^(order - r_d): the tangents of y_d^(order) along the tracking motions;
  // nullopt when not finite.
  std::optional<Eigen::VectorXd> TrackedGradient(DecisionPoint& point,
                                                 std::size_t d,
                                                 int order) const {
    Eigen::VectorXd gradient(static_cast<Eigen::Index>(states_));
    for (std::size_t s = 0; s < states_; ++s) {
      gradient[Eigen::Index(s)] = point.tracked[s].OutputDerivative(order).tangent[Eigen::Index(d)];
    }
    if (!gradient.allFinite()) return std::nullopt;
    return gradient;
  }

  // The u-coefficients of g_d's derivative that reaches y_d^(order), grad_q' M^-1 B, with the
  // gradient's size; nullopt when not finite.
  std::optional<std::pair<Eigen::VectorXd, double>> CombinedCoefficientsAt(DecisionPoint& point,
                                                                           std::size_t d,
                                                                           int order) const {
    if (!point.input_size) return std::nullopt;
    const std::optional<Eigen::VectorXd> gradient = TrackedGradient(point, d, order - 1);
    if (!gradient) return std::nullopt;
    const auto n = Eigen::Index(model_.dof());
    Eigen::VectorXd coefficients = point.input_acceleration.transpose() * gradient->tail(n);
    if (!coefficients.allFinite()) return std::nullopt;
    return std::make_pair(std::move(coefficients), gradient->norm());
  }

  // As CoefficientsVanish, for a combined row.
  bool CombinedCoefficientsVanish(std::size_t d, int order) {
    bool decided = false;
    for (DecisionPoint& point : points_) {
      if (scratch_.work > max_work_) throw PastWorkBudget(d, order);
      const auto coefficients = CombinedCoefficientsAt(point, d, order);
      if (!coefficients) continue;
      decided = true;
      if (coefficients->first.norm() > tolerance_ * coefficients->second * *point.input_size) {
        return false;
      }
    }
    return decided;
  }

  // Each order is dearer than the last: its motions reach a higher degree, and a gradient takes
  // 2 dof of them.
  NoSolution PastWorkBudget(std::size_t i, int order) const {
    std::ostringstream message;
    message << "output y" << i + 1 << ": deciding whether the inputs appear in its derivative "
            << "of order " << order << " takes the structure algorithm past its work budget ("
            << max_work_ << " Taylor operations); in the orders below, the inputs' "
            << "coefficients vanish to the rank tolerance";
    return NoSolution(message.str());
  }

  const Model& model_;
  const double tolerance_, max_work_;
  const std::size_t states_, outputs_;
  std::size_t constraints_ = 0;            // the u-free constraints so far
  mutable MotionSeries::Scratch scratch_;  // shared by every motion: one at a time runs
  std::vector<DecisionPoint> points_;
};

}  // namespace

NumericStructure DeriveNumericStructure(const Model& model,
                                        const NonlinearStructureOptions& options) {
  return NumericAlgorithm(model, options).Run();
}

}  // namespace servokit
