#pragma once
// What the fuzz targets feed to servokit (issues #7 and #29): one function per reader or
// writer, shared by the libFuzzer executables (tests/fuzz/fuzzer.cpp, clang only) and the
// regression test that replays the seed corpus and every input the fuzzer ever found
// (tests/fuzz/regressions_test.cpp, any compiler). Each function reads its input as `servokit`
// would read a file a user wrote, or names an output with it as a user would. It may throw
// servokit::Error, the clear one-line message a user gets; anything else that escapes (another
// exception, a crash, a sanitizer report, a hang) is a finding, and so is a broken property
// that a function checks itself: it prints the property to stderr and aborts.
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

/// A CSV file of samples of y_d, as `servokit solve --trajectory samples.csv` reads it
/// (trajectories/sampled_trajectory.h): loaded, joined by the spline with Eq. (65)'s 4
/// continuous derivatives, and y_d with its derivatives up to order 4 evaluated before, at,
/// between and after the samples. Aborts when a derivative that the spline promises finite
/// (orders up to 4) is not.
void ReadTrajectoryFile(std::string_view bytes);

/// A YAML waypoint file (trajectories/waypoint_trajectory.h), loaded and evaluated as
/// ReadTrajectoryFile does; aborts when a derivative up to the file's continuous derivatives
/// is not finite.
void ReadWaypointFile(std::string_view bytes);

/// Bytes naming an output file, relative to a private sandbox directory (made once per process
/// under the temporary directory, beside an `outside` directory holding a sentinel file), checked
/// and written as servokit writes its outputs (files/output_file.h): CheckOutputPath, then an
/// OutputFile committed over the name, then the same name published from a ScratchDirectory as
/// the figures are. The sandbox holds what an output must never replace or follow: a link to the
/// sentinel, a dangling link pointing outside, a link to /dev/null (and a device node where the
/// system allows one), a FIFO, a directory, a file read as an input (and a hard link to it),
/// besides a plain file that an output may replace. Names that are absolute, hold a NUL or leave
/// the sandbox by their `..` alone are skipped (the harness writes nowhere else). Aborts unless,
/// after each write, the sentinel is unchanged (bytes and modification time), nothing planted was
/// replaced or followed, and either a servokit::Error was thrown and nothing is new, or the name
/// holds exactly the bytes written and nothing else is new (no temporary file left). What an input
/// created is removed after it.
void WriteOutputPath(std::string_view bytes);

}  // namespace servokit::fuzz
