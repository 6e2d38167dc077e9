#include "analysis/gsl_support.h"

#include <gsl/gsl_errno.h>

#include <mutex>

namespace servokit {

void UseGslStatusCodes() {
  static std::once_flag once;
  std::call_once(once, [] { gsl_set_error_handler_off(); });
}

}  // namespace servokit
