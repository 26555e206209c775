// The test moth for the CFD model's tests (cfd/navier_stokes/cfd_model): a tiny grid (4 cells per mean chord), a
// gentle wingbeat (stroke +-10 deg, pitch 90 +- 10 deg) at Re = 20, 60 steps per wingbeat: a wingbeat costs about a
// second.
#pragma once
#include <string>
#include "common/case_text.hpp"
#include "core/case_file.hpp"

namespace flapstab::testing {

// `extra`: more [aero.cfd] keys; with an [aero.cfd.fpm] table in it the case takes the CFD model (the case file
// accepts the table with that model only).
inline Case model_case(const std::string& name, const std::string& extra) {
  const std::string keys =
      "cells_per_chord = 4\nfine_margin_R = 0.4\nupstream_R = 0\ndownstream_R = 0\nlateral_R = 0\nabove_R = 0\n"
      "below_R = 0.5\nsteps_per_cycle = 60\nbody_divisions = 6\nwing_span_stations = 12\nwing_chord_divisions = 4\n"
      "threads = 1\nreynolds = 20\n" + extra;
  std::string text = replace(valid_cfd_case_text(), "[trim]\n", "[aero.cfd]\n" + keys + "\n[trim]\n");
  text = replace(replace(text, "cos_deg = [-60.0]", "cos_deg = [-10.0]"), "sin_deg = [-55.0]", "sin_deg = [-10.0]");
  if (extra.find("[aero.cfd.fpm]") != std::string::npos)
    text = replace(text, "model = \"quasi-steady\"", "model = \"cfd\"");
  return load_case(write_temp(name, text));
}

}  // namespace flapstab::testing
