// The plan of a CFD run: grid around the volume the insect sweeps, far field, Reynolds number, time step; every
// check that needs no solver (docs/case-file.md, [aero.cfd]).
//
//  - Grid in stability axes S, origin O. The uniform fine box (spacing h = mean chord / cells_per_chord or
//    R / cells_per_wing_length) covers the volume swept by body and wings over the whole run (sampled at 64
//    phases per wingbeat) plus fine_margin_R; outside it the cells grow geometrically (stretch_ratio) out to the
//    domain faces, upstream_R ... below_R wing lengths beyond the fine box.
//  - Reynolds number Re = U_ref L_ref / nu with U_ref = 2 Phi f R (mean wingtip speed), L_ref = mean chord; the
//    kinematic viscosity is [fluid] kinematic_viscosity_m2_s unless [aero.cfd] reynolds sets it to U_ref L_ref / Re.
#pragma once
#include <array>
#include <string>
#include <vector>
#include "cfd/navier_stokes/geometry.hpp"
#include "cfd/navier_stokes/grid.hpp"
#include "core/aero_model.hpp"
#include "core/case_file.hpp"

namespace flapstab::ns {

// Everything decided before the run starts.
struct CfdPlan {
  Vec3 swept_lo = Vec3::Zero(), swept_hi = Vec3::Zero();  // swept volume of the parts over the run (S, m)
  Vec3 fine_lo = Vec3::Zero(), fine_hi = Vec3::Zero();    // uniform fine box (m)
  Vec3 domain_lo = Vec3::Zero(), domain_hi = Vec3::Zero();
  std::vector<StretchedAxis> axes;                         // the three axis generators
  double h = 0;                   // requested fine spacing (m)
  double h_actual = 0;            // largest cell width inside the fine box (m)
  double chord_cells = 0;         // mean chord / h_actual
  double rho = 0, nu = 0;         // kg/m^3, m^2/s
  double u_ref = 0, l_ref = 0, reynolds = 0;
  double period = 0;              // s
  int parts = 3;                  // parts of the insect's geometry: 3, or 5 with a hind pair
  double tip_speed_max = 0;       // largest wingtip speed over the cycle, either pair (m/s), for the CFL check of a fixed dt
  double body_speed_max = 0;      // largest far-field speed |V| + |Omega| r of the planned motions (m/s)
  double sponge_width = 0;        // sponge layer depth (m; 0: none) ...
  double sponge_rate = 0;         // ... its relaxation rate at the face (1/s) ...
  std::array<bool, 6> sponge_faces{};  // ... and the faces it lines (face(axis, side))
  int cycles = 1;
  int steps_per_cycle = 0;        // 0: adaptive dt
  double dt = 0;                  // fixed dt (s) or 0
  std::vector<std::string> warnings;
};

// Builds the plan; InputError (case file, aero.cfd.KEY) for a part too close to the domain's faces or a mean
// chord resolved by fewer than 4 fine cells (fewer than 8: a warning in plan.warnings).
CfdPlan plan_cfd(const Case& c, const Kinematics& kin, const BodyMotion& motion, int cycles_override = 0);
// One grid for several runs (a derivative campaign restarted from one hover state): the grid is fixed to the body,
// so it is the same for every motion; the CFL estimate of a fixed step takes the fastest far field of the motions.
CfdPlan plan_cfd(const Case& c, const Kinematics& kin, const std::vector<BodyMotion>& motions, int cycles_override = 0);

// One grid for several kinematics (a trim or control campaign): the swept volume is the union over `kinematics`
// (the first sets the period and the time step).
CfdPlan plan_cfd(const Case& c, const std::vector<Kinematics>& kinematics, const std::vector<BodyMotion>& motions,
                 int cycles_override = 0);

// The plan's grid.
Grid plan_grid(const CfdPlan& plan);

// A fine box re-planned on the lattice of a plan's (a free flight's body leaving the room it was given): each face
// of the fine box moved by a whole number of its fine cells (lo: the lower faces, hi: the upper ones; positive
// along the axis). The stretched cells and the domain faces keep their distances from the box (the domain moves
// with it), so the fine cells of the two grids coincide where their boxes overlap.
struct FineBoxShift {
  std::array<int, 3> lo{0, 0, 0}, hi{0, 0, 0};
  bool empty() const { return lo == std::array<int, 3>{0, 0, 0} && hi == std::array<int, 3>{0, 0, 0}; }
  bool operator==(const FineBoxShift&) const = default;
};
// The plan with its fine box shifted (an empty shift: the plan itself). std::invalid_argument for a box of fewer
// than 1 cell along an axis.
CfdPlan shifted_plan(const CfdPlan& plan, const FineBoxShift& shift);
// The shift of plan's fine box to the smallest box on its lattice that holds [lo, hi] (m, grid axes).
FineBoxShift fine_box_shift(const CfdPlan& plan, const Vec3& lo, const Vec3& hi);
// Cells and extents of a grid, exactly (checkpoints compare it).
std::string grid_summary(const Grid& g);
MeshResolution mesh_resolution(const CfdSettings& s);

// Memory a Simulation of this plan will hold at most (bytes): the solver's fields, the Poisson solver and its
// multigrid levels, the parts' level sets, and the transient arrays of a flow-field output; an upper estimate
// (tests compare it with Simulation::bytes()).
std::size_t estimated_bytes(const CfdPlan& plan);
// The memory the system says is available (MemAvailable of /proc/meminfo; 0 when unknown).
std::size_t available_memory_bytes();
// Refuses a plan that does not fit in `available` bytes (0: available_memory_bytes()) before anything is
// allocated: InputError naming the case file and aero.cfd.cells_per_chord with the grid, the estimate and the
// memory available.
void check_memory(const CfdPlan& plan, const std::string& case_path, std::size_t available = 0);

}  // namespace flapstab::ns
