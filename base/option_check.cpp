#include "base/option_check.h"

namespace servokit {
namespace {}  // namespace

std::string OptionValueText(const Eigen::VectorXd& values) {
  std::string text = "[";
  for (Eigen::Index i = 0; i < values.size(); ++i) {
    text += (i ? ", " : "") + FormatNumber(values(i));
  }
  return text + "]";
}

}  // namespace servokit
