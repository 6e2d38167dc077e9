// Linear models from Matrix Market files (modeling/linear_model.h, modeling/matrix_market.h): the
// small model tests/data/linear/tiny.yaml against its matrices written out by hand, the strict
// reader's messages, bit-exact round trips through WriteLinearModel, and one bad file per
// mistake, each named with its file and key.
#include "modeling/linear_model.h"

#include <unistd.h>

#include <catch2/catch.hpp>
#include <cmath>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <limits>
#include <numbers>
#include <random>
#include <sstream>
#include <string>
#include <vector>

#include "base/errors.h"
#include "modeling/loaded_model.h"
#include "modeling/matrix_market.h"
#include "tests/test_files.h"
#include "tests/test_paths.h"

namespace servokit {
namespace {

using testing::ReadFile;
using testing::TemporaryDirectory;

namespace fs = std::filesystem;
using testing::ModelPath;
using testing::TestDataPath;

std::string LinearData(const std::string& file) { return TestDataPath("linear/" + file); }

void WriteText(const std::string& path, const std::string& text) {
  std::ofstream file(path, std::ios::binary);
  file << text;
}

// Same shape, same pattern, same bits in every stored value (so 0.0 and -0.0 differ).
bool BitIdentical(SparseMatrix a, SparseMatrix b) {
  a.makeCompressed();
  b.makeCompressed();
  if (a.rows() != b.rows() || a.cols() != b.cols() || a.nonZeros() != b.nonZeros()) return false;
  const auto same = [](const auto* x, const auto* y, Eigen::Index count) {
    return std::memcmp(x, y, static_cast<std::size_t>(count) * sizeof(*x)) == 0;
  };
  return same(a.outerIndexPtr(), b.outerIndexPtr(), a.cols() + 1) &&
         same(a.innerIndexPtr(), b.innerIndexPtr(), a.nonZeros()) &&
         same(a.valuePtr(), b.valuePtr(), a.nonZeros());
}

// The ModelError message LoadLinearModel(path) throws; fails the test if there is none.
std::string LoadError(const std::string& path) {
  try {
    LoadLinearModel(path);
  } catch (const ModelError& error) {
    return error.what();
  }
  FAIL("no ModelError for " << path);
  return {};
}

TEST_CASE("the tiny linear model assembles to its matrices written out by hand", "[models]") {
  const LinearModel model = LoadLinearModel(LinearData("tiny.yaml"));
  CHECK(model.name() == "tiny");
  CHECK(model.description() == "two-mass test model for the linear loader");
  CHECK(model.source() == LinearData("tiny.yaml"));
  CHECK(model.dof() == 2);
  CHECK(model.num_inputs() == 1);
  CHECK(model.num_outputs() == 1);
  CHECK(model.parameter_names() == std::vector<std::string>{"m", "k", "d", "alpha"});
  // "30 deg" in the file; pi/6 computed here independently of units.cpp.
  CHECK(model.parameters()[3] == Approx(std::numbers::pi / 6).epsilon(1e-15));
  CHECK(model.FindParameter("k") == std::optional<std::size_t>(1));
  // alpha: 30 deg is remembered as given in degrees (shown in degrees; the value is SI).
  CHECK(model.parameter_display_units() ==
        std::vector<DisplayUnit>{DisplayUnit::kSI, DisplayUnit::kSI, DisplayUnit::kSI,
                                 DisplayUnit::kDegree});
  CHECK_FALSE(model.FindParameter("beta").has_value());
  REQUIRE(model.mass_terms().size() == 2);
  CHECK(model.mass_terms()[1].factor_text == "m*sin(alpha)");
  CHECK(model.content_hash().size() == 16);

  const LinearMatrices matrices = AssembleLinearMatrices(model, model.parameters());
  // M = m diag(1, 0.5) + m sin(30 deg) [[0, 0.25], [0.25, 0]] with m = 2, sin(30 deg) = 1/2.
  Eigen::Matrix2d mass;
  mass << 2.0, 0.25, 0.25, 1.0;
  Eigen::Matrix2d laplacian;
  laplacian << 2.0, -1.0, -1.0, 1.0;
  // sin(pi/6) evaluates to 0.49999999999999994: a few ulps.
  CHECK((Eigen::MatrixXd(matrices.mass) - mass).cwiseAbs().maxCoeff() < 1e-15);
  CHECK(Eigen::MatrixXd(matrices.stiffness) == 5.0 * laplacian);
  CHECK(Eigen::MatrixXd(matrices.damping) == 0.1 * laplacian);
  CHECK(Eigen::MatrixXd(model.input_matrix()) == Eigen::Vector2d(1.0, 0.0));
  CHECK(Eigen::MatrixXd(model.output_matrix()) == Eigen::RowVector2d(0.0, 1.0));
}

TEST_CASE("the assembled pattern is the union of the terms' patterns whatever the factors",
          "[models]") {
  const LinearModel model = LoadLinearModel(LinearData("tiny.yaml"), {{"alpha", "0"}});
  CHECK(model.parameters()[3] == 0.0);
  // tiny.M.mtx stores the diagonal, tiny.N.mtx the off-diagonal pair and an explicit zero at
  // (2, 2): four stored entries, also when the coupling factor m sin(0) vanishes.
  CHECK(AssembleLinearMatrices(model, model.parameters()).mass.nonZeros() == 4);
  const Eigen::Vector4d zero_mass(0.0, 5.0, 0.1, 0.3);  // m = 0 makes both factors zero
  const LinearMatrices zeros = AssembleLinearMatrices(model, zero_mass);
  CHECK(zeros.mass.nonZeros() == 4);
  CHECK(Eigen::MatrixXd(zeros.mass).isZero(0.0));
  CHECK(zeros.stiffness.nonZeros() == 4);
}

TEST_CASE("overrides follow the nonlinear format: degrees, and unknown names are usage errors",
          "[models]") {
  const LinearModel model = LoadLinearModel(LinearData("tiny.yaml"), {{"alpha", "90 deg"}});
  CHECK(model.parameters()[3] == Approx(std::numbers::pi / 2).epsilon(1e-15));
  CHECK_THROWS_AS(LoadLinearModel(LinearData("tiny.yaml"), {{"beta", "1"}}), UsageError);
  CHECK_THROWS_WITH(
      LoadLinearModel(LinearData("tiny.yaml"), {{"k", "five"}}),
      Catch::Contains("parameter override k=five") && Catch::Contains("not a number"));
}

TEST_CASE("AssembleLinearMatrices rejects a wrong parameter count and a non-finite factor",
          "[models]") {
  const LinearModel model = LoadLinearModel(LinearData("tiny.yaml"));
  CHECK_THROWS_AS(AssembleLinearMatrices(model, Eigen::Vector2d(1.0, 2.0)), UsageError);

  TemporaryDirectory directory;
  for (const char* file : {"tiny.M.mtx", "tiny.N.mtx", "tiny.K.mtx", "tiny.B.mtx", "tiny.C.mtx"}) {
    fs::copy_file(LinearData(file), directory / file);
  }
  std::string yaml = ReadFile(LinearData("tiny.yaml"));
  yaml.replace(yaml.find("factor: d}"), 10, "factor: k/d}");
  WriteText(directory / "ratio.yaml", yaml);
  const LinearModel ratio = LoadLinearModel(directory / "ratio.yaml");
  Eigen::VectorXd parameters = ratio.parameters();
  parameters[2] = 0.0;  // d = 0: k/d = inf
  CHECK_THROWS_WITH(AssembleLinearMatrices(ratio, parameters),
                    Catch::Contains("ratio.yaml: damping_matrix[0].factor: k/d = inf"));
  // And at load time, at the nominal values.
  CHECK_THROWS_WITH(LoadLinearModel(directory / "ratio.yaml", {{"d", "0"}}),
                    Catch::Contains("damping_matrix[0].factor: k/d = inf"));
}

TEST_CASE("the content hash covers the model file and every matrix file", "[models]") {
  TemporaryDirectory directory;
  for (const char* file :
       {"tiny.yaml", "tiny.M.mtx", "tiny.N.mtx", "tiny.K.mtx", "tiny.B.mtx", "tiny.C.mtx"}) {
    fs::copy_file(LinearData(file), directory / file);
  }
  const std::string original = LoadLinearModel(LinearData("tiny.yaml")).content_hash();
  CHECK(LoadLinearModel(directory / "tiny.yaml").content_hash() == original);
  WriteText(directory / "tiny.C.mtx", ReadFile(LinearData("tiny.C.mtx")) + "\n");
  const std::string changed_matrix = LoadLinearModel(directory / "tiny.yaml").content_hash();
  CHECK(changed_matrix != original);
  WriteText(directory / "tiny.yaml", ReadFile(LinearData("tiny.yaml")) + "# comment\n");
  CHECK(LoadLinearModel(directory / "tiny.yaml").content_hash() != changed_matrix);
}

TEST_CASE("LoadModelFile tells the two formats apart by kind and rejects unknown kinds",
          "[models]") {
  const LoadedModel linear = LoadModelFile(LinearData("tiny.yaml"));
  REQUIRE(linear.kind() == ModelKind::kLinear);
  REQUIRE(linear.linear() != nullptr);
  CHECK(linear.multibody() == nullptr);
  CHECK(linear.linear()->dof() == 2);  // two masses (tiny.yaml)
  CHECK(linear.name() == "tiny");
  const LoadedModel multibody = LoadModelFile(ModelPath("mass_on_car.yaml"));
  REQUIRE(multibody.kind() == ModelKind::kMultibody);
  CHECK(multibody.multibody()->dof() == 2);  // car position x and mass position s
  // `kind: multibody` on a linear model's keys: read as a multibody file, which it is not.
  CHECK_THROWS_WITH(
      LoadModelFile(LinearData("multibody.yaml")),
      Catch::StartsWith(LinearData("multibody.yaml") + ": ") && Catch::Contains(": unknown key"));
  CHECK_THROWS_WITH(LoadModelFile(LinearData("unknown_kind.yaml")),
                    Catch::Contains("unknown_kind.yaml: kind: unknown kind 'finite-element'"));
  CHECK_THROWS_WITH(LoadModelFile(LinearData("no_such_model.yaml")),
                    Catch::Contains("no_such_model.yaml: cannot read the model file"));
}

TEST_CASE("LoadModelText reads a linear model with matrix files next to its source", "[models]") {
  const std::string path = LinearData("tiny.yaml");
  const LoadedModel from_text = LoadModelText(ReadFile(path), path, {{"k", "7"}});
  REQUIRE(from_text.linear() != nullptr);
  const LinearModel from_file = LoadLinearModel(path, {{"k", "7"}});
  CHECK(from_text.linear()->content_hash() == from_file.content_hash());
  const std::optional<std::size_t> k = from_text.linear()->FindParameter("k");
  REQUIRE(k);
  CHECK(from_text.parameters()[static_cast<Eigen::Index>(*k)] == 7.0);
}

TEST_CASE("each bad linear model file gives a ModelError naming the file, the key and the line",
          "[models]") {
  struct BadFile {
    std::string file;
    std::vector<std::string> expected;  // substrings of the message
  };
  const std::vector<BadFile> bad_files = {
      {"missing_key.yaml", {"missing_key.yaml: stiffness_matrix: missing required key"}},
      {"missing_mtx.yaml",
       {"missing_mtx.yaml: input_matrix: cannot read the matrix file", "no_such_file.B.mtx"}},
      {"malformed.yaml",
       {"malformed.yaml: stiffness_matrix[0].matrix: ",
        "malformed.K.mtx:4: extra text 'junk' in '2 1 -1 junk'"}},
      {"wrong_shape.yaml",
       {"wrong_shape.yaml: stiffness_matrix[0]: expected 2 x 2", "found 2 x 3"}},
      {"nonfinite.yaml",
       {"nonfinite.yaml: stiffness_matrix[0].matrix: ", "nonfinite.K.mtx:4: non-finite value"}},
      {"unknown_symbol.yaml",
       {"unknown_symbol.yaml: mass_matrix[1].factor: unknown symbol 'beta'"}},
      {"multibody.yaml", {"multibody.yaml: kind: expected linear"}},
      {"unknown_kind.yaml", {"unknown_kind.yaml: kind: unknown kind"}},
      {"output_shape.yaml", {"output_shape.yaml: output_matrix: expected 2 columns"}},
  };
  for (const BadFile& bad : bad_files) {
    const std::string message = LoadError(LinearData(bad.file));
    INFO(message);
    CHECK(message.rfind(LinearData(bad.file), 0) == 0);  // starts with the model file
    for (const std::string& expected : bad.expected) {
      CHECK_THAT(message, Catch::Contains(expected));
    }
  }
  CHECK_THROWS_WITH(LoadLinearModel(LinearData("no_such_model.yaml")),
                    Catch::Contains("no_such_model.yaml: cannot read the model file"));
}

TEST_CASE("the Matrix Market reader expands symmetric files and keeps explicit zeros", "[models]") {
  const SparseMatrix matrix = ParseMatrixMarket(
      "%%MatrixMarket matrix coordinate real symmetric\r\n"
      "% comment\r\n"
      "\r\n"
      "3 3 4\r\n"
      "1 1 4.5\r\n"
      "3 1 -2e-3\r\n"
      "2 2 0\r\n"
      "  3   +3\t+7  \r\n"
      "\r\n",
      "inline");
  Eigen::Matrix3d expected;
  expected << 4.5, 0, -2e-3, 0, 0, 0, -2e-3, 0, 7;
  CHECK(Eigen::MatrixXd(matrix) == expected);
  CHECK(matrix.nonZeros() == 5);  // (1,1), (3,1), (1,3), the explicit zero (2,2), (3,3)
}

TEST_CASE("the Matrix Market reader names the line of each malformed part", "[models]") {
  const std::string general = "%%MatrixMarket matrix coordinate real general\n";
  const std::vector<std::pair<std::string, std::string>> cases = {
      {"", "m.mtx: empty file"},
      {"%%MatrixMarket matrix array real general\n2 2\n1\n2\n3\n4\n",
       "m.mtx:1: format 'array' is not supported"},
      {"%%MatrixMarket matrix coordinate complex general\n", "m.mtx:1: field 'complex'"},
      {"%%MatrixMarket matrix coordinate pattern general\n", "m.mtx:1: field 'pattern'"},
      {"%%MatrixMarket matrix coordinate real skew-symmetric\n", "m.mtx:1: symmetry"},
      {"%MatrixMarket matrix coordinate real general\n", "m.mtx:1: expected the header"},
      {general, "m.mtx: missing the size line"},
      {general + "2 2\n", "m.mtx:2: expected the size line"},
      {general + "2 -2 1\n", "m.mtx:2: bad size line"},
      {general + "2 2 5\n", "m.mtx:2: 5 entries do not fit in a 2 x 2 matrix"},
      {general + "2 2 2\n1 1 1\n", "m.mtx: expected 2 entries (size line), found 1"},
      {general + "2 2 1\n1 1 1\n2 2 2\n", "m.mtx:4: more entries than the 1 of the size line"},
      {general + "2 2 1\n3 1 1\n", "m.mtx:3: entry (3, 1) outside the 2 x 2 matrix"},
      {general + "2 2 1\n0 1 1\n", "m.mtx:3: entry (0, 1) outside"},
      {general + "2 2 1\n1 x 1\n", "m.mtx:3: bad column index in '1 x 1'"},
      {general + "2 2 1\n1 1\n", "m.mtx:3: missing value in '1 1'"},
      {general + "2 2 1\n1 1 1.5.2\n", "m.mtx:3: bad value"},
      {general + "2 2 1\n1 1 inf\n", "m.mtx:3: non-finite value"},
      {general + "2 2 1\n1 1 1e400\n", "m.mtx:3: value out of the range of a double"},
      {general + "2 2 3\n1 1 1\n2 2 1\n1 1 2\n",
       "m.mtx:5: entry (1, 1) given twice (first on line 3)"},
      {"%%MatrixMarket matrix coordinate real symmetric\n2 2 1\n1 2 1\n",
       "m.mtx:3: entry (1, 2) above the diagonal"},
      {"%%MatrixMarket matrix coordinate real symmetric\n2 3 0\n", "must be square"},
  };
  for (const auto& [text, expected] : cases) {
    INFO(text);
    CHECK_THROWS_WITH(ParseMatrixMarket(text, "m.mtx"), Catch::Contains(expected));
  }
}

// A matrix whose values need all 17 significant digits, span the exponent range, and include
// -0.0, a subnormal and an explicit zero.
SparseMatrix AwkwardMatrix(int size, unsigned seed) {
  std::mt19937 random(seed);
  std::uniform_real_distribution<double> mantissa(-1.0, 1.0);
  std::uniform_int_distribution<int> exponent(-300, 300);
  std::vector<Eigen::Triplet<double>> triplets;
  for (int i = 0; i < size; ++i) {
    triplets.emplace_back(i, i, std::ldexp(mantissa(random), exponent(random)));
    if (i + 1 < size) triplets.emplace_back(i + 1, i, mantissa(random) / 3.0);
  }
  triplets.emplace_back(0, size - 1, -0.0);
  triplets.emplace_back(size - 1, 0, std::numeric_limits<double>::denorm_min());
  if (size > 2) triplets.emplace_back(1, size - 1, 0.0);
  SparseMatrix matrix(size, size);
  matrix.setFromTriplets(triplets.begin(), triplets.end());
  return matrix;
}

TEST_CASE("FormatMatrixMarket then ParseMatrixMarket gives the matrix back bit for bit",
          "[models]") {
  const SparseMatrix matrix = AwkwardMatrix(50, 7);
  CHECK(BitIdentical(ParseMatrixMarket(FormatMatrixMarket(matrix, "a comment"), "m"), matrix));
}

TEST_CASE("WriteLinearModel then LoadLinearModel gives the same model bit for bit", "[models]") {
  LinearModelFiles files;
  files.name = "round_trip";
  files.description = "round trip: with a colon, # and \"quotes\"";
  files.parameters = {{"a", 0.1}, {"b", 1.0 / 3.0}, {"c", -2.5e-300}};
  const SparseMatrix symmetric = [] {
    const SparseMatrix awkward = AwkwardMatrix(6, 1);
    return SparseMatrix(SparseMatrix(awkward.transpose()) + awkward);
  }();
  const SparseMatrix stiffness = AwkwardMatrix(6, 2);
  files.mass = {{symmetric, "a"}, {SparseMatrix(symmetric * 3.0), "b^2"}};
  files.damping = {{stiffness, "a*b"}};
  files.stiffness = {{stiffness, "1"}};
  files.input_matrix = AwkwardMatrix(6, 4).leftCols(2);
  files.output_matrix = AwkwardMatrix(6, 5).topRows(2);

  TemporaryDirectory directory;
  const std::string path = WriteLinearModel(files, directory.path().string());
  CHECK(path == directory / "round_trip.yaml");
  const LinearModel model = LoadLinearModel(path);
  CHECK(model.name() == files.name);
  CHECK(model.description() == files.description);
  REQUIRE(model.parameter_names() == std::vector<std::string>{"a", "b", "c"});
  CHECK(model.parameters() == Eigen::Vector3d(0.1, 1.0 / 3.0, -2.5e-300));
  REQUIRE(model.mass_terms().size() == 2);
  REQUIRE(model.damping_terms().size() == 1);
  REQUIRE(model.stiffness_terms().size() == 1);
  CHECK(BitIdentical(model.mass_terms()[0].matrix, files.mass[0].first));
  CHECK(BitIdentical(model.mass_terms()[1].matrix, files.mass[1].first));
  CHECK(model.mass_terms()[1].factor_text == "b^2");
  CHECK(BitIdentical(model.damping_terms()[0].matrix, stiffness));
  CHECK(model.damping_terms()[0].factor_text == "a*b");
  CHECK(BitIdentical(model.stiffness_terms()[0].matrix, stiffness));
  CHECK(BitIdentical(model.input_matrix(), files.input_matrix));
  CHECK(BitIdentical(model.output_matrix(), files.output_matrix));
  // D and K hold the same matrix: one file, named by both keys.
  CHECK(fs::exists(directory / "round_trip.D.mtx"));
  CHECK_FALSE(fs::exists(directory / "round_trip.K.mtx"));
  CHECK(ReadFile(path).find("stiffness_matrix: round_trip.D.mtx") != std::string::npos);
  CHECK(fs::exists(directory / "round_trip.M.1.mtx"));
  CHECK(fs::exists(directory / "round_trip.M.2.mtx"));
}

TEST_CASE("WriteLinearModel needs an existing directory and a name fit for file names",
          "[models]") {
  LinearModelFiles files;
  files.name = "x";
  files.mass = {{SparseMatrix(1, 1), "1"}};
  files.stiffness = files.mass;
  files.input_matrix = SparseMatrix(1, 1);
  files.output_matrix = SparseMatrix(1, 1);
  TemporaryDirectory directory;
  CHECK_THROWS_WITH(WriteLinearModel(files, directory / "missing"),
                    Catch::Contains("missing: no such directory"));
  files.name = "../escape";
  CHECK_THROWS_AS(WriteLinearModel(files, directory.path().string()), UsageError);
}

}  // namespace
}  // namespace servokit
