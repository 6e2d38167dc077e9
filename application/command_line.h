#pragma once
// The `servokit` command line (one docs/ page per command: docs/analyze.md, docs/sweep.md, ...),
// callable from tests.
#include <iosfwd>

namespace servokit {

/// Runs servokit with `argv` (argv[0] is the program name), writing results to `out` and the
/// one-line "servokit: error: ..." to `err`. Returns the documented exit status
/// (application/exit_codes.h); never throws.
int RunCommandLine(int argc, const char* const* argv, std::ostream& out, std::ostream& err);

}  // namespace servokit
