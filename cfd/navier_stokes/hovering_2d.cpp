#include "cfd/navier_stokes/hovering_2d.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <fstream>
#include <limits>
#include <sstream>
#include <stdexcept>
#include <Eigen/Geometry>
#include "cfd/navier_stokes/immersed.hpp"
#include "core/errors.hpp"

namespace flapstab::ns {

void Hovering2dCase::check() const {
  auto need = [](bool ok, const char* field, const char* expected) {
    if (!ok) throw std::invalid_argument(std::string("hovering 2-D case: ") + field + " must be " + expected);
  };
  need(thickness > 0 && thickness < 1, "thickness", "in (0, 1) chords");
  need(amplitude > 0, "amplitude", "positive (chords)");
  need(frequency > 0, "frequency", "positive");
  need(reynolds > 0, "reynolds", "positive");
  need(cycles > 0 && cycles <= 100, "cycles", "in (0, 100]");
  need(cells_per_chord >= 4 && cells_per_chord <= 512, "cells_per_chord", "in [4, 512]");
  need(stretch_ratio >= 1 && stretch_ratio <= 1.3, "stretch_ratio", "in [1, 1.3]");
  need(span_cells >= 2, "span_cells", "at least 2 (a one-cell slab diverges on fine grids, docs/validation.md)");
  need(outline_points >= 16, "outline_points", "at least 16");
  need(cfl > 0 && cfl < std::sqrt(3.0), "cfl", "in (0, sqrt 3)");
  const double reach = amplitude / 2 + 0.5;  // the chord's farthest point from the origin along x
  need(box_x[0] < -reach && box_x[1] > reach, "box_x", "wider than the swept region (A0/2 + c/2 each side)");
  need(box_y[0] < -0.5 && box_y[1] > 0.5, "box_y", "wider than the chord (c/2 each side)");
  need(half_width > std::max({-box_x[0], box_x[1], -box_y[0], box_y[1]}) + 1, "half_width",
       "at least one chord beyond the fine box");
}

Hovering2dKinematics hovering_2d_kinematics(const Hovering2dCase& c, double t) {
  const double w = 2 * pi * c.frequency, A = c.amplitude / 2, b = c.pitch_amplitude;
  Hovering2dKinematics k;
  k.x = A * std::cos(w * t);
  k.u = -A * w * std::sin(w * t);
  k.a = -A * w * w * std::cos(w * t);
  k.alpha = pi / 2 + b * std::sin(w * t);
  k.omega = b * w * std::cos(w * t);
  k.omega_dot = -b * w * w * std::sin(w * t);
  const double phase = t * c.frequency - std::floor(t * c.frequency);
  k.direction = phase < 0.5 ? -1 : 1;
  return k;
}

QuasiSteadyMaxima hovering_2d_quasi_steady_maxima(const Hovering2dCase& c, int chord_points, int samples_per_cycle) {
  if (chord_points < 2 || samples_per_cycle < 4) throw std::invalid_argument("quasi-steady maxima: too few points");
  QuasiSteadyMaxima m;
  m.chord_points = chord_points, m.time_samples = samples_per_cycle;
  m.lift_translational = 0.5 * c.max_speed() * c.max_speed() * 1.2;
  m.drag_translational = 0.5 * c.max_speed() * c.max_speed() * 1.4;
  for (int n = 0; n < samples_per_cycle; ++n) {
    const double t = c.period() * n / samples_per_cycle;
    const Hovering2dKinematics k = hovering_2d_kinematics(c, t);
    // alpha_e: the chord angle folded with the direction of motion (PetIBM's flapping.py: pi - alpha while u <= 0).
    const double ae = k.u <= 0 ? pi - k.alpha : k.alpha;
    const double cl = 1.2 * std::sin(2 * ae), cd = 1.4 - std::cos(2 * ae);
    for (int j = 0; j < chord_points; ++j) {
      const double s = -0.5 + double(j) / (chord_points - 1);  // along the chord from its centre (c = 1)
      // v = u e_x + omega e_z x (s (cos alpha, sin alpha))
      const double vx = k.u - k.omega * s * std::sin(k.alpha), vy = k.omega * s * std::cos(k.alpha);
      const double q = 0.5 * (vx * vx + vy * vy);
      m.lift = std::max(m.lift, q * cl);
      m.drag = std::max(m.drag, q * cd);
    }
  }
  return m;
}

namespace {

// The ellipse's outline (counter-clockwise, x along the chord), extruded along z over [z0, z1] and closed by two
// flat caps: a closed surface with outward normals. One layer of long side triangles suffices: the level set
// sampled from it does not depend on z (to rounding).
TriangleMesh extruded_ellipse(double chord, double thickness, int points, double z0, double z1) {
  TriangleMesh m;
  m.label = "wing";
  const double a = chord / 2, b = thickness / 2;
  const int n = points;
  for (double z : {z0, z1})
    for (int i = 0; i < n; ++i) {
      const double th = 2 * pi * i / n;  // uniform in the parameter: vertices cluster at the edges
      m.vertices.emplace_back(a * std::cos(th), b * std::sin(th), z);
    }
  const int c0 = int(m.vertices.size()), c1 = c0 + 1;
  m.vertices.emplace_back(0, 0, z0);
  m.vertices.emplace_back(0, 0, z1);
  for (int i = 0; i < n; ++i) {
    const int j = (i + 1) % n;
    m.triangles.push_back({i, j, n + j});  // side: (p_{i+1} - p_i) x e_z points outwards
    m.triangles.push_back({i, n + j, n + i});
    m.triangles.push_back({c1, n + i, n + j});  // cap at z1, normal +z
    m.triangles.push_back({c0, j, i});          // cap at z0, normal -z
  }
  return m;
}

double interpolate(const std::vector<double>& x, const std::vector<double>& y, double at) {
  auto it = std::upper_bound(x.begin(), x.end(), at);
  if (it == x.begin()) return y.front();
  if (it == x.end()) return y.back();
  const std::size_t i = std::size_t(it - x.begin());
  const double w = (at - x[i - 1]) / (x[i] - x[i - 1]);
  return (1 - w) * y[i - 1] + w * y[i];
}

// Trapezoid mean of y(x) over [lo, hi], ends interpolated.
double window_mean(const std::vector<double>& x, const std::vector<double>& y, double lo, double hi) {
  if (x.size() < 2 || x.front() > lo + 1e-9 * std::abs(hi - lo) || x.back() < hi - 1e-9 * std::abs(hi - lo))
    return std::numeric_limits<double>::quiet_NaN();
  std::vector<double> px{lo}, py{interpolate(x, y, lo)};
  for (std::size_t i = 0; i < x.size(); ++i)
    if (x[i] > lo && x[i] < hi) px.push_back(x[i]), py.push_back(y[i]);
  px.push_back(hi), py.push_back(interpolate(x, y, hi));
  double s = 0;
  for (std::size_t i = 1; i < px.size(); ++i) s += 0.5 * (py[i] + py[i - 1]) * (px[i] - px[i - 1]);
  return s / (hi - lo);
}

}  // namespace

double cycle_mean(const std::vector<double>& tau, const std::vector<double>& v, int k) {
  return window_mean(tau, v, k - 1, k);
}

Hovering2dResult run_hovering_2d(const Hovering2dCase& c, const std::function<void(const Hovering2dSample&)>& progress) {
  c.check();
  const auto t0 = std::chrono::steady_clock::now();
  const double h = 1.0 / c.cells_per_chord;
  const double depth = c.span_cells * h;
  const Grid g(Axis::stretched(StretchedAxis{-c.half_width, c.half_width, c.box_x[0], c.box_x[1], h, c.stretch_ratio, 8}, false),
               Axis::stretched(StretchedAxis{-c.half_width, c.half_width, c.box_y[0], c.box_y[1], h, c.stretch_ratio, 8}, false),
               Axis::uniform(0, depth, c.span_cells, true));
  Boundaries bc = Boundaries::all(BC::velocity);  // walls at rest
  bc.face[face(2, 0)].type = bc.face[face(2, 1)].type = BC::periodic;
  SolverOptions opt;
  opt.nu = c.viscosity();
  opt.cfl = c.cfl;
  if (c.hypre) opt.poisson.backend = PoissonBackend::hypre;
  Solver solver(g, bc, opt);
  solver.initialise([](double, double, double) { return Vec3::Zero(); });
  ImmersedBoundary ib(g);
  // The extrusion reaches 8 cells past each end of the slab: ghosts, probes (2.5 cells) and the level set's
  // lattice never see the caps.
  const double overhang = 8 * h, length = depth + 2 * overhang;
  const TriangleMesh mesh = extruded_ellipse(1.0, c.thickness, c.outline_points, -overhang, depth + overhang);
  if (mesh.open_or_inconsistent_edges() != 0) throw std::logic_error("hovering 2-D case: the wing mesh is not closed");
  ib.add_part(mesh, [c](double t) {
    const Hovering2dKinematics k = hovering_2d_kinematics(c, t);
    const Mat3 R = Eigen::AngleAxisd(k.alpha, Vec3::UnitZ()).toRotationMatrix();
    const Vec3 centre(k.x, 0, 0);
    PartState s{RigidTransform{R, centre}, RigidVelocity{centre, Vec3(k.u, 0, 0), Vec3(0, 0, k.omega)}};
    s.acceleration = Vec3(k.a, 0, 0);
    s.angular_acceleration = Vec3(0, 0, k.omega_dot);
    return s;
  });
  ib.attach(solver);

  Hovering2dResult r;
  r.settings = c;
  r.normalisation = hovering_2d_quasi_steady_maxima(c);
  const Shape sh = g.shape();
  r.nx = sh.nx, r.ny = sh.ny, r.nz = sh.nz;
  const double t_end = c.cycles * c.period();
  while (solver.time() < t_end - 1e-12 * t_end) {
    const double dt = solver.step();
    ++r.steps;
    Hovering2dSample s;
    s.t = solver.time();
    s.phase = s.t * c.frequency;
    const Hovering2dKinematics k = hovering_2d_kinematics(c, s.t);
    s.x = k.x, s.alpha = k.alpha;
    const Vec3 F = ib.exchange_loads(solver, Vec3::Zero())[0].force() / depth;
    const Vec3 Fs = ib.loads(solver, Vec3::Zero())[0].force() / length;
    s.lift = F.y(), s.drag = -F.x() * k.direction;
    s.lift_surface = Fs.y(), s.drag_surface = -Fs.x() * k.direction;
    s.cl = s.lift / r.normalisation.lift, s.cd = s.drag / r.normalisation.drag;
    s.cfl = solver.cfl(dt);
    if (!std::isfinite(s.lift) || !std::isfinite(s.drag))
      throw SolveError("hovering 2-D case: the loads are not finite at t = " + std::to_string(s.t));
    r.samples.push_back(s);
    if (progress) progress(s);
  }
  {  // how far the flow is from two-dimensional: spanwise velocity and spanwise variation of u, v
    const VectorField& u = solver.velocity();
    double dev = 0;
    for (int k = 1; k <= sh.nz; ++k)
      for (int j = 1; j <= sh.ny; ++j)
        for (int i = 1; i <= sh.nx; ++i) {
          dev = std::max(dev, std::abs(double(u[2](i, j, k))));
          for (int d = 0; d < 2; ++d) dev = std::max(dev, std::abs(double(u[d](i, j, k) - u[d](i, j, 1))));
        }
    r.spanwise_deviation = dev / c.max_speed();
  }
  std::vector<double> tau, cl, cd, cls, cds;
  for (const auto& s : r.samples) {
    tau.push_back(s.phase), cl.push_back(s.cl), cd.push_back(s.cd);
    cls.push_back(s.lift_surface / r.normalisation.lift), cds.push_back(s.drag_surface / r.normalisation.drag);
  }
  tau.insert(tau.begin(), 0.0);  // the start from rest: no load before the first step
  for (auto* v : {&cl, &cd, &cls, &cds}) v->insert(v->begin(), v->front());
  for (int k = 1; k <= int(std::floor(c.cycles + 1e-9)); ++k) {
    r.cycle_cl.push_back(cycle_mean(tau, cl, k));
    r.cycle_cd.push_back(cycle_mean(tau, cd, k));
    r.cycle_cl_surface.push_back(cycle_mean(tau, cls, k));
    r.cycle_cd_surface.push_back(cycle_mean(tau, cds, k));
  }
  r.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  return r;
}

CoefficientHistory read_coefficient_history(const std::string& path, std::string label) {
  std::ifstream in(path);
  if (!in) throw InputError(path, "", "cannot be opened", "a two-column file: t/T and the coefficient");
  CoefficientHistory h;
  h.label = std::move(label), h.file = path;
  std::string line;
  int n = 0;
  while (std::getline(in, line)) {
    ++n;
    if (line.find_first_not_of(" \t\r") == std::string::npos || line[line.find_first_not_of(" \t")] == '#') continue;
    std::istringstream ls(line);
    double a, b;
    std::string rest;
    if (!(ls >> a >> b) || (ls >> rest) || !std::isfinite(a) || !std::isfinite(b))
      throw InputError(path, "line " + std::to_string(n), "is not two numbers", "t/T and the coefficient");
    h.phase.push_back(a), h.value.push_back(b);
  }
  if (h.phase.size() < 2) throw InputError(path, "", "holds fewer than two points", "a history");
  return h;
}

double published_mean(const CoefficientHistory& h, double from, double to) {
  double s = 0, lo = std::numeric_limits<double>::infinity(), hi = -lo;
  bool have = false;
  double tp = 0, vp = 0;
  for (std::size_t i = 0; i < h.phase.size(); ++i) {
    if (h.phase[i] < from || h.phase[i] > to) continue;
    if (have) s += 0.5 * (h.value[i] + vp) * (h.phase[i] - tp);
    tp = h.phase[i], vp = h.value[i], have = true;
    lo = std::min(lo, tp), hi = std::max(hi, tp);
  }
  return hi > lo ? s / (hi - lo) : std::numeric_limits<double>::quiet_NaN();
}

HistoryComparison compare_history(const std::vector<double>& phase, const std::vector<double>& value,
                                  const CoefficientHistory& ref, int from, int to, double reversal_gap) {
  if (to <= from) throw std::invalid_argument("compare_history: empty window");
  HistoryComparison c;
  for (int k = from + 1; k <= to; ++k) {
    c.mean += window_mean(phase, value, k - 1, k) / (to - from);
    c.reference_mean += published_mean(ref, k - 1, k) / (to - from);
  }
  std::vector<double> a, b;
  for (std::size_t i = 0; i < ref.phase.size(); ++i) {
    const double tau = ref.phase[i], half = 2 * tau;
    if (tau < from || tau > to || std::abs(half - std::round(half)) < 2 * reversal_gap) continue;
    a.push_back(interpolate(phase, value, tau)), b.push_back(ref.value[i]);
  }
  c.points = int(a.size());
  if (a.size() < 3) return c;
  double ma = 0, mb = 0;
  for (std::size_t i = 0; i < a.size(); ++i) ma += a[i], mb += b[i];
  ma /= double(a.size()), mb /= double(b.size());
  double sab = 0, saa = 0, sbb = 0, sd = 0;
  for (std::size_t i = 0; i < a.size(); ++i) {
    sab += (a[i] - ma) * (b[i] - mb), saa += (a[i] - ma) * (a[i] - ma), sbb += (b[i] - mb) * (b[i] - mb);
    sd += (a[i] - b[i]) * (a[i] - b[i]);
  }
  c.correlation = sab / std::sqrt(saa * sbb);
  c.rms_difference = std::sqrt(sd / double(a.size()));
  return c;
}

}  // namespace flapstab::ns
