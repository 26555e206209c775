// Triangulated body surfaces for the immersed-boundary solver: closed surfaces and zero-thickness
// membranes, rigid motion, and the analytic generators (ellipsoid, sphere, membrane wing, insect).
//
// Orientation: a triangle (a, b, c) has the normal (b - a) x (c - a). Closed surfaces point their
// normals outwards; a membrane's normal marks its front face (a wing's +z_wing side, ventral for the
// right wing at rest). A rigid transform with det R = -1 (the left wing's mirror image) reverses the
// winding, so that normals always map as n' = R n: a closed surface stays outward, and the left
// wing's front face is the mirror image of the right wing's.
#pragma once
#include <array>
#include <string>
#include <vector>
#include "core/configuration.hpp"

namespace flapstab::ns {

struct BoundingBox {
  Vec3 lo = Vec3::Constant(1e300), hi = Vec3::Constant(-1e300);
  void add(const Vec3& p) { lo = lo.cwiseMin(p); hi = hi.cwiseMax(p); }
  bool empty() const { return (hi.array() < lo.array()).any(); }
};

// A rigid displacement x' = R x + t; R orthogonal, det R = +1 or -1 (mirror image).
struct RigidTransform {
  Mat3 rotation = Mat3::Identity();
  Vec3 translation = Vec3::Zero();
  Vec3 apply(const Vec3& x) const { return rotation * x + translation; }
  Vec3 apply_inverse(const Vec3& x) const { return rotation.transpose() * (x - translation); }
  bool mirrors() const { return rotation.determinant() < 0; }
  // Composition: (a * b).apply(x) = a.apply(b.apply(x)), e.g. body motion * a part's pose in the body.
  friend RigidTransform operator*(const RigidTransform& a, const RigidTransform& b) {
    return {a.rotation * b.rotation, a.rotation * b.translation + a.translation};
  }
};

// Velocity field of a rigid motion: v(x) = velocity + omega x (x - centre).
struct RigidVelocity {
  Vec3 centre = Vec3::Zero();    // m
  Vec3 velocity = Vec3::Zero();  // m/s, of the point at `centre`
  Vec3 omega = Vec3::Zero();     // rad/s
  Vec3 at(const Vec3& x) const { return velocity + omega.cross(x - centre); }
};

struct TriangleMesh {
  std::string label;
  std::vector<Vec3> vertices;              // m
  std::vector<std::array<int, 3>> triangles;
  bool membrane = false;                   // zero-thickness open surface, two-sided

  std::size_t size() const { return triangles.size(); }
  const Vec3& vertex(std::size_t tri, int k) const { return vertices[std::size_t(triangles[tri][k])]; }
  // (b - a) x (c - a) / 2: the triangle's area times its unit normal.
  Vec3 area_vector(std::size_t tri) const;
  Vec3 normal(std::size_t tri) const { return area_vector(tri).normalized(); }
  double area() const;
  // Centroid of the surface (area-weighted).
  Vec3 surface_centroid() const;
  // Enclosed volume (divergence theorem) and its centroid; closed meshes only (std::logic_error).
  double volume() const;
  Vec3 volume_centroid() const;
  BoundingBox bounding_box() const;
  // Number of edges with other than two triangles, or whose two triangles traverse them the same way;
  // zero for a closed, consistently oriented surface.
  std::size_t open_or_inconsistent_edges() const;
  // A copy moved by T (winding reversed when T mirrors).
  TriangleMesh transformed(const RigidTransform& T) const;
  // Velocity of each vertex under a rigid motion.
  std::vector<Vec3> vertex_velocities(const RigidVelocity& v) const;
  // Merges vertices closer than tol (m), renumbers, drops triangles that collapse. Returns the number
  // of vertices removed.
  std::size_t weld(double tol);
  // Throws std::invalid_argument naming the mesh if an index is out of range or a triangle has zero area.
  void check() const;
};

// Closed ellipsoid with the given diameters along x, y, z (m), centred at the origin, outward normals.
// Cube-sphere triangulation: each cube face split into n x n equiangular cells, 12 n^2 triangles, all
// vertices on the ellipsoid (area and volume converge as n^-2).
TriangleMesh ellipsoid_mesh(const Vec3& diameters, int n);
TriangleMesh sphere_mesh(double radius, int n);

// The wing planform as a membrane in the wing frame (core/insect.hpp): z = 0, y from 0 (hinge) to R,
// leading edge x = x0 c(y), trailing edge x = -(1 - x0) c(y); front face +z. Spanwise stations:
// y = R sin(pi/2 j/n_span) for the elliptic planform (clustered at the tip, where c ~ sqrt(R - y)),
// uniform otherwise (tabulated: each table segment subdivided, so the piecewise-linear planform is
// exact); n_chord equal chordwise divisions; a station of zero chord collapses to one vertex.
// The mesh area is the trapezoidal rule for int c dr on those stations.
TriangleMesh wing_mesh(const Wing& wing, int n_span, int n_chord);
// Triangles between consecutive rows of vertex indices of a planar membrane (rows along y, x growing along a
// row; a row of one vertex is a tip or root point), counter-clockwise seen from +z: appended to m.triangles.
void triangulate_rows(TriangleMesh& m, const std::vector<std::vector<int>>& rows);

// Where a wing-frame mesh goes for a pose: x = hinge + axes xi (axes improper for the left wing).
RigidTransform wing_transform(const WingPose& pose);
// The wing's rigid velocity relative to the body frame: v = omega x (x - hinge).
RigidVelocity wing_velocity(const WingPose& pose);
// A wing's part label: "right", "left" (fore pair), "hind_right", "hind_left" (forces.csv, run.json, surfaces).
const char* part_label(Pair pair, Side side);

struct MeshResolution {
  int body = 16;        // ellipsoid cube-sphere divisions per face edge (12 n^2 triangles)
  int wing_span = 40;   // spanwise stations per wing
  int wing_chord = 10;  // chordwise divisions per wing
};

// Where a part of the insect is at an instant relative to its body: reference frame -> S, and its velocity
// relative to the body frame (zero for the body).
struct PartPose {
  RigidTransform pose;
  RigidVelocity motion;
};
// Body, right wing, left wing, and for a four-winged insect the hind pair's right and left wing (the order of
// InsectSurfaces::at and forces_csv.hpp's part_names), without moving any mesh.
std::vector<PartPose> insect_part_poses(const Configuration& config, double t);
// The number of parts in the CFD geometry: 3, or 5 with a hind pair.
int insect_part_count(const Insect& insect);

// One rigid part of the insect at an instant, in stability axes S (origin O, m).
struct MeshPart {
  TriangleMesh mesh;            // label "body", "right", "left", "hind_right" or "hind_left"
  RigidTransform pose;          // reference frame (body: A at the body CoM; wing: wing frame) -> S
  RigidVelocity motion;         // velocity relative to the body frame (zero for the body)
};

// The insect's surfaces: reference meshes built once, placed at any time by the configuration.
class InsectSurfaces {
 public:
  InsectSurfaces(const Configuration& config, const MeshResolution& resolution);
  // Body (closed ellipsoid, anatomical axes rotated into S, centred at the body CoM), right and left wing
  // (membranes placed by Configuration::wing_pose), then the hind pair's right and left wing (their own planform,
  // placed by Configuration::wing_pose(side, t, Pair::hind)) when the insect has one, in that order.
  std::vector<MeshPart> at(double t) const;
  // The reference meshes, in the order of at().
  const std::vector<TriangleMesh>& reference() const { return reference_; }

 private:
  Configuration config_;  // refers to the insect and kinematics, which must outlive this
  std::vector<TriangleMesh> reference_;
};

// InsectSurfaces(config, resolution).at(t).
std::vector<MeshPart> insect_meshes(const Configuration& config, double t, const MeshResolution& resolution);

}  // namespace flapstab::ns
