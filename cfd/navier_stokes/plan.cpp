// The plan of a CFD run (plan.hpp).
#include "cfd/navier_stokes/plan.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <fstream>
#include <optional>
#include <stdexcept>
#include <fmt/format.h>

#include "cfd/navier_stokes/insect_motion.hpp"
#include "cfd/navier_stokes/mesh_query.hpp"
#include "core/configuration.hpp"
#include "core/errors.hpp"

namespace flapstab::ns {

MeshResolution mesh_resolution(const CfdSettings& s) {
  MeshResolution r;
  r.body = s.body_divisions;
  r.wing_span = s.wing_span_stations;
  r.wing_chord = s.wing_chord_divisions;
  return r;
}

std::string grid_summary(const Grid& g) {
  std::string s = fmt::format("{}x{}x{}", g.axis[0].n, g.axis[1].n, g.axis[2].n);
  for (const auto& a : g.axis) s += fmt::format(" [{:.17g},{:.17g},{:.17g}]", a.lo, a.hi, a.min_width());
  return s;
}

Grid plan_grid(const CfdPlan& plan) {
  return Grid(Axis::stretched(plan.axes[0], false), Axis::stretched(plan.axes[1], false),
              Axis::stretched(plan.axes[2], false));
}

namespace {

// The fine cells of plan's axis d: their count and width (the generator divides the box evenly).
std::pair<int, double> fine_cells(const CfdPlan& plan, int d) {
  const StretchedAxis& a = plan.axes[std::size_t(d)];
  const Axis axis = Axis::stretched(a, false);
  int n = 0;
  for (int i = 1; i <= axis.n; ++i)
    if (axis.xc[i] > a.box_lo && axis.xc[i] < a.box_hi) ++n;
  return {n, (a.box_hi - a.box_lo) / n};
}

// Axis d of plan with its fine box's low face moved by lo and its high face by hi fine cells.
StretchedAxis shifted_axis(const CfdPlan& plan, int d, int lo, int hi) {
  const auto [n, h] = fine_cells(plan, d);
  if (n + hi - lo < 1) throw std::invalid_argument(fmt::format("shifted_plan: no fine cell left along {}", "xyz"[d]));
  StretchedAxis a = plan.axes[std::size_t(d)];
  a.lo += lo * h;
  a.box_lo += lo * h;
  a.box_hi += hi * h;
  a.hi += hi * h;
  a.h = h;
  a.box_cells = n + hi - lo;
  return a;
}

}  // namespace

CfdPlan shifted_plan(const CfdPlan& plan, const FineBoxShift& shift) {
  if (shift.empty()) return plan;
  CfdPlan p = plan;
  for (int d = 0; d < 3; ++d) {
    StretchedAxis& a = p.axes[std::size_t(d)];
    a = shifted_axis(plan, d, shift.lo[std::size_t(d)], shift.hi[std::size_t(d)]);
    p.fine_lo[d] = a.box_lo;
    p.fine_hi[d] = a.box_hi;
    p.domain_lo[d] = a.lo;
    p.domain_hi[d] = a.hi;
  }
  return p;
}

FineBoxShift fine_box_shift(const CfdPlan& plan, const Vec3& lo, const Vec3& hi) {
  FineBoxShift s;
  for (int d = 0; d < 3; ++d) {
    const double h = fine_cells(plan, d).second;
    const StretchedAxis& a = plan.axes[std::size_t(d)];
    // Outward to the lattice, a face already on it (to rounding) kept.
    int& l = s.lo[std::size_t(d)];
    int& u = s.hi[std::size_t(d)];
    l = int(std::floor((lo[d] - a.box_lo) / h + 1e-9));
    u = int(std::ceil((hi[d] - a.box_hi) / h - 1e-9));
    // The total cell count must be a multiple of the multigrid's; where the stretched cells cannot make it so (none
    // on either side, or sides too short to take another cell), the high face moves further out until it is.
    for (int extra = 0;; ++extra) {
      try {
        Axis::stretched(shifted_axis(plan, d, l, u + extra), false);
        u += extra;
        break;
      } catch (const std::invalid_argument&) {
        if (extra > 2 * a.multiple_of) throw;
      }
    }
  }
  return s;
}

std::size_t estimated_bytes(const CfdPlan& plan) {
  const Grid g = plan_grid(plan);
  const Shape sh = g.shape();
  const double with_ghosts = double(sh.size());
  // Solver: 14 double arrays (u, u*, N_prev, phi: 3 each; p, div) + flags; Poisson: 3 double Krylov vectors and
  // 3 float arrays per multigrid level (a geometric series, 8/7 of the finest); immersed boundary: one float level
  // set per part (3, or 5 with a hind pair); a field output: cell-centred u, vorticity (3 each), Q and pressure as
  // doubles (8).
  const double per_cell = 14 * 8 + 1 + 3 * 8 + 3 * 4 * 8.0 / 7.0 + plan.parts * 4 + 8 * 8;
  return std::size_t(with_ghosts * per_cell) + (std::size_t(64) << 20);  // + meshes, tables, the program
}

std::size_t available_memory_bytes() {
  std::ifstream in("/proc/meminfo");
  std::string key;
  std::size_t kb = 0;
  std::string unit;
  while (in >> key >> kb >> unit)
    if (key == "MemAvailable:") return kb * 1024;
  return 0;
}

void check_memory(const CfdPlan& plan, const std::string& case_path, std::size_t available) {
  if (available == 0) available = available_memory_bytes();
  if (available == 0) return;
  const std::size_t need = estimated_bytes(plan);
  if (need <= available) return;
  const Grid g = plan_grid(plan);
  throw InputError(case_path, "aero.cfd.cells_per_chord",
                   fmt::format("the grid of {} x {} x {} = {:.4g} cells ({:.1f} cells per mean chord) needs about "
                               "{:.2f} GiB; {:.2f} GiB of memory is available",
                               g.axis[0].n, g.axis[1].n, g.axis[2].n, double(g.cells()), plan.chord_cells,
                               need / 1073741824.0, available / 1073741824.0),
                   fmt::format("a grid that fits: memory grows with the cube of cells_per_chord, so at most about "
                               "{:.1f} cells per chord, or a smaller domain (fine_margin_R, upstream_R ...)",
                               plan.chord_cells * std::cbrt(double(available) / double(need))));
}

namespace {

// The edges of a mesh, each once (vertex index pairs).
std::vector<std::array<int, 2>> mesh_edges(const TriangleMesh& m) {
  std::vector<std::array<int, 2>> e;
  for (const auto& t : m.triangles)
    for (int k = 0; k < 3; ++k) e.push_back({std::min(t[k], t[(k + 1) % 3]), std::max(t[k], t[(k + 1) % 3])});
  std::sort(e.begin(), e.end());
  e.erase(std::unique(e.begin(), e.end()), e.end());
  return e;
}

// Whether wing `a` (its reference mesh, placed by `pose`) passes through or touches the placed wing `b`: an edge of
// a that crosses b, or a vertex of a within `touch` (m) of it.
bool wings_meet(const TriangleMesh& a, const std::vector<std::array<int, 2>>& edges, const RigidTransform& pose,
                const MeshQuery& b, double touch) {
  for (const Vec3& v : a.vertices)
    if (b.closest(pose.apply(v), touch).found()) return true;
  for (const auto& e : edges)
    if (b.first_crossing(pose.apply(a.vertices[std::size_t(e[0])]), pose.apply(a.vertices[std::size_t(e[1])])))
      return true;
  return false;
}

}  // namespace

CfdPlan plan_cfd(const Case& c, const Kinematics& kin, const BodyMotion& motion, int cycles_override) {
  return plan_cfd(c, kin, std::vector<BodyMotion>{motion}, cycles_override);
}

CfdPlan plan_cfd(const Case& c, const Kinematics& kin, const std::vector<BodyMotion>& motions, int cycles_override) {
  return plan_cfd(c, std::vector<Kinematics>{kin}, motions, cycles_override);
}

CfdPlan plan_cfd(const Case& c, const std::vector<Kinematics>& kinematics, const std::vector<BodyMotion>& motions,
                 int cycles_override) {
  if (motions.empty()) throw std::invalid_argument("plan_cfd: no motion");
  if (kinematics.empty()) throw std::invalid_argument("plan_cfd: no kinematics");
  const Kinematics& kin = kinematics.front();
  const CfdSettings& s = c.aero.cfd;
  const std::string& file = c.path;
  CfdPlan p;
  p.cycles = cycles_override > 0 ? cycles_override : s.cycles;
  p.period = kin.period();
  const double R = c.insect.wing.length, cbar = c.insect.wing.mean_chord;
  p.rho = c.fluid.density;
  p.u_ref = 2 * kin.stroke_amplitude() * kin.frequency_hz * R;
  p.l_ref = cbar;
  if (s.reynolds > 0) {
    if (!(p.u_ref > 0))
      throw InputError(file, "aero.cfd.reynolds", "the wings do not move (U_ref = 2 Phi f R = 0)",
                       "a case with a non-zero stroke amplitude, or [fluid] viscosity instead");
    p.reynolds = s.reynolds;
    p.nu = p.u_ref * p.l_ref / s.reynolds;
  } else {
    p.nu = c.fluid.kinematic_viscosity;
    p.reynolds = p.u_ref * p.l_ref / p.nu;
  }
  // Swept volume: every vertex of every part over the run (one wingbeat suffices without body rotation).
  const Configuration config(c.insect, kin);
  const InsectSurfaces surfaces(config, mesh_resolution(s));
  const auto& ref = surfaces.reference();
  // Swept volume: every vertex of every part over one wingbeat (the grid is fixed to the body, so body motions
  // do not move the insect in it). Every part: a hind pair's swept region is in the box, and so in the fine box and
  // the domain built around it, whatever its hinge, span or phase.
  // Wings must not cut through each other: the immersed boundary treats two parts that come within a few cells (an
  // unresolved gap, ImmersedOptions::contact), not one membrane passing through another or two that coincide. Where
  // two wings overlap, the faces inside both are forced with the two wings' different velocities, so the fluid
  // caught between them has a mass source the projection cannot remove: its pressure drifts without bound and the
  // run blows up once the grid resolves the overlap (the hawkmoth of data/cases/hawkmoth_cfd.toml with its
  // widest chord at the root, 2026-12-04: the right wing's trailing edge swept 4 mm past the plane of symmetry
  // behind the hinges, the pocket's pressure reached 100 times the dynamic pressure, and the runs at 12 and 16
  // cells per chord diverged at t/T = 0.2). Checked at the same instants as the swept volume for the kinematics that
  // is run (the first), every pair of wings (left against right, and fore against hind of a four-winged insect): an
  // edge of one that crosses the other, or a vertex closer to it than 1e-6 R.
  std::vector<MeshQuery> wing_query;
  std::vector<std::vector<std::array<int, 2>>> wing_edges;
  for (std::size_t i = 1; i < ref.size(); ++i) {
    wing_query.emplace_back(ref[i]);
    wing_edges.push_back(mesh_edges(ref[i]));
  }
  const auto wing_name = [&](std::size_t i) {
    return std::string(i % 2 == 1 ? "right " : "left ") + (ref.size() == 5 ? (i <= 2 ? "fore wing" : "hind wing") : "wing");
  };
  BoundingBox box;
  for (const Kinematics& k : kinematics) {
    const Configuration conf(c.insect, k);
    const InsectMotion im(conf, BodyMotion{});
    constexpr int samples = 64;
    for (int j = 0; j <= samples; ++j) {
      const double t = k.period() * j / samples;
      const auto parts = im.parts(t);
      for (std::size_t i = 0; i < ref.size(); ++i)
        for (const Vec3& v : ref[i].vertices) {
          const Vec3 x = parts[i].pose.apply(v);
          box.add(x);
          if (i > 0) p.tip_speed_max = std::max(p.tip_speed_max, parts[i].velocity.at(x).norm());
        }
      // The first kinematics is the one run; the others only widen the grid to hold what a campaign may ask (the
      // extremes of the trim parameters' bounds), and each of those is checked when it is run (CfdModel).
      if (&k != &kinematics.front()) continue;
      for (std::size_t a = 1; a < ref.size(); ++a) wing_query[a - 1].set_pose(parts[a].pose);
      for (std::size_t a = 1; a < ref.size(); ++a)
        for (std::size_t b = a + 1; b < ref.size(); ++b) {
          if (!wings_meet(ref[a], wing_edges[a - 1], parts[a].pose, wing_query[b - 1], 1e-6 * R) &&
              !wings_meet(ref[b], wing_edges[b - 1], parts[b].pose, wing_query[a - 1], 1e-6 * R))
            continue;
          const std::string when = fmt::format("at t/T = {:.4g}", double(j) / samples);
          const bool same_side = (a % 2) == (b % 2);
          if (same_side)
            throw InputError(file, "hind_wing.hinge_m",
                             fmt::format("the {} meets the {} {}: the CFD geometry does not model wings that cut "
                                         "through each other or coincide",
                                         wing_name(b), wing_name(a), when),
                             "a hind wing hinged, sized ([hind_wing]) or phased ([kinematics.hind] phase_deg) so that "
                             "the two pairs stay apart");
          // Left against right: how far the right-hand wing reaches past the plane of symmetry (y = 0) then.
          const std::size_t right = a % 2 == 1 ? a : b;
          double y_min = std::numeric_limits<double>::infinity();
          for (const Vec3& v : ref[right].vertices) y_min = std::min(y_min, parts[right].pose.apply(v).y());
          throw InputError(file, "wing",
                           fmt::format("the {} meets the {} {} (the {} reaches y = {:.3g} mm, past the plane of "
                                       "symmetry y = 0): the two wings cut through each other behind or in front of "
                                       "the body, which the CFD geometry does not model (the fluid caught in the "
                                       "overlap is forced both ways and the run blows up on fine grids)",
                                       wing_name(b), wing_name(a), when, wing_name(right), 1e3 * y_min),
                           "wings that stay on their own side of the plane of symmetry: a narrower root chord "
                           "(wing.planform), a hinge further from the mid-plane (wing.hinge_m) or a stroke that does "
                           "not sweep the root chord across it (kinematics.stroke)");
        }
    }
  }
  p.parts = int(ref.size());
  p.swept_lo = box.lo;
  p.swept_hi = box.hi;
  p.h = s.cells_per_wing_length > 0 ? R / s.cells_per_wing_length : cbar / s.cells_per_chord;
  const std::string res_key = s.cells_per_wing_length > 0 ? "aero.cfd.cells_per_wing_length" : "aero.cfd.cells_per_chord";
  p.fine_lo = box.lo - Vec3::Constant(s.fine_margin_R * R);
  p.fine_hi = box.hi + Vec3::Constant(s.fine_margin_R * R);
  // Faces: x- downstream (behind), x+ upstream (ahead), y +-lateral, z- above, z+ below.
  const double lo_margin[3] = {s.downstream_R, s.lateral_R, s.above_R};
  const double hi_margin[3] = {s.upstream_R, s.lateral_R, s.below_R};
  const char* lo_key[3] = {"aero.cfd.downstream_R", "aero.cfd.lateral_R", "aero.cfd.above_R"};
  const char* hi_key[3] = {"aero.cfd.upstream_R", "aero.cfd.lateral_R", "aero.cfd.below_R"};
  for (int d = 0; d < 3; ++d) {
    p.domain_lo[d] = p.fine_lo[d] - lo_margin[d] * R;
    p.domain_hi[d] = p.fine_hi[d] + hi_margin[d] * R;
    StretchedAxis a;
    a.lo = p.domain_lo[d];
    a.hi = p.domain_hi[d];
    a.box_lo = p.fine_lo[d];
    a.box_hi = p.fine_hi[d];
    a.h = p.h;
    a.max_ratio = s.stretch_ratio;
    a.multiple_of = 8;
    p.axes.push_back(a);
  }
  // The sponge layer stays in the stretched cells: its inner edge never inside the fine box.
  if (s.sponge_R > 0) {
    const char* face_name[6] = {"downstream", "upstream", "lateral", "lateral", "above", "below"};
    int worst = -1;
    for (int f = 0; f < 6; ++f) {
      const std::string name = face_name[f];
      p.sponge_faces[std::size_t(f)] =
          std::find(s.sponge_faces.begin(), s.sponge_faces.end(), name) != s.sponge_faces.end();
      if (p.sponge_faces[std::size_t(f)] &&
          (worst < 0 || (f % 2 ? hi_margin : lo_margin)[f / 2] < (worst % 2 ? hi_margin : lo_margin)[worst / 2]))
        worst = f;
    }
    const double room = (worst % 2 ? hi_margin : lo_margin)[worst / 2];
    if (s.sponge_R > room)
      throw InputError(file, "aero.cfd.sponge_R",
                       fmt::format("{:.6g} wing lengths, more than the {:.6g} between the fine box and the "
                                   "domain's {}{} face ({}): the layer would damp the flow around the insect",
                                   s.sponge_R, room, "xyz"[worst / 2], worst % 2 ? '+' : '-',
                                   (worst % 2 ? hi_key : lo_key)[worst / 2]),
                       fmt::format("a width of at most {:.6g} (or larger margins)", room));
    p.sponge_width = s.sponge_R * R;
    p.sponge_rate = s.sponge_rate / p.period;
  }
  // Largest far-field speed over the planned motions (|V| plus |Omega| times the farthest swept point).
  for (const BodyMotion& motion : motions) {
    double r = 0;
    for (int c = 0; c < 8; ++c)
      r = std::max(r, Vec3(c & 1 ? box.hi.x() : box.lo.x(), c & 2 ? box.hi.y() : box.lo.y(),
                           c & 4 ? box.hi.z() : box.lo.z()).norm());
    p.body_speed_max = std::max(p.body_speed_max, motion.velocity.norm() + motion.rate.norm() * r);
  }
  // The immersed boundary's forcing band and probes reach about 4 fine cells beyond a surface: every part must
  // stay that far from the box faces over the whole run.
  const double clearance = 4 * p.h;
  for (int d = 0; d < 3; ++d)
    for (int side = 0; side < 2; ++side) {
      const double gap = side == 0 ? p.swept_lo[d] - p.domain_lo[d] : p.domain_hi[d] - p.swept_hi[d];
      if (gap < clearance)
        throw InputError(file, (side == 0 ? lo_key : hi_key)[d],
                         fmt::format("a part comes within {:.3g} m of the domain's {}{} face (the run needs {:.3g} m, "
                                     "4 fine cells): the insect leaves the domain",
                                     gap, "xyz"[d], side == 0 ? '-' : '+', clearance),
                         "a larger margin (this key or aero.cfd.fine_margin_R)");
    }
  // The fine box's actual spacing (the generator rounds the cell count up).
  double hmax = 0;
  for (int d = 0; d < 3; ++d) {
    const Axis a = Axis::stretched(p.axes[std::size_t(d)], false);
    for (int i = 1; i <= a.n; ++i)
      if (a.xc[i] > p.fine_lo[d] && a.xc[i] < p.fine_hi[d]) hmax = std::max(hmax, a.dc[i]);
  }
  p.h_actual = hmax > 0 ? hmax : p.h;
  p.chord_cells = cbar / p.h_actual;
  if (p.chord_cells < 4)
    throw InputError(file, res_key,
                     fmt::format("the mean chord ({:.4g} m) spans only {:.2f} fine cells (h = {:.4g} m)", cbar,
                                 p.chord_cells, p.h_actual),
                     "at least 4 cells per mean chord (8 or more recommended)");
  if (p.chord_cells < 8)
    p.warnings.push_back(fmt::format("the mean chord spans only {:.2f} fine cells: loads will be rough "
                                     "(8 or more recommended; key {})", p.chord_cells, res_key));
  // The resolution is set on the fore wing's chord; a narrower hind wing is resolved by fewer cells.
  if (c.insect.hind_wing && c.insect.hind_wing->mean_chord / p.h_actual < 8)
    p.warnings.push_back(fmt::format("the hind wing's mean chord ({:.4g} m) spans only {:.2f} fine cells: its loads will "
                                     "be rough (8 or more recommended; key {})", c.insect.hind_wing->mean_chord,
                                     c.insect.hind_wing->mean_chord / p.h_actual, res_key));
  if (s.stretch_ratio > 1.08)
    p.warnings.push_back(fmt::format("stretch_ratio = {} above 1.08: the multigrid preconditioner converges more "
                                     "slowly on strongly stretched cells", s.stretch_ratio));
  p.steps_per_cycle = s.steps_per_cycle;
  if (p.steps_per_cycle > 0) {
    p.dt = p.period / p.steps_per_cycle;
    const double speed = p.tip_speed_max + p.body_speed_max;
    const double cfl = p.dt * speed / p.h_actual;
    if (cfl > 1.0)
      p.warnings.push_back(fmt::format("steps_per_cycle = {}: the wingtip moves {:.2f} fine cells per step (CFL "
                                       "estimate {:.2f} > 1); the run may diverge", p.steps_per_cycle, cfl, cfl));
  }
  return p;
}

}  // namespace flapstab::ns
