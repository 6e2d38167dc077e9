#include "integrators/dense_output.h"

#include <algorithm>
#include <cmath>
#include <numbers>
#include <stdexcept>
#include <string>

namespace servokit {

std::vector<double> LobattoNodes(double start, double end, int count) {
  if (count < 2) throw std::invalid_argument("LobattoNodes: count must be at least 2");
  std::vector<double> nodes(static_cast<std::size_t>(count));
  for (int j = 0; j < count; ++j) {
    const double cosine = std::cos(std::numbers::pi * j / (count - 1));
    nodes[std::size_t(j)] = start + (end - start) * (1.0 - cosine) / 2.0;
  }
  nodes.front() = start;  // exactly, not up to the cosine's round-off
  nodes.back() = end;
  // A step of a few ulps of t has no room for inner nodes: its ends alone (a straight line).
  for (std::size_t j = 1; j < nodes.size(); ++j) {
    if (!(nodes[j] > nodes[j - 1])) return {start, end};
  }
  return nodes;
}

void DenseOutput::AppendPiece(const std::vector<double>& times,
                              const std::vector<Eigen::VectorXd>& values) {
  if (times.size() < 2 || values.size() != times.size()) {
    throw std::invalid_argument(
        "DenseOutput::AppendPiece: needs two or more times, one value each");
  }
  for (std::size_t i = 1; i < times.size(); ++i) {
    if (!(times[i] > times[i - 1])) {
      throw std::invalid_argument("DenseOutput::AppendPiece: times must increase");
    }
  }
  if (!empty() && times.front() != end_) {
    throw std::invalid_argument(
        "DenseOutput::AppendPiece: a piece must start where the last ended");
  }
  for (const Eigen::VectorXd& value : values) {
    if (value.size() != size_) {
      throw std::invalid_argument("DenseOutput::AppendPiece: a value of size " +
                                  std::to_string(value.size()) + " instead of " +
                                  std::to_string(size_));
    }
  }
  piece_starts_.push_back(times.front());
  end_ = times.back();
  first_node_.push_back(nodes_.size());
  // Weights from the nodes scaled to [0, 1]: the same up to a common factor, which cancels in
  // the barycentric quotient, and free of overflow for short steps.
  const double length = times.back() - times.front();
  for (std::size_t j = 0; j < times.size(); ++j) {
    double weight = 1.0;
    for (std::size_t k = 0; k < times.size(); ++k) {
      if (k != j) weight /= (times[j] - times[k]) / length;
    }
    nodes_.push_back(times[j]);
    weights_.push_back(weight);
    values_.insert(values_.end(), values[j].data(), values[j].data() + size_);
  }
}

void DenseOutput::Evaluate(double t, Eigen::VectorXd& value) const {
  if (empty()) throw std::logic_error("DenseOutput::Evaluate: no piece");
  t = std::clamp(t, start(), end_);
  const std::size_t piece = std::size_t(
      std::max<std::ptrdiff_t>(
          std::upper_bound(piece_starts_.begin(), piece_starts_.end(), t) - piece_starts_.begin(),
          1) -
      1);
  const std::size_t first = first_node_[piece];
  const std::size_t last = piece + 1 < first_node_.size() ? first_node_[piece + 1] : nodes_.size();
  value.setZero(size_);
  double denominator = 0.0;
  for (std::size_t j = first; j < last; ++j) {
    const Eigen::Map<const Eigen::VectorXd> node_value(values_.data() + j * std::size_t(size_),
                                                       size_);
    if (t == nodes_[j]) {
      value = node_value;
      return;
    }
    const double factor = weights_[j] / (t - nodes_[j]);
    value += factor * node_value;
    denominator += factor;
  }
  value /= denominator;
}

}  // namespace servokit
