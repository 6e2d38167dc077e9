#include <iostream>

#include "reports/command_line.h"

int main(int argc, char** argv) {
  return servokit::RunCommandLine(argc, argv, std::cout, std::cerr);
}
