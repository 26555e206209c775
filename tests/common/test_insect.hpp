// A small hawkmoth-like insect and harmonic kinematics built in code, shared by the unit tests.
#pragma once
#include "core/insect.hpp"
#include "core/kinematics.hpp"

namespace flapstab::testing {

// Hawkmoth-sized insect (Willmott & Ellington 1997 morphology as tabulated by Berman & Wang 2007:
// 1.648 g, R 51.9 mm, c 18.26 mm, wing 47 mg); hinge position and body size are round numbers.
inline Insect test_insect() {
  Insect i;
  i.name = "test-moth";
  i.wing.length = 0.0519;
  i.wing.mean_chord = 0.01826;
  i.wing.planform = Planform::elliptic;
  i.wing.pitch_axis = 0.25;
  i.wing.mass = 47e-6;
  i.wing.hinge = Vec3(0.006, 0.004, -0.003);
  Vec3 c;
  Mat3 ih;
  i.wing.plate_mass_properties(c, ih);
  i.wing.mass_centre = c;
  i.wing.inertia_cg = ih - i.wing.mass * (c.squaredNorm() * Mat3::Identity() - c * c.transpose());
  i.body.mass = 1.648e-3 - 2 * 47e-6;
  i.body.length = 0.045;
  i.body.width = 0.011;
  i.body.height = 0.011;
  i.body.inertia = i.body.ellipsoid_inertia();
  return i;
}

// phi = -(Phi/2) cos(2 pi tau), alpha = 90 - (90 - a_mid) sin(2 pi tau) (deg), optional deviation.
inline WingAngles harmonic_wing(double amplitude_deg, double incidence_deg, double stroke_mean_deg = 0,
                                double deviation_deg = 0) {
  WingAngles w;
  w.stroke = FourierSeries{stroke_mean_deg * deg, {-0.5 * amplitude_deg * deg}, {0.0}};
  w.pitch = FourierSeries{90 * deg, {0.0}, {-(90 - incidence_deg) * deg}};
  w.deviation = FourierSeries{0.0, {0.0, deviation_deg * deg}, {0.0, 0.0}};
  return w;
}

inline Kinematics harmonic_kinematics(double freq = 26.0, double amplitude_deg = 120, double incidence_deg = 35,
                                      double body_angle_deg = 40, double stroke_plane_deg = 0) {
  Kinematics k;
  k.frequency_hz = freq;
  k.body_angle = body_angle_deg * deg;
  k.stroke_plane = stroke_plane_deg * deg;
  k.right = harmonic_wing(amplitude_deg, incidence_deg);
  k.left = k.right;
  return k;
}

}  // namespace flapstab::testing
