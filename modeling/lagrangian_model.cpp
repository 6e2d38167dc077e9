#include "modeling/lagrangian_model.h"

#include <cassert>

namespace servokit::detail {

GiNaC::matrix KineticMassMatrix(const GiNaC::ex& kinetic,
                                const std::vector<GiNaC::realsymbol>& velocities) {
  const auto dof = static_cast<unsigned>(velocities.size());
  GiNaC::matrix mass(dof, dof);
  for (unsigned i = 0; i < dof; ++i) {
    const GiNaC::ex momentum = kinetic.diff(velocities[i]);
    for (unsigned j = i; j < dof; ++j) {
      mass(i, j) = momentum.diff(velocities[j]).expand();
      mass(j, i) = mass(i, j);
    }
  }
  return mass;
}

GiNaC::matrix LagrangeForces(const Energies& energies,
                             const std::vector<GiNaC::realsymbol>& coordinates,
                             const std::vector<GiNaC::realsymbol>& velocities) {
  assert(coordinates.size() == velocities.size());
  const auto dof = static_cast<unsigned>(coordinates.size());
  assert(energies.generalized_forces.rows() == dof && energies.generalized_forces.cols() == 1);
  GiNaC::matrix forces(dof, 1);
  for (unsigned i = 0; i < dof; ++i) {
    const GiNaC::ex momentum = energies.kinetic.diff(velocities[i]);  // dT/dq'_i
    GiNaC::ex force = 0;
    // d/dt dT/dq'_i = sum_j d2T/dq'_i dq'_j q''_j + sum_j d2T/dq'_i dq_j q'_j; the first sum
    // is M q'', the second belongs to f.
    for (unsigned j = 0; j < dof; ++j) force += momentum.diff(coordinates[j]) * velocities[j];
    force += -energies.kinetic.diff(coordinates[i]) + energies.potential.diff(coordinates[i]) +
             energies.dissipation.diff(velocities[i]) - energies.generalized_forces(i, 0);
    forces(i, 0) = force.expand();
  }
  return forces;
}

GiNaC::ex QuadraticFormRemainder(const GiNaC::ex& kinetic,
                                 const GiNaC::matrix& mass_matrix,
                                 const std::vector<GiNaC::realsymbol>& velocities) {
  GiNaC::ex quadratic_form = 0;
  for (unsigned i = 0; i < velocities.size(); ++i) {
    for (unsigned j = 0; j < velocities.size(); ++j) {
      quadratic_form += mass_matrix(i, j) * velocities[i] * velocities[j];
    }
  }
  return (kinetic - quadratic_form / 2).expand();
}

}  // namespace servokit::detail
