// Case files (TOML): the insect, its kinematics, the fluid, the aerodynamic model, trim and outputs.
// Every field is validated; errors name the file, the key and what was expected (docs/case-file.md).
#pragma once
#include <string>
#include <vector>
#include "core/insect.hpp"
#include "core/kinematics.hpp"

namespace flapstab {

struct FluidProperties {
  double density = 1.225;                // kg/m^3
  double kinematic_viscosity = 1.5e-5;   // m^2/s
};

struct QuasiSteadySettings {
  std::string coefficients = "robofly";  // "robofly" | "berman-wang"
  int blade_elements = 40;
  bool rotational = true;
  bool added_mass = true;
  int samples_per_cycle = 128;
};

struct AeroSettings {
  std::string model = "quasi-steady";    // "quasi-steady" | "cfd"
  QuasiSteadySettings quasi_steady;
};

enum class ParameterSide { both, right, left };

struct TrimParameterSpec {
  std::string name;     // e.g. "stroke_amplitude_deg"
  double lower = 0, upper = 0;  // in the parameter's unit (deg or Hz)
  ParameterSide side = ParameterSide::both;
  std::string label() const;    // name with the side appended when not "both"
};

struct TrimSettings {
  std::string solver = "ipopt";          // "ipopt" | "nlopt"
  std::string objective = "least-change";  // "least-change" | "min-power"
  double tolerance = 1e-10;
  int max_iterations = 200;
  std::vector<TrimParameterSpec> parameters;
};

struct DerivativeSettings {
  double relative_step = 0.01;
};

struct Case {
  std::string path;          // the case file
  std::string description;
  std::vector<std::string> sources;
  Insect insect;
  Kinematics kinematics;
  FluidProperties fluid;
  AeroSettings aero;
  TrimSettings trim;
  DerivativeSettings derivatives;
  std::string output_directory = "out";
};

// Names accepted in [[trim.parameter]] name = ...
const std::vector<std::string>& trim_parameter_names();

// Loads and validates a case file. Throws InputError(file, key, problem, expected).
Case load_case(const std::string& path);

}  // namespace flapstab
