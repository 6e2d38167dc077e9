#pragma once
// A solver's continuous extension (its dense output): on each step, the polynomial the method
// itself defines there — Radau IIA's collocation polynomial, Euler backward's straight line,
// the interpolant SUNDIALS keeps for IDAGetDky, CVodeGetDky and ERKStepGetDky — stored by its
// values at nodes of the step and evaluated in barycentric form (Berrut & Trefethen, SIAM
// Review 46, 2004), which is stable for any node set.
//
// This, not a polynomial through unevenly spaced step values, is what u_d between steps is:
// a degree-5 interpolant through steps 7e-7 s to 0.5 s apart swung by +-30 N m around a 4 N m
// rest torque.
#include <Eigen/Dense>
#include <cstddef>
#include <vector>

namespace servokit {

/// Chebyshev-Lobatto nodes on [start, end], ends included: `count` >= 2 of them. A polynomial
/// of degree count - 1 is reproduced exactly from its values there. An interval too short to
/// hold distinct inner nodes (a few ulps) gets its two ends only.
std::vector<double> LobattoNodes(double start, double end, int count);

class DenseOutput {
 public:
  /// An empty extension of vectors of `size` components.
  explicit DenseOutput(Eigen::Index size = 0) : size_(size) {}

  /// Appends the polynomial through (times[i], values[i]) as the piece [times.front(),
  /// times.back()]. At least two strictly increasing times; the first is end() of the previous
  /// piece when there is one; every value has size() components. Throws std::invalid_argument
  /// otherwise (a solver's bug, not a user's).
  void AppendPiece(const std::vector<double>& times, const std::vector<Eigen::VectorXd>& values);

  bool empty() const { return piece_starts_.empty(); }
  Eigen::Index size() const { return size_; }
  std::size_t pieces() const { return piece_starts_.size(); }
  /// The span covered; both NaN-free only when !empty().
  double start() const { return piece_starts_.front(); }
  double end() const { return end_; }

  /// The value at t, clamped to [start(), end()]. At the boundary of two pieces, the later
  /// piece's polynomial (the same value: each piece passes through its ends).
  void Evaluate(double t, Eigen::VectorXd& value) const;
  Eigen::VectorXd operator()(double t) const {
    Eigen::VectorXd value;
    Evaluate(t, value);
    return value;
  }

 private:
  Eigen::Index size_;
  std::vector<double> piece_starts_;
  double end_ = 0.0;
  // Piece k's nodes are nodes_[first_node_[k]] .. nodes_[first_node_[k + 1] - 1].
  std::vector<std::size_t> first_node_;
  std::vector<double> nodes_;
  std::vector<double> weights_;  // barycentric weights, per node
  std::vector<double> values_;   // size_ values per node
};

}  // namespace servokit
