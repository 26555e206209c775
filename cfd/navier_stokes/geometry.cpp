// Triangle meshes: integrals, rigid motion, welding, and the ellipsoid / wing / insect generators.
#include "cfd/navier_stokes/geometry.hpp"
#include <algorithm>
#include <cmath>
#include <cstdint>
#include <map>
#include <stdexcept>
#include <unordered_map>

namespace flapstab::ns {

Vec3 TriangleMesh::area_vector(std::size_t tri) const {
  const Vec3 &a = vertex(tri, 0), &b = vertex(tri, 1), &c = vertex(tri, 2);
  return 0.5 * (b - a).cross(c - a);
}

double TriangleMesh::area() const {
  double s = 0;
  for (std::size_t t = 0; t < size(); ++t) s += area_vector(t).norm();
  return s;
}

Vec3 TriangleMesh::surface_centroid() const {
  Vec3 m = Vec3::Zero();
  double s = 0;
  for (std::size_t t = 0; t < size(); ++t) {
    const double a = area_vector(t).norm();
    m += a * (vertex(t, 0) + vertex(t, 1) + vertex(t, 2)) / 3;
    s += a;
  }
  return m / s;
}

namespace {
void require_closed(const TriangleMesh& m, const char* what) {
  if (m.membrane) throw std::logic_error(std::string(what) + " of membrane '" + m.label + "': it encloses nothing");
}
}  // namespace

// Divergence theorem over the tetrahedra (origin, a, b, c).
double TriangleMesh::volume() const {
  require_closed(*this, "volume");
  double v = 0;
  for (std::size_t t = 0; t < size(); ++t) v += vertex(t, 0).dot(vertex(t, 1).cross(vertex(t, 2)));
  return v / 6;
}

Vec3 TriangleMesh::volume_centroid() const {
  require_closed(*this, "volume centroid");
  // About the surface centroid rather than the origin, so far-away meshes lose no digits.
  const Vec3 o = surface_centroid();
  Vec3 m = Vec3::Zero();
  double v = 0;
  for (std::size_t t = 0; t < size(); ++t) {
    const Vec3 a = vertex(t, 0) - o, b = vertex(t, 1) - o, c = vertex(t, 2) - o;
    const double dv = a.dot(b.cross(c)) / 6;
    m += dv * (a + b + c) / 4;
    v += dv;
  }
  return o + m / v;
}

BoundingBox TriangleMesh::bounding_box() const {
  BoundingBox b;
  for (const Vec3& p : vertices) b.add(p);
  return b;
}

std::size_t TriangleMesh::open_or_inconsistent_edges() const {
  struct Use {
    int count = 0, direction = 0;
  };
  std::map<std::pair<int, int>, Use> edges;
  for (const auto& t : triangles)
    for (int k = 0; k < 3; ++k) {
      const int a = t[k], b = t[(k + 1) % 3];
      Use& u = edges[{std::min(a, b), std::max(a, b)}];
      ++u.count;
      u.direction += a < b ? 1 : -1;
    }
  return std::size_t(std::count_if(edges.begin(), edges.end(),
                                   [](const auto& e) { return e.second.count != 2 || e.second.direction != 0; }));
}

TriangleMesh TriangleMesh::transformed(const RigidTransform& T) const {
  TriangleMesh m = *this;
  for (Vec3& p : m.vertices) p = T.apply(p);
  if (T.mirrors())
    for (auto& t : m.triangles) std::swap(t[1], t[2]);
  return m;
}

std::vector<Vec3> TriangleMesh::vertex_velocities(const RigidVelocity& v) const {
  std::vector<Vec3> u(vertices.size());
  for (std::size_t i = 0; i < vertices.size(); ++i) u[i] = v.at(vertices[i]);
  return u;
}

std::size_t TriangleMesh::weld(double tol) {
  // Hash grid of cell size tol: a vertex's partner lies in one of the 27 cells around it.
  struct Key {
    std::int64_t i, j, k;
    bool operator==(const Key&) const = default;
  };
  struct Hash {
    std::size_t operator()(const Key& k) const {
      return std::size_t(std::uint64_t(k.i) * 73856093u ^ std::uint64_t(k.j) * 19349663u ^ std::uint64_t(k.k) * 83492791u);
    }
  };
  const double h = tol > 0 ? tol : 1.0;
  auto key = [&](const Vec3& p) {
    return Key{std::int64_t(std::floor(p.x() / h)), std::int64_t(std::floor(p.y() / h)),
               std::int64_t(std::floor(p.z() / h))};
  };
  std::unordered_map<Key, std::vector<int>, Hash> grid;
  std::vector<Vec3> kept;
  std::vector<int> map(vertices.size());
  for (std::size_t v = 0; v < vertices.size(); ++v) {
    const Vec3& p = vertices[v];
    const Key c = key(p);
    int found = -1;
    for (std::int64_t di = -1; di <= 1 && found < 0; ++di)
      for (std::int64_t dj = -1; dj <= 1 && found < 0; ++dj)
        for (std::int64_t dk = -1; dk <= 1 && found < 0; ++dk) {
          auto it = grid.find(Key{c.i + di, c.j + dj, c.k + dk});
          if (it == grid.end()) continue;
          for (int q : it->second)
            if (tol > 0 ? (kept[std::size_t(q)] - p).norm() <= tol : kept[std::size_t(q)] == p) {
              found = q;
              break;
            }
        }
    if (found < 0) {
      found = int(kept.size());
      kept.push_back(p);
      grid[c].push_back(found);
    }
    map[v] = found;
  }
  std::vector<std::array<int, 3>> tris;
  tris.reserve(triangles.size());
  for (const auto& t : triangles) {
    const std::array<int, 3> u{map[std::size_t(t[0])], map[std::size_t(t[1])], map[std::size_t(t[2])]};
    if (u[0] != u[1] && u[1] != u[2] && u[2] != u[0]) tris.push_back(u);
  }
  // Drop vertices that only collapsed triangles used.
  std::vector<int> renumber(kept.size(), -1);
  std::vector<Vec3> used;
  for (auto& t : tris)
    for (int& i : t) {
      if (renumber[std::size_t(i)] < 0) {
        renumber[std::size_t(i)] = int(used.size());
        used.push_back(kept[std::size_t(i)]);
      }
      i = renumber[std::size_t(i)];
    }
  const std::size_t removed = vertices.size() - used.size();
  vertices = std::move(used);
  triangles = std::move(tris);
  return removed;
}

void TriangleMesh::check() const {
  const std::string name = "mesh '" + label + "'";
  if (triangles.empty()) throw std::invalid_argument(name + " has no triangles");
  const BoundingBox b = bounding_box();
  const double floor_area = 1e-14 * (b.hi - b.lo).squaredNorm();
  for (std::size_t t = 0; t < size(); ++t) {
    for (int k = 0; k < 3; ++k)
      if (triangles[t][k] < 0 || std::size_t(triangles[t][k]) >= vertices.size())
        throw std::invalid_argument(name + ": triangle " + std::to_string(t) + " has vertex index " +
                                    std::to_string(triangles[t][k]) + " out of range");
    if (!(area_vector(t).norm() > floor_area))
      throw std::invalid_argument(name + ": triangle " + std::to_string(t) + " has zero area");
  }
}

TriangleMesh ellipsoid_mesh(const Vec3& diameters, int n) {
  if (n < 1) throw std::invalid_argument("ellipsoid_mesh: resolution must be >= 1");
  if ((diameters.array() <= 0).any()) throw std::invalid_argument("ellipsoid_mesh: diameters must be positive");
  // Equiangular cube coordinates t_i = tan(-pi/4 + i pi/(2n)), exactly -1, 0 (n even) and 1 at the
  // ends and centre, antisymmetric, so vertices shared by two cube faces coincide bitwise.
  std::vector<double> t(std::size_t(n) + 1);
  for (int i = 0; i <= n; ++i) t[std::size_t(i)] = std::tan(-pi / 4 + i * pi / (2 * n));
  for (int i = 0; i <= n / 2; ++i) t[std::size_t(n - i)] = -t[std::size_t(i)];
  t[0] = -1;
  t[std::size_t(n)] = 1;
  if (n % 2 == 0) t[std::size_t(n / 2)] = 0;

  TriangleMesh m;
  m.label = "ellipsoid";
  const Vec3 radius = diameters / 2;
  std::map<std::array<int, 3>, int> index;  // integer cube position -> vertex
  auto vertex = [&](const std::array<int, 3>& q) {
    auto [it, fresh] = index.emplace(q, int(m.vertices.size()));
    if (fresh) {
      const Vec3 s = Vec3(t[std::size_t(q[0])], t[std::size_t(q[1])], t[std::size_t(q[2])]).normalized();
      m.vertices.push_back(radius.cwiseProduct(s));
    }
    return it->second;
  };
  for (int axis = 0; axis < 3; ++axis)
    for (int sign : {-1, 1}) {
      const int u = (axis + 1) % 3, v = (axis + 2) % 3;  // e_u x e_v = e_axis
      auto at = [&](int i, int j) {
        std::array<int, 3> q{};
        q[std::size_t(axis)] = sign > 0 ? n : 0;
        q[std::size_t(u)] = i;
        q[std::size_t(v)] = j;
        return vertex(q);
      };
      for (int i = 0; i < n; ++i)
        for (int j = 0; j < n; ++j) {
          const int a = at(i, j), b = at(i + 1, j), c = at(i + 1, j + 1), d = at(i, j + 1);
          // Split along the shorter diagonal; (a, b, c) runs counter-clockwise about +e_axis.
          const auto& P = m.vertices;
          const bool ac = (P[std::size_t(a)] - P[std::size_t(c)]).squaredNorm() <=
                          (P[std::size_t(b)] - P[std::size_t(d)]).squaredNorm();
          std::array<int, 3> t1 = ac ? std::array<int, 3>{a, b, c} : std::array<int, 3>{a, b, d};
          std::array<int, 3> t2 = ac ? std::array<int, 3>{a, c, d} : std::array<int, 3>{b, c, d};
          if (sign < 0) {
            std::swap(t1[1], t1[2]);
            std::swap(t2[1], t2[2]);
          }
          m.triangles.push_back(t1);
          m.triangles.push_back(t2);
        }
    }
  return m;
}

TriangleMesh sphere_mesh(double radius, int n) {
  TriangleMesh m = ellipsoid_mesh(Vec3::Constant(2 * radius), n);
  m.label = "sphere";
  return m;
}

namespace {
// Spanwise stations of the wing mesh (m), from 0 to R.
std::vector<double> span_stations(const Wing& w, int n) {
  std::vector<double> y;
  const double R = w.length;
  if (w.planform == Planform::elliptic) {
    for (int j = 0; j <= n; ++j) y.push_back(R * std::sin(pi / 2 * j / n));
    y.back() = R;
    return y;
  }
  std::vector<double> breaks{0.0};
  if (w.planform == Planform::tabulated)
    for (double r : w.table_r)
      if (r > 0 && r < 1) breaks.push_back(r * R);
  breaks.push_back(R);
  std::sort(breaks.begin(), breaks.end());
  breaks.erase(std::unique(breaks.begin(), breaks.end()), breaks.end());
  y.push_back(0);
  for (std::size_t s = 1; s < breaks.size(); ++s) {
    const double a = breaks[s - 1], b = breaks[s];
    const int m = std::max(1, int(std::lround(n * (b - a) / R)));
    for (int j = 1; j <= m; ++j) y.push_back(j == m ? b : a + (b - a) * j / m);
  }
  return y;
}
}  // namespace

TriangleMesh wing_mesh(const Wing& wing, int n_span, int n_chord) {
  if (n_span < 1 || n_chord < 1) throw std::invalid_argument("wing_mesh: resolution must be >= 1");
  if (!(wing.length > 0) || !(wing.mean_chord > 0))
    throw std::invalid_argument("wing_mesh: wing length and mean chord must be positive");
  TriangleMesh m;
  m.label = "wing";
  m.membrane = true;
  const double x0 = wing.pitch_axis;
  std::vector<std::vector<int>> rows;  // vertex indices per station, trailing edge to leading edge
  for (double y : span_stations(wing, n_span)) {
    const double c = wing.chord(y);
    std::vector<int> row;
    if (c <= 1e-12 * wing.mean_chord) {
      row.push_back(int(m.vertices.size()));
      m.vertices.emplace_back(0.0, y, 0.0);
    } else {
      for (int i = 0; i <= n_chord; ++i) {
        row.push_back(int(m.vertices.size()));
        const double x = i == n_chord ? x0 * c : -(1 - x0) * c + c * i / n_chord;
        m.vertices.emplace_back(x, y, 0.0);
      }
    }
    rows.push_back(std::move(row));
  }
  triangulate_rows(m, rows);
  return m;
}

void triangulate_rows(TriangleMesh& m, const std::vector<std::vector<int>>& rows) {
  // Counter-clockwise seen from +z (x grows along a row, y from row to row): front face +z.
  for (std::size_t j = 0; j + 1 < rows.size(); ++j) {
    const auto &lo = rows[j], &hi = rows[j + 1];
    if (lo.size() > 1 && hi.size() > 1) {
      for (std::size_t i = 0; i + 1 < lo.size(); ++i) {
        m.triangles.push_back({lo[i], lo[i + 1], hi[i + 1]});
        m.triangles.push_back({lo[i], hi[i + 1], hi[i]});
      }
    } else if (lo.size() > 1) {
      for (std::size_t i = 0; i + 1 < lo.size(); ++i) m.triangles.push_back({lo[i], lo[i + 1], hi[0]});
    } else if (hi.size() > 1) {
      for (std::size_t i = 0; i + 1 < hi.size(); ++i) m.triangles.push_back({lo[0], hi[i + 1], hi[i]});
    }
  }
}

RigidTransform wing_transform(const WingPose& pose) { return RigidTransform{pose.axes, pose.hinge}; }

RigidVelocity wing_velocity(const WingPose& pose) { return RigidVelocity{pose.hinge, Vec3::Zero(), pose.omega}; }

const char* part_label(Pair pair, Side side) {
  if (pair == Pair::fore) return side == Side::right ? "right" : "left";
  return side == Side::right ? "hind_right" : "hind_left";
}

InsectSurfaces::InsectSurfaces(const Configuration& config, const MeshResolution& resolution) : config_(config) {
  const Insect& insect = config.insect();
  TriangleMesh body =
      ellipsoid_mesh(Vec3(insect.body.length, insect.body.width, insect.body.height), resolution.body);
  body.label = "body";
  reference_.push_back(std::move(body));
  // Each pair's left wing is the right wing's mesh: its pose mirrors it (det R = -1, TriangleMesh::transformed).
  for (Pair pair : {Pair::fore, Pair::hind}) {
    if (pair == Pair::hind && !insect.hind_wing) break;
    const TriangleMesh wing = wing_mesh(insect.pair_wing(pair), resolution.wing_span, resolution.wing_chord);
    for (Side s : {Side::right, Side::left}) {
      reference_.push_back(wing);
      reference_.back().label = part_label(pair, s);
    }
  }
}

int insect_part_count(const Insect& insect) { return insect.hind_wing ? 5 : 3; }

std::vector<PartPose> insect_part_poses(const Configuration& config, double t) {
  std::vector<PartPose> p(std::size_t(insect_part_count(config.insect())));
  p[0].pose = RigidTransform{config.anatomical_to_stability(), config.body_centre()};
  std::size_t i = 1;
  for (Pair pair : {Pair::fore, Pair::hind}) {
    if (pair == Pair::hind && !config.insect().hind_wing) break;
    for (Side s : {Side::right, Side::left}) {
      const WingPose w = config.wing_pose(s, t, pair);
      PartPose& q = p[i++];
      q.pose = wing_transform(w);
      q.motion = wing_velocity(w);
    }
  }
  return p;
}

std::vector<MeshPart> InsectSurfaces::at(double t) const {
  const std::vector<PartPose> poses = insect_part_poses(config_, t);
  std::vector<MeshPart> parts(reference_.size());
  for (std::size_t i = 0; i < parts.size(); ++i) {
    parts[i].pose = poses[i].pose;
    parts[i].motion = poses[i].motion;
    parts[i].mesh = reference_[i].transformed(parts[i].pose);
  }
  return parts;
}

std::vector<MeshPart> insect_meshes(const Configuration& config, double t, const MeshResolution& resolution) {
  return InsectSurfaces(config, resolution).at(t);
}

}  // namespace flapstab::ns
