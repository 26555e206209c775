// The derivative table: reference quantities, mass properties and non-dimensional stability derivatives.
//
// File format (TOML, docs/derivative-table.md): [reference] time, U, c, S_t, rho, frequency, g;
// [mass] m, Ixx, Iyy, Izz, Ixz (SI) or m_plus, Ixx_plus, Iyy_plus, Izz_plus, Ixz_plus, g_plus (non-dimensional);
// [derivatives.longitudinal] Xu Xw Xq Zu Zw Zq Mu Mw Mq;
// [derivatives.lateral] Yv Yp Yr Lv Lp Lr Nv Np Nr; optional [derivatives.coupling] (e.g. Xv, Lu, Mp);
// optional [derivatives.control.<parameter>] X Y Z L M N per unit of the parameter (e.g. stroke_plane_deg).
// A file may state its rates and mass parameters with the wingbeat period T as reference time
// ([reference] time = "wingbeat": q+ = q T, m+ = m / (1/2 rho U S_t T), ..., as Sun & Xiong 2005, J Exp Biol
// 208:447) or with c / U (time = "chord", the default); the reader converts either to the one internal
// convention the DerivativeTable holds: SI mass properties and g, derivatives in hover stability axes with
// forces / (1/2 rho U^2 S_t), moments / (1/2 rho U^2 S_t c), velocities / U, rates * c / U.
#pragma once
#include <map>
#include <optional>
#include <string>
#include <vector>
#include "core/types.hpp"

namespace flapstab {

struct ReferenceQuantities {
  double U = 0;          // m/s, reference speed 2 Phi n r2
  double c = 0;          // m, mean chord
  double S_t = 0;        // m^2, area of both wings
  double rho = 0;        // kg/m^3
  double frequency = 0;  // Hz, wingbeat frequency
  double g = standard_gravity;  // m/s^2
  double force_scale() const { return 0.5 * rho * U * U * S_t; }
  double moment_scale() const { return force_scale() * c; }
  double time_scale() const { return c / U; }  // s per unit non-dimensional time
};

struct MassProperties {
  double m = 0;                          // kg
  double Ixx = 0, Iyy = 0, Izz = 0, Ixz = 0;  // kg m^2, about O in stability axes
};

// A control derivative column: d[X Y Z L M N]+ / d(parameter) of one actuated kinematic parameter, per unit of
// the parameter (deg or Hz), forces / (1/2 rho U^2 S_t), moments / (1/2 rho U^2 S_t c) about the trimmed O,
// including the gravitational moment of the centre of mass the parameter moves.
struct ControlDerivative {
  std::string parameter;  // trim parameter name, e.g. "stroke_plane_deg"
  std::string unit;       // "deg" | "Hz"
  Eigen::Matrix<double, 6, 1> nd = Eigen::Matrix<double, 6, 1>::Zero();
};

// Non-dimensional derivatives, 6 x 6: rows X Y Z L M N, columns u v w p q r.
struct DerivativeTable {
  ReferenceQuantities reference;
  MassProperties mass;
  Eigen::Matrix<double, 6, 6> nd = Eigen::Matrix<double, 6, 6>::Zero();
  bool has_longitudinal = false, has_lateral = false, has_coupling = false;
  std::vector<ControlDerivative> control;  // [derivatives.control.<parameter>]: X Y Z L M N (optional)
  std::string source;  // where the table came from (file path or "flapstab <model>")

  // Element by name, e.g. "Xu", "Mq", "Lp" (rows X Y Z L M N, columns u v w p q r).
  double& at(const std::string& name);
  double at(const std::string& name) const;
};

// Reads a derivative table in either time convention and either mass set, returning it in the internal
// convention above; throws InputError naming the file and key on any problem.
DerivativeTable read_derivative_table(const std::string& path);
// TOML text of the table (with a header comment giving axes, units and scalings), in the internal convention:
// [reference] time = "chord", SI mass properties.
std::string derivative_table_toml(const DerivativeTable& table);
// Writes derivative_table_toml(table) to path atomically (temporary file, then rename).
void write_derivative_table(const DerivativeTable& table, const std::string& path);

// Name of entry (row, col) of DerivativeTable::nd, e.g. (4, 4) -> "Mq".
std::string derivative_name(int row, int col);
// The nine names of each section, in file order; coupling names are the other 18.
const std::vector<std::string>& longitudinal_derivative_names();
const std::vector<std::string>& lateral_derivative_names();
const std::vector<std::string>& coupling_derivative_names();

}  // namespace flapstab
