// Calls the shared library built on servokit's public API (zero_dynamics.cpp) and checks its
// answer against the closed form there.
#include <cstdio>

extern "C" double ZeroDynamicsError();

int main() {
  const double error = ZeroDynamicsError();
  std::printf("error against the closed form: %.3g\n", error);
  return error >= 0 && error < 1e-9 ? 0 : 1;
}
