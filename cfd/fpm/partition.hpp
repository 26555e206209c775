// Force partitioning (FPM) of the loads on immersed parts: each pressure force and moment component split into a
// kinematic part fixed by the parts' own accelerations (classical added mass and the centripetal acceleration
// reaction), a vortex-induced part (the Q criterion of the flow weighted by an influence potential), a viscous part
// and an outer-boundary part (Zhang 2015, PhD thesis, Johns Hopkins University, ch. 3-4; Zhang, Hedrick & Mittal
// 2015, PLoS ONE 10:e0132093; Menon & Mittal 2021, J Comput Phys 443:110515). Derivation, discrete forms and signs:
// docs/theory/force-partitioning.md.
//
// Discretisation: cut cells (geometry.hpp): face apertures and surface pieces from the parts' level sets.
// For part i and component k the influence potential phi solves  lap phi = 0 in the fluid, d phi/dn = g_k on part
// i (n out of the part into the fluid; g = n_k for a force component, ((x - x0) x n)_k for a moment about x0),
// d phi/dn = 0 on the other parts and the domain's faces, phi -> 0 far away (its mean on the domain's faces is set
// to zero). Then, exactly for incompressible flow with no-slip parts,
//   F_k^pressure = -oint_{part i} p g_k dS
//                =  rho sum_j oint_{part j} phi (a_j . n) dS   kinematic (a_j: part j's surface acceleration)
//                 - 2 rho int_fluid Q phi dV                   vortex-induced
//                 + mu int_fluid lap u . grad phi dV           viscous
//                 - rho oint_domain phi (Du/Dt . n) dS         outer boundary (n out of the domain)
//                 + rho int_fluid f . grad phi dV              its sponge layer (f = -sigma (u - u_far); none without)
// The skin friction on the part is not part of the pressure force; it is reported beside (the solver's loads).
#pragma once
#include <array>
#include <string>
#include <vector>
#include <Eigen/Core>
#include "cfd/fpm/laplace.hpp"
#include "cfd/navier_stokes/immersed.hpp"
#include "cfd/navier_stokes/solver.hpp"

namespace flapstab::fpm {

// The MAC Laplacian of velocity component d at its face (i, j, k) (1/s per m/s of u; non-uniform axes): the viscous
// term's integrand, mu lap u . grad phi, per open face not forced by the immersed boundary.
inline double face_laplacian(const ns::Grid& g, const ns::Field& ud, int d, int i, int j, int k) {
  const ns::Axis& ad = g.axis[std::size_t(d)];
  const int I[3] = {i, j, k};
  int A[3] = {i, j, k}, B[3] = {i, j, k};
  ++A[d];
  --B[d];
  const std::size_t F = std::size_t(I[d]);
  const double u0 = ud(i, j, k);
  double lap = ((ud(A[0], A[1], A[2]) - u0) * ad.idc[F] - (u0 - ud(B[0], B[1], B[2])) * ad.idc[F - 1]) * ad.idf[F];
  for (int a : {(d + 1) % 3, (d + 2) % 3}) {
    const ns::Axis& aa = g.axis[std::size_t(a)];
    int P[3] = {i, j, k}, M[3] = {i, j, k};
    ++P[a];
    --M[a];
    const std::size_t J = std::size_t(I[a]);
    lap += ((ud(P[0], P[1], P[2]) - u0) * aa.idf[J + 1] - (u0 - ud(M[0], M[1], M[2])) * aa.idf[J]) * aa.idc[J];
  }
  return lap;
}

using Vec6 = Eigen::Matrix<double, 6, 1>;  // F_x, F_y, F_z (N), M_x, M_y, M_z (N m, about the moment point)
using ns::PartState;
using flapstab::Vec3;

// The partition of one part's pressure load (grid axes).
struct PartPartition {
  std::string label;
  Vec6 kinematic = Vec6::Zero();    // rho sum_j oint phi (a_j . n) dS, all parts' accelerations
  Vec6 centripetal = Vec6::Zero();  // its share from the centripetal accelerations omega x (omega x r): the CAR
  Vec6 vortex = Vec6::Zero();       // -2 rho int Q phi dV
  Vec6 viscous = Vec6::Zero();      // mu int lap u . grad phi dV
  Vec6 outer = Vec6::Zero();        // -rho oint_domain phi Du/Dt . n dS + rho int f_sponge . grad phi dV
  Vec6 pressure = Vec6::Zero();     // -oint p g dS on the staircase surface (the partition's sum, computed directly)
  // The share of `pressure` on the faces the immersed boundary forces (FluidGeometry::forced): the terms of the
  // discrete Green identity pressure = sum over open faces of a_f (p_c - p_nb)(phi_c - phi_nb) there. Direct forcing
  // replaces the momentum equation on those faces, so no part accounts for it: the parts sum to pressure -
  // pressure_forced up to their own discretisation error, and pressure_forced is the forcing's share of the closure
  // gap (docs/theory/force-partitioning.md).
  Vec6 pressure_forced = Vec6::Zero();
  std::vector<Vec6> vortex_regions; // the vortex-induced part by region (set_regions; empty without), summing to vortex
  // Rate of work of the part on the fluid by mechanism, W: -(F . v(x0) + M . omega) with the part's rigid velocity.
  // With FpmOptions::power they come from the power potential (one Laplace problem instead of six; the same up to the
  // solver's tolerance), otherwise from the six components (zero unless all six are partitioned). The power's regions
  // and its centripetal share are filled with FpmOptions::power only.
  double power_kinematic = 0, power_vortex = 0, power_viscous = 0, power_outer = 0, power_pressure = 0;
  double power_centripetal = 0, power_pressure_forced = 0;
  std::vector<double> power_vortex_regions;
  Vec6 sum() const { return kinematic + vortex + viscous + outer; }
  Vec6 added_mass() const { return kinematic - centripetal; }  // classical: from a + alpha x r
};

struct FpmOptions {
  double rtol = 1e-8;        // potentials: max residual / max right-hand side
  int max_iterations = 400;  // per potential solve
  Vec3 moment_point = Vec3::Zero();  // x0 of the moment potentials (grid axes)
  std::vector<int> components{0, 1, 2, 3, 4, 5};  // which of F_x .. M_z to partition (the rest stay zero)
  int face_samples = 4;  // m x m points per face near a surface for the cut-cell apertures
  // The region the potentials treat as the parts (fluid_geometry). With FpmBody::forced_region the kinematic term is
  // rho oint phi n . (du/dt + u . grad u) dS over the widened body's faces with the fluid's velocity there, which
  // slides along the body; `centripetal` stays the rigid parts' centripetal acceleration reaction on those faces.
  // Every term is then taken in the form of the last Runge-Kutta stage (the solver must keep its stage velocities,
  // ns::SolverOptions::keep_stage_velocities; std::invalid_argument otherwise): du/dt its rate, u . grad u and the
  // vortex-induced term's Q the solver's own discrete convective term (ns::convective_acceleration) of its velocities,
  // the viscous term their Laplacian, so that the parts sum exactly to the pressure force on the widened body (to the
  // projection's and the potentials' tolerances). docs/theory/force-partitioning.md, "The forced region as the body".
  FpmBody body = FpmBody::surface;
  // Also the power potential of each part: d phi/dn = v . n with the part's rigid velocity v at the update (its
  // partition is the rate of work by mechanism, PartPartition::power_*). Needs the part states in update().
  bool power = false;
};

struct PotentialReport {
  int part = 0, component = 0;  // component 6: the power potential
  LaplaceStats stats;
  double imbalance = 0;  // |sum of the Neumann fluxes| / sum of their magnitudes (0 for a closed wetted surface)
  double outflow = 0;    // that sum: the flux of the potential that leaves through the domain's faces (m^2 for F)
  std::size_t pocket_cells = 0;  // fluid cells cut off by the parts, left out (FluidGeometry::pocket_cells)
};

class ForcePartition {
 public:
  ForcePartition(const Grid& g, FpmOptions options = {});

  // Solves the influence potentials of every part and chosen component for the parts at `states` (the cell owners
  // from the immersed boundary's level sets), each from the last two calls' potentials extrapolated (warm start).
  // std::invalid_argument when the states do not match the immersed boundary's parts.
  const std::vector<PotentialReport>& update(const ns::ImmersedBoundary& ib, const std::vector<PartState>& states);
  // The same for parts given by their level sets (`owners`: the part holding each interior cell's centre, x fastest,
  // -1 fluid; owners_of() computes it; `near`: the cells from which faces are tested, fluid_geometry).
  const std::vector<PotentialReport>& update(const LevelFunction& level, int parts, const std::vector<int>& owners,
                                            const std::vector<PartState>& states = {},
                                            const std::vector<int>* near = nullptr);

  // The partition at the solver's current state for the parts at `states` (the same as the last update's), fluid
  // density rho. Needs update() first (std::logic_error). The outer term's d u_n / dt comes from the previous call's
  // boundary velocities (zero at the first call). Throws std::invalid_argument for a rotating grid frame (the
  // partition is derived for an inertial frame).
  std::vector<PartPartition> partition(const ns::Solver& solver, const std::vector<PartState>& states, double rho);

  const FluidGeometry& geometry() const;
  // Added-mass matrix of part i with respect to the motion of part j (6 x 6, kg, kg m, kg m^2): the kinematic load on
  // part i is -M_ij (a_j, alpha_j) for rigid accelerations of part j about the moment point,
  // M_ij(k, l) = -rho oint_{part j} phi_(i,k) g_l dS (g_l part j's Neumann datum of component l). Rows of components
  // not partitioned are zero.
  Eigen::Matrix<double, 6, 6> added_mass(int part_i, int part_j, double rho) const;
  const Field& potential(int part, int component) const;  // component 6: the power potential
  // -2 rho Q phi at the cell centres for (part, component) from the last partition (N/m^3 for a force component):
  // the vortex-induced force density whose volume integral is that part's vortex term. Interior cells, x fastest.
  std::vector<double> vortex_density(int part, int component) const;
  // Labels of the interior cells (x fastest) by region, 0 .. count - 1: partition() then splits each vortex-induced part
  // over them (PartPartition::vortex_regions). An empty vector switches the split off.
  void set_regions(std::vector<int> labels, int count);
  // Keeps the normal velocities on the domain's faces at the solver's time: the outer term's d u_n / dt at the next
  // partition() is then a difference over one step (a run's observer calls this every step; partition() does it too).
  void record_boundary(const ns::Solver& solver);
  const FpmOptions& options() const { return opt_; }
  const std::vector<PotentialReport>& reports() const { return reports_; }

 private:
  const Grid* grid_;
  FpmOptions opt_;
  std::unique_ptr<FluidGeometry> geometry_;
  std::unique_ptr<NeumannLaplacian> laplace_;  // the last update's operator (its work arrays go to the next one)
  std::vector<std::array<Field, 7>> phi_;  // per part: the six components, then the power potential
  std::vector<std::array<Field, 7>> phi_prev_;  // the previous sample's potentials (the extrapolated start)
  int updates_ = 0;                              // update() calls so far
  std::vector<PotentialReport> reports_;
  std::vector<double> q_;                   // last partition's Q at the cell centres
  std::vector<int> region_labels_;          // per interior cell (set_regions)
  int region_count_ = 0;
  double rho_ = 0;
  // The domain's faces next to fluid cells (no-flux for the potentials), from the last update()
  struct DomainFace {
    std::ptrdiff_t cell;
    int d, side;  // face index F = 1 (side 0) or n+1 (side 1) along d
    int i, j, k;  // the cell
    double area;
  };
  std::vector<DomainFace> outer_;
  double outer_area_ = 0;
  // previous normal velocities on the domain's faces (per face 2 d + side, indexed by the cell's position in it)
  std::array<std::vector<double>, 6> un_prev_;
  double t_prev_ = 0;
  bool have_prev_ = false;
};

}  // namespace flapstab::fpm
