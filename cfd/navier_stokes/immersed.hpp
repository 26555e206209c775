// Immersed rigid parts: sharp-interface direct forcing on the staggered grid, closed bodies and two-sided
// zero-thickness membranes, prescribed 6DoF motion, loads per part by surface integration.
//
// Method (docs/theory/navier-stokes.md, "Immersed boundary"):
//  - Each part carries a level set phi in its reference frame, sampled once on a lattice (spacing a fraction
//    of the finest grid spacing near the part) from its triangle mesh: phi = signed distance for a closed
//    surface (negative inside), phi = |distance| - half_thickness for a membrane (a membrane is solid within
//    `membrane_half_thickness` local cell widths of its surface, enough that every grid line crossing it meets a
//    forced face). A moving part maps grid points into its reference frame and interpolates: no per-step
//    mesh search.
//  - After each Runge-Kutta predictor, faces inside a part (phi < 0) take the part's rigid velocity; fluid
//    faces within one local cell width of it (the interface band) take the value interpolated along the normal
//    (quadratic through the surface point, at the part's velocity, and two probe points in the fluid) (Fadlun
//    et al. 2000, J Comput Phys 161:35; Balaras 2004, Comput Fluids 33:375). The whole solid moves with the
//    part, so a face that leaves it (a fresh cell) already holds the part's velocity; after each projection
//    the pressure of fully forced cells near the surface is replaced by the fluid's, extended along the
//    normal, so an uncovered cell brings no stale pressure into the fluid: no force spike.
//  - Loads: per surface triangle and per wetted side (both sides of a membrane), pressure and wall-relative
//    velocity are sampled at probe points along the normal; pressure is carried to the surface with the
//    wall-normal momentum balance dp/dn = -rho a.n, the viscous traction is mu d(u - V)/dn from a one-sided
//    second-order difference. Sums give force, moment about a point and power per part, split into pressure
//    and viscous parts. The probes sit 1.5-2.5 cells out, so on coarse grids this under-reads the wall layer;
//    exchange_loads() gives the momentum exchanged by the forcing instead (accurate on coarse grids).
#pragma once
#include <functional>
#include <memory>
#include <string>
#include <vector>
#include "cfd/navier_stokes/geometry.hpp"
#include "cfd/navier_stokes/solver.hpp"

namespace flapstab::ns {

// Where a rigid part is at one instant (its reference frame placed in the grid's axes), its velocity field and
// its acceleration field (the kinematics handed to the immersed boundary at each Runge-Kutta stage).
struct PartState {
  RigidTransform pose;     // reference frame -> grid axes (m)
  RigidVelocity velocity;  // rigid velocity of the part's points, grid axes (m/s, rad/s)
  Vec3 acceleration = Vec3::Zero();          // of the material point at velocity.centre (m/s^2)
  Vec3 angular_acceleration = Vec3::Zero();  // rad/s^2
  // Rate of the grid's frame (rad/s) when it rotates (SolverOptions::frame_rate): the apparent acceleration of a
  // point then carries the Coriolis term 2 Omega x v (the centrifugal one sits in the reduced pressure).
  Vec3 frame_rate = Vec3::Zero();
  // dOmega/dt when the frame's rate changes (SolverOptions::frame_rate_at): the Euler term dOmega/dt x x, with x
  // measured from the grid's origin (the frame's centre of rotation).
  Vec3 frame_rate_rate = Vec3::Zero();
  // Apparent acceleration of the material point at x in the grid's frame: a + alpha x r + omega x (omega x r)
  // (rigid body, r = x - centre) + 2 Omega x v(x) + dOmega/dt x x.
  Vec3 acceleration_at(const Vec3& x) const {
    const Vec3 r = x - velocity.centre;
    return acceleration + angular_acceleration.cross(r) + velocity.omega.cross(velocity.omega.cross(r)) +
           2 * frame_rate.cross(velocity.at(x)) + frame_rate_rate.cross(x);
  }
};
// A prescribed motion as a function of time (pose and velocity; the accelerations are taken by central
// differences of the velocity field when the immersed boundary samples it).
using PartMotion = std::function<PartState(double t)>;

// A part that does not move.
PartMotion fixed_part(const RigidTransform& pose = {});

struct ImmersedOptions {
  double density = 1.0;                  // kg/m^3: loads are density times the kinematic ones
  double membrane_half_thickness = 0.6;  // local cell widths
  double lattice_refinement = 2.0;       // lattice spacing = finest local grid spacing / this
  double probe_near = 1.5;               // probe distances, local cell widths: loads from the (effective) surface,
  double probe_far = 2.5;                // the band's quadratic from the forced face
  // Band faces whose probes reach into another part's band or inside it (a wing root sweeping past the body):
  //  - gap (default): the value is interpolated linearly between the two parts' surface velocities, by the face's
  //    distances to the two effective surfaces (the Couette profile of an unresolved gap); no fluid value is read,
  //    so the two parts' forcings cannot feed each other;
  //  - bounded: the quadratic through the surface velocity and the two probes, bounded by those three values;
  //  - quadratic: the quadratic as everywhere else (the forcing before contact was treated).
  // A part alone in the flow is not affected by this choice.
  enum class Contact { gap, bounded, quadratic };
  Contact contact = Contact::gap;
};

// Loads of one part on the fluid's side: force and moment the fluid exerts on the part (grid axes).
struct PartLoads {
  std::string label;
  Vec3 pressure_force = Vec3::Zero(), viscous_force = Vec3::Zero();    // N
  Vec3 pressure_moment = Vec3::Zero(), viscous_moment = Vec3::Zero();  // N m, about the given point
  double power = 0;  // W: rate of work of the part on the fluid, -sum over the surface of traction . velocity
  Vec3 force() const { return pressure_force + viscous_force; }
  Vec3 moment() const { return pressure_moment + viscous_moment; }
};

// Surface pressure of one part per triangle (Pa, relative to the far field's mean): front side (the normal's
// side; outside of a closed surface) and, for membranes, back side.
struct SurfacePressure {
  std::vector<double> front, back;
};

class ImmersedBoundary final : public StageHooks {
 public:
  ImmersedBoundary(const Grid& grid, ImmersedOptions options = {});
  ~ImmersedBoundary() override;

  // Adds a rigid part (reference-frame mesh, closed or membrane, labelled by mesh.label); returns its index.
  // Throws std::invalid_argument for a degenerate mesh or a closed mesh with open edges.
  int add_part(TriangleMesh reference, PartMotion motion);
  // A part moved by its driver: set_parts() gives its kinematics at every stage time (no closure of time); the
  // initial state places its level-set lattice.
  int add_part(TriangleMesh reference, const PartState& initial);
  // The kinematics of every part at time t (a driver calls it before each stage at the stage's time, and before
  // attach()/restore at the solver's time). Parts with a PartMotion closure take the given value as well.
  // std::invalid_argument if the count differs from parts().
  void set_parts(double t, const std::vector<PartState>& states);
  std::size_t parts() const;
  const std::string& label(int part) const;
  // The part's kinematics at time t: from its closure, or the value set for t (std::logic_error if none).
  PartState state(int part, double t) const;
  // The part's surface at time t in grid axes (for VTK output).
  TriangleMesh surface(int part, double t) const;
  // The part's surface placed at a given state (no evaluation of the parts' motion).
  TriangleMesh surface(int part, const PartState& state) const;
  BoundingBox bounding_box(int part, double t) const;
  // The part's lattice level set at world point x and time t (m): signed distance (negative inside) for a
  // closed part, unsigned distance to the membrane's mid-surface for a membrane; capped at a few cell widths.
  double level_set(int part, double t, const Vec3& x) const;
  // 1 in the cells whose centre lies inside a part at time t (closed parts: inside the surface; membranes: within
  // the half thickness the forcing uses), else 0; interior cells, x fastest (the field files' order).
  std::vector<double> solid_mask(double t) const;
  // Which part holds each interior cell (x fastest) for the given part states (one per part): -1 where the cell's
  // centre lies in the fluid, else the index of the part whose level set is lowest there (solid as in solid_mask).
  // The force partitioning's staircase fluid region. With reach > 0 a cell counts where the level set at its centre
  // is below reach local widths instead of below 0 (reach 1: the cells of the forcing's band as well).
  std::vector<int> cell_owners(const std::vector<PartState>& states, double reach = 0) const;
  // The level set that decides solid and fluid for part `part` placed at `state`, at world point x for a cell or
  // face of local width h (m): signed distance (negative inside) for a closed part; for a membrane the distance to
  // its mid-surface less the half thickness the forcing uses (membrane_half_thickness h).
  double solid_level_set(int part, const PartState& state, const Vec3& x, double h) const;

  // Places the parts at the solver's time, marks cell flags (solid / ghost = interface band / fluid) and
  // attaches itself to the solver's stages. Call after solver.initialise() (or restore()).
  void attach(Solver& solver);

  void after_predictor(VectorField& ustar, double t, double alpha_dt) override;
  void after_projection(VectorField& u, Field& p, double t) override;  // extends p into the parts; u unread
  bool reads_projected_velocity() const override { return false; }

  // Loads at the solver's current time, about `moment_point` (grid axes, m); viscosity from the solver.
  std::vector<PartLoads> loads(const Solver& solver, const Vec3& moment_point) const;
  SurfacePressure surface_pressure(const Solver& solver, int part) const;

  // Loads from the momentum exchange of the direct forcing in the last stage (Uhlmann 2005, J Comput Phys
  // 209:448): force = -rho sum over forced faces of (u_forced - u*) dV / (alpha dt) + rho sum over solid faces
  // of a dV (the fictitious fluid inside a part moves with it), moment and power likewise. The viscous parts
  // are the surface integral's (as in loads()), the pressure parts the remainder. Conservative by construction
  // and accurate on coarse grids, where the probe-based surface integral under-resolves the wall layer
  // (docs/validation.md, "Immersed boundary"); noisier from stage to stage.
  std::vector<PartLoads> exchange_loads(const Solver& solver, const Vec3& moment_point) const;
  // Faces forced in the last stage (solid, interface band), for diagnostics and benchmarks.
  std::size_t solid_faces() const;
  std::size_t band_faces() const;
  std::size_t bytes() const;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace flapstab::ns
