#pragma once
// GSL's default error handler aborts the program; servokit checks every GSL status itself.

namespace servokit {

/// Turns GSL's abort-on-error handler off, once per process (thread-safe).
void UseGslStatusCodes();

}  // namespace servokit
