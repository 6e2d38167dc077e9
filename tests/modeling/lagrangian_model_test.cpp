// The derivation budget of modeling/lagrangian_model.h (issue #31): the terms of the derived
// M and f are counted as they are derived, and the entry that passes the budget is named.
// Counted by hand for T = m/2 (x'^2 + y'^2) + c x' y', V = k/2 (x^2 + y^2) + e x y:
//   M = [[m, c], [c, m]]: three entries above the diagonal, one term each;
//   f = [k x + e y, k y + e x]: two terms each (T's coefficients are constant, so the
//   velocity terms of Lagrange's equations vanish).
// Seven terms in all, charged in the order M_xx, M_xy, M_yy, f_x, f_y: a budget of 7 passes,
// 6 stops at f's entry for y, 1 at M's entry d2T/dx' dy'. And a projected chain:
// M = sum w J^T J and f = sum w J^T gamma charge one term per product.
#include "modeling/lagrangian_model.h"

#include <catch2/catch.hpp>
#include <string>
#include <vector>

#include "modeling/symbolic_lock.h"

namespace servokit::detail {
namespace {

struct TwoMasses {
  GiNaC::realsymbol x{"x"}, y{"y"}, vx{"x_dot"}, vy{"y_dot"}, m{"m"}, c{"c"}, k{"k"}, e{"e"};
  std::vector<GiNaC::realsymbol> coordinates{x, y}, velocities{vx, vy};

  Energies TheEnergies() const {
    Energies energies;
    energies.kinetic = m / 2 * (vx * vx + vy * vy) + c * vx * vy;
    energies.potential = k / 2 * (x * x + y * y) + e * x * y;
    energies.generalized_forces = GiNaC::matrix(2, 1);
    return energies;
  }

  // Derives M and f under `budget`; the message of the DerivationTooLarge, or "" for none.
  std::string Derive(TermBudget& budget) const {
    const Energies energies = TheEnergies();
    try {
      const std::vector<GiNaC::ex> momenta = Momenta(energies.kinetic, velocities);
      const GiNaC::matrix mass = KineticMassMatrix(momenta, velocities, budget);
      CHECK((mass(0, 1) - c).is_zero());
      const GiNaC::matrix forces =
          LagrangeForces(energies, momenta, coordinates, velocities, budget);
      CHECK((forces(1, 0) - (k * y + e * x)).expand().is_zero());
    } catch (const DerivationTooLarge& error) {
      return error.what();
    }
    return "";
  }
};

}  // namespace

TEST_CASE("the derived M and f are charged to the budget term by term", "[modeling]") {
  const SymbolicLock lock;
  const TwoMasses model;
  TermBudget enough(7);
  CHECK(model.Derive(enough).empty());
  CHECK(enough.used() == 7);

  TermBudget one_short(6);
  const std::string in_f = model.Derive(one_short);
  CHECK(in_f.find("too large: its equations of motion pass the budget of 6 terms") !=
        std::string::npos);
  CHECK(in_f.find("at f's entry for y") != std::string::npos);

  TermBudget tiny(1);
  const std::string in_m = model.Derive(tiny);
  CHECK(in_m.find("at M's entry d2T/dx_dot dy_dot") != std::string::npos);
}

TEST_CASE("projected equations charge each product of Jacobians", "[modeling]") {
  // Two point masses on a chain of two rods in the plane, x-positions only: p1 = l sin(q1),
  // p2 = l sin(q1) + l sin(q2). J1 = [l cos q1, 0], J2 = [l cos q1, l cos q2]: products for
  // M (upper triangle) 1 + 3 = 4, for f one per nonzero J entry, 1 + 2 = 3: 7 in all, charged
  // position by position, row by row, f's before M's: the 6th is f's for q2, the 7th M_22.
  const SymbolicLock lock;
  const GiNaC::realsymbol q1("q1"), q2("q2"), v1("q1_dot"), v2("q2_dot"), l("l"), m("m");
  const std::vector<GiNaC::realsymbol> coordinates = {q1, q2}, velocities = {v1, v2};
  const std::vector<WeightedPosition> positions = {{m, l * GiNaC::sin(q1)},
                                                   {m, l * GiNaC::sin(q1) + l * GiNaC::sin(q2)}};
  Energies energies;
  energies.generalized_forces = GiNaC::matrix(2, 1);
  TermBudget enough(7);
  const EquationsOfMotion equations =
      ProjectedEquations(positions, energies, coordinates, velocities, enough);
  CHECK(enough.used() == 7);
  const GiNaC::ex expected_m11 = 2 * m * l * l * GiNaC::pow(GiNaC::cos(q1), 2);
  CHECK((equations.mass_matrix(0, 0) - expected_m11).expand().is_zero());
  TermBudget one_short(6);
  CHECK_THROWS_WITH(ProjectedEquations(positions, energies, coordinates, velocities, one_short),
                    Catch::Contains("at M's entry for q2 and q2"));
  TermBudget two_short(5);
  CHECK_THROWS_WITH(ProjectedEquations(positions, energies, coordinates, velocities, two_short),
                    Catch::Contains("at f's entry for q2"));
}

}  // namespace servokit::detail
