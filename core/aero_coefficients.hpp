// The constants of the quasi-steady translational coefficient sets, as a case file gives them (docs/case-file.md
// [aero.quasi_steady]; the formulas and sources: docs/theory/quasi-steady.md section 3).
#pragma once
#include <vector>

namespace flapstab {

// The constants of each set ([aero.quasi_steady.robofly], [aero.quasi_steady.berman-wang], [aero.quasi_steady.table];
// the names of docs/theory/quasi-steady.md section 3). Defaults: the published values.
struct RoboflyConstants {
  // C_L = lift_mean + lift_amplitude sin(lift_rate alpha - lift_offset_deg) (alpha in deg), less the end terms;
  // C_D = drag_mean - drag_amplitude cos(drag_rate alpha - drag_offset_deg).
  double lift_mean = 0.225, lift_amplitude = 1.58, lift_rate = 2.13, lift_offset_deg = 7.20;
  double drag_mean = 1.92, drag_amplitude = 1.55, drag_rate = 2.04, drag_offset_deg = 9.82;
};
struct BermanWangConstants {
  double c_t = 1.678, c_d_0 = 0.07, c_d_90 = 3.06;  // C_L = C_T sin 2a, C_D = C_D(0) cos^2 a + C_D(pi/2) sin^2 a
};
// Natural-order tables: alpha_deg strictly increasing from 0 to 90; lift and drag at those angles.
struct CoefficientTable {
  std::vector<double> alpha_deg, lift, drag;
};
struct CoefficientConstants {
  RoboflyConstants robofly;
  BermanWangConstants berman_wang;
  CoefficientTable table;
};

}  // namespace flapstab
