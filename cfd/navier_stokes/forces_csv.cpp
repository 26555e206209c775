// forces.csv (forces_csv.hpp).
#include "cfd/navier_stokes/forces_csv.hpp"

#include <stdexcept>
#include <vector>
#include <fmt/format.h>

namespace flapstab::ns {

Wrench CfdLoadRow::total() const {
  Wrench w;
  for (int i = 0; i < parts; ++i) {
    const Part& q = part[i];
    w.force += q.pressure_force + q.viscous_force;
    w.moment += q.pressure_moment + q.viscous_moment;
  }
  return w;
}

std::string forces_csv_header(int parts) {
  if (parts < 1 || parts > max_parts) throw std::invalid_argument("forces.csv: " + std::to_string(parts) + " parts");
  // One header row, units in the column names (pandas.read_csv and Python's csv module need no options); what the
  // columns mean (axes, origin, parts) is in run.json's "files" block and docs/cfd-files.md.
  std::string cols = "time_s,step,phase";
  for (int i = 0; i < parts; ++i) {
    const char* part = part_names[i];
    for (const char* kind : {"p", "v"})
      for (const char* a : {"x", "y", "z"}) cols += fmt::format(",{}_F{}_{}_N", part, a, kind);
    for (const char* kind : {"p", "v"})
      for (const char* a : {"x", "y", "z"}) cols += fmt::format(",{}_M{}_{}_N_m", part, a, kind);
    cols += fmt::format(",{}_P_W", part);
  }
  cols += ",Fx_N,Fy_N,Fz_N,Mx_N_m,My_N_m,Mz_N_m,wing_power_W";
  return cols + "\n";
}

std::string forces_csv_row(const CfdLoadRow& r) {
  std::string s = fmt::format("{:.17g},{},{:.17g}", r.time, r.step, r.phase);
  auto v3 = [&](const Vec3& v) { s += fmt::format(",{:.17g},{:.17g},{:.17g}", v.x(), v.y(), v.z()); };
  for (int i = 0; i < r.parts; ++i) {
    const auto& q = r.part[i];
    v3(q.pressure_force);
    v3(q.viscous_force);
    v3(q.pressure_moment);
    v3(q.viscous_moment);
    s += fmt::format(",{:.17g}", q.power);
  }
  const Wrench w = r.total();
  v3(w.force);
  v3(w.moment);
  s += fmt::format(",{:.17g}\n", r.wing_power);
  return s;
}

CfdLoadRow parse_forces_csv_row(const std::string& line) {
  std::vector<double> v;
  std::size_t pos = 0;
  while (pos <= line.size()) {
    std::size_t next = line.find(',', pos);
    if (next == std::string::npos) next = line.size();
    const std::string cell = line.substr(pos, next - pos);
    std::size_t used = 0;
    const double x = std::stod(cell, &used);
    if (used == 0) throw std::invalid_argument("forces.csv: not a number: " + cell);
    v.push_back(x);
    pos = next + 1;
  }
  // time, step, phase; 13 per part; 7 totals
  const std::size_t per_part = 13, fixed = 3 + 7;
  const std::size_t parts = v.size() >= fixed ? (v.size() - fixed) / per_part : 0;
  if (v.size() != fixed + per_part * parts || (parts != 3 && parts != std::size_t(max_parts)))
    throw std::invalid_argument("forces.csv: a row with " + std::to_string(v.size()) + " columns");
  CfdLoadRow r;
  r.parts = int(parts);
  r.time = v[0];
  r.step = long(v[1]);
  r.phase = v[2];
  std::size_t k = 3;
  auto v3 = [&] {
    const Vec3 a(v[k], v[k + 1], v[k + 2]);
    k += 3;
    return a;
  };
  for (int i = 0; i < r.parts; ++i) {
    auto& q = r.part[i];
    q.pressure_force = v3();
    q.viscous_force = v3();
    q.pressure_moment = v3();
    q.viscous_moment = v3();
    q.power = v[k++];
  }
  r.wing_power = v.back();
  return r;
}

}  // namespace flapstab::ns
