#include "analysis/structure_options.h"

#include <string>

namespace servokit {
namespace {

std::string OutputName(std::size_t output) { return "y" + std::to_string(output + 1); }

}  // namespace

NoSolution OutputsNotIndependent(std::size_t output, std::size_t states) {
  return NoSolution("the outputs do not determine the inputs: with output " + OutputName(output) +
                    " the structure algorithm needs more than 2 dof = " + std::to_string(states) +
                    " constraints on the state (the outputs are not independent; no left "
                    "inverse exists)");
}

NoSolution OutputNeverDependsOnInputs(std::size_t output, std::size_t max_order) {
  return NoSolution("output " + OutputName(output) +
                    " never depends on the inputs (checked up to its derivative of order " +
                    std::to_string(max_order) + " = 2 dof), so it cannot be tracked");
}

}  // namespace servokit
