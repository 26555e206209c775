// Closest point, signed distance and segment crossings on a triangle mesh through a bounding-volume tree.
#include "cfd/navier_stokes/mesh_query.hpp"
#include <algorithm>
#include <cmath>
#include <limits>
#include <map>
#include <numeric>
#include <stdexcept>

namespace flapstab::ns {

namespace {

constexpr int leaf_size = 4;
constexpr int max_depth = 64;

// Closest point of triangle (a, b, c) to p (Ericson, Real-Time Collision Detection, 5.1.5), with the
// feature it lies on: vertex k, edge k = (k, k+1 mod 3), or the face.
struct TrianglePoint {
  Vec3 w;  // barycentric weights of a, b, c
  Feature feature;
  int index;
};

TrianglePoint closest_on_triangle(const Vec3& p, const Vec3& a, const Vec3& b, const Vec3& c) {
  const Vec3 ab = b - a, ac = c - a, ap = p - a;
  const double d1 = ab.dot(ap), d2 = ac.dot(ap);
  if (d1 <= 0 && d2 <= 0) return {Vec3(1, 0, 0), Feature::vertex, 0};
  const Vec3 bp = p - b;
  const double d3 = ab.dot(bp), d4 = ac.dot(bp);
  if (d3 >= 0 && d4 <= d3) return {Vec3(0, 1, 0), Feature::vertex, 1};
  const double vc = d1 * d4 - d3 * d2;
  if (vc <= 0 && d1 >= 0 && d3 <= 0) {
    const double v = d1 / (d1 - d3);
    return {Vec3(1 - v, v, 0), Feature::edge, 0};
  }
  const Vec3 cp = p - c;
  const double d5 = ab.dot(cp), d6 = ac.dot(cp);
  if (d6 >= 0 && d5 <= d6) return {Vec3(0, 0, 1), Feature::vertex, 2};
  const double vb = d5 * d2 - d1 * d6;
  if (vb <= 0 && d2 >= 0 && d6 <= 0) {
    const double w = d2 / (d2 - d6);
    return {Vec3(1 - w, 0, w), Feature::edge, 2};
  }
  const double va = d3 * d6 - d5 * d4;
  if (va <= 0 && d4 - d3 >= 0 && d5 - d6 >= 0) {
    const double w = (d4 - d3) / ((d4 - d3) + (d5 - d6));
    return {Vec3(0, 1 - w, w), Feature::edge, 1};
  }
  const double denom = 1 / (va + vb + vc);
  const double v = vb * denom, w = vc * denom;
  return {Vec3(1 - v - w, v, w), Feature::face, 0};
}

double box_distance2(const Vec3& x, const Vec3& lo, const Vec3& hi) {
  return (lo - x).cwiseMax(x - hi).cwiseMax(0.0).squaredNorm();
}

// Slab test: does the segment a + s d, s in [0, 1], meet the box?
bool segment_meets_box(const Vec3& a, const Vec3& inv_d, const Vec3& lo, const Vec3& hi) {
  double s0 = 0, s1 = 1;
  for (int k = 0; k < 3; ++k) {
    double t0 = (lo[k] - a[k]) * inv_d[k], t1 = (hi[k] - a[k]) * inv_d[k];
    if (std::isnan(t0) || std::isnan(t1)) {  // d_k = 0 with a_k on a slab plane
      if (a[k] < lo[k] || a[k] > hi[k]) return false;
      continue;
    }
    if (t0 > t1) std::swap(t0, t1);
    s0 = std::max(s0, t0);
    s1 = std::min(s1, t1);
    if (s0 > s1) return false;
  }
  return true;
}

}  // namespace

MeshQuery::MeshQuery(TriangleMesh reference, const RigidTransform& pose) : mesh_(std::move(reference)), pose_(pose) {
  mesh_.check();
  if (!mesh_.membrane) {
    const std::size_t bad = mesh_.open_or_inconsistent_edges();
    if (bad > 0)
      throw std::invalid_argument("mesh '" + mesh_.label + "' is not a closed, consistently oriented surface (" +
                                  std::to_string(bad) + " open or inconsistent edges); load it as a membrane");
  }
  const std::size_t n = mesh_.size();
  face_normal_.resize(n);
  for (std::size_t t = 0; t < n; ++t) face_normal_[t] = mesh_.normal(t);

  // Edge pseudonormal: sum of the unit normals of the triangles sharing the edge (one on a membrane's rim).
  std::map<std::pair<int, int>, Vec3> edge_sum;
  for (std::size_t t = 0; t < n; ++t)
    for (int k = 0; k < 3; ++k) {
      const int a = mesh_.triangles[t][k], b = mesh_.triangles[t][(k + 1) % 3];
      auto [it, fresh] = edge_sum.emplace(std::pair{std::min(a, b), std::max(a, b)}, face_normal_[t]);
      if (!fresh) it->second += face_normal_[t];
    }
  edge_normal_.resize(3 * n);
  for (std::size_t t = 0; t < n; ++t)
    for (int k = 0; k < 3; ++k) {
      const int a = mesh_.triangles[t][k], b = mesh_.triangles[t][(k + 1) % 3];
      const Vec3& s = edge_sum.at({std::min(a, b), std::max(a, b)});
      // A membrane folded flat onto itself has no edge normal; its face normal decides.
      edge_normal_[3 * t + std::size_t(k)] = s.norm() > 1e-12 ? s.normalized() : face_normal_[t];
    }

  // Vertex pseudonormal: incident face normals weighted by the incident angle.
  vertex_normal_.assign(mesh_.vertices.size(), Vec3::Zero());
  for (std::size_t t = 0; t < n; ++t)
    for (int k = 0; k < 3; ++k) {
      const Vec3& p = mesh_.vertex(t, k);
      const Vec3 e1 = (mesh_.vertex(t, (k + 1) % 3) - p).normalized();
      const Vec3 e2 = (mesh_.vertex(t, (k + 2) % 3) - p).normalized();
      const double angle = std::acos(std::clamp(e1.dot(e2), -1.0, 1.0));
      vertex_normal_[std::size_t(mesh_.triangles[t][k])] += angle * face_normal_[t];
    }
  for (std::size_t t = 0; t < n; ++t)
    for (int k = 0; k < 3; ++k) {
      Vec3& v = vertex_normal_[std::size_t(mesh_.triangles[t][k])];
      if (v.norm() < 1e-12) v = face_normal_[t];
    }
  for (Vec3& v : vertex_normal_) v.normalize();

  order_.resize(n);
  std::iota(order_.begin(), order_.end(), 0);
  std::vector<Vec3> centres(n);
  for (std::size_t t = 0; t < n; ++t) centres[t] = (mesh_.vertex(t, 0) + mesh_.vertex(t, 1) + mesh_.vertex(t, 2)) / 3;
  nodes_.reserve(2 * n / leaf_size + 2);
  build(0, int(n), centres, 0);
  corners_.resize(n);
  for (std::size_t i = 0; i < n; ++i) {
    const std::size_t t = std::size_t(order_[i]);
    corners_[i] = {mesh_.vertex(t, 0), mesh_.vertex(t, 1), mesh_.vertex(t, 2)};
  }
}

namespace {
double half_area(const BoundingBox& b) {
  const Vec3 d = b.hi - b.lo;
  return d.x() * d.y() + d.y() * d.z() + d.z() * d.x();
}
}  // namespace

// Surface-area heuristic (MacDonald & Booth 1990): of the splits of the triangles sorted by centre along
// each axis, take the one minimising area(left) n_left + area(right) n_right; median split below
// max_depth / 2 levels so the traversal stack cannot overflow.
int MeshQuery::build(int first, int count, std::vector<Vec3>& centres, int depth) {
  const int id = int(nodes_.size());
  nodes_.emplace_back();
  BoundingBox box;
  for (int i = first; i < first + count; ++i)
    for (int k = 0; k < 3; ++k) box.add(mesh_.vertex(std::size_t(order_[std::size_t(i)]), k));
  nodes_[std::size_t(id)].lo = box.lo;
  nodes_[std::size_t(id)].hi = box.hi;
  if (count <= leaf_size) {
    nodes_[std::size_t(id)].first = first;
    nodes_[std::size_t(id)].count = count;
    return id;
  }
  auto begin = order_.begin() + first, end = begin + count;
  int best_axis = 0, best_split = count / 2;
  if (depth < max_depth / 2) {
    double best_cost = std::numeric_limits<double>::infinity();
    std::vector<double> right_area(std::size_t(count) + 1);
    for (int axis = 0; axis < 3; ++axis) {
      std::sort(begin, end, [&](int a, int b) { return centres[std::size_t(a)][axis] < centres[std::size_t(b)][axis]; });
      BoundingBox r;
      for (int i = count - 1; i >= 1; --i) {
        for (int k = 0; k < 3; ++k) r.add(mesh_.vertex(std::size_t(begin[i]), k));
        right_area[std::size_t(i)] = half_area(r);
      }
      BoundingBox l;
      for (int i = 1; i < count; ++i) {
        for (int k = 0; k < 3; ++k) l.add(mesh_.vertex(std::size_t(begin[i - 1]), k));
        const double cost = half_area(l) * i + right_area[std::size_t(i)] * (count - i);
        if (cost < best_cost) {
          best_cost = cost;
          best_axis = axis;
          best_split = i;
        }
      }
    }
  } else {
    (box.hi - box.lo).maxCoeff(&best_axis);
  }
  std::sort(begin, end,
            [&](int a, int b) { return centres[std::size_t(a)][best_axis] < centres[std::size_t(b)][best_axis]; });
  const int left = build(first, best_split, centres, depth + 1);
  const int right = build(first + best_split, count - best_split, centres, depth + 1);
  nodes_[std::size_t(id)].left = left;
  nodes_[std::size_t(id)].right = right;
  return id;
}

void MeshQuery::local_closest(const Vec3& x, double max_distance, SurfacePoint& out) const {
  double best2 = max_distance * max_distance;
  int best = -1;
  TrianglePoint best_tp{};
  int stack[max_depth];
  int top = 0;
  stack[top++] = 0;
  while (top > 0) {
    const Node& node = nodes_[std::size_t(stack[--top])];
    if (box_distance2(x, node.lo, node.hi) > best2) continue;
    if (node.count > 0) {
      for (int i = node.first; i < node.first + node.count; ++i) {
        const auto& c = corners_[std::size_t(i)];
        const TrianglePoint tp = closest_on_triangle(x, c[0], c[1], c[2]);
        const double d2 = (x - (tp.w[0] * c[0] + tp.w[1] * c[1] + tp.w[2] * c[2])).squaredNorm();
        if (d2 < best2 || (best < 0 && d2 <= best2)) {
          best2 = d2;
          best = order_[std::size_t(i)];
          best_tp = tp;
        }
      }
      continue;
    }
    // Visit the nearer child first: push it last.
    const Node &l = nodes_[std::size_t(node.left)], &r = nodes_[std::size_t(node.right)];
    const double dl = box_distance2(x, l.lo, l.hi), dr = box_distance2(x, r.lo, r.hi);
    if (dl <= dr) {
      stack[top++] = node.right;
      stack[top++] = node.left;
    } else {
      stack[top++] = node.left;
      stack[top++] = node.right;
    }
  }
  if (best < 0) return;
  const std::size_t t = std::size_t(best);
  out.triangle = best;
  out.barycentric = best_tp.w;
  out.point = best_tp.w[0] * mesh_.vertex(t, 0) + best_tp.w[1] * mesh_.vertex(t, 1) + best_tp.w[2] * mesh_.vertex(t, 2);
  out.feature = best_tp.feature;
  switch (best_tp.feature) {
    case Feature::face: out.normal = face_normal_[t]; break;
    case Feature::edge: out.normal = edge_normal_[3 * t + std::size_t(best_tp.index)]; break;
    case Feature::vertex: out.normal = vertex_normal_[std::size_t(mesh_.triangles[t][best_tp.index])]; break;
  }
  out.distance = std::sqrt(best2);
  out.signed_distance = (x - out.point).dot(out.normal) >= 0 ? out.distance : -out.distance;
}

SurfacePoint MeshQuery::closest(const Vec3& x, double max_distance) const {
  SurfacePoint p;
  local_closest(pose_.apply_inverse(x), max_distance, p);
  if (!p.found()) return p;
  p.point = pose_.apply(p.point);
  p.normal = pose_.rotation * p.normal;
  if (pose_.mirrors()) std::swap(p.barycentric[1], p.barycentric[2]);  // transformed() swaps vertices 1 and 2
  return p;
}

bool MeshQuery::inside(const Vec3& x) const {
  if (mesh_.membrane) throw std::logic_error("inside(): membrane '" + mesh_.label + "' encloses nothing");
  return closest(x).signed_distance < 0;
}

std::optional<SegmentHit> MeshQuery::first_crossing(const Vec3& a_world, const Vec3& b_world) const {
  const Vec3 a = pose_.apply_inverse(a_world), d = pose_.apply_inverse(b_world) - a;
  const Vec3 inv_d = d.cwiseInverse();
  // Moeller & Trumbore 1997 with a tolerance that counts hits on shared edges and vertices.
  constexpr double eps = 1e-12;
  std::optional<SegmentHit> hit;
  int stack[max_depth];
  int top = 0;
  stack[top++] = 0;
  while (top > 0) {
    const Node& node = nodes_[std::size_t(stack[--top])];
    if (!segment_meets_box(a, inv_d, node.lo, node.hi)) continue;
    if (node.count == 0) {
      stack[top++] = node.left;
      stack[top++] = node.right;
      continue;
    }
    for (int i = node.first; i < node.first + node.count; ++i) {
      const std::size_t t = std::size_t(order_[std::size_t(i)]);
      const auto& c = corners_[std::size_t(i)];
      const Vec3 &v0 = c[0], e1 = c[1] - v0, e2 = c[2] - v0;
      const Vec3 p = d.cross(e2);
      const double det = e1.dot(p);
      if (std::abs(det) < 1e-300) continue;  // segment parallel to the triangle
      const Vec3 tv = a - v0;
      const double u = tv.dot(p) / det;
      if (u < -eps || u > 1 + eps) continue;
      const Vec3 q = tv.cross(e1);
      const double v = d.dot(q) / det;
      if (v < -eps || u + v > 1 + eps) continue;
      const double s = e2.dot(q) / det;
      if (s < 0 || s > 1 || (hit && s >= hit->s)) continue;
      hit = SegmentHit{s, Vec3::Zero(), int(t), Vec3(1 - u - v, u, v), face_normal_[t]};
    }
  }
  if (hit) {
    hit->point = a_world + hit->s * (b_world - a_world);
    hit->normal = pose_.rotation * hit->normal;
    if (pose_.mirrors()) std::swap(hit->barycentric[1], hit->barycentric[2]);
  }
  return hit;
}

Vec3 interpolate(const TriangleMesh& mesh, const SurfacePoint& p, const std::vector<Vec3>& values) {
  const auto& t = mesh.triangles.at(std::size_t(p.triangle));
  return p.barycentric[0] * values[std::size_t(t[0])] + p.barycentric[1] * values[std::size_t(t[1])] +
         p.barycentric[2] * values[std::size_t(t[2])];
}

double interpolate(const TriangleMesh& mesh, const SurfacePoint& p, const std::vector<double>& values) {
  const auto& t = mesh.triangles.at(std::size_t(p.triangle));
  return p.barycentric[0] * values[std::size_t(t[0])] + p.barycentric[1] * values[std::size_t(t[1])] +
         p.barycentric[2] * values[std::size_t(t[2])];
}

}  // namespace flapstab::ns
