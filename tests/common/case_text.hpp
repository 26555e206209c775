// A complete, valid case file as text (hawkmoth-like), for tests that edit one field at a time.
#pragma once
#include <filesystem>
#include <fstream>
#include <iterator>
#include <string>
#include <stdexcept>
#include <unistd.h>

namespace flapstab::testing {

inline std::string valid_case_text() {
  return R"(# test case (numbers: Willmott & Ellington 1997 via Berman & Wang 2007; hinge assumed)
[insect]
name = "test-moth"
sources = ["Berman & Wang 2007, J Fluid Mech 582:153, Table 2"]

[body]
mass_kg = 1.554e-3
length_m = 0.045
width_m = 0.011
height_m = 0.011

[wing]
length_m = 0.0519
mean_chord_m = 0.01826
planform = "elliptic"
pitch_axis_chord_fraction = 0.25
mass_kg = 47e-6
hinge_m = [0.006, 0.004, -0.003]

[kinematics]
frequency_hz = 26.0
stroke_plane_deg = 0.0
body_angle_deg = 40.0
[kinematics.stroke]
mean_deg = 0.0
cos_deg = [-60.0]
sin_deg = [0.0]
[kinematics.pitch]
mean_deg = 90.0
cos_deg = [0.0]
sin_deg = [-55.0]

[fluid]
density_kg_m3 = 1.225

[aero]
model = "quasi-steady"
[aero.quasi_steady]
coefficients = "robofly"
blade_elements = 40

[trim]
solver = "ipopt"
objective = "least-change"
tolerance = 1e-10
[[trim.parameter]]
name = "stroke_amplitude_deg"
lower = 60.0
upper = 170.0
[[trim.parameter]]
name = "stroke_mean_deg"
lower = -40.0
upper = 40.0
[[trim.parameter]]
name = "pitch_mean_deg"
lower = 60.0
upper = 120.0
)";
}

// Writes text to a fresh file in a per-test temporary directory; returns its path.
inline std::string write_temp(const std::string& name, const std::string& text) {
  const auto dir = std::filesystem::temp_directory_path() / ("flapstab_test_" + std::to_string(::getpid()));
  std::filesystem::create_directories(dir);
  const auto p = dir / name;
  std::ofstream(p) << text;
  return p.string();
}

// The whole text of a file (a shipped case to edit); std::runtime_error if it cannot be read.
inline std::string read_file(const std::string& path) {
  std::ifstream in(path);
  if (!in) throw std::runtime_error("test: cannot read " + path);
  return std::string(std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>());
}

// Replaces the first occurrence of `from` in `s` with `to` (the test fails loudly if absent).
inline std::string replace(std::string s, const std::string& from, const std::string& to) {
  const auto i = s.find(from);
  if (i == std::string::npos) throw std::runtime_error("test edit: '" + from + "' not in case text");
  return s.replace(i, from.size(), to);
}

// The valid case for Navier-Stokes runs: its elliptic planform has the widest chord at the hinge, and swept back its
// trailing edge crosses the plane of symmetry, so the two wings would cut through each other, which plan_cfd
// refuses (the immersed boundary cannot model it). A narrow wing base instead, the planform of
// data/cases/hawkmoth_cfd.toml: c ~ (r/R + 0.05)^0.7 (1 - r/R)^0.85, r2 = 0.518 R.
inline std::string valid_cfd_case_text() {
  return replace(valid_case_text(), "planform = \"elliptic\"\n",
                 "planform = \"tabulated\"\n"
                 "r_over_R = [0.00, 0.05, 0.10, 0.15, 0.20, 0.25, 0.30, 0.35, 0.40, 0.45, "
                 "0.50, 0.55, 0.60, 0.65, 0.70, 0.75, 0.80, 0.85, 0.90, 0.95, 1.00]\n"
                 "chord_over_mean = [0.4507, 0.7009, 0.8892, 1.0360, 1.1503, 1.2371, 1.2996, 1.3398, 1.3592, 1.3589, "
                 "1.3396, 1.3018, 1.2457, 1.1712, 1.0782, 0.9661, 0.8338, 0.6796, 0.5001, 0.2876, 0.0000]\n");
}

// The valid case with Berman & Wang (2007, J Fluid Mech 582:153) angle forms instead of Fourier series.
inline std::string berman_wang_case_text() {
  std::string t = valid_case_text();
  t = replace(t, "[kinematics.stroke]\nmean_deg = 0.0\ncos_deg = [-60.0]\nsin_deg = [0.0]\n",
              "[kinematics.stroke]\ntype = \"berman-wang\"\namplitude_deg = 60.0\nshape_k = 0.7\n"
              "phase_deg = 180.0\n");
  t = replace(t, "[kinematics.pitch]\nmean_deg = 90.0\ncos_deg = [0.0]\nsin_deg = [-55.0]\n",
              "[kinematics.pitch]\ntype = \"berman-wang\"\nmean_deg = 90.0\namplitude_deg = -55.0\n"
              "shape_c = 2.4\n[kinematics.deviation]\ntype = \"berman-wang\"\namplitude_deg = 4.0\n"
              "harmonic = 2\n");
  return t;
}

}  // namespace flapstab::testing
