// Loads of one CFD step per part and the forces.csv format (docs/cfd-files.md).
#pragma once
#include <string>
#include "core/types.hpp"

namespace flapstab::ns {

// The insect's parts in the CFD geometry, in this order: body, fore wings, then the hind pair of a four-winged insect.
// A two-winged insect has the first three; a four-winged one all five.
inline constexpr int max_parts = 5;
inline constexpr const char* part_names[max_parts] = {"body", "right", "left", "hind_right", "hind_left"};

// Loads of one step, about O in stability axes S (N, N m, W).
struct CfdLoadRow {
  double time = 0;
  long step = 0;
  double phase = 0;  // t / T modulo 1
  struct Part {
    Vec3 pressure_force = Vec3::Zero(), viscous_force = Vec3::Zero();
    Vec3 pressure_moment = Vec3::Zero(), viscous_moment = Vec3::Zero();
    double power = 0;  // W: rate of work of the part on the air (grid frame)
    Wrench wrench() const { return Wrench{pressure_force + viscous_force, pressure_moment + viscous_moment}; }
  } part[max_parts];   // body, right, left[, hind_right, hind_left] (part_names); those past `parts` stay zero
  int parts = 3;       // parts in the geometry: 3, or 5 with a hind pair
  double wing_power = 0;  // W: the wings' work on the air from their motion relative to the body (AeroModel power)
  Wrench total() const;
};

// The header row of forces.csv for a geometry of `parts` parts: the column names with their units (axes and parts:
// run.json, docs/cfd-files.md).
std::string forces_csv_header(int parts = 3);
// The row's r.parts parts, then the totals.
std::string forces_csv_row(const CfdLoadRow& r);
// The inverse of forces_csv_row (without its newline), its part count from the number of columns (3 or 5 parts);
// std::invalid_argument for a malformed row.
CfdLoadRow parse_forces_csv_row(const std::string& line);

}  // namespace flapstab::ns
