// Builds the aerodynamic model a case file asks for.
#include "cfd/aero_factory.hpp"
#include "cfd/navier_stokes/run.hpp"
#include "cfd/quasi_steady/quasi_steady.hpp"
#include "core/errors.hpp"

namespace flapstab {

std::unique_ptr<AeroModel> make_aero_model(const Case& c) {
  if (c.aero.model == "quasi-steady") {
    QuasiSteadyOptions o;
    o.rho = c.fluid.density;
    const std::string& set = c.aero.quasi_steady.coefficients;
    o.coefficients = set == "berman-wang" ? CoefficientSet::berman_wang
                     : set == "table"     ? CoefficientSet::table
                                          : CoefficientSet::robofly;
    o.constants = c.aero.quasi_steady.constants;
    o.rotational_coefficient = c.aero.quasi_steady.rotational_coefficient;
    o.centre_of_pressure = c.aero.quasi_steady.centre_of_pressure;
    o.blade_elements = c.aero.quasi_steady.blade_elements;
    o.rotational = c.aero.quasi_steady.rotational;
    o.added_mass = c.aero.quasi_steady.added_mass;
    o.samples_per_cycle = c.aero.quasi_steady.samples_per_cycle;
    return std::make_unique<QuasiSteadyModel>(o);
  }
  if (c.aero.model == "cfd") return std::make_unique<ns::CfdModel>(c);
  throw InputError(c.path, "aero.model", "unknown model \"" + c.aero.model + "\"", "\"quasi-steady\" or \"cfd\"");
}

}  // namespace flapstab
