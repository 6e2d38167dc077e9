// The files of a solve (reports/solve_files.h): which format a name asks for, which names a
// format refuses, and which column names MATLAB can load. The files' contents are compared with
// the CSV of the same solve in tests/python/test_solve_files.py (SciPy reads the MAT file).
#include "reports/solve_files.h"

#include <catch2/catch.hpp>

#include "reports/mat_file.h"

namespace servokit {
namespace {

TEST_CASE("each solve file format reads back from its name", "[reports]") {
  for (const SolveFileFormat format :
       {SolveFileFormat::kCsv, SolveFileFormat::kMat, SolveFileFormat::kModelica}) {
    CHECK(SolveFileFormatFromString(ToString(format)) == format);
  }
  CHECK_FALSE(SolveFileFormatFromString("hdf5"));
}

TEST_CASE("a name ending in .mat asks for a MAT file, any other for CSV", "[reports]") {
  CHECK(SolveFileFormatOfName("out/u.mat") == SolveFileFormat::kMat);
  CHECK(SolveFileFormatOfName("U.MAT") == SolveFileFormat::kMat);
  CHECK(SolveFileFormatOfName("u.csv") == SolveFileFormat::kCsv);
  CHECK(SolveFileFormatOfName("u.txt") == SolveFileFormat::kCsv);
  CHECK(SolveFileFormatOfName("u") == SolveFileFormat::kCsv);
  CHECK(SolveFileFormatOfName("mat") == SolveFileFormat::kCsv);
}

TEST_CASE("the endings .csv and .mat belong to their formats", "[reports]") {
  CHECK_FALSE(SolveFileNameProblem("u.csv", SolveFileFormat::kCsv));
  CHECK_FALSE(SolveFileNameProblem("u.txt", SolveFileFormat::kCsv));
  CHECK_FALSE(SolveFileNameProblem("u.mat", SolveFileFormat::kMat));
  CHECK_FALSE(SolveFileNameProblem("u.txt", SolveFileFormat::kModelica));
  CHECK_FALSE(SolveFileNameProblem("u", SolveFileFormat::kModelica));
  CHECK_THAT(SolveFileNameProblem("u.csv", SolveFileFormat::kMat).value_or(""),
             Catch::Contains("must end in .mat"));
  CHECK_THAT(SolveFileNameProblem("u", SolveFileFormat::kMat).value_or(""),
             Catch::Contains("must end in .mat"));
  CHECK_THAT(SolveFileNameProblem("u.Mat", SolveFileFormat::kCsv).value_or(""),
             Catch::Contains("for a MAT file, not csv"));
  CHECK_THAT(SolveFileNameProblem("u.mat", SolveFileFormat::kModelica).value_or(""),
             Catch::Contains("for a MAT file, not modelica"));
  CHECK_THAT(SolveFileNameProblem("u.csv", SolveFileFormat::kModelica).value_or(""),
             Catch::Contains("for CSV, not a Modelica table"));
}

TEST_CASE("MATLAB names: a letter, then letters, digits and _, at most 63, no keyword",
          "[reports]") {
  for (const char* name : {"t", "x_dot", "y1_d", "F", "alpha2"}) {
    CHECK_FALSE(MatlabNameProblem(name));
  }
  CHECK(MatlabNameProblem(std::string(63, 'a')) == std::nullopt);
  CHECK_THAT(MatlabNameProblem(std::string(64, 'a')).value_or(""), Catch::Contains("63"));
  for (const char* name : {"", "_x", "1x", "x-y", "x y"}) {
    CHECK_THAT(MatlabNameProblem(name).value_or(""), Catch::Contains("not a MATLAB name"));
  }
  for (const char* name : {"end", "if", "function", "parfor"}) {
    CHECK_THAT(MatlabNameProblem(name).value_or(""), Catch::Contains("MATLAB keyword"));
  }
}

}  // namespace
}  // namespace servokit
