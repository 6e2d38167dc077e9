#include "solvers/motion_extension.h"

#include <algorithm>
#include <limits>

namespace servokit {
namespace {

class Interpolated final : public MotionExtension {
 public:
  Interpolated(DenseOutput states, Eigen::Index dof)
      : MotionExtension(states.start(), states.end()), states_(std::move(states)), dof_(dof) {}

  bool Evaluate(double t,
                Eigen::VectorXd& q,
                Eigen::VectorXd& q_dot,
                Eigen::VectorXd& u,
                std::string&) const override {
    states_.Evaluate(t, x_);
    q = x_.head(dof_);
    q_dot = x_.segment(dof_, dof_);
    u = x_.tail(x_.size() - 2 * dof_);
    return true;
  }

 private:
  DenseOutput states_;
  Eigen::Index dof_;
  mutable Eigen::VectorXd x_;
};

class Mapped final : public MotionExtension {
 public:
  Mapped(InternalStateMap map,
         std::function<Eigen::VectorXd(double)> internal_state,
         double start,
         double end)
      : MotionExtension(start, end),
        map_(std::move(map)),
        internal_state_(std::move(internal_state)) {}

  bool Evaluate(double t,
                Eigen::VectorXd& q,
                Eigen::VectorXd& q_dot,
                Eigen::VectorXd& u,
                std::string& why) const override {
    t = std::clamp(t, start(), end());
    return map_(t, internal_state_(t), q, q_dot, u, why);
  }

 private:
  InternalStateMap map_;
  std::function<Eigen::VectorXd(double)> internal_state_;
};

class Algebraic final : public MotionExtension {
 public:
  Algebraic(std::shared_ptr<const AlgebraicInverse> inverse,
            const Model& model,
            const OutputTrajectory& trajectory,
            std::vector<double> times,
            std::vector<Eigen::VectorXd> q,
            std::vector<Eigen::VectorXd> q_dot)
      : MotionExtension(times.front(), times.back()),
        inverse_(std::move(inverse)),
        parameters_(model.parameters()),
        trajectory_(trajectory),
        times_(std::move(times)),
        q_(std::move(q)),
        q_dot_(std::move(q_dot)) {}

  bool Evaluate(double t,
                Eigen::VectorXd& q,
                Eigen::VectorXd& q_dot,
                Eigen::VectorXd& u,
                std::string& why) const override {
    t = std::clamp(t, start(), end());
    const auto after = std::upper_bound(times_.begin(), times_.end(), t) - times_.begin();
    const auto index = std::size_t(std::max<std::ptrdiff_t>(after - 1, 0));
    q = q_[index];
    q_dot = q_dot_[index];
    const int highest = inverse_->highest_output_derivative();
    Eigen::MatrixXd derivatives;
    trajectory_.Derivatives(t, highest, derivatives);
    return inverse_->Evaluate(derivatives, parameters_, q, q_dot, u, why);
  }

 private:
  std::shared_ptr<const AlgebraicInverse> inverse_;
  Eigen::VectorXd parameters_;
  const OutputTrajectory& trajectory_;
  std::vector<double> times_;
  std::vector<Eigen::VectorXd> q_, q_dot_;
};

class Padded final : public MotionExtension {
 public:
  Padded(std::shared_ptr<const MotionExtension> inner,
         double start,
         double end,
         RestState before,
         RestState after)
      : MotionExtension(start, end),
        inner_(std::move(inner)),
        before_(std::move(before)),
        after_(std::move(after)) {}

  bool Evaluate(double t,
                Eigen::VectorXd& q,
                Eigen::VectorXd& q_dot,
                Eigen::VectorXd& u,
                std::string& why) const override {
    if (t < inner_->start() || t > inner_->end()) {
      const RestState& rest = t < inner_->start() ? before_ : after_;
      q = rest.q;
      q_dot = Eigen::VectorXd::Zero(rest.q.size());
      u = rest.u;
      return true;
    }
    return inner_->Evaluate(t, q, q_dot, u, why);
  }

 private:
  std::shared_ptr<const MotionExtension> inner_;
  RestState before_, after_;
};

}  // namespace

std::shared_ptr<const MotionExtension> InterpolatedMotion(DenseOutput states, Eigen::Index dof) {
  return std::make_shared<const Interpolated>(std::move(states), dof);
}

std::shared_ptr<const MotionExtension> MappedMotion(
    InternalStateMap map,
    std::function<Eigen::VectorXd(double)> internal_state,
    double start,
    double end) {
  return std::make_shared<const Mapped>(std::move(map), std::move(internal_state), start, end);
}

std::shared_ptr<const MotionExtension> InternalMotion(
    std::shared_ptr<ServoConstraintProblem> problem,
    std::function<Eigen::VectorXd(double)> internal_state,
    const Eigen::VectorXd& q_guess,
    double start,
    double end) {
  // The last q found starts the next Newton iteration (the motion is smooth).
  auto last_q = std::make_shared<Eigen::VectorXd>(q_guess);
  InternalStateMap map = [problem, last_q](double t, const Eigen::VectorXd& x, Eigen::VectorXd& q,
                                           Eigen::VectorXd& q_dot, Eigen::VectorXd& u,
                                           std::string& why) {
    const Eigen::Index internal = problem->num_internal();
    q = *last_q;
    Eigen::VectorXd q_ddot;
    if (!problem->StateFromInternal(t, x.head(internal), x.tail(internal), q, q_dot, why) ||
        !problem->NormalForm(t, q, q_dot, u, q_ddot, why)) {
      return false;
    }
    *last_q = q;
    return true;
  };
  return MappedMotion(std::move(map), std::move(internal_state), start, end);
}

std::shared_ptr<const MotionExtension> AlgebraicMotion(
    std::shared_ptr<const AlgebraicInverse> inverse,
    const Model& model,
    const OutputTrajectory& trajectory,
    std::vector<double> times,
    std::vector<Eigen::VectorXd> q,
    std::vector<Eigen::VectorXd> q_dot) {
  return std::make_shared<const Algebraic>(std::move(inverse), model, trajectory, std::move(times),
                                           std::move(q), std::move(q_dot));
}

std::shared_ptr<const MotionExtension> PaddedWithRest(std::shared_ptr<const MotionExtension> inner,
                                                      double start,
                                                      double end,
                                                      RestState before,
                                                      RestState after) {
  return std::make_shared<const Padded>(std::move(inner), start, end, std::move(before),
                                        std::move(after));
}

}  // namespace servokit
