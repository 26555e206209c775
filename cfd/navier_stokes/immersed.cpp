// Immersed rigid parts: level sets on lattices, direct forcing after each predictor, loads by surface
// integration (docs/theory/navier-stokes.md, section 7; the header states the method).
#include "cfd/navier_stokes/immersed.hpp"
#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <deque>
#include <limits>
#include <stdexcept>
#include "cfd/navier_stokes/mesh_query.hpp"

namespace flapstab::ns {

namespace {

// ---------------------------------------------------------------------------------------------------------------
// Grid sampling helpers (non-uniform axes: binary search on the coordinates).

// Trilinear interpolation of a field stored at the points of component d (d = -1: cell centres), padded
// indices 0..n+1 (ghosts carry the box conditions).
double sample(const Grid& g, const Field& f, int d, const Vec3& x) {
  int I[3];
  double W[3];
  for (int a = 0; a < 3; ++a) {
    const Axis& ax = g.axis[std::size_t(a)];
    if (a == d)
      bracket(ax.xf, 1, ax.n + 1, x[a], I[a], W[a]);  // faces 1..n+1 (boundary faces included)
    else
      bracket(ax.xc, 0, ax.n + 1, x[a], I[a], W[a]);  // centres with the ghost layer
  }
  return trilinear(f, I, W);
}

// Largest width of the cell containing x (m): the local grid spacing h.
double local_width(const Grid& g, const Vec3& x) {
  double h = 0;
  for (int a = 0; a < 3; ++a) {
    const Axis& ax = g.axis[std::size_t(a)];
    int i;
    double w;
    bracket(ax.xf, 1, ax.n + 1, x[a], i, w);
    h = std::max(h, ax.dc[std::size_t(i)]);
  }
  return h;
}

// Index range [first, last] of coords c[lo..hi] inside [a, b] (empty when first > last).
inline void index_range(const std::vector<double>& c, int lo, int hi, double a, double b, int& first, int& last) {
  first = int(std::lower_bound(c.begin() + lo, c.begin() + hi + 1, a) - c.begin());
  last = int(std::upper_bound(c.begin() + lo, c.begin() + hi + 1, b) - c.begin()) - 1;
}

BoundingBox transformed_box(const BoundingBox& b, const RigidTransform& T, double grow) {
  BoundingBox out;
  for (int c = 0; c < 8; ++c)
    out.add(T.apply(Vec3(c & 1 ? b.hi.x() : b.lo.x(), c & 2 ? b.hi.y() : b.lo.y(), c & 4 ? b.hi.z() : b.lo.z())));
  out.lo.array() -= grow;
  out.hi.array() += grow;
  return out;
}

// ---------------------------------------------------------------------------------------------------------------
// Level set of one part on a uniform lattice in its reference frame (float storage: 4 bytes per point).

struct LevelSet {
  Vec3 origin = Vec3::Zero();
  double h = 1;
  int n[3] = {0, 0, 0};
  double cap = 0;  // |values| are capped here; outside the lattice = +cap (far fluid)
  std::vector<float> v;

  std::size_t index(int i, int j, int k) const { return std::size_t(i) + std::size_t(n[0]) * (std::size_t(j) + std::size_t(n[1]) * std::size_t(k)); }

  double at(const Vec3& y) const {
    const Vec3 s = (y - origin) / h;
    int I[3];
    double W[3];
    for (int a = 0; a < 3; ++a) {
      const double f = std::floor(s[a]);
      if (!(f >= 0 && f <= n[a] - 2)) {
        if (s[a] == double(n[a] - 1)) {  // on the upper lattice face
          I[a] = n[a] - 2;
          W[a] = 1;
          continue;
        }
        return cap;
      }
      I[a] = int(f);
      W[a] = s[a] - f;
    }
    const std::size_t sy = std::size_t(n[0]), sz = std::size_t(n[0]) * std::size_t(n[1]);
    const float* p = v.data() + index(I[0], I[1], I[2]);
    const double x0 = W[0], x1 = 1 - W[0];
    const double c00 = x1 * p[0] + x0 * p[1], c10 = x1 * p[sy] + x0 * p[sy + 1];
    const double c01 = x1 * p[sz] + x0 * p[sz + 1], c11 = x1 * p[sz + sy] + x0 * p[sz + sy + 1];
    const double c0 = (1 - W[1]) * c00 + W[1] * c10, c1 = (1 - W[1]) * c01 + W[1] * c11;
    return (1 - W[2]) * c0 + W[2] * c1;
  }

  // Gradient by central differences of the interpolated field, step = the lattice spacing.
  Vec3 gradient(const Vec3& y) const {
    Vec3 gr;
    for (int a = 0; a < 3; ++a) {
      Vec3 e = Vec3::Zero();
      e[a] = h;
      gr[a] = (at(y + e) - at(y - e)) / (2 * h);
    }
    return gr;
  }
};

constexpr std::size_t max_lattice_points = std::size_t(64) << 20;  // 64 M points = 256 MB

LevelSet build_level_set(const TriangleMesh& mesh, double spacing, double margin) {
  const MeshQuery q(mesh);
  const BoundingBox b = mesh.bounding_box();
  LevelSet ls;
  ls.h = spacing;
  ls.cap = margin;
  std::size_t total = 1;
  for (int a = 0; a < 3; ++a) {
    ls.n[a] = int(std::ceil((b.hi[a] - b.lo[a] + 2 * margin) / spacing)) + 1;
    ls.n[a] = std::max(ls.n[a], 2);
    // Centred on the box: a part symmetric about a plane of its frame (the body about its x-z plane) gets a
    // lattice symmetric about that plane, so its interpolated level set is symmetric too. Anchored at the box's
    // low corner, the lattice's nodes were offset on one side only, and the mirror-image faces of a symmetric
    // insect saw level sets differing by the interpolation error.
    ls.origin[a] = 0.5 * (b.lo[a] + b.hi[a]) - 0.5 * (ls.n[a] - 1) * spacing;
    total *= std::size_t(ls.n[a]);
    if (total > max_lattice_points)
      throw std::invalid_argument("immersed boundary: the level-set lattice of part '" + mesh.label + "' would exceed " +
                                  std::to_string(max_lattice_points >> 20) + " M points (spacing " + std::to_string(spacing) +
                                  " m over a box of " + std::to_string(b.hi[0] - b.lo[0]) + " x " + std::to_string(b.hi[1] - b.lo[1]) +
                                  " x " + std::to_string(b.hi[2] - b.lo[2]) +
                                  " m); lower lattice_refinement or refine the grid only where the part moves");
  }
  ls.v.assign(total, float(margin));
  std::vector<std::uint8_t> unknown(total, 0);
  const bool closed = !mesh.membrane;
#pragma omp parallel for schedule(dynamic, 1)
  for (int k = 0; k < ls.n[2]; ++k)
    for (int j = 0; j < ls.n[1]; ++j)
      for (int i = 0; i < ls.n[0]; ++i) {
        const Vec3 y = ls.origin + spacing * Vec3(i, j, k);
        const SurfacePoint s = q.closest(y, margin);
        const std::size_t n = ls.index(i, j, k);
        if (!s.found()) {
          unknown[n] = 1;
          continue;
        }
        ls.v[n] = float(closed ? std::clamp(s.signed_distance, -margin, margin) : std::min(s.distance, margin));
      }
  if (closed) {
    // Points beyond the search radius: inside where connected to known inside points (flood fill).
    std::deque<std::size_t> queue;
    for (std::size_t n = 0; n < total; ++n)
      if (!unknown[n] && ls.v[n] < 0) queue.push_back(n);
    const std::size_t sy = std::size_t(ls.n[0]), sz = sy * std::size_t(ls.n[1]);
    while (!queue.empty()) {
      const std::size_t n = queue.front();
      queue.pop_front();
      const std::size_t i = n % sy, j = (n / sy) % std::size_t(ls.n[1]), k = n / sz;
      const std::size_t nb[6] = {i > 0 ? n - 1 : n, i + 1 < sy ? n + 1 : n, j > 0 ? n - sy : n,
                                 j + 1 < std::size_t(ls.n[1]) ? n + sy : n, k > 0 ? n - sz : n,
                                 k + 1 < std::size_t(ls.n[2]) ? n + sz : n};
      for (std::size_t m : nb)
        if (unknown[m]) {
          unknown[m] = 0;
          ls.v[m] = float(-margin);
          queue.push_back(m);
        }
    }
  }
  return ls;
}

// One forced face (or flagged cell): key = component * size + padded index.
struct Entry {
  std::int64_t key;
  float phi;
  std::int16_t part;  // add_part keeps the part count below 2^15; 16 bytes per entry in all
  // Another part at exactly the same level-set value (-1: none): a face on a plane of mirror symmetry between the
  // two wings' bands, forced with the mean of both parts' values and its load shared (force()).
  std::int16_t tie = -1;
};

}  // namespace

// ---------------------------------------------------------------------------------------------------------------

struct ImmersedBoundary::Impl {
  struct Part {
    TriangleMesh mesh;  // reference frame
    PartMotion motion;  // empty: moved by set_parts
    LevelSet ls;
    BoundingBox box;              // reference-frame mesh bounding box
    std::vector<Vec3> centroid;   // per triangle, reference frame
    std::vector<Vec3> normal;     // unit, reference frame
    std::vector<double> area;
  };

  Grid grid;
  ImmersedOptions opt;
  std::vector<Part> parts;
  std::array<std::vector<double>, 3> hface, hcell;  // per axis: width at a face (max of its two cells), at a cell
  Solver* solver = nullptr;
  std::vector<Entry> entries;         // forced faces of the last stage
  std::vector<double> values;         // their new values
  std::vector<std::int64_t> flagged;  // cells flagged in the last stage
  std::vector<Entry> cells;           // their level-set values (key = 3 * size + cell index)
  std::vector<std::uint8_t> forced_bits;  // per cell: bit d set when its lower d-face was forced this stage
  std::vector<PartState> stage_states;    // the parts at the last stage's time
  double stage_time = 0;
  std::vector<PartState> given;           // the kinematics from set_parts, at given_time
  double given_time = std::numeric_limits<double>::quiet_NaN();
  std::size_t n_solid = 0, n_band = 0;
  double last_adt = 0;
  struct Exchange {
    Vec3 force = Vec3::Zero(), moment = Vec3::Zero();  // N, N m about the origin of the grid axes
    double power = 0;                                   // W
  };
  std::vector<Exchange> exchange;  // per part, from the last stage's forcing
  // Over MPI ranks the grid is the solver's window (Solver::hook_grid): the planes this rank owns, and the z range
  // of the surface triangles it integrates (the others' are summed in by the reductions).
  int own_first = 1, own_last = std::numeric_limits<int>::max();
  double own_z_lo = -std::numeric_limits<double>::infinity(), own_z_hi = std::numeric_limits<double>::infinity();
  const Decomposition* dec = nullptr;
  bool owns(double z) const { return z >= own_z_lo && z < own_z_hi; }
  // Element-wise sum over the ranks (nothing on one rank).
  void sum(double* v, int n) const {
    if (dec) dec->sum(v, n);
  }

  Impl(const Grid& g, ImmersedOptions o) : grid(g), opt(o) {
    for (int a = 0; a < 3; ++a) {
      const Axis& ax = grid.axis[std::size_t(a)];
      hcell[std::size_t(a)].assign(std::size_t(ax.n + 2), 0);
      hface[std::size_t(a)].assign(std::size_t(ax.n + 2), 0);
      for (int i = 0; i <= ax.n + 1; ++i) hcell[std::size_t(a)][std::size_t(i)] = ax.dc[std::size_t(i)];
      for (int i = 1; i <= ax.n + 1; ++i)
        hface[std::size_t(a)][std::size_t(i)] = std::max(ax.dc[std::size_t(i) - 1], ax.dc[std::size_t(std::min(i, ax.n + 1))]);
      hface[std::size_t(a)][0] = ax.dc[0];
    }
  }

  // Largest cell width over the cells overlapping a world box (m).
  double max_width(const BoundingBox& b) const {
    double h = 0;
    for (int a = 0; a < 3; ++a) {
      const Axis& ax = grid.axis[std::size_t(a)];
      int f, l;
      index_range(ax.xc, 1, ax.n, b.lo[a], b.hi[a], f, l);
      f = std::max(1, f - 1);
      l = std::min(ax.n, l + 1);
      for (int i = f; i <= l; ++i) h = std::max(h, ax.dc[std::size_t(i)]);
    }
    return h;
  }

  // The level-set value of part p at world point x for a face or cell of local width h (membrane offset).
  double phi(const Part& p, const RigidTransform& pose, const Vec3& x, double h) const {
    const double v = p.ls.at(pose.apply_inverse(x));
    return p.mesh.membrane ? v - opt.membrane_half_thickness * h : v;
  }

  // Collects the faces of component d (d = 3: cell centres) with phi < h_local for every part at time t.
  void collect(int d, const std::vector<PartState>& states, std::vector<Entry>& out) const {
    const Shape s = grid.shape();
    for (std::size_t ip = 0; ip < parts.size(); ++ip) {
      const Part& p = parts[ip];
      const RigidTransform& pose = states[ip].pose;
      const BoundingBox world0 = transformed_box(p.box, pose, 0);
      const double hmax = max_width(world0);
      const double grow = (1.5 + (p.mesh.membrane ? opt.membrane_half_thickness : 0)) * hmax + 2 * p.ls.h;
      const BoundingBox world = transformed_box(p.box, pose, grow);
      int lo[3], hi[3];
      bool empty = false;
      for (int a = 0; a < 3; ++a) {
        const Axis& ax = grid.axis[std::size_t(a)];
        if (a == d) {
          // Normal component: interior faces (boundary faces belong to the box conditions); periodic: 1..n.
          const int first = ax.lower_face_unknown() ? 1 : 2, last = ax.n;
          index_range(ax.xf, first, last, world.lo[a], world.hi[a], lo[a], hi[a]);
        } else {
          index_range(ax.xc, 1, ax.n, world.lo[a], world.hi[a], lo[a], hi[a]);
        }
        if (lo[a] > hi[a]) empty = true;
      }
      if (empty) continue;
      const Axis &X = grid.axis[0], &Y = grid.axis[1], &Z = grid.axis[2];
      const auto& hx = d == 0 ? hface[0] : hcell[0];
      const auto& hy = d == 1 ? hface[1] : hcell[1];
      const auto& hz = d == 2 ? hface[2] : hcell[2];
      const auto& cx = d == 0 ? X.xf : X.xc;
      const auto& cy = d == 1 ? Y.xf : Y.xc;
      const auto& cz = d == 2 ? Z.xf : Z.xc;
      const std::int64_t base = std::int64_t(d) * std::int64_t(s.size());
      const std::size_t ncells = std::size_t(hi[0] - lo[0] + 1) * std::size_t(hi[1] - lo[1] + 1) * std::size_t(hi[2] - lo[2] + 1);
      // Each grid line along x maps to the line b + s e in the part's frame (e = R^T e_x): clip it to the lattice
      // (outside is far fluid), and skip ahead where the level set is far above the band: the trilinear
      // interpolant of a distance field changes by at most sqrt(3) per unit length.
      const Vec3 e = pose.rotation.transpose() * Vec3::UnitX();
      const Vec3 L0 = p.ls.origin, L1 = p.ls.origin + p.ls.h * Vec3(p.ls.n[0] - 1, p.ls.n[1] - 1, p.ls.n[2] - 1);
      double hxmax = 0;
      for (int i = lo[0]; i <= hi[0]; ++i) hxmax = std::max(hxmax, hx[std::size_t(i)]);
      const double thick = p.mesh.membrane ? opt.membrane_half_thickness : 0.0;
      constexpr double inv_sqrt3 = 0.57735026918962576;
#pragma omp parallel if (ncells >= min_parallel_cells)
      {
        std::vector<Entry> mine;
#pragma omp for schedule(dynamic, 1) nowait
        for (int k = lo[2]; k <= hi[2]; ++k)
          for (int j = lo[1]; j <= hi[1]; ++j) {
            const double hjk = std::max(hy[std::size_t(j)], hz[std::size_t(k)]);
            const Vec3 b = pose.apply_inverse(Vec3(0, cy[std::size_t(j)], cz[std::size_t(k)]));
            double s0 = -std::numeric_limits<double>::infinity(), s1 = std::numeric_limits<double>::infinity();
            for (int a = 0; a < 3; ++a) {
              if (std::abs(e[a]) < 1e-12) {
                if (b[a] < L0[a] || b[a] > L1[a]) s0 = 1, s1 = 0;
                continue;
              }
              const double ta = (L0[a] - b[a]) / e[a], tb = (L1[a] - b[a]) / e[a];
              s0 = std::max(s0, std::min(ta, tb));
              s1 = std::min(s1, std::max(ta, tb));
            }
            if (!(s0 <= s1)) continue;
            int i0, i1;
            index_range(cx, lo[0], hi[0], s0, s1, i0, i1);
            const double T = (1 + thick) * std::max(hjk, hxmax);  // above this raw value: no band anywhere near
            for (int i = i0; i <= i1; ++i) {
              const double h = std::max(hjk, hx[std::size_t(i)]);
              const double r = p.ls.at(b + cx[std::size_t(i)] * e);
              const double ph = r - thick * h;
              if (ph < h) {
                mine.push_back({base + s(i, j, k), float(ph), std::int16_t(ip)});
              } else if (r > T) {
                const double stop = cx[std::size_t(i)] + (r - T) * inv_sqrt3;
                while (i < i1 && cx[std::size_t(i) + 1] < stop) ++i;
              }
            }
          }
#pragma omp critical(flapstab_ib_collect)
        out.insert(out.end(), mine.begin(), mine.end());
      }
    }
    // Overlapping parts: a face solid in any part is solid (deepest part), band faces take the nearest part. Where
    // two parts are equally near (the float values equal: a y-face on the mirror plane between a symmetric
    // insect's wing bands), the face keeps the lower-numbered part and notes the other as its tie, so the choice
    // does not depend on the order of the parts (force() uses both). Without it the first part's value was taken,
    // and the mirror plane's normal velocity was not zero: the left and right wings' loads differed by percent
    // on a coarse grid, and by another percent with the parts in the other order.
    if (parts.size() > 1) {
      std::sort(out.begin(), out.end(), [](const Entry& a, const Entry& b) {
        return a.key < b.key || (a.key == b.key && (a.phi < b.phi || (a.phi == b.phi && a.part < b.part)));
      });
      std::size_t w = 0;
      for (std::size_t r = 0; r < out.size(); ++r) {
        if (w > 0 && out[w - 1].key == out[r].key) {
          if (out[w - 1].tie < 0 && out[r].phi == out[w - 1].phi && out[r].part != out[w - 1].part) out[w - 1].tie = out[r].part;
          continue;
        }
        out[w++] = out[r];
      }
      out.resize(w);
    }
  }

  // The kinematics of every part at time t: the values set for t (set_parts), else the closures with their
  // accelerations by central differences of the material points' velocity (step eps).
  static bool same_time(double a, double b) { return std::abs(a - b) <= 1e-12 * std::max(1.0, std::abs(a)); }
  PartState state_of(std::size_t ip, double t, double eps) const {
    if (!given.empty() && same_time(t, given_time)) return given[ip];
    const Part& p = parts[ip];
    if (!p.motion)
      throw std::logic_error("immersed boundary: part '" + p.mesh.label + "' has no kinematics for t = " +
                             std::to_string(t) + " (call set_parts at every stage time)");
    PartState st = p.motion(t);
    const PartState sp = p.motion(t + eps), sm = p.motion(t - eps);
    const Vec3 y = st.pose.apply_inverse(st.velocity.centre);
    st.acceleration = (sp.velocity.at(sp.pose.apply(y)) - sm.velocity.at(sm.pose.apply(y))) / (2 * eps);
    st.angular_acceleration = (sp.velocity.omega - sm.velocity.omega) / (2 * eps);
    return st;
  }
  std::vector<PartState> states_at(double t, double eps) const {
    std::vector<PartState> st;
    st.reserve(parts.size());
    for (std::size_t ip = 0; ip < parts.size(); ++ip) st.push_back(state_of(ip, t, eps));
    return st;
  }
  // The parts at the solver's time t: the last stage's (its end is the step's end), or sampled.
  std::vector<PartState> states_now(double t) const {
    if (stage_states.size() == parts.size() && same_time(t, stage_time)) return stage_states;
    return states_at(t, last_adt > 0 ? 0.05 * last_adt : 1e-6 * std::max(1.0, std::abs(t)));
  }

  // Whether x lies in the band (or the inside) of a part other than `self`: within one local width h of its
  // effective surface (membranes: the mid-surface less their half thickness).
  bool near_other_part(const std::vector<PartState>& states, std::size_t self, const Vec3& x, double h) const {
    for (std::size_t k = 0; k < parts.size(); ++k) {
      if (k == self) continue;
      const Part& q = parts[k];
      const double thick = q.mesh.membrane ? opt.membrane_half_thickness : 0.0;
      if (q.ls.at(states[k].pose.apply_inverse(x)) - thick * h < h) return true;
    }
    return false;
  }

  // The nearest effective surface of the parts other than `self` seen from x (a face of local width h): the
  // distance phi to it (membranes: less their half thickness; negative inside) and the d-component of that
  // surface's velocity at the point nearest x. Parts whose surfaces are equally near (within 1e-9 h: a face on
  // a plane of mirror symmetry between the two wings' roots) share the velocity equally, so the choice does not
  // depend on the order of the parts and a mirror-symmetric flow stays symmetric. false if no other part's
  // lattice gives a direction there.
  bool nearest_other_surface(const std::vector<PartState>& states, std::size_t self, const Vec3& x, double h, int d,
                             double& phi_out, double& velocity_out) const {
    // Running mean over the parts within the tie window of the nearest so far (no allocation: called per contact face).
    double best = std::numeric_limits<double>::infinity(), sum = 0;
    int count = 0;
    const double window = 1e-9 * h;
    for (std::size_t k = 0; k < parts.size(); ++k) {
      if (k == self) continue;
      const Part& q = parts[k];
      const Vec3 y = states[k].pose.apply_inverse(x);
      const double v = q.ls.at(y) - (q.mesh.membrane ? opt.membrane_half_thickness * h : 0.0);
      if (v > best + window) continue;
      const Vec3 g = states[k].pose.rotation * q.ls.gradient(y);
      if (!(g.norm() > 1e-6)) continue;
      const double u = states[k].velocity.at(x - v * g.normalized())[d];
      if (v < best - window) sum = u, count = 1;  // a clearly nearer part starts the mean again
      else sum += u, ++count;
      best = std::min(best, v);
    }
    if (count == 0) return false;
    phi_out = best;
    velocity_out = sum / count;
    return true;
  }

  // Decodes an entry's component and indices.
  void decode(std::int64_t key, int& d, int& i, int& j, int& k) const {
    const Shape s = grid.shape();
    d = int(key / std::int64_t(s.size()));
    std::int64_t n = key % std::int64_t(s.size());
    k = int(n / s.sz);
    n -= std::int64_t(k) * s.sz;
    j = int(n / s.sy);
    i = int(n - std::int64_t(j) * s.sy);
  }

  double face_width(int d, int i, int j, int k) const {
    const int I[3] = {i, j, k};
    double h = 0;
    for (int a = 0; a < 3; ++a) h = std::max(h, (a == d ? hface : hcell)[std::size_t(a)][std::size_t(I[a])]);
    return h;
  }

  void mark_flags(const std::vector<PartState>& states) {
    if (!solver) return;
    auto& flags = solver->flags();
    for (std::int64_t n : flagged) flags[std::size_t(n)] = CellFlag::fluid;
    flagged.clear();
    cells.clear();
    collect(3, states, cells);
    const std::int64_t base = 3 * std::int64_t(grid.shape().size());
    for (const Entry& e : cells) {
      const std::int64_t n = e.key - base;
      flags[std::size_t(n)] = e.phi < 0 ? CellFlag::solid : CellFlag::ghost;
      flagged.push_back(n);
    }
  }

  void force(VectorField& ustar, double t, double adt) {
    const std::vector<PartState> states = states_at(t, 0.05 * adt);
    entries.clear();
    for (int d = 0; d < 3; ++d) collect(d, states, entries);
    values.resize(entries.size());
    const Shape s = grid.shape();
    std::size_t solid = 0;
    // The forced value of entry e's face as part `ip` sees it (a tied face asks both of its parts).
    const auto forced_value = [&](const Entry& e, std::size_t ip) -> double {
      int d, i, j, k;
      decode(e.key, d, i, j, k);
      const auto xp = grid.point(d, i, j, k);
      const Vec3 x(xp[0], xp[1], xp[2]);
      const PartState& st = states[ip];
      if (e.phi < 0) return st.velocity.at(x)[d];
      const Part& p = parts[ip];
      const double h = face_width(d, i, j, k);
      Vec3 n = st.pose.rotation * p.ls.gradient(st.pose.apply_inverse(x));
      const double norm = n.norm();
      if (!(norm > 1e-6)) return st.velocity.at(x)[d];  // no direction (medial point): treat as solid
      n /= norm;
      const double ph = e.phi;
      const double vs = st.velocity.at(x - ph * n)[d];
      // Quadratic along the normal through the surface point (part velocity) and two probes in the fluid at
      // probe_near and probe_far local widths beyond the face (Balaras 2004): closer to the near-wall profile
      // than the linear law, so a face entering or leaving the band sees a smaller jump.
      const double d1 = opt.probe_near * h, d2 = opt.probe_far * h;
      const double u1 = sample(grid, ustar[d], d, x + d1 * n), u2 = sample(grid, ustar[d], d, x + d2 * n);
      const double p1 = ph + d1, p2 = ph + d2;  // probe distances from the surface
      const double l0 = (ph - p1) * (ph - p2) / (p1 * p2), l1 = ph * (ph - p2) / (p1 * (p1 - p2)),
                   l2 = ph * (ph - p1) / (p2 * (p2 - p1));
      double value = l0 * vs + l1 * u1 + l2 * u2;
      // Where a probe reaches into another part's band (a wing root sweeping past the body), the probes of the two
      // parts' bands sample each other's forced faces, so whatever one forcing sets is read back by the other,
      // stage after stage through this Jacobi update; the quadratic can also overshoot the values it interpolates.
      // Unbounded, the fruit fly at 8 cells per chord blew up in its fourth wingbeat at the wing root (CFL 0.65 to
      // 1.73 within 13 steps); bounded by the three values, later in other runs (docs/validation.md). The gap
      // treatment reads no fluid value there: the face takes the linear profile between the two surfaces.
      if (opt.contact != ImmersedOptions::Contact::quadratic && parts.size() > 1 &&
          (near_other_part(states, ip, x + d1 * n, h) || near_other_part(states, ip, x + d2 * n, h))) {
        double phq = 0, vq = 0;
        if (opt.contact == ImmersedOptions::Contact::gap && nearest_other_surface(states, ip, x, h, d, phq, vq)) {
          phq = std::max(phq, 0.0);
          value = ph + phq > 0 ? (phq * vs + ph * vq) / (ph + phq) : 0.5 * (vs + vq);
        } else {
          value = std::clamp(value, std::min({vs, u1, u2}), std::max({vs, u1, u2}));
        }
      }
      return value;
    };
    // Jacobi: every new value from the predicted field before any forcing of this stage.
#pragma omp parallel for schedule(static) reduction(+ : solid) if (entries.size() >= 4096)
    for (std::size_t m = 0; m < entries.size(); ++m) {
      const Entry& e = entries[m];
      values[m] = e.tie < 0 ? forced_value(e, std::size_t(e.part))
                            : 0.5 * (forced_value(e, std::size_t(e.part)) + forced_value(e, std::size_t(e.tie)));
      if (e.phi < 0) ++solid;
    }
    // Momentum exchange (Uhlmann 2005): the forcing adds rho (u_forced - u*) dV per stage of length alpha dt to
    // the fluid; the fictitious fluid inside a part (solid faces) is accelerated with the part, which takes
    // rho a dV of that. The fluid's force on the part is therefore -sum rho (u_forced - u*) dV / (alpha dt) over
    // all forced faces + sum over solid faces of rho a dV.
    exchange.assign(parts.size(), Exchange{});
    // Keys are unique (one entry per face), so the write-back runs in parallel; the sums are per thread.
#pragma omp parallel if (entries.size() >= 4096)
    {
      std::vector<Exchange> mine(parts.size());
#pragma omp for schedule(static) nowait
    for (std::size_t m = 0; m < entries.size(); ++m) {
      int d, i, j, k;
      decode(entries[m].key, d, i, j, k);
      real& u = ustar[d][std::ptrdiff_t(entries[m].key % std::int64_t(s.size()))];
      double vol = 1;
      const int I[3] = {i, j, k};
      for (int a = 0; a < 3; ++a) vol *= a == d ? grid.axis[std::size_t(a)].dv[std::size_t(I[a])] : grid.axis[std::size_t(a)].dc[std::size_t(I[a])];
      const auto xp = grid.point(d, i, j, k);
      const Vec3 x(xp[0], xp[1], xp[2]);
      // A tied face's load goes half to each of its two parts; over ranks, a face of the window's overlap is summed
      // by the rank that owns it.
      const bool tied = entries[m].tie >= 0;
      const bool own = I[2] >= own_first && I[2] <= own_last;
      for (int share = 0; share < (tied ? 2 : 1) && own; ++share) {
        const std::size_t ip = std::size_t(share == 0 ? entries[m].part : entries[m].tie);
        const double weight = tied ? 0.5 : 1.0;
        const PartState& st = states[ip];
        double f = -weight * opt.density * (values[m] - u) * vol / adt;  // d-component of the force on the part (N)
        if (entries[m].phi < 0) f += weight * opt.density * vol * st.acceleration_at(x)[d];
        Vec3 F = Vec3::Zero();
        F[d] = f;
        Exchange& e = mine[ip];
        e.force += F;
        e.moment += x.cross(F);
        e.power -= F.dot(st.velocity.at(x));
      }
      u = values[m];
      // A periodic axis: face n+1 is face 1's image (the divergence of cell n reads it).
      const Axis& ax = grid.axis[std::size_t(d)];
      if (ax.periodic && I[d] == 1) ustar[d][std::ptrdiff_t(entries[m].key % std::int64_t(s.size())) + ax.n * s.stride(d)] = values[m];
    }
#pragma omp critical(flapstab_ib_exchange)
      for (std::size_t ip = 0; ip < parts.size(); ++ip) {
        exchange[ip].force += mine[ip].force;
        exchange[ip].moment += mine[ip].moment;
        exchange[ip].power += mine[ip].power;
      }
    }
    n_solid = solid;
    n_band = entries.size() - solid;
    mark_flags(states);
    stage_states = states;
    stage_time = t;
  }

  // The pressure of a cell whose six faces are all forced never enters the fluid's momentum, and the projections
  // keep adding to it (it would grow linearly in time inside a part). When a moving part uncovers such a cell, its
  // pressure would enter the fluid suddenly: a force spike. So after each projection those cells take the fluid
  // pressure extended along the normal with the wall-normal momentum balance dp/dn = -a.n: p(x) = p(x_probe) +
  // (distance to the probe) a.n, the probe probe_near local widths outside the surface. Only cells within 2
  // local widths of the surface are extended (the deeper interior keeps a drifting, unused pressure).
  void extend_pressure(Field& p) {
    if (cells.empty() || stage_states.size() != parts.size()) return;
    const Shape s = grid.shape();
    forced_bits.resize(s.size(), 0);
    // The face of component d at index I, and on a periodic axis d face n+1 as the image of face 1 (the upper face
    // of the last cell): without it no cell of the last layer would ever count as fully forced.
    const auto for_face_and_image = [&](const Entry& e, auto&& visit) {
      const std::int64_t d = e.key / std::int64_t(s.size()), at = e.key % std::int64_t(s.size());
      visit(std::size_t(at), d);
      const Axis& ax = grid.axis[std::size_t(d)];
      if (!ax.periodic) return;
      int dd, i, j, k;
      decode(e.key, dd, i, j, k);
      const int I[3] = {i, j, k};
      if (I[d] == 1) visit(std::size_t(at + std::int64_t(ax.n) * s.stride(int(d))), d);
    };
    for (const Entry& e : entries)
      for_face_and_image(e, [&](std::size_t at, std::int64_t d) { forced_bits[at] |= std::uint8_t(1u << d); });
    const std::int64_t base = 3 * std::int64_t(s.size());
    std::vector<double> newp(cells.size(), std::numeric_limits<double>::quiet_NaN());
#pragma omp parallel for schedule(static) if (cells.size() >= 4096)
    for (std::size_t m = 0; m < cells.size(); ++m) {
      const std::ptrdiff_t n = std::ptrdiff_t(cells[m].key - base);
      // Cells deeper than 2 local widths cannot be uncovered within a stage (CFL < 1); they are extended on
      // their way out.
      if (cells[m].phi < -2 * std::max({hcell[0][std::size_t(n % s.sy)], hcell[1][std::size_t((n / s.sy) % (s.ny + 2))],
                                         hcell[2][std::size_t(n / s.sz)]}))
        continue;
      const auto all = [&](std::ptrdiff_t c, int d) { return (forced_bits[std::size_t(c)] >> d) & 1u; };
      if (!(all(n, 0) && all(n + 1, 0) && all(n, 1) && all(n + s.sy, 1) && all(n, 2) && all(n + s.sz, 2))) continue;
      const int k = int(n / s.sz), j = int((n - std::ptrdiff_t(k) * s.sz) / s.sy), i = int(n - std::ptrdiff_t(k) * s.sz - std::ptrdiff_t(j) * s.sy);
      const std::size_t ip = std::size_t(cells[m].part);
      const Part& q = parts[ip];
      const PartState& st = stage_states[ip];
      const auto xc = grid.centre(i, j, k);
      const Vec3 x(xc[0], xc[1], xc[2]);
      const double h = std::max({hcell[0][std::size_t(i)], hcell[1][std::size_t(j)], hcell[2][std::size_t(k)]});
      const Vec3 y = st.pose.apply_inverse(x);
      Vec3 nrm = st.pose.rotation * q.ls.gradient(y);
      if (!(nrm.norm() > 1e-6)) continue;  // deep inside (beyond the lattice's cap): never near the fluid
      nrm.normalize();
      const double dist = opt.probe_near * h - double(cells[m].phi);  // from the cell centre to the probe
      const Vec3 probe = x + dist * nrm;
      const Vec3 a = st.acceleration_at(x);
      newp[m] = sample_fluid_pressure(p, stage_states, ip, probe) + dist * a.dot(nrm);
    }
    for (std::size_t m = 0; m < cells.size(); ++m)
      if (!std::isnan(newp[m])) p[std::ptrdiff_t(cells[m].key - base)] = newp[m];
    for (const Entry& e : entries) for_face_and_image(e, [&](std::size_t at, std::int64_t) { forced_bits[at] = 0; });
  }

  // Trilinear interpolation of the pressure at x from the fluid cells only (weights renormalised). The pressure of a cell whose faces are all forced is not physical: the forcing
  // resets those faces every stage, so the projections keep adding to it (it grows linearly in time where
  // mass leaks through the interface, see the theory notes); it never enters the fluid's momentum but must
  // not enter the loads.
  // Parts in contact (contact != quadratic): a cell inside or near another part (its interior pressure is as
  // unphysical as this part's) counts by the lowest of the parts' level sets, so a probe near the wing root that
  // falls into the body reads the fluid's pressure only.
  double sample_fluid_pressure(const Field& pr, const std::vector<PartState>& states, std::size_t ip, const Vec3& x) const {
    const Part& part = parts[ip];
    const RigidTransform& pose = states[ip].pose;
    const bool all_parts = opt.contact != ImmersedOptions::Contact::quadratic && parts.size() > 1;
    int I[3];
    double W[3];
    for (int a = 0; a < 3; ++a) {
      const Axis& ax = grid.axis[std::size_t(a)];
      bracket(ax.xc, 0, ax.n + 1, x[a], I[a], W[a]);
    }
    double v = 0, wsum = 0;
    for (int c = 0; c < 8; ++c) {
      const int dx = c & 1, dy = (c >> 1) & 1, dz = (c >> 2) & 1;
      const double w = (dx ? W[0] : 1 - W[0]) * (dy ? W[1] : 1 - W[1]) * (dz ? W[2] : 1 - W[2]);
      if (w == 0) continue;
      const int i = I[0] + dx, j = I[1] + dy, k = I[2] + dz;
      const auto xc = grid.centre(i, j, k);
      const double h = std::max({hcell[0][std::size_t(i)], hcell[1][std::size_t(j)], hcell[2][std::size_t(k)]});
      // Weight ramps from 0 at phi = 0.75 h (below it a cell can have all its faces forced) to 1 at 1.5 h, so
      // that the sample changes smoothly as a moving part crosses the cells.
      const Vec3 X(xc[0], xc[1], xc[2]);
      double ph = phi(part, pose, X, h);
      if (all_parts)
        for (std::size_t k = 0; k < parts.size(); ++k)
          if (k != ip) ph = std::min(ph, phi(parts[k], states[k].pose, X, h));
      const double m = std::clamp((ph - 0.75 * h) / (0.75 * h), 0.0, 1.0);
      v += m * w * pr(i, j, k);
      wsum += m * w;
    }
    return wsum > 0 ? v / wsum : sample(grid, pr, -1, x);
  }


  // Visits every triangle and wetted side of part ip at the solver's time: (triangle, side, surface point,
  // side normal, area, kinematic wall pressure, viscous traction per unit nu, wall velocity).
  template <class F>
  void visit(const Solver& sv, int ip, F&& f) const {
    const Part& p = parts[std::size_t(ip)];
    const std::vector<PartState> states = states_now(sv.time());
    const PartState& st = states[std::size_t(ip)];
    const VectorField& u = sv.hook_velocity();
    const Field& pr = sv.hook_pressure();
    const int sides = p.mesh.membrane ? 2 : 1;
    for (std::size_t tri = 0; tri < p.centroid.size(); ++tri) {
      const Vec3 x = st.pose.apply(p.centroid[tri]);
      if (!owns(x.z())) continue;  // another rank's triangle
      const Vec3 n = st.pose.rotation * p.normal[tri];
      const double h = local_width(grid, x);
      const Vec3 a = st.acceleration_at(x);
      for (int side = 0; side < sides; ++side) {
        const Vec3 ns = side == 0 ? n : Vec3(-n);
        const Vec3 xs = p.mesh.membrane ? Vec3(x + opt.membrane_half_thickness * h * ns) : x;  // effective surface
        const double d1 = opt.probe_near * h, d2 = opt.probe_far * h;
        const Vec3 x1 = xs + d1 * ns, x2 = xs + d2 * ns;
        // Wall pressure: the quadratic through the two probes with the wall-normal momentum balance
        // dp/dn = -a.n (kinematic) at the wall, p(d) = p_w - (a.n) d + c d^2.
        const double p1 = sample_fluid_pressure(pr, states, std::size_t(ip), x1),
                     p2 = sample_fluid_pressure(pr, states, std::size_t(ip), x2);
        const double slope = -a.dot(ns);
        const double curv = ((p2 - p1) - slope * (d2 - d1)) / (d2 * d2 - d1 * d1);
        const double pwall = p1 - slope * d1 - curv * d1 * d1;
        Vec3 w1, w2;
        const Vec3 v1 = st.velocity.at(x1), v2 = st.velocity.at(x2);
        for (int d = 0; d < 3; ++d) {
          w1[d] = sample(grid, u[d], d, x1) - v1[d];
          w2[d] = sample(grid, u[d], d, x2) - v2[d];
        }
        const Vec3 g = (d2 * d2 * w1 - d1 * d1 * w2) / (d1 * d2 * (d2 - d1));
        f(tri, side, x, ns, p.area[tri], pwall, g, st.velocity.at(x));
      }
    }
  }
};

PartMotion fixed_part(const RigidTransform& pose) {
  return [pose](double) { return PartState{pose, RigidVelocity{pose.translation, Vec3::Zero(), Vec3::Zero()}}; };
}

ImmersedBoundary::ImmersedBoundary(const Grid& grid, ImmersedOptions options)
    : impl_(std::make_unique<Impl>(grid, options)) {
  const auto& o = impl_->opt;
  if (!(o.density > 0) || !(o.lattice_refinement > 0) || !(o.membrane_half_thickness > 0) || !(o.probe_near > 0) ||
      !(o.probe_far > o.probe_near))
    throw std::invalid_argument("immersed boundary: need density > 0, lattice_refinement > 0, membrane_half_thickness > 0 and 0 < probe_near < probe_far");
}

ImmersedBoundary::~ImmersedBoundary() = default;

int ImmersedBoundary::add_part(TriangleMesh reference, PartMotion motion) {
  if (!motion) throw std::invalid_argument("immersed boundary: part '" + reference.label + "' has no motion");
  const PartState s0 = motion(0.0);
  const int i = add_part(std::move(reference), s0);
  impl_->parts.back().motion = std::move(motion);
  return i;
}

int ImmersedBoundary::add_part(TriangleMesh reference, const PartState& s0) {
  reference.check();
  if (reference.size() == 0) throw std::invalid_argument("immersed boundary: part '" + reference.label + "' has no triangles");
  if (!reference.membrane && reference.open_or_inconsistent_edges() != 0)
    throw std::invalid_argument("immersed boundary: closed part '" + reference.label +
                                "' has open or inconsistently oriented edges (load it as a membrane)");
  Impl& m = *impl_;
  Impl::Part p;
  p.box = reference.bounding_box();
  // Lattice spacing: the finest grid spacing over the refinement; margin (probe_far + 2) local widths, the local
  // width taken where the part starts (t = 0).
  double hmin = std::numeric_limits<double>::infinity();
  for (const Axis& ax : m.grid.axis) hmin = std::min(hmin, ax.min_width());
  const double href = m.max_width(transformed_box(p.box, s0.pose, 0));
  const double spacing = hmin / m.opt.lattice_refinement;
  const double margin = (m.opt.probe_far + 2 + (reference.membrane ? m.opt.membrane_half_thickness : 0)) * href;
  p.ls = build_level_set(reference, spacing, margin);
  p.centroid.resize(reference.size());
  p.normal.resize(reference.size());
  p.area.resize(reference.size());
  for (std::size_t t = 0; t < reference.size(); ++t) {
    p.centroid[t] = (reference.vertex(t, 0) + reference.vertex(t, 1) + reference.vertex(t, 2)) / 3;
    const Vec3 av = reference.area_vector(t);
    p.area[t] = av.norm();
    p.normal[t] = av / p.area[t];
  }
  p.mesh = std::move(reference);
  if (m.parts.size() >= std::size_t(INT16_MAX)) throw std::invalid_argument("immersed boundary: too many parts");
  m.parts.push_back(std::move(p));
  return int(m.parts.size()) - 1;
}

std::size_t ImmersedBoundary::parts() const { return impl_->parts.size(); }
const std::string& ImmersedBoundary::label(int part) const { return impl_->parts.at(std::size_t(part)).mesh.label; }
PartState ImmersedBoundary::state(int part, double t) const {
  impl_->parts.at(std::size_t(part));
  return impl_->states_now(t)[std::size_t(part)];
}

void ImmersedBoundary::set_parts(double t, const std::vector<PartState>& states) {
  if (states.size() != impl_->parts.size())
    throw std::invalid_argument("immersed boundary: set_parts got " + std::to_string(states.size()) +
                                " part states for " + std::to_string(impl_->parts.size()) + " parts");
  impl_->given = states;
  impl_->given_time = t;
}

TriangleMesh ImmersedBoundary::surface(int part, double t) const {
  const auto& p = impl_->parts.at(std::size_t(part));
  return p.mesh.transformed(state(part, t).pose);
}

TriangleMesh ImmersedBoundary::surface(int part, const PartState& state) const {
  return impl_->parts.at(std::size_t(part)).mesh.transformed(state.pose);
}

BoundingBox ImmersedBoundary::bounding_box(int part, double t) const {
  const auto& p = impl_->parts.at(std::size_t(part));
  return transformed_box(p.box, state(part, t).pose, 0);
}

double ImmersedBoundary::level_set(int part, double t, const Vec3& x) const {
  const auto& p = impl_->parts.at(std::size_t(part));
  return p.ls.at(state(part, t).pose.apply_inverse(x));
}

double ImmersedBoundary::solid_level_set(int part, const PartState& st, const Vec3& x, double h) const {
  return impl_->phi(impl_->parts.at(std::size_t(part)), st.pose, x, h);
}

std::vector<double> ImmersedBoundary::solid_mask(double t) const {
  std::vector<PartState> states;
  for (std::size_t n = 0; n < impl_->parts.size(); ++n) states.push_back(state(int(n), t));
  const std::vector<int> owners = cell_owners(states);
  std::vector<double> mask(owners.size(), 0.0);
  for (std::size_t c = 0; c < owners.size(); ++c) mask[c] = owners[c] >= 0 ? 1.0 : 0.0;
  return mask;
}

std::vector<int> ImmersedBoundary::cell_owners(const std::vector<PartState>& states, double reach) const {
  if (states.size() != impl_->parts.size())
    throw std::invalid_argument("immersed boundary: cell_owners got " + std::to_string(states.size()) +
                                " part states for " + std::to_string(impl_->parts.size()) + " parts");
  const Shape sh = impl_->grid.shape();
  const std::size_t cells = std::size_t(sh.nx) * sh.ny * sh.nz;
  std::vector<int> owner(cells, -1);
  std::vector<double> lowest(cells, 0.0);
  const Grid& g = impl_->grid;
  for (std::size_t n = 0; n < impl_->parts.size(); ++n) {
    const auto& p = impl_->parts[n];
    const RigidTransform& pose = states[n].pose;
    BoundingBox b = transformed_box(p.box, pose, 0);
    const double thick = p.mesh.membrane ? impl_->opt.membrane_half_thickness : 0.0;
    if (p.mesh.membrane || reach > 0) b = transformed_box(p.box, pose, (thick + 1 + reach) * impl_->max_width(b));
    int lo[3], hi[3];
    for (int a = 0; a < 3; ++a) index_range(g.axis[a].xc, 1, g.axis[a].n, b.lo[a], b.hi[a], lo[a], hi[a]);
#pragma omp parallel for schedule(static)
    for (int k = lo[2]; k <= hi[2]; ++k)
      for (int j = lo[1]; j <= hi[1]; ++j)
        for (int i = lo[0]; i <= hi[0]; ++i) {
          const Vec3 x(g.axis[0].xc[std::size_t(i)], g.axis[1].xc[std::size_t(j)], g.axis[2].xc[std::size_t(k)]);
          const double h = std::max({g.axis[0].dc[std::size_t(i)], g.axis[1].dc[std::size_t(j)], g.axis[2].dc[std::size_t(k)]});
          const double v = impl_->phi(p, pose, x, h);
          const std::size_t c = (std::size_t(k - 1) * sh.ny + std::size_t(j - 1)) * sh.nx + std::size_t(i - 1);
          if (v < reach * h && (owner[c] < 0 || v < lowest[c])) {
            owner[c] = int(n);
            lowest[c] = v;
          }
        }
  }
  return owner;
}

void ImmersedBoundary::attach(Solver& solver) {
  if (!(solver.hook_grid().shape() == impl_->grid.shape()))
    throw std::invalid_argument("immersed boundary: the solver's grid is not the one the boundary was built on (over "
                                "MPI ranks: build it on solver.hook_grid())");
  impl_->solver = &solver;
  solver.attach(this);
  if (solver.decomposition().distributed()) {
    Impl& m = *impl_;
    const Axis& z = m.grid.axis[2];
    m.dec = &solver.decomposition();
    m.own_first = solver.hook_first_plane();
    m.own_last = solver.hook_last_plane();
    if (solver.slab().cut_lo) m.own_z_lo = z.xf[std::size_t(m.own_first)];
    if (solver.slab().cut_hi) m.own_z_hi = z.xf[std::size_t(m.own_last + 1)];
  }
  impl_->mark_flags(impl_->states_now(solver.time()));
}

void ImmersedBoundary::after_predictor(VectorField& ustar, double t, double alpha_dt) {
  impl_->last_adt = alpha_dt;
  impl_->force(ustar, t, alpha_dt);
}

void ImmersedBoundary::after_projection(VectorField&, Field& p, double) { impl_->extend_pressure(p); }

std::vector<PartLoads> ImmersedBoundary::loads(const Solver& solver, const Vec3& moment_point) const {
  const Impl& m = *impl_;
  const double rho = m.opt.density, nu = solver.options().nu;
  std::vector<PartLoads> out(m.parts.size());
  for (std::size_t ip = 0; ip < m.parts.size(); ++ip) {
    PartLoads& L = out[ip];
    L.label = m.parts[ip].mesh.label;
    m.visit(solver, int(ip), [&](std::size_t, int, const Vec3& x, const Vec3& ns, double A, double pw, const Vec3& g, const Vec3& V) {
      const Vec3 fp = -rho * A * pw * ns, fv = rho * A * nu * g;
      const Vec3 r = x - moment_point;
      L.pressure_force += fp;
      L.viscous_force += fv;
      L.pressure_moment += r.cross(fp);
      L.viscous_moment += r.cross(fv);
      L.power -= (fp + fv).dot(V);
    });
    double v[13] = {L.pressure_force.x(),  L.pressure_force.y(),  L.pressure_force.z(),  L.viscous_force.x(),
                    L.viscous_force.y(),   L.viscous_force.z(),   L.pressure_moment.x(), L.pressure_moment.y(),
                    L.pressure_moment.z(), L.viscous_moment.x(),  L.viscous_moment.y(),  L.viscous_moment.z(),
                    L.power};
    m.sum(v, 13);
    L.pressure_force = Vec3(v[0], v[1], v[2]);
    L.viscous_force = Vec3(v[3], v[4], v[5]);
    L.pressure_moment = Vec3(v[6], v[7], v[8]);
    L.viscous_moment = Vec3(v[9], v[10], v[11]);
    L.power = v[12];
  }
  return out;
}

SurfacePressure ImmersedBoundary::surface_pressure(const Solver& solver, int part) const {
  const Impl& m = *impl_;
  const auto& p = m.parts.at(std::size_t(part));
  // Far-field reference: the volume-weighted mean pressure of the cells along the box's faces.
  const Grid& g = m.grid;
  const Shape s = g.shape();
  const Field& pr = solver.hook_pressure();
  double sum = 0, vol = 0;
  for (int k = std::max(1, m.own_first); k <= std::min(s.nz, m.own_last); ++k)
    for (int j = 1; j <= s.ny; ++j)
      for (int i = 1; i <= s.nx; ++i) {
        if (!(i == 1 || i == s.nx || j == 1 || j == s.ny || k == 1 || k == s.nz)) {
          i = s.nx - 1;  // skip the interior of this line
          continue;
        }
        const double v = g.volume(i, j, k);
        sum += v * pr(i, j, k);
        vol += v;
      }
  double sv[2] = {sum, vol};
  m.sum(sv, 2);
  sum = sv[0];
  vol = sv[1];
  const double pfar = vol > 0 ? sum / vol : 0;
  SurfacePressure out;
  out.front.assign(p.mesh.size(), 0);
  if (p.mesh.membrane) out.back.assign(p.mesh.size(), 0);
  m.visit(solver, part, [&](std::size_t tri, int side, const Vec3&, const Vec3&, double, double pw, const Vec3&, const Vec3&) {
    (side == 0 ? out.front : out.back)[tri] = m.opt.density * (pw - pfar);
  });
  m.sum(out.front.data(), int(out.front.size()));  // each triangle from the rank that owns it, zero elsewhere
  if (!out.back.empty()) m.sum(out.back.data(), int(out.back.size()));
  return out;
}

std::vector<PartLoads> ImmersedBoundary::exchange_loads(const Solver& solver, const Vec3& moment_point) const {
  std::vector<PartLoads> out = loads(solver, moment_point);
  const auto& ex = impl_->exchange;
  for (std::size_t ip = 0; ip < out.size(); ++ip) {
    PartLoads& L = out[ip];
    Impl::Exchange e = ip < ex.size() ? ex[ip] : Impl::Exchange{};
    double v[7] = {e.force.x(), e.force.y(), e.force.z(), e.moment.x(), e.moment.y(), e.moment.z(), e.power};
    impl_->sum(v, 7);
    e.force = Vec3(v[0], v[1], v[2]);
    e.moment = Vec3(v[3], v[4], v[5]);
    e.power = v[6];
    const Vec3 moment = e.moment - moment_point.cross(e.force);
    // viscous part from the surface integral; the rest of the exchanged momentum is the pressure part
    L.pressure_force = e.force - L.viscous_force;
    L.pressure_moment = moment - L.viscous_moment;
    L.power = e.power;
  }
  return out;
}

std::size_t ImmersedBoundary::solid_faces() const { return impl_->n_solid; }
std::size_t ImmersedBoundary::band_faces() const { return impl_->n_band; }

std::size_t ImmersedBoundary::bytes() const {
  std::size_t b = sizeof(Impl);
  for (const auto& p : impl_->parts)
    b += p.ls.v.capacity() * sizeof(float) + p.mesh.vertices.capacity() * sizeof(Vec3) +
         p.mesh.triangles.capacity() * sizeof(std::array<int, 3>) + p.centroid.capacity() * 2 * sizeof(Vec3) +
         p.area.capacity() * sizeof(double);
  b += impl_->entries.capacity() * sizeof(Entry) + impl_->values.capacity() * sizeof(double) +
       impl_->flagged.capacity() * sizeof(std::int64_t);
  return b;
}

}  // namespace flapstab::ns
