#include "modeling/symbolic_lock.h"

namespace servokit {

std::recursive_mutex& SymbolicMutex() {
  // A function-local static: initialized on first use, so that loading a model from another
  // static initializer finds it ready.
  static std::recursive_mutex mutex;
  return mutex;
}

}  // namespace servokit
