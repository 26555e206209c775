// Builds the aerodynamic model a case file asks for ([aero] model = ...).
#pragma once
#include <memory>
#include "core/aero_model.hpp"
#include "core/case_file.hpp"

namespace flapstab {

// Throws InputError (file, "aero.model") if the model is not available in this build.
std::unique_ptr<AeroModel> make_aero_model(const Case& c);

}  // namespace flapstab
