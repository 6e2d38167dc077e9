#pragma once
// What the fuzz targets feed to servokit (issue #7): one function per reader, shared by the
// libFuzzer executables (tests/fuzz/*_fuzzer.cpp, clang only) and the regression test that
// replays the seed corpus and every input the fuzzer ever found (tests/fuzz/regressions_test.cpp,
// any compiler). Each function reads its input as `servokit` would read a file a user wrote.
// It may throw servokit::Error, the clear one-line message a user gets; anything else that
// escapes (another exception, a crash, a sanitizer report, a hang) is a finding.
#include <string_view>

namespace servokit::fuzz {

/// A model file: `kind: linear` files are read with their Matrix Market terms (the
/// Matrix Market files of tests/data/linear sit beside it), all others as multibody
/// models, whose every derived quantity is then evaluated once at a fixed state.
void ReadModelFile(std::string_view bytes);

/// One expression, put into a two-coordinate model as a force and in the output (so that its
/// first and second derivatives are derived and compiled), then evaluated. Inputs with bytes a
/// YAML scalar cannot carry on one line (control characters, non-ASCII) are skipped: they test
/// the YAML reader, which ReadModelFile covers.
void ReadExpression(std::string_view bytes);

/// A Matrix Market file (the matrices of linear models).
void ReadMatrixMarket(std::string_view bytes);

}  // namespace servokit::fuzz
