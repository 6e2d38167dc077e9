#pragma once
// A finiteness test for the per-point analyses, which check every matrix they form.
#include <Eigen/Core>

namespace servokit {

/// True when no entry of `values` is NaN or +-Inf: Eigen's allFinite(), in one vectorized
/// pass. x * 0 is (+-)0 for a finite x and NaN for NaN or +-Inf, and a sum of zeros cannot
/// overflow, so the sum is 0 exactly when every entry is finite. (allFinite() tests entry by
/// entry with a branch each: a tenth of a sweep point's time on the general path.)
template <typename Derived>
bool AllFinite(const Eigen::DenseBase<Derived>& values) {
  return (values.derived().array() * 0.0).sum() == 0.0;
}

}  // namespace servokit
