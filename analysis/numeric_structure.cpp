#include "analysis/numeric_structure.h"

#include <algorithm>
#include <cmath>
#include <optional>
#include <sstream>
#include <string>
#include <utility>

#include "modeling/motion_series.h"

namespace servokit {
namespace {

// A decision point and the motions from it under u = 0: motions[j] carries the derivatives along
// input j, shifted[s] along state coordinate s (made when a gradient is first needed).
struct DecisionPoint {
  MotionStart start;
  std::optional<double> input_size;  // |M^-1 B| (Frobenius), nullopt when not finite
  std::vector<MotionSeries> motions, shifted;
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
    // As the symbolic route's generic points: small, unrelated values, no multiple of pi/2.
    for (Eigen::Index j = 0; j < n; ++j) {
      const double jj = double(j);
      points_[1].start.q[j] = 0.137 + 0.071 * jj;
      points_[1].start.q_dot[j] = 0.093 - 0.041 * jj;
      points_[2].start.q[j] = -0.211 + 0.053 * jj;
      points_[2].start.q_dot[j] = 0.177 + 0.029 * jj;
    }
    for (DecisionPoint& point : points_) Prepare(point);
  }

  NumericStructure Run() {
    NumericStructure structure;
    std::size_t constraints = 0;
    for (std::size_t i = 0; i < outputs_; ++i) {
      for (int order = 1;; ++order) {
        if (constraints == states_) throw OutputsNotIndependent(i, states_);
        ++constraints;
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
    structure.reference_rank = RankAt(points_[0], structure.relative_degree).value_or(0);
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

  // The motions along the inputs, and |M^-1 B| from them: column j is the derivative of q''(0)
  // along u_j.
  void Prepare(DecisionPoint& point) const {
    double sum = 0.0;
    point.motions.reserve(model_.num_inputs());  // front() is read while the others are made
    for (Eigen::Index j = 0; j < Eigen::Index(model_.num_inputs()); ++j) {
      if (point.motions.empty()) {
        point.motions.emplace_back(model_, model_.parameters(), point.start,
                                   Direction(&MotionStart::u, j), scratch_);
      } else {  // the same start: M(q(0)) factorised once
        point.motions.emplace_back(point.motions.front(), Direction(&MotionStart::u, j));
      }
      sum += point.motions.back().Acceleration().tangent.squaredNorm();
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
        point.shifted.emplace_back(
            point.motions.front(),
            s < n ? Direction(&MotionStart::q, s) : Direction(&MotionStart::q_dot, s - n));
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

  // The rank of A at a point by the rule of the symbolic route's RankAt (singular values above
  // tolerance max_i |grad phi_i| |M^-1 B|), nullopt when undecidable there.
  std::optional<std::size_t> RankAt(DecisionPoint& point,
                                    const std::vector<int>& relative_degree) const {
    if (!point.input_size) return std::nullopt;
    Eigen::MatrixXd matrix(Eigen::Index(outputs_), Eigen::Index(model_.num_inputs()));
    double gradient = 0.0;
    for (std::size_t i = 0; i < outputs_; ++i) {
      const std::optional<Eigen::VectorXd> values = CoefficientsAt(point, i, relative_degree[i]);
      const std::optional<double> size = GradientSize(point, i, relative_degree[i] - 1);
      if (!values || !size) return std::nullopt;
      matrix.row(Eigen::Index(i)) = values->transpose();
      gradient = std::max(gradient, *size);
    }
    const Eigen::JacobiSVD<Eigen::MatrixXd> svd(matrix);
    const double threshold = tolerance_ * gradient * *point.input_size;
    return std::size_t((svd.singularValues().array() > threshold).count());
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
  mutable MotionSeries::Scratch scratch_;  // shared by every motion: one at a time runs
  std::vector<DecisionPoint> points_;
};

}  // namespace

NumericStructure DeriveNumericStructure(const Model& model,
                                        const NonlinearStructureOptions& options) {
  return NumericAlgorithm(model, options).Run();
}

}  // namespace servokit
