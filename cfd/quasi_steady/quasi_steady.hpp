// Quasi-steady blade-element aerodynamics of flapping wings (translational + rotational + added mass).
//
// Theory, formulas and sources: docs/theory/quasi-steady.md. All vectors in stability axes S, moments
// about the reference point O (core/configuration.hpp).
#pragma once
#include <array>
#include <memory>
#include <optional>
#include <string>
#include <vector>
#include "core/aero_coefficients.hpp"
#include "core/aero_model.hpp"
#include "core/configuration.hpp"

namespace flapstab {

enum class CoefficientSet {
  robofly,      // Dickinson, Lehmann & Sane 1999 fits (3D revolving wing, Re ~ 100)
  berman_wang,  // Berman & Wang 2007 thin-plate set (C_T = 1.678, C_D(0) = 0.07, C_D(pi/2) = 3.06)
  table,        // user C_L(alpha), C_D(alpha) tables on [0, 90] deg (clamped cubic splines)
};

struct QuasiSteadyOptions {
  double rho = 1.225;  // fluid density, kg/m^3
  CoefficientSet coefficients = CoefficientSet::robofly;
  int blade_elements = 40;  // spanwise quadrature nodes per wing
  bool rotational = true;   // Sane & Dickinson 2002 rotational circulation
  bool added_mass = true;   // non-circulatory (added-mass) normal force
  int samples_per_cycle = 128;
  CoefficientConstants constants;
  // Rotational circulation coefficient C_R (Gamma_rot = C_R c^2 omega_s); unset: pi (3/4 - x0), thin-aerofoil theory.
  std::optional<double> rotational_coefficient;
  // Where the translational and rotational forces act, fraction of the chord from the leading edge (0.25: the
  // thin-aerofoil aerodynamic centre), independent of the pitch axis.
  double centre_of_pressure = 0.25;
};

// Translational force coefficients at angle of attack alpha (rad, folded into [0, pi/2]).
struct TranslationalCoefficients {
  double lift = 0, drag = 0;
};
TranslationalCoefficients translational_coefficients(CoefficientSet set, double alpha,
                                                     const CoefficientConstants& constants = {});

// translational_coefficients of one set as a piecewise polynomial in t = tan(alpha/2) in [0, 1], which the
// blade elements get from their velocity components without a trigonometric call (the model's hot loop).
// Interpolates the exact definition at Chebyshev points: |error| < 1e-14 (tests/cfd/test_quasi_steady.cpp).
class CoefficientFit {
 public:
  explicit CoefficientFit(CoefficientSet set, const CoefficientConstants& constants = {});
  TranslationalCoefficients operator()(double t) const;
  // The coefficients and their derivatives d/dt (the same polynomials differentiated).
  TranslationalCoefficients operator()(double t, TranslationalCoefficients& slope) const;

 private:
  static constexpr int pieces = 64, degree = 9;
  std::array<std::array<double, degree + 1>, pieces> lift_{}, drag_{};  // monomial coefficients, local u in [-1, 1]
};

// Spanwise quadrature of one wing: sum_i w[i] f(r[i]) c[i] approximates int_0^R f(r) c(r) dr.
// Gauss-Legendre in theta with r = R sin(theta), theta in [0, pi/2]: the substitution turns the
// elliptic planform's sqrt(1 - (r/R)^2) tip into a smooth integrand (docs/theory/quasi-steady.md).
struct SpanQuadrature {
  std::vector<double> r, w, c;  // node radius (m), weight (m), local chord (m)
  // The hind wing's nodes for a four-winged insect (span_quadrature of the Insect); null otherwise.
  std::shared_ptr<const SpanQuadrature> hind;
};
SpanQuadrature span_quadrature(const Wing& wing, int n);
// The fore wing's quadrature with the hind wing's (when the insect has a hind pair) attached.
SpanQuadrature span_quadrature(const Insect& insect, int n);

class QuasiSteadyModel : public AeroModel {
 public:
  explicit QuasiSteadyModel(QuasiSteadyOptions o);
  const QuasiSteadyOptions& options() const { return opt_; }
  std::string name() const override;
  // Samples `loads` at t_k = k T / N, k = 0..N-1 (one cycle suffices: the model has no memory).
  WrenchHistory run(const Insect& insect, const Kinematics& kin, const BodyMotion& motion,
                    const AeroRunOptions& options) const override;
  bool is_instantaneous() const override { return true; }
  WrenchSample instantaneous(const Insect& insect, const Kinematics& kin, double t,
                             const BodyMotion& motion) const override;
  // Loads at time t for a configuration and quadrature built once by the caller (the fast path).
  WrenchSample loads(const Configuration& config, const SpanQuadrature& span, double t,
                     const BodyMotion& motion) const;
  // The total wrench of `loads` and its exact derivative d[F; M] / d[velocity; rate] (6 x 6, SI) at time t:
  // the blade-element sums differentiated strip by strip (docs/theory/quasi-steady.md, section 9).
  Wrench loads_jacobian(const Configuration& config, const SpanQuadrature& span, double t, const BodyMotion& motion,
                        Eigen::Matrix<double, 6, 6>& jacobian) const;

 private:
  Wrench wing_loads_jacobian(const WingPose& pose, double pitch_axis, const SpanQuadrature& span,
                             const BodyMotion& motion, Eigen::Matrix<double, 6, 6>& jacobian) const;
  Wrench wing_loads(const WingPose& pose, double pitch_axis, const SpanQuadrature& span,
                    const BodyMotion& motion, double& power) const;
  Wrench body_loads(const Configuration& config, const BodyMotion& motion) const;
  // [abdomen] drag: the wrench about O at time t and, if jacobian != nullptr, its d[F; M] / d[v; Omega] added there.
  Wrench abdomen_loads(const Configuration& config, double t, const BodyMotion& motion,
                       Eigen::Matrix<double, 6, 6>* jacobian) const;
  QuasiSteadyOptions opt_;
  CoefficientFit fit_;
};

}  // namespace flapstab
