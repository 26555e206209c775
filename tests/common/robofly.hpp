// The dynamically scaled fruit-fly wing ("Robofly", Dickinson, Lehmann & Sane 1999, Science 284:1954):
// translational force-coefficient fits, planforms, the flapping kinematics of the paper's Fig. 3 and small
// geometry helpers, shared by tests/cfd/test_ns_revolving_wing.cpp and tests/cfd/test_ns_flapping_wing.cpp.
// Sources and what is confirmed versus assumed: docs/validation.md, "Revolving wing (Robofly)" and
// "Flapping wing (Robofly, Dickinson et al. 1999)".
#pragma once
#include <algorithm>
#include <array>
#include <cmath>
#include <vector>
#include "cfd/navier_stokes/geometry.hpp"
#include "cfd/navier_stokes/immersed.hpp"
#include "core/insect.hpp"
#include "core/series.hpp"

namespace flapstab::robofly {

constexpr double deg = pi / 180;

// Translational coefficients of the revolving Robofly wing (alpha in degrees; Dickinson, Lehmann & Sane 1999, Science 284:1954).
inline double translational_cl(double alpha_deg) { return 0.225 + 1.58 * std::sin((2.13 * alpha_deg - 7.20) * deg); }
inline double translational_cd(double alpha_deg) { return 1.92 - 1.55 * std::cos((2.04 * alpha_deg - 9.82) * deg); }

// Drosophila-like stand-in planform: a full ellipse over 0 <= r <= R = 1 (chord zero at root and tip),
// mean chord R / aspect_ratio, tabulated with stations clustered at both ends; pitch axis at the quarter chord.
inline Wing elliptic_wing(double aspect_ratio) {
  Wing w;
  w.length = 1;
  w.mean_chord = 1 / aspect_ratio;
  w.planform = Planform::tabulated;
  w.pitch_axis = 0.25;
  const int n = 40;
  for (int j = 0; j <= n; ++j) {
    const double r = 0.5 * (1 - std::cos(pi * j / n));  // clustered at root and tip
    w.table_r.push_back(r);
    w.table_c.push_back(4 / pi * std::sqrt(std::max(0.0, 1 - (2 * r - 1) * (2 * r - 1))));
  }
  return w;
}

// One wing in fluid at rest in a walled box: the solver (viscosity nu, adaptive step at CFL 1.2) and the
// immersed boundary with the wing attached (constructed in place: the boundary keeps a pointer to the solver).
struct SingleWingFlow {
  ns::Solver solver;
  ns::ImmersedBoundary ib;
  SingleWingFlow(const ns::Grid& g, double nu, const ns::TriangleMesh& mesh, ns::PartMotion motion)
      : solver(g, ns::Boundaries::all(ns::BC::velocity), options(nu)), ib(g) {
    solver.initialise([](double, double, double) { return Vec3::Zero(); });
    ib.add_part(mesh, std::move(motion));
    ib.attach(solver);
  }
  static ns::SolverOptions options(double nu) {
    ns::SolverOptions o;
    o.nu = nu;
    o.cfl = 1.2;
    return o;
  }
};

// Radius of the second moment of area of a planar wing-frame mesh about the hinge axis (distance along
// wing-frame y): (int y^2 dA / S)^(1/2), exact for piecewise-linear triangles.
inline double second_moment_radius(const ns::TriangleMesh& mesh) {
  double I2 = 0;
  for (std::size_t k = 0; k < mesh.size(); ++k) {
    const double a = mesh.area_vector(k).norm();
    const double y0 = mesh.vertex(k, 0).y(), y1 = mesh.vertex(k, 1).y(), y2 = mesh.vertex(k, 2).y();
    I2 += a / 6 * (y0 * y0 + y1 * y1 + y2 * y2 + y0 * y1 + y1 * y2 + y2 * y0);
  }
  return std::sqrt(I2 / mesh.area());
}

// ---------------------------------------------------------------------------------------------------------
// The Robofly planform digitised by the FLUSI authors "from the hand drawn figure M. Dickinson sent via
// email, which contained the exact location of the pivot point": published Fourier coefficients of the
// outline radius about a centre (xc, yc), in pseudospectators/FLUSI, src/insects/wings_geometry.f90, case
// 'robofly_dickinson' (commit 0af2b58fcacf61e8b1c7e70a1661ff3f3286bce3). Wing frame: y spanwise from the
// pivot, x chordwise, positive towards the leading edge (ASSUMED: the pivot lies 0.08-0.16 from the +x edge
// and 0.22-0.25 from the -x edge, and FLUSI's wing-frame x points to the leading edge); the outline is
// R0(theta) = a0/2 + sum_k a_k cos(2 pi k theta) + b_k sin(2 pi k theta), theta = (atan2(y - yc, x - xc) + pi)
// / (2 pi). The evaluation below is ours.
struct DickinsonOutline {
  static constexpr double a0 = 0.5313628, xc = -0.0716018, yc = 0.4645238;
  static constexpr std::array<double, 28> a{
      -0.0245658, -0.0842918, 0.0218028,  0.0105418,  -0.0095288, 0.0012928,  0.0021928,
      0.0000328,  -0.0007648, -0.0015808, 0.0013808,  0.0013068,  -0.0010748, 0.0002408,
      -0.0000378, -0.0010888, 0.0008248,  0.0004708,  -0.0003988, 0.0002658,  -0.0003178,
      -0.0004218, 0.0002768,  0.0000818,  0.0000318,  0.0001228,  -0.0001918, -0.0000558};
  static constexpr std::array<double, 28> b{
      -0.0905448, 0.0278058,  0.0392558,  -0.0125248, -0.0159598, 0.0048268,  0.0038898,
      -0.0028828, 0.0012618,  0.0012998,  -0.0019058, 0.0003118,  0.0003198,  -0.0004298,
      0.0006388,  -0.0000648, -0.0002308, 0.0002518,  -0.0003948, 0.0000928,  0.0004478,
      -0.0003078, -0.0000888, 0.0001638,  -0.0002348, 0.0001398,  0.0001398,  -0.0002358};
  static double radius(double theta) {
    double r = a0 / 2;
    for (std::size_t k = 0; k < a.size(); ++k) {
      const double w = 2 * pi * double(k + 1) * theta;
      r += a[k] * std::cos(w) + b[k] * std::sin(w);
    }
    return r;
  }
};

// The outline as a closed polygon of n points in FLUSI's units (tip about 0.998 from the pivot).
inline std::vector<std::array<double, 2>> dickinson_outline(int n = 4000) {
  std::vector<std::array<double, 2>> p(static_cast<std::size_t>(n));
  for (int k = 0; k < n; ++k) {
    const double theta = double(k) / n, r = DickinsonOutline::radius(theta), ang = 2 * pi * theta - pi;
    p[std::size_t(k)] = {DickinsonOutline::xc + r * std::cos(ang), DickinsonOutline::yc + r * std::sin(ang)};
  }
  return p;
}

// Chordwise extent [trailing edge, leading edge] of a polygon at height y (the outermost crossings).
inline std::array<double, 2> chord_extent(const std::vector<std::array<double, 2>>& p, double y) {
  double lo = 1e300, hi = -1e300;
  for (std::size_t k = 0; k < p.size(); ++k) {
    const auto& u = p[k];
    const auto& v = p[(k + 1) % p.size()];
    if ((u[1] - y) * (v[1] - y) <= 0 && u[1] != v[1]) {
      const double x = u[0] + (y - u[1]) * (v[0] - u[0]) / (v[1] - u[1]);
      lo = std::min(lo, x), hi = std::max(hi, x);
    }
  }
  return {lo, hi};
}

// The Dickinson planform as a membrane in the wing frame, scaled so that the tip is at distance 1 from the
// pivot (the hinge, at the origin): z = 0, y from the root (about 0.247) to the tip, leading edge +x, front
// face +z (the same conventions as ns::wing_mesh). n_span stations clustered at root and tip (cosine),
// n_chord equal chordwise divisions; the end stations collapse to the outline's extreme points.
struct DickinsonPlanform {
  double scale = 1, root = 0, tip = 1;  // FLUSI units per our unit; root and tip radii (ours)
  std::vector<double> y, te, le;        // stations (ours)
};

inline DickinsonPlanform dickinson_planform(int n_span) {
  const auto p = dickinson_outline();
  double ymin = 1e300, ymax = -1e300, xmin_at = 0, xmax_at = 0;
  for (const auto& q : p) {
    if (q[1] < ymin) ymin = q[1], xmin_at = q[0];
    if (q[1] > ymax) ymax = q[1], xmax_at = q[0];
  }
  DickinsonPlanform d;
  d.scale = ymax;
  d.root = ymin / ymax;
  for (int j = 0; j <= n_span; ++j) {
    const double s = 0.5 * (1 - std::cos(pi * j / n_span));
    const double y = ymin + (ymax - ymin) * s;
    std::array<double, 2> e{};
    if (j == 0) e = {xmin_at, xmin_at};
    else if (j == n_span) e = {xmax_at, xmax_at};
    else e = chord_extent(p, y);
    d.y.push_back(y / ymax), d.te.push_back(e[0] / ymax), d.le.push_back(e[1] / ymax);
  }
  return d;
}

inline ns::TriangleMesh dickinson_wing_mesh(int n_span, int n_chord) {
  const DickinsonPlanform d = dickinson_planform(n_span);
  ns::TriangleMesh m;
  m.label = "wing";
  m.membrane = true;
  std::vector<std::vector<int>> rows;
  for (std::size_t j = 0; j < d.y.size(); ++j) {
    std::vector<int> row;
    const int n = (j == 0 || j + 1 == d.y.size()) ? 0 : n_chord;
    for (int i = 0; i <= n; ++i) {
      row.push_back(int(m.vertices.size()));
      const double x = n == 0 ? d.te[j] : d.te[j] + (d.le[j] - d.te[j]) * i / n;
      m.vertices.emplace_back(x, d.y[j], 0.0);
    }
    rows.push_back(std::move(row));
  }
  ns::triangulate_rows(m, rows);
  return m;
}

// The same planform as a flapstab Wing for the quasi-steady model (R = 1): tabulated chord (zero inboard of
// the root, a step at the root), mean chord = area / R, and a single pitch-axis fraction, the area-weighted
// mean of the pivot's local chordwise position from the leading edge (the model's one approximation here).
inline Wing dickinson_wing(int n_span = 40) {
  const DickinsonPlanform d = dickinson_planform(n_span);
  double S = 0, Sx = 0;
  for (std::size_t j = 0; j + 1 < d.y.size(); ++j) {
    const double dy = d.y[j + 1] - d.y[j];
    S += dy * 0.5 * ((d.le[j] - d.te[j]) + (d.le[j + 1] - d.te[j + 1]));
    Sx += dy * 0.5 * (d.le[j] + d.le[j + 1]);  // int x_le dy = int (x_le / c) c dy
  }
  Wing w;
  w.length = 1;
  w.mean_chord = S;
  w.planform = Planform::tabulated;
  w.pitch_axis = Sx / S;
  w.table_r = {0.0, d.root * (1 - 1e-9)};
  w.table_c = {0.0, 0.0};
  for (std::size_t j = 0; j < d.y.size(); ++j) {
    w.table_r.push_back(d.y[j]);
    w.table_c.push_back((d.le[j] - d.te[j]) / S);
  }
  return w;
}

// ---------------------------------------------------------------------------------------------------------
// Flapping kinematics of Dickinson et al. 1999, Fig. 3 (advanced, symmetrical and delayed rotation), as the
// FLUSI authors fitted them: pseudospectators/FLUSI, src/insects/wings_motion.f90, case "flapper_dickinson"
// (stored versions 04f1b12119b2efcbd3a658d6897fc8886b99b1be; "Fourier coefficients analyzed with matlab,
// Gaussian filter that fits fig 3D"). Odd harmonics only, phase tau in cycles, degrees:
//   stroke      phi(tau) = sum_k A_k cos(2 pi k tau)                     (FLUSI scales by phicdeg/180 = 1)
//   feathering  psi(tau) = (50/40) sum_k B_k sin(2 pi k (tau + t_adv))  (from the VERTICAL, not the angle of
//               attack; FLUSI scales its 40-degree fit to 90 - 40 = 50 degrees: mid-stroke incidence 40 deg)
// t_adv = +0.08 advanced rotation, 0 symmetrical, -0.08 delayed (FLUSI's comment). The coefficients are
// numbers published in that file; the series evaluation is ours.
inline const std::array<double, 16>& dickinson_stroke_coefficients() {  // A_1, A_3, ..., A_31
  static const std::array<double, 16> c{63.24528806534019,     5.753991800610726,     1.3887974015525626,
                                        0.3889856512386744,    0.10577402496901325,   0.026061339604144987,
                                        0.005623376646981709,  0.001042285996467963,  1.639611509380189e-4,
                                        2.1716252827442023e-5, 2.408190194815521e-6,  2.2268710288534648e-7,
                                        1.7118916093759426e-8, 1.0914870312823793e-9, 5.76135101855556e-11,
                                        2.513944479978149e-12};
  return c;
}
inline const std::array<double, 15>& dickinson_feathering_coefficients() {  // B_1, B_3, ..., B_29
  static const std::array<double, 15> c{48.23094285611071,      10.224154661301371,    2.1623763046726396,
                                        0.05049394424178093,    -0.17550942623071494,  -0.06634193748204852,
                                        -0.008925020495896451,  0.0011292567942149407, 6.471071566666472e-4,
                                        1.0018757795834964e-4,  3.0105550216312524e-6, -1.237567150768195e-6,
                                        -1.988004402010933e-7,  -1.10165545174181e-8,  2.4135650975460306e-10};
  return c;
}
constexpr double dickinson_feathering_scale = 50.0 / 40.0;

// The two angles as flapstab Fourier series (radians, phase in cycles): stroke phi and feathering psi.
inline FourierSeries dickinson_stroke() {
  FourierSeries s;
  const auto& A = dickinson_stroke_coefficients();
  for (std::size_t i = 0; i < A.size(); ++i) {
    s.a.push_back(0), s.b.push_back(0);
    s.a.push_back(A[i] * deg), s.b.push_back(0);
  }
  s.a.erase(s.a.begin()), s.b.erase(s.b.begin());  // harmonics 1, 2, 3, ...: odd ones non-zero
  return s;
}
inline FourierSeries dickinson_feathering(double t_adv) {
  FourierSeries s;
  const auto& B = dickinson_feathering_coefficients();
  for (std::size_t i = 0; i < B.size(); ++i) {
    const int k = int(2 * i + 1);
    const double c = dickinson_feathering_scale * B[i] * deg, w = 2 * pi * k * t_adv;
    if (k > 1) s.a.push_back(0), s.b.push_back(0);
    // sin(2 pi k (tau + t_adv)) = sin(2 pi k tau) cos(w) + cos(2 pi k tau) sin(w)
    s.a.push_back(c * std::sin(w)), s.b.push_back(c * std::cos(w));
  }
  return s;
}

}  // namespace flapstab::robofly
