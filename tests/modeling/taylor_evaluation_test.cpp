// Taylor-mode differentiation through compiled programs (ExpressionProgram::EvaluateTaylor),
// checked against a second route: GiNaC differentiates the same expression along the same
// curve symbolically, d^k/dt^k f(x(t), y(t), z(t)) at t = 0, divided by k!.
#include <catch2/catch.hpp>
#include <cmath>
#include <cstddef>
#include <limits>
#include <string>
#include <vector>

#include "modeling/dual_number.h"
#include "modeling/expression_program.h"
#include "modeling/model.h"
#include "modeling/symbolic_lock.h"
#include "modeling/symbolic_model.h"
#include "tests/test_paths.h"

namespace servokit {
namespace {

constexpr int kDegree = 5;

// The curve x(t), y(t), z(t): quadratic, so that every coefficient of the result mixes products
// of the inputs' coefficients, inside the domains of every function below (x in [0.2, 1.5],
// y in [0.3, 2], z in [-0.9, 0.9] near t = 0).
struct Curve {
  double start, slope, curvature;
};
const Curve kCurves[3] = {{0.7, 0.3, -0.2}, {1.1, -0.4, 0.25}, {0.35, 0.5, 0.1}};

struct Symbols {
  GiNaC::realsymbol x{"x"}, y{"y"}, z{"z"}, t{"t"};
  std::vector<GiNaC::ex> inputs() const { return {x, y, z}; }
};

// Coefficient k of f along the curve, by GiNaC: f^(k)(0) / k!.
std::vector<double> GinacCoefficients(const Symbols& s, const GiNaC::ex& f) {
  GiNaC::exmap along;
  const GiNaC::realsymbol* symbols[3] = {&s.x, &s.y, &s.z};
  for (int i = 0; i < 3; ++i) {
    along[*symbols[i]] =
        kCurves[i].start + kCurves[i].slope * s.t + kCurves[i].curvature * GiNaC::pow(s.t, 2);
  }
  GiNaC::ex derivative = f.subs(along);
  std::vector<double> coefficients;
  double factorial = 1.0;
  for (int k = 0; k <= kDegree; ++k) {
    if (k > 0) {
      derivative = derivative.diff(s.t);
      factorial *= k;
    }
    const GiNaC::ex value = derivative.subs(s.t == 0).evalf();
    coefficients.push_back(GiNaC::ex_to<GiNaC::numeric>(value).to_double() / factorial);
  }
  return coefficients;
}

std::vector<double> TaylorCoefficients(const Symbols& s, const GiNaC::ex& f) {
  const ExpressionProgram program = CompileExpressions({f}, s.inputs());
  std::vector<double> inputs;
  for (const Curve& curve : kCurves) {
    inputs.push_back(curve.start);
    inputs.push_back(curve.slope);
    inputs.push_back(curve.curvature);
    for (int k = 3; k <= kDegree; ++k) inputs.push_back(0.0);
  }
  std::vector<double> registers(program.num_registers() * (kDegree + 1));
  std::vector<double> coefficients(kDegree + 1);
  program.EvaluateTaylor(kDegree, inputs.data(), registers.data(), coefficients.data());
  return coefficients;
}

void CheckAgainstGinac(const Symbols& s, const GiNaC::ex& f) {
  const std::vector<double> expected = GinacCoefficients(s, f);
  const std::vector<double> computed = TaylorCoefficients(s, f);
  // Each coefficient against the largest of the series: a small coefficient that is a
  // difference of large terms carries their rounding.
  double scale = 0.0;
  for (const double value : expected) scale = std::max(scale, std::abs(value));
  for (int k = 0; k <= kDegree; ++k) {
    INFO(f << ", coefficient " << k);
    CHECK(computed[std::size_t(k)] ==
          Approx(expected[std::size_t(k)]).margin(1e-13 * std::max(scale, 1.0)));
  }
}

// Over dual numbers with x's start carrying tangent 1, the tangents of f's coefficients are the
// coefficients of df/dx along the same curve (x(t) moves with its start), by GiNaC; the values
// are those of the double evaluation, to the bit.
void CheckDualAgainstGinac(const Symbols& s, const GiNaC::ex& f) {
  const std::vector<double> expected = GinacCoefficients(s, f.diff(s.x));
  const std::vector<double> values = TaylorCoefficients(s, f);
  const ExpressionProgram program = CompileExpressions({f}, s.inputs());
  std::vector<Dual> inputs;
  for (const Curve& curve : kCurves) {
    inputs.emplace_back(curve.start, &curve == &kCurves[0] ? 1.0 : 0.0);
    inputs.emplace_back(curve.slope);
    inputs.emplace_back(curve.curvature);
    for (int k = 3; k <= kDegree; ++k) inputs.emplace_back(0.0);
  }
  std::vector<Dual> registers(program.num_registers() * (kDegree + 1));
  std::vector<Dual> coefficients(kDegree + 1);
  program.EvaluateTaylor(kDegree, inputs.data(), registers.data(), coefficients.data());
  double scale = 0.0;
  for (const double value : expected) scale = std::max(scale, std::abs(value));
  for (int k = 0; k <= kDegree; ++k) {
    INFO(f << ", tangent of coefficient " << k);
    CHECK(coefficients[std::size_t(k)].value == values[std::size_t(k)]);
    CHECK(coefficients[std::size_t(k)].tangent ==
          Approx(expected[std::size_t(k)]).margin(1e-13 * std::max(scale, 1.0)));
  }
}

// A pass over DualChunk, its directions the starts and slopes of x, y, z and the curvature of
// z, gives in each direction the bits of a pass over Dual along that direction alone (vector
// mode computes the values and each function's derivative once, the tangents as Dual does).
void CheckChunkAgainstDual(const Symbols& s, const GiNaC::ex& f) {
  const ExpressionProgram program = CompileExpressions({f}, s.inputs());
  const std::size_t width = kDegree + 1;
  // Input (curve i, coefficient k) is entry i * width + k; the directions seed these entries.
  const std::vector<std::size_t> seeded = {0, width, 2 * width, 1, width + 1, 2 * width + 2};
  const auto start = [&](std::size_t entry) {
    const Curve& curve = kCurves[entry / width];
    const std::size_t k = entry % width;
    return k == 0 ? curve.start : (k == 1 ? curve.slope : (k == 2 ? curve.curvature : 0.0));
  };
  std::vector<DualChunk> chunk_inputs(3 * width);
  for (std::size_t entry = 0; entry < chunk_inputs.size(); ++entry)
    chunk_inputs[entry] = start(entry);
  for (std::size_t d = 0; d < seeded.size(); ++d) chunk_inputs[seeded[d]].tangent.d[d] = 1.0;
  std::vector<DualChunk> chunk_registers(program.num_registers() * width), chunk(width);
  program.EvaluateTaylor(kDegree, chunk_inputs.data(), chunk_registers.data(), chunk.data());
  for (std::size_t d = 0; d < seeded.size(); ++d) {
    std::vector<Dual> inputs(3 * width);
    for (std::size_t entry = 0; entry < inputs.size(); ++entry) inputs[entry] = start(entry);
    inputs[seeded[d]].tangent = 1.0;
    std::vector<Dual> registers(program.num_registers() * width), single(width);
    program.EvaluateTaylor(kDegree, inputs.data(), registers.data(), single.data());
    for (std::size_t k = 0; k < width; ++k) {
      INFO(f << ", direction " << d << ", coefficient " << k);
      CHECK(chunk[k].value == single[k].value);
      const double chunk_tangent = chunk[k].tangent.d[d], tangent = single[k].tangent;
      CHECK((chunk_tangent == tangent || (std::isnan(chunk_tangent) && std::isnan(tangent))));
    }
  }
}

}  // namespace

TEST_CASE("Taylor coefficients through every instruction equal GiNaC's derivatives",
          "[modeling][taylor]") {
  const SymbolicLock lock;
  const Symbols s;
  const GiNaC::ex x = s.x, y = s.y, z = s.z;
  const std::vector<GiNaC::ex> expressions = {
      x + y - z,
      x * y * z,
      x / y,
      3 / (x + y),
      GiNaC::pow(x, 7),
      GiNaC::pow(x, GiNaC::numeric(5, 2)),
      GiNaC::pow(x, GiNaC::numeric(1, 3)),
      GiNaC::pow(x, y),
      GiNaC::sqrt(x * y + 1),
      GiNaC::sin(x * y),
      GiNaC::cos(z) * x,
      GiNaC::tan(z + x / 3),
      GiNaC::asin(z),
      GiNaC::acos(z / 2 + x / 5),
      GiNaC::atan(x - y),
      GiNaC::atan2(y, x - 1),
      GiNaC::atan2(z, -x),
      GiNaC::exp(-x * z),
      GiNaC::log(x + y),
      GiNaC::sinh(z),
      GiNaC::cosh(x * z),
      GiNaC::tanh(y - x),
      GiNaC::abs(z - 1),
      GiNaC::sin(x) * GiNaC::cos(y) / (1 + GiNaC::pow(z, 2)) +
          GiNaC::exp(GiNaC::cos(x)) * GiNaC::log(y),
  };
  for (const GiNaC::ex& f : expressions) {
    CheckAgainstGinac(s, f);
    CheckDualAgainstGinac(s, f);
    CheckChunkAgainstDual(s, f);
  }
}

TEST_CASE("degree 1 along e_j is the Jacobian column GiNaC derives for a shipped model",
          "[modeling][taylor]") {
  // The forces of the three-link arm (trigonometric in q, quadratic in q_dot): d f / d q_j by
  // Taylor mode equals the compiled symbolic Jacobian at a point away from 0.
  const Model model = LoadModel(testing::ModelPath("three_link_arm.yaml"));
  const SymbolicModel& symbolic = model.symbolic();
  const SymbolicLock lock;
  const std::vector<GiNaC::ex> inputs = symbolic.ProgramInputs();
  std::vector<GiNaC::ex> forces, jacobian;
  for (std::size_t i = 0; i < symbolic.dof(); ++i) {
    forces.push_back(symbolic.forces()(unsigned(i), 0));
    for (std::size_t j = 0; j < symbolic.dof(); ++j) {
      jacobian.push_back(symbolic.forces_position_jacobian()(unsigned(i), unsigned(j)));
    }
  }
  const ExpressionProgram forces_program = CompileExpressions(forces, inputs);
  const ExpressionProgram jacobian_program = CompileExpressions(jacobian, inputs);
  // [parameters, q, q_dot] at the model's parameters and a point where no term vanishes.
  std::vector<double> point(model.parameters().data(),
                            model.parameters().data() + model.parameters().size());
  const std::size_t dof = symbolic.dof();
  for (std::size_t k = 0; k < dof; ++k) point.push_back(0.3 + 0.2 * double(k));
  for (std::size_t k = 0; k < dof; ++k) point.push_back(-0.5 + 0.4 * double(k));
  std::vector<double> expected(dof * dof), registers(jacobian_program.num_registers());
  jacobian_program.Evaluate(point.data(), registers.data(), expected.data());
  const std::size_t q_first = point.size() - 2 * dof;
  std::vector<double> series(point.size() * 2),
      taylor_registers(forces_program.num_registers() * 2), column(dof * 2);
  for (std::size_t j = 0; j < dof; ++j) {
    for (std::size_t i = 0; i < point.size(); ++i) {
      series[2 * i] = point[i];
      series[2 * i + 1] = i == q_first + j ? 1.0 : 0.0;
    }
    forces_program.EvaluateTaylor(1, series.data(), taylor_registers.data(), column.data());
    for (std::size_t i = 0; i < dof; ++i) {
      INFO("d f_" << i << " / d q_" << j);
      CHECK(column[2 * i + 1] == Approx(expected[i * dof + j]).epsilon(1e-13).margin(1e-14));
    }
  }
}

TEST_CASE("coefficient 0 is the value Evaluate computes, to the bit", "[modeling][taylor]") {
  const SymbolicLock lock;
  const Symbols s;
  const GiNaC::ex f = GiNaC::pow(s.x, 7) * GiNaC::sin(s.y) / (s.z + 3) + GiNaC::atan2(s.z, s.x);
  const ExpressionProgram program = CompileExpressions({f}, s.inputs());
  const std::vector<double> point = {0.7, 1.1, 0.35};
  std::vector<double> registers(program.num_registers() * 4), value(1), series(4);
  program.Evaluate(point.data(), registers.data(), value.data());
  const std::vector<double> inputs = {0.7, 1.0, 0.0, 0.0, 1.1, 0.0, 0.0, 0.0, 0.35, 0.0, 0.0, 0.0};
  program.EvaluateTaylor(3, inputs.data(), registers.data(), series.data());
  CHECK(series[0] == value[0]);
}

// Jacobian columns that skip the instructions a chunk's inputs do not reach
// (PropagateTangents) against full passes over DualChunk seeded the same way: every tangent the
// same number (a skipped instruction's tangent is +0 where a full pass may give -0, which ==
// does not tell apart), chunk after chunk on the same registers.
TEST_CASE("tangents propagated through the reached instructions equal full passes",
          "[modeling][taylor]") {
  const SymbolicLock lock;
  const GiNaC::realsymbol x("x"), y("y"), z("z"), w("w");
  const std::vector<GiNaC::ex> inputs = {x, y, z, w};
  const std::vector<GiNaC::ex> outputs = {GiNaC::sin(x) * y + GiNaC::pow(z, 3) / y,
                                          GiNaC::exp(z) - GiNaC::log(y) * GiNaC::sqrt(x),
                                          GiNaC::atan2(y, x) + GiNaC::pow(x, y) + GiNaC::abs(z - 1),
                                          GiNaC::cos(w) * w + 2,
                                          GiNaC::ex(7),
                                          z};
  const ExpressionProgram program = CompileExpressions(outputs, inputs);
  const std::vector<double> point = {0.7, 1.3, -0.4, 0.9};
  std::vector<DualChunk> values(inputs.size()), registers(program.num_registers()),
      unused(program.num_outputs());
  for (std::size_t i = 0; i < inputs.size(); ++i) values[i] = point[i];
  program.EvaluateTaylor(0, values.data(), registers.data(), unused.data());
  std::vector<std::uint32_t> carrying;
  std::vector<char> carries;
  // Two chunks on the same registers: {x, z} in directions 0 and 1, then {w, y}.
  for (const std::vector<std::uint32_t>& seeds :
       {std::vector<std::uint32_t>{0, 2}, std::vector<std::uint32_t>{3, 1}}) {
    std::vector<DualChunk> seeded = values, full_registers(program.num_registers()),
                           full(program.num_outputs());
    for (std::size_t c = 0; c < seeds.size(); ++c) {
      seeded[seeds[c]].tangent.d[c] = 1.0;
      registers[seeds[c]].tangent.d[c] = 1.0;
      carrying.push_back(seeds[c]);
    }
    program.EvaluateTaylor(0, seeded.data(), full_registers.data(), full.data());
    program.PropagateTangents(registers.data(), carrying, carries);
    for (std::size_t k = 0; k < program.num_outputs(); ++k) {
      INFO("output " << k);
      const DualChunk& propagated = registers[program.output_register(k)];
      CHECK(propagated.value == full[k].value);
      for (std::size_t c = 0; c < kChunk; ++c) {
        CHECK(propagated.tangent.d[c] == full[k].tangent.d[c]);
      }
    }
    program.ClearTangents(registers.data(), carrying, carries);
    CHECK(carrying.empty());
  }
  for (const DualChunk& r : registers) {
    for (std::size_t c = 0; c < kChunk; ++c) CHECK(r.tangent.d[c] == 0.0);
  }
}

}  // namespace servokit
