#include "numerics/sundials_support.h"

#include <cstdlib>
#include <stdexcept>

namespace servokit {

SundialsContext::SundialsContext() {
  if (SUNContext_Create(nullptr, &context_) != 0) {
    throw std::runtime_error("SUNContext_Create failed");
  }
}

SundialsContext::~SundialsContext() { SUNContext_Free(&context_); }

NVectorPtr MakeSerialVector(Eigen::Index size, SUNContext context) {
  NVectorPtr vector(N_VNew_Serial(static_cast<sunindextype>(size), context));
  CheckSundialsPointer(vector.get(), "N_VNew_Serial");
  N_VConst(0.0, vector.get());
  return vector;
}

Eigen::Map<Eigen::VectorXd> AsEigen(N_Vector vector) {
  return {N_VGetArrayPointer(vector), static_cast<Eigen::Index>(N_VGetLength(vector))};
}

std::string SundialsFlagName(SundialsFlagNamer namer, int flag) {
  char* name = namer(flag);
  std::string result = name ? name : "";
  std::free(name);  // the *GetReturnFlagName functions return malloc'ed memory
  // "NONE" is what SUNDIALS answers for a flag its table lacks (KINSOL 6.4: KIN_SYSFUNC_FAIL).
  if (result.empty() || result == "NONE") return "flag " + std::to_string(flag);
  return result;
}

void CheckSundialsCall(SundialsFlagNamer namer, int flag, const char* call) {
  if (flag < 0) {
    throw std::runtime_error(std::string(call) + " failed: " + SundialsFlagName(namer, flag));
  }
}

void CheckSundialsPointer(const void* pointer, const char* call) {
  if (pointer == nullptr) throw std::runtime_error(std::string(call) + " returned null");
}

}  // namespace servokit
