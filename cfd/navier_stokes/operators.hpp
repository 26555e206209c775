// Discrete MAC operators of the fractional step: momentum predictor, divergence, projection, diagnostics.
#pragma once
#include "cfd/navier_stokes/boundary.hpp"
#include "cfd/navier_stokes/field.hpp"
#include "cfd/navier_stokes/grid.hpp"

namespace flapstab::ns {

// One low-storage Runge-Kutta stage u* = u + dt (gamma N(u) + zeta N_prev) - (gamma + zeta) dt G p,
// N(u) = -div(u u) + nu lap(u) (flux form, central, linear interpolation in the coordinates).
struct StageCoefficients {
  double gamma = 1, zeta = 0;
  double alpha() const { return gamma + zeta; }
};

// Predictor: ustar = u + dt (gamma N + zeta Nprev) - alpha dt G p on the faces; Nprev <- N.
// u, p must have BC-consistent ghosts. Boundary faces of ustar are then set by impose_normal_velocity.
void predict(const Grid& g, const VectorField& u, const Field& p, VectorField& Nprev, VectorField& ustar, double nu,
             double dt, const StageCoefficients& c);

// The convective acceleration sum_e d/dx_e (u_e u_d) at the u_d point (i, j, k) (face i, j or k of cell (i, j, k)
// along d, 1 .. n), in the predictor's discrete form (flux form, central): du_d/dt = -it + nu lap u_d - dp/dx_d there.
// Reads the neighbours and ghosts the predictor reads (faces 0 and cells 0 along d at face 1).
double convective_acceleration(const Grid& g, const VectorField& u, int d, int i, int j, int k);

// The Coriolis acceleration of a frame rotating at omega (rad/s), C = -2 omega x u, on every interior face (the
// other components averaged from their four nearest faces): ustar += gamma dt C(u) and Nprev += C(u), so the next
// stage's zeta term carries it as part of N. Call after predict with the same u and coefficients.
void add_coriolis(const Grid& g, const VectorField& u, VectorField& Nprev, VectorField& ustar, const Vec3& omega,
                  double dt, const StageCoefficients& c);

// u += w x r on the unknowns add_coriolis sweeps (r from the grid's origin): a rigid rotation's velocity field, e.g.
// the integral over a stage of the Euler acceleration -dOmega/dt x r of a frame whose rate changes.
void add_rotation(const Grid& g, VectorField& u, const Vec3& w);

// div = scale * D u on the cells.
void divergence(const Grid& g, const VectorField& u, Field& div, double scale);

// u = ustar - alpha dt G phi on all faces (phi with BC ghosts), p += phi on the cells.
void project(const Grid& g, const VectorField& ustar, const Field& phi, VectorField& u, Field& p, double alpha_dt);

// Diagnostics.
double kinetic_energy(const Grid& g, const VectorField& u);       // 1/2 sum over faces of u^2 times face volume
// Rate at which the momentum predictor's viscous term removes kinetic energy: -nu sum over the interior velocity
// unknowns of u lap(u) times their control volume (the discrete dissipation, per unit density; the stencil of
// predict(), so the boundary links use the ghosts as they stand: call with BC-consistent ghosts for the exact value).
double viscous_dissipation(const Grid& g, const VectorField& u, double nu);
double max_divergence(const Grid& g, const VectorField& u);       // max over cells of |D u|
double max_rate(const Grid& g, const VectorField& u);             // max over cells of sum_a |u_a| / dx_a
// Where that maximum is (a slow scan, for messages): the cell (1-based interior indices), its centre and the rate.
struct RateLocation {
  int i = 0, j = 0, k = 0;
  Vec3 centre = Vec3::Zero();
  double rate = 0;
};
RateLocation max_rate_location(const Grid& g, const VectorField& u);
double max_viscous_rate(const Grid& g, double nu);                // max over cells of nu sum_a 1 / dx_a^2

}  // namespace flapstab::ns
