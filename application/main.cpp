#include <iostream>
#include <ostream>

#include "application/command_line.h"
#include "servokit/servokit.h"

int main(int argc, char** argv) {
  // Started by mpirun, every rank runs the command (a sweep shares its grid out); only rank 0
  // prints, the others write to a stream without a buffer, which drops everything.
  const servokit::api::MpiSession mpi(argc, argv);
  if (servokit::api::Processes().IsRoot()) {
    return servokit::RunCommandLine(argc, argv, std::cout, std::cerr);
  }
  std::ostream discard(nullptr);
  return servokit::RunCommandLine(argc, argv, discard, discard);
}
