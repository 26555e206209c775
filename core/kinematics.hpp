// Wing kinematics: stroke, deviation and pitch angle histories per wing, stroke plane, body angle, frequency.
//
// Angle conventions (docs/theory/conventions.md): for each wing, in its stroke-plane frame,
//  - stroke (positional) angle phi: in the stroke plane, 0 = span perpendicular to the plane of
//    symmetry, positive towards the head;
//  - deviation theta: out of the stroke plane, positive towards the dorsal side (up in hover);
//  - pitch (feathering) alpha: about the span axis, 0 = chord in the stroke plane with the leading
//    edge pointing forward (towards the head), positive rotating the leading edge dorsally.
//    A hovering downstroke (phi increasing) at 35 deg incidence has alpha = 35 deg; the upstroke
//    at the same incidence has alpha = 145 deg; the wing passes alpha = 90 deg at the reversals.
// The phase tau = t * frequency is in cycles; all series hold radians.
#pragma once
#include "core/series.hpp"
#include "core/types.hpp"

namespace flapstab {

struct WingAngles {
  AngleSeries stroke;     // phi
  AngleSeries deviation;  // theta
  AngleSeries pitch;      // alpha
};

// The three angles and their time derivatives (rad, rad/s, rad/s^2) at one instant.
struct WingAngleState {
  double phi = 0, theta = 0, alpha = 0;
  double dphi = 0, dtheta = 0, dalpha = 0;
  double ddphi = 0, ddtheta = 0, ddalpha = 0;
};

struct Kinematics {
  double frequency_hz = 0;    // wingbeat frequency n
  double stroke_plane = 0;    // beta (rad): stroke-plane inclination from the stability x-y plane, positive nose-up
  double body_angle = 0;      // chi (rad): body long axis above the stability x axis, positive nose-up
  // When true ([kinematics] stroke_plane_reference = "body"), stroke_plane is measured from the body long axis, so the
  // stroke plane turns with the body (a body-angle change leaves the wing motion relative to the body unchanged).
  bool stroke_plane_on_body = false;
  // The stroke plane's inclination from the stability x-y plane (rad), whichever its reference.
  double stroke_plane_in_stability() const { return stroke_plane + (stroke_plane_on_body ? body_angle : 0.0); }
  // Abdominal flexion (rad): added to the abdomen's relative pitch eta ([abdomen.pitch]) at every phase; 0 = the
  // case's abdomen motion. The trim and actuator parameter abdomen_flexion_deg (an insect with an [abdomen] only):
  // hawkmoths flex the abdomen to steer (Dyhr et al. 2013, J Exp Biol 216:1523).
  double abdomen_flexion = 0;
  WingAngles right, left;     // left uses the same conventions as right (mirror-image definitions)
  // The hind pair of a four-winged insect ([kinematics.hind]): its own angle histories in the same stroke plane,
  // evaluated hind_phase cycles ahead of the fore pair (tau_hind = tau + hind_phase).
  bool has_hind = false;
  WingAngles hind_right, hind_left;
  double hind_phase = 0;

  double period() const { return 1.0 / frequency_hz; }
  const WingAngles& wing(Side s) const { return s == Side::right ? right : left; }
  WingAngles& wing(Side s) { return s == Side::right ? right : left; }
  const WingAngles& wing(Side s, Pair p) const {
    return p == Pair::fore ? wing(s) : (s == Side::right ? hind_right : hind_left);
  }
  // Angles of one wing at time t (s).
  WingAngleState angles(Side s, double t, Pair p = Pair::fore) const;
  // True when left and right angle histories agree at every sampled phase (to 1e-14 rad).
  bool symmetric() const;
  // Stroke amplitude Phi (rad, peak to peak), the mean of the two wings. For revolving wings, half the
  // angle swept per cycle, so that 2 Phi n r2 is the mean speed at r2 in both cases.
  double stroke_amplitude() const;
  // True when the wings revolve (constant stroke velocity, docs/case-file.md) instead of flapping.
  bool revolving() const { return right.stroke.revolving(); }
};

}  // namespace flapstab
