// Reader for FLUSI/WABBIT wing-kinematics .ini files (Fourier or periodic Hermite descriptors).
//
// The file describes one wing's positional angle phi, feathering angle alpha and deviation theta
// over one wingbeat (t in periods) in FLUSI's own convention. The reader maps each angle onto
// flapstab's convention (core/kinematics.hpp) by an exact linear map (docs/flusi-kinematics.md):
//     phi_flapstab   = -phi_flusi
//     theta_flapstab = -theta_flusi        (convention=flusi; convention=sisc: +theta_sisc)
//     alpha_flapstab = 90 deg - alpha_flusi
// The map acts on coefficients (Fourier a0/2, ai, bi; Hermite node values and slopes), so the
// series stay exact. The file carries no stroke-plane or body angle: those come from the case file.
#pragma once
#include <string>
#include "core/kinematics.hpp"

namespace flapstab {

// Reads a FLUSI kinematics .ini file; returns the three angle series in flapstab's convention (radians).
// Throws InputError(file, key, problem, expected) for: missing file, missing [kinematics] section
// (naming FLUSI's kinematics_loader format when the file is one), unknown or repeated keys,
// unknown type/units/convention, nfft mismatch with the number of ai/bi values, non-numeric values,
// NaN/inf, missing required keys.
WingAngles read_flusi_kinematics(const std::string& path);

}  // namespace flapstab
