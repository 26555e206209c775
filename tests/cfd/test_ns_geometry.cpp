// Tests of the immersed-boundary geometry (cfd/navier_stokes/geometry, mesh_query): mesh integrals
// against closed forms, convergence order, rigid motion, the insect's placed surfaces, and the
// closest-point / signed-distance / side queries.
//
// References: sphere area 4 pi r^2 and volume 4/3 pi r^3; ellipsoid volume 4/3 pi abc and area by
// Legendre's closed form in incomplete elliptic integrals (S = 2 pi c^2 + 2 pi ab/sin(phi)
// [E(phi,k) sin^2(phi) + F(phi,k) cos^2(phi)], cos(phi) = c/a, k^2 = a^2 (b^2 - c^2) / (b^2 (a^2 - c^2)),
// a >= b >= c; std::ellint_1/2), cross-checked against Knud Thomsen's approximation (max error 1.061 %).
// Inside/outside reference in the discretisation band: the generalised winding number (sum of solid
// angles, Van Oosterom & Strackee 1983).
#include <gtest/gtest.h>
#include <cmath>
#include <functional>
#include <map>
#include <random>
#include "cfd/navier_stokes/geometry.hpp"
#include "cfd/navier_stokes/mesh_query.hpp"
#include "common/test_insect.hpp"
#include "core/case_file.hpp"
#include "core/rotation.hpp"

namespace flapstab::ns {
namespace {

double ellipsoid_area(double a, double b, double c) {  // semi-axes, a >= b >= c
  const double phi = std::acos(c / a);
  const double k = std::sqrt(a * a * (b * b - c * c) / (b * b * (a * a - c * c)));
  const double s = std::sin(phi), co = std::cos(phi);
  return 2 * pi * c * c + 2 * pi * a * b / s * (std::ellint_2(k, phi) * s * s + std::ellint_1(k, phi) * co * co);
}

double thomsen_area(double a, double b, double c) {
  const double p = 1.6075;
  return 4 * pi * std::pow((std::pow(a * b, p) + std::pow(a * c, p) + std::pow(b * c, p)) / 3, 1 / p);
}

// 1 inside a closed, outward-oriented mesh, 0 outside.
double winding_number(const TriangleMesh& m, const Vec3& x) {
  double w = 0;
  for (std::size_t t = 0; t < m.size(); ++t) {
    const Vec3 a = m.vertex(t, 0) - x, b = m.vertex(t, 1) - x, c = m.vertex(t, 2) - x;
    const double la = a.norm(), lb = b.norm(), lc = c.norm();
    w += 2 * std::atan2(a.dot(b.cross(c)), la * lb * lc + a.dot(b) * lc + a.dot(c) * lb + b.dot(c) * la);
  }
  return w / (4 * pi);
}

double order(double coarse_error, double fine_error) { return std::log2(coarse_error / fine_error); }

TEST(NsGeometry, SphereAreaAndVolumeConvergeAtSecondOrder) {
  const double r = 0.7;
  std::vector<double> ea, ev;
  for (int n : {8, 16, 32}) {
    const TriangleMesh m = sphere_mesh(r, n);
    EXPECT_EQ(m.size(), std::size_t(12 * n * n));
    EXPECT_EQ(m.vertices.size(), std::size_t(6 * n * n + 2));
    ea.push_back(std::abs(m.area() / (4 * pi * r * r) - 1));
    ev.push_back(std::abs(m.volume() / (4.0 / 3 * pi * r * r * r) - 1));
  }
  for (int i = 0; i < 2; ++i) {  // observed order 2 +- 0.15
    EXPECT_NEAR(order(ea[std::size_t(i)], ea[std::size_t(i) + 1]), 2.0, 0.15);
    EXPECT_NEAR(order(ev[std::size_t(i)], ev[std::size_t(i) + 1]), 2.0, 0.15);
  }
  EXPECT_LT(ea.back(), 6e-4);  // n = 32: 5.2e-4 and 9.9e-4 measured
  EXPECT_LT(ev.back(), 1.2e-3);
}

TEST(NsGeometry, EllipsoidAreaAndVolumeConvergeAtSecondOrder) {
  const Vec3 d(4.5, 1.2, 0.9);  // an insect body's proportions
  const double a = d[0] / 2, b = d[1] / 2, c = d[2] / 2;
  const double area = ellipsoid_area(a, b, c), volume = 4.0 / 3 * pi * a * b * c;
  EXPECT_NEAR(thomsen_area(a, b, c) / area, 1.0, 0.01061);  // the reference itself, against Thomsen's bound
  EXPECT_NEAR(ellipsoid_area(1, 1 - 1e-7, 1 - 2e-7), 4 * pi, 1e-5);  // near-sphere limit
  std::vector<double> ea, ev;
  for (int n : {8, 16, 32}) {
    const TriangleMesh m = ellipsoid_mesh(d, n);
    EXPECT_EQ(m.open_or_inconsistent_edges(), 0u);
    ea.push_back(std::abs(m.area() / area - 1));
    ev.push_back(std::abs(m.volume() / volume - 1));
  }
  for (int i = 0; i < 2; ++i) {  // observed order 2 +- 0.2
    EXPECT_NEAR(order(ea[std::size_t(i)], ea[std::size_t(i) + 1]), 2.0, 0.2);
    EXPECT_NEAR(order(ev[std::size_t(i)], ev[std::size_t(i) + 1]), 2.0, 0.2);
  }
  EXPECT_LT(ea.back(), 6.5e-4);  // n = 32: 5.4e-4 measured
  EXPECT_LT(ev.back(), 1.25e-3);  // 1.03e-3
}

TEST(NsGeometry, EllipsoidIsClosedWithOutwardNormals) {
  const Vec3 d(3, 2, 1);
  const TriangleMesh m = ellipsoid_mesh(d, 10);
  EXPECT_FALSE(m.membrane);
  EXPECT_EQ(m.open_or_inconsistent_edges(), 0u);
  for (std::size_t t = 0; t < m.size(); ++t) {
    const Vec3 centre = (m.vertex(t, 0) + m.vertex(t, 1) + m.vertex(t, 2)) / 3;
    ASSERT_GT(m.normal(t).dot(centre), 0) << "triangle " << t;  // convex about the origin
  }
  for (const Vec3& p : m.vertices)  // vertices on the surface to round-off
    EXPECT_NEAR(p.cwiseQuotient(d / 2).squaredNorm(), 1.0, 1e-14);
  const BoundingBox box = m.bounding_box();
  EXPECT_NEAR((box.hi - box.lo - d).norm(), 0.0, 1e-14);  // poles are vertices (n even)
  EXPECT_NEAR(m.volume_centroid().norm(), 0.0, 1e-14);
}

TEST(NsGeometry, MembraneWingAreaConvergesToMeanChordTimesSpan) {
  Wing w = testing::test_insect().wing;
  std::vector<double> err;
  for (int n : {20, 40, 80}) {
    const TriangleMesh m = wing_mesh(w, n, 8);
    EXPECT_TRUE(m.membrane);
    err.push_back(std::abs(m.area() / w.area() - 1));
  }
  EXPECT_NEAR(order(err[0], err[1]), 2.0, 0.15);  // trapezoidal rule in the sine-clustered stations
  EXPECT_NEAR(order(err[1], err[2]), 2.0, 0.15);
  EXPECT_LT(err[1], 3e-4);  // 40 stations: 2.6e-4 measured

  w.planform = Planform::rectangular;  // exact for a piecewise-linear planform
  EXPECT_NEAR(wing_mesh(w, 7, 3).area() / w.area(), 1.0, 1e-14);
  w.planform = Planform::tabulated;
  w.table_r = {0.0, 0.3, 0.75, 1.0};
  w.table_c = {0.6, 1.4, 1.1, 0.2};
  double table_area = 0;  // trapezoidal integral of the table, the exact area of the linear planform
  for (std::size_t i = 1; i < w.table_r.size(); ++i)
    table_area += 0.5 * (w.table_c[i] + w.table_c[i - 1]) * (w.table_r[i] - w.table_r[i - 1]);
  table_area *= w.mean_chord * w.length;
  EXPECT_NEAR(wing_mesh(w, 10, 4).area() / table_area, 1.0, 1e-14);
}

// The constant polynomial planform is the rectangle: the same stations and chords, the same mesh vertex for vertex.
TEST(NsGeometry, PolynomialWingMeshOfTheRectangle) {
  Wing r = testing::test_insect().wing, p = r;
  r.planform = Planform::rectangular;
  p.planform = Planform::polynomial;
  p.poly = {1.0};
  const TriangleMesh a = wing_mesh(r, 12, 5), b = wing_mesh(p, 12, 5);
  ASSERT_EQ(a.vertices.size(), b.vertices.size());
  for (std::size_t i = 0; i < a.vertices.size(); ++i) EXPECT_EQ((a.vertices[i] - b.vertices[i]).norm(), 0.0);
  // A tapered polynomial: the membrane's area is the trapezoidal rule of its chord on the uniform stations,
  // second-order accurate; c/c_bar = 1.5 - x^2 (mean 1.5 - 1/3, normalised) on 80 stations: within 1e-4.
  p.poly = {1.5 / (7.0 / 6.0), 0.0, -1.0 / (7.0 / 6.0)};
  EXPECT_NEAR(wing_mesh(p, 80, 4).area() / p.area(), 1.0, 1e-4);
}

TEST(NsGeometry, MembraneWingPlanformFollowsChord) {
  const Wing w = testing::test_insect().wing;
  const TriangleMesh m = wing_mesh(w, 30, 6);
  std::map<double, std::pair<double, double>> span;  // y -> (min x, max x)
  for (const Vec3& p : m.vertices) {
    EXPECT_EQ(p.z(), 0.0);
    auto [it, fresh] = span.emplace(p.y(), std::pair{p.x(), p.x()});
    it->second.first = std::min(it->second.first, p.x());
    it->second.second = std::max(it->second.second, p.x());
  }
  EXPECT_EQ(span.size(), 31u);
  EXPECT_EQ(span.begin()->first, 0.0);
  EXPECT_EQ(span.rbegin()->first, w.length);
  for (const auto& [y, x] : span) {
    const double c = w.chord(y);
    EXPECT_NEAR(x.second, w.pitch_axis * c, 1e-15) << "leading edge at y = " << y;
    EXPECT_NEAR(x.first, -(1 - w.pitch_axis) * c, 1e-15) << "trailing edge at y = " << y;
  }
  for (std::size_t t = 0; t < m.size(); ++t) EXPECT_NEAR(m.normal(t).z(), 1.0, 1e-12);  // front face +z
  EXPECT_NO_THROW(m.check());
}

TEST(NsGeometry, RigidTransformPreservesAreaVolumeAndMovesTheCentroid) {
  const TriangleMesh m = ellipsoid_mesh(Vec3(3, 2, 1), 8).transformed({Mat3::Identity(), Vec3(0.1, -0.2, 0.3)});
  const RigidTransform T{Eigen::AngleAxisd(0.7, Vec3(1, -2, 0.5).normalized()).toRotationMatrix(), Vec3(5, -3, 2)};
  const RigidTransform mirror{mirror_y() * T.rotation, T.translation};
  const Vec3 x(0.3, -1.2, 2.0);
  EXPECT_NEAR(((T * mirror).apply(x) - T.apply(mirror.apply(x))).norm(), 0.0, 1e-14);
  EXPECT_NEAR((T.apply_inverse(T.apply(x)) - x).norm(), 0.0, 1e-14);
  for (const RigidTransform& X : {T, mirror}) {
    const TriangleMesh n = m.transformed(X);
    EXPECT_NEAR(n.area() / m.area(), 1.0, 1e-13);
    EXPECT_NEAR(n.volume() / m.volume(), 1.0, 1e-13);  // positive: a mirror keeps the normals outward
    EXPECT_NEAR((n.volume_centroid() - X.apply(m.volume_centroid())).norm(), 0.0, 1e-13);
    EXPECT_NEAR((n.surface_centroid() - X.apply(m.surface_centroid())).norm(), 0.0, 1e-13);
    EXPECT_EQ(n.open_or_inconsistent_edges(), 0u);
    for (std::size_t t = 0; t < m.size(); ++t)
      ASSERT_NEAR((n.normal(t) - X.rotation * m.normal(t)).norm(), 0.0, 1e-12);  // n' = R n
  }
}

TEST(NsGeometry, VertexVelocitiesAreTheRigidMotion) {
  const TriangleMesh m = ellipsoid_mesh(Vec3(2, 1, 1), 4);
  const RigidVelocity v{Vec3(0.3, 0.1, -0.2), Vec3(1.0, -2.0, 0.5), Vec3(0.4, 3.0, -1.0)};
  // x(t) = c + v t + exp(t [omega]x) (x0 - c): its derivative at t = 0 (central difference, O(dt^2)).
  const double dt = 1e-5;
  auto moved = [&](double t) {
    const Mat3 R = Eigen::AngleAxisd(v.omega.norm() * t, v.omega.normalized()).toRotationMatrix();
    return m.transformed({R, v.centre + v.velocity * t - R * v.centre});
  };
  const TriangleMesh a = moved(-dt), b = moved(dt);
  const std::vector<Vec3> u = m.vertex_velocities(v);
  for (std::size_t i = 0; i < m.vertices.size(); ++i)
    EXPECT_NEAR(((b.vertices[i] - a.vertices[i]) / (2 * dt) - u[i]).norm(), 0.0, 1e-8);
}

TEST(NsGeometry, InsectPartsArePlacedByTheConfiguration) {
  const Insect insect = testing::test_insect();
  const Kinematics kin = testing::harmonic_kinematics();
  const Configuration config(insect, kin);
  const MeshResolution res{12, 20, 6};
  const InsectSurfaces surfaces(config, res);
  const double t = 0.3 / kin.frequency_hz;
  const std::vector<MeshPart> parts = surfaces.at(t);
  ASSERT_EQ(parts.size(), 3u);
  EXPECT_EQ(parts[0].mesh.label, "body");
  EXPECT_EQ(parts[1].mesh.label, "right");
  EXPECT_EQ(parts[2].mesh.label, "left");

  // Body: the ellipsoid of the body's diameters, centred at the body CoM, long axis along A's x.
  const TriangleMesh& body = parts[0].mesh;
  EXPECT_FALSE(body.membrane);
  EXPECT_NEAR((body.volume_centroid() - config.body_centre()).norm(), 0.0, 1e-15);
  EXPECT_NEAR(body.volume() / (pi / 6 * insect.body.length * insect.body.width * insect.body.height), 1.0, 0.01);
  const Vec3 long_axis = config.anatomical_to_stability() * Vec3::UnitX();
  double reach = 0;
  for (const Vec3& p : body.vertices) reach = std::max(reach, (p - config.body_centre()).dot(long_axis));
  EXPECT_NEAR(reach, insect.body.length / 2, 1e-15);
  EXPECT_EQ(parts[0].motion.omega, Vec3::Zero());

  // Wings: x = hinge + axes xi, front face = the pose's normal column, velocity = the pose's.
  const TriangleMesh& ref = surfaces.reference()[1];
  for (Side s : {Side::right, Side::left}) {
    const WingPose pose = config.wing_pose(s, t);
    const MeshPart& part = parts[s == Side::right ? 1 : 2];
    EXPECT_TRUE(part.mesh.membrane);
    for (std::size_t i = 0; i < ref.vertices.size(); ++i) {
      ASSERT_NEAR((part.mesh.vertices[i] - pose.position(ref.vertices[i])).norm(), 0.0, 1e-15);
      ASSERT_NEAR((part.motion.at(part.mesh.vertices[i]) - pose.velocity(ref.vertices[i])).norm(), 0.0, 1e-12);
    }
    for (std::size_t k = 0; k < part.mesh.size(); ++k)
      ASSERT_NEAR((part.mesh.normal(k) - pose.axes.col(2)).norm(), 0.0, 1e-9);
    EXPECT_NEAR(part.mesh.area() / ref.area(), 1.0, 1e-13);
  }
  // Symmetric kinematics: the left wing is the mirror image of the right one, vertex by vertex.
  for (std::size_t i = 0; i < ref.vertices.size(); ++i)
    ASSERT_NEAR((parts[2].mesh.vertices[i] - mirror_y() * parts[1].mesh.vertices[i]).norm(), 0.0, 1e-15);

  // The wing velocity is the time derivative of the placed vertices (the body frame is fixed here).
  const double dt = 1e-7 / kin.frequency_hz;
  const auto before = surfaces.at(t - dt), after = surfaces.at(t + dt);
  for (int p = 1; p <= 2; ++p) {
    double scale = 0, err = 0;
    for (std::size_t i = 0; i < ref.vertices.size(); ++i) {
      const Vec3 fd = (after[std::size_t(p)].mesh.vertices[i] - before[std::size_t(p)].mesh.vertices[i]) / (2 * dt);
      const Vec3 u = parts[std::size_t(p)].motion.at(parts[std::size_t(p)].mesh.vertices[i]);
      scale = std::max(scale, u.norm());
      err = std::max(err, (fd - u).norm());
    }
    EXPECT_LT(err, 1e-6 * scale) << "part " << p;
  }
  // insect_meshes is the same thing in one call.
  EXPECT_EQ(insect_meshes(config, t, res)[2].mesh.vertices, parts[2].mesh.vertices);
}

// The hind pair of a four-winged insect in the CFD geometry: parts 3 and 4 (hind_right, hind_left) are the hind wing's
// own planform placed by the configuration's hind-pair pose, the pose the quasi-steady model and the mass properties
// use, so the CFD's hind wings are where the rest of the program thinks they are. The shipped example
// (data/examples/four_wing_hawkmoth.toml) has a hind pair identical to the fore pair, at the same hinge and in phase:
// there a mix-up of the two pairs (the fore wing's mesh or pose for the hind wing) would go unseen, so the example is
// also run with a hind pair of its own (rectangular, shorter, hinged 9 mm further back, a quarter wingbeat ahead).
TEST(NsGeometry, HindPairIsPlacedByTheConfigurationsHindPose) {
  const Case example = load_case(std::string(FLAPSTAB_SOURCE_DIR) + "/data/examples/four_wing_hawkmoth.toml");
  ASSERT_TRUE(example.insect.hind_wing.has_value());
  Insect distinct = example.insect;
  distinct.hind_wing->planform = Planform::rectangular;
  distinct.hind_wing->length *= 0.8;
  distinct.hind_wing->hinge.x() -= 0.009;
  Kinematics distinct_kin = example.kinematics;
  distinct_kin.hind_phase = 0.25;
  struct Variant {
    const char* name;
    const Insect* insect;
    const Kinematics* kin;
  };
  const MeshResolution res{8, 16, 5};
  for (const Variant& v : {Variant{"example", &example.insect, &example.kinematics},
                           Variant{"distinct hind pair", &distinct, &distinct_kin}}) {
    SCOPED_TRACE(v.name);
    const Configuration config(*v.insect, *v.kin);
    const InsectSurfaces surfaces(config, res);
    ASSERT_EQ(surfaces.reference().size(), 5u);
    // The hind wings' reference mesh is the hind planform in the wing frame.
    const TriangleMesh hind = wing_mesh(*v.insect->hind_wing, res.wing_span, res.wing_chord);
    for (std::size_t p : {3u, 4u}) {
      EXPECT_EQ(surfaces.reference()[p].vertices, hind.vertices);
      EXPECT_EQ(surfaces.reference()[p].triangles, hind.triangles);
    }
    for (double phase : {0.0, 0.17, 0.5, 0.81}) {
      const double t = phase * v.kin->period();
      const std::vector<MeshPart> parts = surfaces.at(t);
      ASSERT_EQ(parts.size(), 5u);
      EXPECT_EQ(parts[3].mesh.label, "hind_right");
      EXPECT_EQ(parts[4].mesh.label, "hind_left");
      double err = 0, verr = 0, scale = 0;
      for (Side s : {Side::right, Side::left}) {
        const WingPose pose = config.wing_pose(s, t, Pair::hind);
        const MeshPart& part = parts[s == Side::right ? 3 : 4];
        EXPECT_TRUE(part.mesh.membrane);
        EXPECT_EQ(part.pose.mirrors(), s == Side::left);  // the left wing: the right mesh mirrored, det R = -1
        ASSERT_EQ(part.mesh.vertices.size(), hind.vertices.size());
        for (std::size_t i = 0; i < hind.vertices.size(); ++i) {
          err = std::max(err, (part.mesh.vertices[i] - pose.position(hind.vertices[i])).norm());
          verr = std::max(verr, (part.motion.at(part.mesh.vertices[i]) - pose.velocity(hind.vertices[i])).norm());
          scale = std::max(scale, pose.velocity(hind.vertices[i]).norm());
        }
        // Front faces map with the pose's normal column (winding reversed for the mirrored wing).
        for (std::size_t k = 0; k < part.mesh.size(); ++k)
          ASSERT_NEAR((part.mesh.normal(k) - pose.axes.col(2)).norm(), 0.0, 1e-9);
      }
      // Round-off: positions of order 0.05 m, the same arithmetic (hinge + axes xi).
      EXPECT_LT(err, 1e-15) << "t/T = " << phase;
      EXPECT_LT(verr, 1e-12 * std::max(scale, 1.0)) << "t/T = " << phase;
      // Symmetric hind kinematics: the left hind wing is the mirror image of the right one, vertex by vertex, so the
      // flow solver is given a mirror-symmetric insect.
      for (std::size_t i = 0; i < hind.vertices.size(); ++i)
        ASSERT_NEAR((parts[4].mesh.vertices[i] - mirror_y() * parts[3].mesh.vertices[i]).norm(), 0.0, 1e-15);
      // The hind wing is not the fore wing: in the distinct variant they differ by centimetres.
      if (v.insect == &distinct) {
        EXPECT_GT((parts[3].mesh.vertices.back() - parts[1].mesh.vertices.back()).norm(), 1e-3);
      }
    }
  }

  // Without the hind pair the geometry is the three parts of a two-winged insect, bit for bit what they were
  // before the hind pair was added (body ellipsoid and fore-wing mesh moved by the configuration's poses), and the
  // four-winged geometry's first three parts are those same parts when O is the same point.
  Insect two = distinct;
  two.hind_wing.reset();
  Kinematics two_kin = distinct_kin;
  two_kin.has_hind = false;
  const Configuration four_config(distinct, distinct_kin);
  const Configuration two_config(two, two_kin), two_same_o(two, two_kin, four_config.reference_point());
  const TriangleMesh body0 = ellipsoid_mesh(Vec3(two.body.length, two.body.width, two.body.height), res.body);
  const TriangleMesh wing0 = wing_mesh(two.wing, res.wing_span, res.wing_chord);
  for (double phase : {0.0, 0.17, 0.5, 0.81}) {
    const double t = phase * two_kin.period();
    const std::vector<MeshPart> three = InsectSurfaces(two_config, res).at(t);
    ASSERT_EQ(three.size(), 3u);
    const std::vector<TriangleMesh> before = {
        body0.transformed(RigidTransform{two_config.anatomical_to_stability(), two_config.body_centre()}),
        wing0.transformed(wing_transform(two_config.wing_pose(Side::right, t))),
        wing0.transformed(wing_transform(two_config.wing_pose(Side::left, t)))};
    for (std::size_t i = 0; i < 3; ++i) {
      EXPECT_EQ(three[i].mesh.vertices, before[i].vertices) << "part " << i;
      EXPECT_EQ(three[i].mesh.triangles, before[i].triangles) << "part " << i;
    }
    EXPECT_EQ(three[0].mesh.label, "body");
    EXPECT_EQ(three[1].mesh.label, "right");
    EXPECT_EQ(three[2].mesh.label, "left");
    const std::vector<MeshPart> five = InsectSurfaces(four_config, res).at(t);
    const std::vector<MeshPart> three_same_o = InsectSurfaces(two_same_o, res).at(t);
    for (std::size_t i = 0; i < 3; ++i) {
      EXPECT_EQ(five[i].mesh.vertices, three_same_o[i].mesh.vertices) << "part " << i;
      EXPECT_EQ(five[i].mesh.label, three_same_o[i].mesh.label);
    }
  }
}

TEST(NsGeometry, WeldMergesATriangleSoup) {
  const TriangleMesh m = sphere_mesh(1.0, 6);
  TriangleMesh soup;
  for (std::size_t t = 0; t < m.size(); ++t) {
    const int first = int(soup.vertices.size());
    for (int k = 0; k < 3; ++k) soup.vertices.push_back(m.vertex(t, k) + Vec3::Constant(1e-12 * (k - 1)));
    soup.triangles.push_back({first, first + 1, first + 2});
  }
  EXPECT_GT(soup.open_or_inconsistent_edges(), 0u);
  soup.weld(1e-9);
  EXPECT_EQ(soup.vertices.size(), m.vertices.size());
  EXPECT_EQ(soup.size(), m.size());
  EXPECT_EQ(soup.open_or_inconsistent_edges(), 0u);
}

TEST(NsGeometry, SphereClosestPointAndSignedDistanceAreSecondOrder) {
  const double r = 1.3;
  const Vec3 centre(0.2, -0.1, 0.4);
  std::mt19937 gen(7);
  std::uniform_real_distribution<double> u(-1, 1), radius(0.3 * r, 1.7 * r);
  std::vector<Vec3> points;
  while (points.size() < 2000) {
    const Vec3 d(u(gen), u(gen), u(gen));
    if (d.norm() > 0.1 && d.norm() <= 1) points.push_back(centre + radius(gen) * d.normalized());
  }
  std::vector<double> err;
  for (int n : {8, 16, 32}) {
    const MeshQuery q(sphere_mesh(r, n), RigidTransform{Mat3::Identity(), centre});
    const TriangleMesh placed = q.mesh().transformed(q.pose());
    double e = 0;
    for (const Vec3& x : points) {
      const SurfacePoint s = q.closest(x);
      ASSERT_TRUE(s.found());
      e = std::max(e, std::abs(s.signed_distance - ((x - centre).norm() - r)));
      e = std::max(e, std::abs((s.point - centre).norm() - r));  // the closest point lies on the sphere
      ASSERT_NEAR(s.distance, (x - s.point).norm(), 1e-14);
      // The barycentric weights rebuild the point from the placed mesh's triangle.
      const auto& tri = placed.triangles[std::size_t(s.triangle)];
      const Vec3 p = s.barycentric[0] * placed.vertices[std::size_t(tri[0])] +
                     s.barycentric[1] * placed.vertices[std::size_t(tri[1])] +
                     s.barycentric[2] * placed.vertices[std::size_t(tri[2])];
      ASSERT_NEAR((p - s.point).norm(), 0.0, 1e-14);
      ASSERT_GE(s.barycentric.minCoeff(), -1e-14);
    }
    err.push_back(e / r);
  }
  EXPECT_NEAR(order(err[0], err[1]), 2.0, 0.2);
  EXPECT_NEAR(order(err[1], err[2]), 2.0, 0.2);
  EXPECT_LT(err[2], 7e-4);  // n = 32: 5.9e-4 measured (of r)
}

// Signs for 10^4 random points: 5000 spread through the box and 5000 within 3 % of the surface.
// Outside the discretisation band the analytic inside test decides; inside it, the winding number.
void check_signs(const MeshQuery& q, const std::function<double(const Vec3&)>& level, double band,
                 const Vec3& half_box, std::mt19937& gen) {
  std::uniform_real_distribution<double> u(-1, 1);
  const TriangleMesh placed = q.mesh().transformed(q.pose());
  int checked_by_winding = 0;
  for (int i = 0; i < 10000; ++i) {
    Vec3 x = half_box.cwiseProduct(Vec3(u(gen), u(gen), u(gen)));
    if (i % 2) {  // push towards the surface along the level set's scale
      for (int it = 0; it < 40 && std::abs(level(x)) > 0.03; ++it) x *= level(x) > 0 ? 0.97 : 1.03;
    }
    x = q.pose().apply(x);
    const bool inside = q.inside(x);
    const double l = level(q.pose().apply_inverse(x));
    if (std::abs(l) > band) {
      ASSERT_EQ(inside, l < 0) << "point " << x.transpose() << " level " << l;
    } else {
      ++checked_by_winding;
      ASSERT_EQ(inside, winding_number(placed, x) > 0.5) << "point " << x.transpose() << " level " << l;
    }
  }
  EXPECT_GT(checked_by_winding, 50);
}

TEST(NsGeometry, SignIsRightInsideAndOutsideForRandomPoints) {
  std::mt19937 gen(11);
  // Sphere, placed by a rotation and translation.
  const RigidTransform pose{Eigen::AngleAxisd(1.1, Vec3(0.3, 1, -0.2).normalized()).toRotationMatrix(), Vec3(1, 2, 3)};
  const MeshQuery sphere(sphere_mesh(1.0, 10), pose);
  check_signs(sphere, [](const Vec3& x) { return x.norm() - 1; }, 0.02, Vec3::Constant(1.5), gen);
  // A non-convex star-shaped body: the sphere's vertices pushed out to r(dir) = 1 + 0.3 sin(3x) sin(2y) cos(z),
  // mirrored through y = 0 to exercise the reversed winding as well.
  auto radius = [](const Vec3& d) { return 1 + 0.3 * std::sin(3 * d.x()) * std::sin(2 * d.y()) * std::cos(d.z()); };
  TriangleMesh blob = sphere_mesh(1.0, 14);
  for (Vec3& p : blob.vertices) p *= radius(p);
  const MeshQuery star(blob, RigidTransform{mirror_y(), Vec3(-1, 0, 0.5)});
  check_signs(
      star, [&](const Vec3& x) { return x.norm() - radius(x.normalized()); }, 0.05, Vec3::Constant(1.5), gen);
}

TEST(NsGeometry, MembraneSideAndDistance) {
  const Insect insect = testing::test_insect();
  const Kinematics kin = testing::harmonic_kinematics();
  const Configuration config(insect, kin);
  const TriangleMesh wing = wing_mesh(insect.wing, 24, 6);
  std::mt19937 gen(3);
  std::uniform_real_distribution<double> u(-1, 1);
  const double R = insect.wing.length;
  for (Side s : {Side::right, Side::left}) {
    const WingPose pose = config.wing_pose(s, 0.2 / kin.frequency_hz);
    const MeshQuery q(wing, wing_transform(pose));
    EXPECT_THROW((void)q.inside(pose.hinge), std::logic_error);
    for (int i = 0; i < 2000; ++i) {
      const Vec3 xi(0.5 * R * u(gen), R * (0.5 + 0.7 * u(gen)), 0.2 * R * u(gen));  // wing frame
      const Vec3 x = pose.position(xi);
      const SurfacePoint p = q.closest(x);
      ASSERT_EQ(p.side(), xi.z() > 0 ? 1 : -1) << "wing frame point " << xi.transpose();
      ASSERT_NEAR((x - pose.hinge).dot(pose.axes.col(2)), xi.z(), 1e-15);  // front = the pose's normal column
      // Above the planform the distance is the height.
      const double c = insect.wing.chord(xi.y());
      const double x0 = insect.wing.pitch_axis;
      if (xi.y() > 0.05 * R && xi.y() < 0.9 * R && xi.x() < 0.9 * x0 * c && xi.x() > -0.9 * (1 - x0) * c) {
        ASSERT_NEAR(p.distance, std::abs(xi.z()), 2e-3 * R);  // chord of the sampled planform ~ (dy)^2
      }
    }
  }
}

TEST(NsGeometry, SegmentCrossings) {
  const MeshQuery sphere(sphere_mesh(1.0, 16), RigidTransform{Mat3::Identity(), Vec3(0, 0, 1)});
  const auto hit = sphere.first_crossing(Vec3(-3, 0.1, 1.2), Vec3(0, 0.1, 1.2));
  ASSERT_TRUE(hit);
  const double x_exact = -std::sqrt(1 - 0.1 * 0.1 - 0.2 * 0.2);
  EXPECT_NEAR(hit->point.x(), x_exact, 5e-3);  // O(h^2) chord depth at n = 16
  EXPECT_LT(hit->normal.x(), -0.9);
  EXPECT_FALSE(sphere.first_crossing(Vec3(-3, 0, 1), Vec3(-1.5, 0, 1)));
  EXPECT_FALSE(sphere.first_crossing(Vec3(-0.2, 0, 1), Vec3(0.2, 0.1, 1)));  // wholly inside

  // A membrane: a stencil from one side to the other crosses it at z = 0.
  Wing w = testing::test_insect().wing;
  const MeshQuery wing(wing_mesh(w, 20, 5));
  const auto h = wing.first_crossing(Vec3(0, 0.5 * w.length, 0.002), Vec3(0.001, 0.5 * w.length, -0.002));
  ASSERT_TRUE(h);
  EXPECT_NEAR(h->s, 0.5, 1e-12);
  EXPECT_NEAR(h->point.z(), 0.0, 1e-15);
  EXPECT_NEAR(h->normal.z(), 1.0, 1e-12);
  EXPECT_FALSE(wing.first_crossing(Vec3(0, 0.5 * w.length, 0.002), Vec3(0, 0.5 * w.length, 0.001)));
  EXPECT_FALSE(wing.first_crossing(Vec3(0, 1.1 * w.length, 0.002), Vec3(0, 1.1 * w.length, -0.002)));  // beyond tip
}

TEST(NsGeometry, QueriesFromManyThreadsMatchSerial) {
  const MeshQuery q(ellipsoid_mesh(Vec3(3, 1, 1), 12));
  std::vector<Vec3> x(4000);
  std::mt19937 gen(5);
  std::uniform_real_distribution<double> u(-2, 2);
  for (Vec3& p : x) p = Vec3(u(gen), u(gen), u(gen));
  std::vector<double> serial(x.size()), parallel(x.size());
  for (std::size_t i = 0; i < x.size(); ++i) serial[i] = q.signed_distance(x[i]);
#pragma omp parallel for
  for (std::ptrdiff_t i = 0; i < std::ptrdiff_t(x.size()); ++i) parallel[std::size_t(i)] = q.signed_distance(x[std::size_t(i)]);
  EXPECT_EQ(serial, parallel);
}

TEST(NsGeometry, BadMeshesAreRejected) {
  TriangleMesh open = sphere_mesh(1.0, 4);
  open.triangles.pop_back();
  EXPECT_THROW(MeshQuery{open}, std::invalid_argument);  // a closed surface with a hole
  open.membrane = true;
  EXPECT_NO_THROW(MeshQuery{open});
  TriangleMesh flipped = sphere_mesh(1.0, 4);
  std::swap(flipped.triangles[0][1], flipped.triangles[0][2]);
  EXPECT_THROW(MeshQuery{flipped}, std::invalid_argument);
  TriangleMesh bad = sphere_mesh(1.0, 2);
  bad.triangles[3][1] = 999;
  EXPECT_THROW(bad.check(), std::invalid_argument);
  EXPECT_THROW((void)wing_mesh(Wing{}, 10, 4), std::invalid_argument);
  TriangleMesh membrane = wing_mesh(testing::test_insect().wing, 4, 2);
  EXPECT_THROW((void)membrane.volume(), std::logic_error);
}

}  // namespace
}  // namespace flapstab::ns
