// The insect's morphology and mass properties: ellipsoidal body, two wings with planform, mass and hinge.
//
// Anatomical body frame A: origin at the body's own centre of mass (wings excluded), x along the
// long axis towards the head, y to the right, z ventral. Wing frame (per wing, origin at the hinge):
// x along the chord towards the leading edge (origin on the pitch axis), y along the span towards the
// tip, z = x cross y (ventral for the right wing at rest). The left wing is the mirror image.
#pragma once
#include <optional>
#include <string>
#include <vector>
#include "core/series.hpp"
#include "core/types.hpp"

namespace flapstab {

struct Body {
  double mass = 0;       // kg, body only (wings excluded)
  double length = 0;     // m, ellipsoid length along x_A (diameter)
  double width = 0;      // m, along y_A
  double height = 0;     // m, along z_A
  Mat3 inertia = Mat3::Zero();  // kg m^2, about the body CoM in A (from the ellipsoid unless given)
  double drag_coefficient = 0;  // body drag on the frontal ellipse area for each axis (0: neglected)
  // Solid uniform ellipsoid inertia of this mass and these diameters.
  Mat3 ellipsoid_inertia() const;
};

enum class Planform { elliptic, rectangular, tabulated, polynomial };

struct Wing {
  double length = 0;        // R (m), hinge to tip
  double mean_chord = 0;    // c_bar (m) = area / R
  Planform planform = Planform::elliptic;
  std::vector<double> table_r, table_c;  // tabulated: r/R in [0,1] and c/c_bar, increasing r
  std::vector<double> poly;              // polynomial: c/c_bar = sum_k poly[k] (r/R)^k, normalised to unit mean
  double pitch_axis = 0.25;  // x0: pitch axis position from the leading edge, fraction of local chord
  double mass = 0;           // kg, one wing
  Vec3 mass_centre = Vec3::Zero();    // wing frame, m (about the hinge)
  Mat3 inertia_cg = Mat3::Zero();     // wing frame, about the wing CoM, kg m^2
  Vec3 hinge = Vec3::Zero();          // right wing hinge in A (m); the left is its mirror

  // Local chord c(r) (m) at distance r (m) from the hinge.
  double chord(double r) const;
  double area() const { return mean_chord * length; }   // one wing, m^2
  // Radius of the k-th moment of area: (int r^k c dr / S)^(1/k) (m).
  double radius_of_moment(int k) const;
  // Mass centre and inertia (about the hinge, wing frame) of a thin plate of uniform areal density.
  void plate_mass_properties(Vec3& centre, Mat3& inertia_hinge) const;
};

// A second body segment hinged to the thorax ([abdomen]): the "body" above is then the thorax (with the head), and
// A keeps its origin at the thorax's own CoM. The abdomen turns about the joint's y axis (the body's pitch axis)
// by a relative pitch eta(t) prescribed as a periodic series of the wingbeat phase; positive eta turns it the way
// a nose-up pitch turns the body (the tip of an aft-pointing abdomen moves ventrally). Its frame coincides with A
// at eta = 0 and is A turned by rot_y(eta) otherwise.
struct Abdomen {
  double mass = 0;                    // kg
  Vec3 joint = Vec3::Zero();          // joint position in A, from the thorax CoM (m)
  Vec3 centre = Vec3::Zero();         // abdomen CoM from the joint, abdomen frame (m)
  Mat3 inertia_cg = Mat3::Zero();     // about the abdomen CoM, abdomen frame (kg m^2)
  AngleSeries pitch;                  // eta (rad) against the wingbeat phase tau = t f (cycles)
  // Quadratic drag of the abdomen as an ellipsoid centred at its CoM (quasi-steady model; 0: none), on the projected
  // ellipse area of each abdomen axis, as [body] drag_coefficient on the thorax.
  double drag_coefficient = 0;
  Vec3 diameters = Vec3::Zero();      // length (x), width (y), height (z) of that ellipsoid, abdomen axes (m)
};

struct Insect {
  std::string name;
  Body body;
  Wing wing;                      // the fore pair (the only pair of a two-winged insect)
  std::optional<Wing> hind_wing;  // the hind pair of a four-winged insect: own planform, hinge and mass
  std::optional<Abdomen> abdomen; // a second body segment with prescribed relative pitch
  // Gravitational acceleration where it flies (m/s^2; [environment] gravity_m_s2). Kept with the insect because
  // everything that weighs it (trim, equations of motion, derivatives, free flight) already takes the insect.
  double gravity = standard_gravity;
  double total_mass() const {
    return body.mass + 2 * wing.mass + (hind_wing ? 2 * hind_wing->mass : 0.0) + (abdomen ? abdomen->mass : 0.0);
  }
  const Wing& pair_wing(Pair p) const { return p == Pair::hind ? *hind_wing : wing; }
  double weight() const { return total_mass() * gravity; }
};

}  // namespace flapstab
