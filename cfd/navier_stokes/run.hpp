// The CFD run driver: an insect case ([aero] model = "cfd", [aero.cfd]) to a Navier-Stokes immersed-boundary
// run in stability axes, with loads, flow fields, surfaces, checkpoints and exact restart.
//
// Set-up (docs/case-file.md, [aero.cfd]; files: docs/cfd-files.md):
//  - Grid in stability axes S, origin O. The uniform fine box (spacing h = mean chord / cells_per_chord or
//    R / cells_per_wing_length) covers the volume swept by body and wings over the whole run (sampled at 64
//    phases per wingbeat) plus fine_margin_R; outside it the cells grow geometrically (stretch_ratio) out to the
//    domain faces, upstream_R ... below_R wing lengths beyond the fine box.
//  - Far field: the body's steady velocity V = (u, v, w) enters as a uniform stream -V through five faces
//    (prescribed velocity; zero in hover: quiescent air at rest); the face below the insect (+z) is a
//    zero-gradient outflow with p = 0, where the downwash leaves. Rotation rates Omega = (p, q, r) turn the whole
//    insect about O in the grid (the grid's axes stay fixed); loads are reported in the turning body's
//    stability axes.
//  - Reynolds number Re = U_ref L_ref / nu with U_ref = 2 Phi f R (mean wingtip speed), L_ref = mean chord; the
//    kinematic viscosity is [fluid] kinematic_viscosity_m2_s unless [aero.cfd] reynolds sets it to U_ref L_ref / Re.
//  - Three immersed parts (body, right wing, left wing) from InsectSurfaces, moved by the kinematics composed
//    with the body's rotation.
#pragma once
#include <atomic>
#include <iostream>
#include <functional>
#include <iosfwd>
#include <string>
#include <vector>
#include "cfd/navier_stokes/grid.hpp"
#include "core/aero_model.hpp"
#include "core/case_file.hpp"

namespace flapstab::ns {

// How a run is driven (the CLI's options; the AeroModel uses the defaults with no directory).
struct CfdRunOptions {
  std::string directory;        // output directory; "" = keep everything in memory (AeroModel use)
  bool restart = false;         // resume from the newest valid checkpoint in directory
  int cycles = 0;               // > 0: overrides [aero.cfd] cycles
  bool dry_run = false;         // plan, check, build and time two steps; write nothing
  bool bodies = true;           // false: a body-free flow in the same box (solver checks, tests)
  std::function<Vec3(double x, double y, double z)> initial_velocity;  // default: the uniform stream -V
  std::ostream* log = nullptr;  // estimate and progress lines (nullptr: silent)
  double progress_seconds = 5;  // wall time between progress lines
  long stop_after_steps = 0;    // > 0: stop after this step as if interrupted (forces.csv flushed, no final
                                // checkpoint or run.json): for tests of --restart and for runs in pieces
};

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
  double tip_speed_max = 0;       // largest wingtip speed over the cycle (m/s), for the CFL check of a fixed dt
  int cycles = 1;
  int steps_per_cycle = 0;        // 0: adaptive dt
  double dt = 0;                  // fixed dt (s) or 0
  std::vector<std::string> warnings;
};

// Builds the plan; InputError (case file, aero.cfd.KEY) for a part too close to the domain's faces or a mean
// chord resolved by fewer than 4 fine cells (fewer than 8: a warning in plan.warnings).
CfdPlan plan_cfd(const Case& c, const Kinematics& kin, const BodyMotion& motion, int cycles_override = 0);

// Loads of one step, about O in stability axes S (N, N m, W).
struct CfdLoadRow {
  double time = 0;
  long step = 0;
  double phase = 0;  // t / T modulo 1
  struct Part {
    Vec3 pressure_force = Vec3::Zero(), viscous_force = Vec3::Zero();
    Vec3 pressure_moment = Vec3::Zero(), viscous_moment = Vec3::Zero();
    double power = 0;  // W: rate of work of the part on the air (grid frame)
  } part[3];           // body, right, left
  double wing_power = 0;  // W: the wings' work on the air from their motion relative to the body (AeroModel power)
  Wrench total() const;
};

struct CfdResult {
  CfdPlan plan;
  std::size_t cells = 0;
  std::size_t bytes = 0;         // solver + immersed boundary
  long steps = 0;                // step counter at the end
  long start_step = 0;           // 0, or the checkpoint's step on restart
  double seconds_per_step_estimate = 0;  // timed on the first two steps
  double seconds_per_step = 0;           // measured over the run (steps after the first two)
  double wall_seconds = 0;
  std::vector<CfdLoadRow> rows;  // every step of this run (restart: from the checkpoint on)
  std::vector<CfdLoadRow> last_cycle;  // rows of the last wingbeat (restart: with those of the earlier run)
  std::string restarted_from;    // checkpoint path
};

// The run. Throws InputError for bad input (before writing anything), SolveError on divergence (after keeping
// the last checkpoint; the message gives step and time).
CfdResult run_cfd(const Case& c, const Kinematics& kin, const BodyMotion& motion, const CfdRunOptions& options);

// FNV-1a 64 of a file's bytes as 16 hex digits (the case hash in checkpoints).
std::string case_hash(const std::string& path);

// The header lines of forces.csv (each starts with '#') and its column names.
std::string forces_csv_header();
std::string forces_csv_row(const CfdLoadRow& r);
// The inverse of forces_csv_row (without its newline); std::invalid_argument for a malformed row.
CfdLoadRow parse_forces_csv_row(const std::string& line);

// The AeroModel over the driver: runs options.cycles wingbeats in memory and returns the last one. Every run is
// a whole CFD run (minutes): trim and derivatives call it tens of times, so each run announces itself and its
// wall time on `log` (std::cerr by default; nullptr: silent).
class CfdModel final : public AeroModel {
 public:
  explicit CfdModel(Case c, std::ostream* log = &std::cerr) : case_(std::move(c)), log_(log) {}
  std::string name() const override { return "navier-stokes-ib"; }
  WrenchHistory run(const Insect& insect, const Kinematics& kin, const BodyMotion& motion,
                    const AeroRunOptions& options) const override;

 private:
  Case case_;
  std::ostream* log_;
  mutable std::atomic<int> runs_{0};
};

}  // namespace flapstab::ns
