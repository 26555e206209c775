// Case-file parsing and validation (toml++). Every key is checked; unknown keys are errors.
#include "core/case_file.hpp"

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <fmt/format.h>
#include <optional>
#include <set>
#include <toml++/toml.h>

#include "core/errors.hpp"
#include "core/flusi_kinematics.hpp"

namespace flapstab {

namespace {

// A TOML table with the file and dotted path it came from; remembers which keys were read so
// that leftovers (typos) can be reported.
struct SensibleRange {
  double first, second;
  const char* why;
};

// Magnitudes from the smallest flying insects (a 25 ug fairyfly, 0.2 mm wings) to flapping MAVs of a few
// hundred grams, in air or water; values outside are typing errors (a unit off by 10^3 is still accepted).
std::optional<SensibleRange> sensible_range(const std::string& unit) {
  if (unit == "kg") return SensibleRange{1e-10, 1e2, "from a microinsect to a large flapping MAV"};
  if (unit == "m") return SensibleRange{1e-6, 1e2, "a length of an insect or a flapping MAV"};
  if (unit == "kg m^2") return SensibleRange{1e-25, 1e2, "a moment of inertia of an insect or a flapping MAV"};
  if (unit == "Hz") return SensibleRange{1e-2, 1e4, "a wingbeat frequency"};
  if (unit == "kg/m^3") return SensibleRange{1e-3, 2e3, "a fluid density (air 1.2, water 1000)"};
  if (unit == "m^2/s") return SensibleRange{1e-8, 1.0, "a kinematic viscosity (air 1.5e-5, water 1e-6)"};
  return std::nullopt;
}

// Minimum of p(x) = sum_k a[k] x^k over [0, 1]: at an end or at a real root of p' inside (the eigenvalues of p''s
// companion matrix).
double polynomial_minimum_on_unit_interval(const std::vector<double>& a) {
  auto p = [&](double x) {
    double v = 0;
    for (auto k = a.rbegin(); k != a.rend(); ++k) v = v * x + *k;
    return v;
  };
  double lowest = std::min(p(0.0), p(1.0));
  std::vector<double> d;  // p' coefficients, trailing zeros dropped
  for (std::size_t k = 1; k < a.size(); ++k) d.push_back(double(k) * a[k]);
  while (!d.empty() && d.back() == 0) d.pop_back();
  if (d.size() >= 2) {
    const Eigen::Index n = Eigen::Index(d.size()) - 1;
    Eigen::MatrixXd companion = Eigen::MatrixXd::Zero(n, n);
    for (Eigen::Index i = 1; i < n; ++i) companion(i, i - 1) = 1;
    for (Eigen::Index i = 0; i < n; ++i) companion(i, n - 1) = -d[std::size_t(i)] / d.back();
    const Eigen::VectorXcd roots = Eigen::EigenSolver<Eigen::MatrixXd>(companion, false).eigenvalues();
    for (const auto& z : roots)
      if (std::abs(z.imag()) < 1e-8 && z.real() > 0 && z.real() < 1) lowest = std::min(lowest, p(z.real()));
  }
  // A dense sample as well: a double root of p' (an inflection) is found above only to the eigenvalue accuracy.
  for (int i = 1; i < 1000; ++i) lowest = std::min(lowest, p(i / 1000.0));
  return lowest;
}

class Section {
 public:
  Section(const toml::table* t, std::string file, std::string path)
      : t_(t), file_(std::move(file)), path_(std::move(path)) {}

  bool present() const { return t_ != nullptr; }
  bool has(const std::string& k) const { return t_ && t_->contains(k); }
  std::string key(const std::string& k) const { return path_.empty() ? k : path_ + "." + k; }
  [[noreturn]] void fail(const std::string& k, const std::string& problem, const std::string& expected) const {
    throw InputError(file_, key(k), problem, expected);
  }

  const toml::node* node(const std::string& k) {
    used_.insert(k);
    return t_ ? t_->get(k) : nullptr;
  }

  Section sub(const std::string& k, bool required) {
    const toml::node* n = node(k);
    if (!n) {
      if (required) fail(k, "missing section", "a table [" + key(k) + "]");
      return Section(nullptr, file_, key(k));
    }
    if (!n->is_table()) fail(k, "is not a table", "a table [" + key(k) + "]");
    return Section(n->as_table(), file_, key(k));
  }

  double number(const std::string& k, const std::string& expected) {
    const toml::node* n = node(k);
    if (!n) fail(k, "missing", expected);
    return to_number(k, *n, expected);
  }
  double number_or(const std::string& k, double dflt, const std::string& expected) {
    return has(k) ? number(k, expected) : (node(k), dflt);
  }
  double positive(const std::string& k, const std::string& unit) {
    const double v = number(k, "a positive number in " + unit);
    if (!(v > 0)) fail(k, fmt::format("must be positive, got {:.6g}", v), "a positive number in " + unit);
    // Physically sensible magnitudes: a finite but absurd value (1e300 kg) would fail much later with a message
    // that points elsewhere (NaN residuals, "widen the bounds").
    if (const auto r = sensible_range(unit); r && (v < r->first || v > r->second))
      fail(k, fmt::format("{:.6g} {} is outside the physically sensible range", v, unit),
           fmt::format("a value in [{:g}, {:g}] {} ({})", r->first, r->second, unit, r->why));
    return v;
  }
  // A positive number within [lo, hi] (a setting's useful range).
  double positive_in(const std::string& k, double dflt, double lo, double hi, const std::string& what) {
    if (!has(k)) return (node(k), dflt);
    const std::string expected = fmt::format("{} in [{:g}, {:g}]", what, lo, hi);
    const double v = number(k, expected);
    if (!(v >= lo && v <= hi)) fail(k, fmt::format("out of range: {:.6g}", v), expected);
    return v;
  }
  double positive_or(const std::string& k, double dflt, const std::string& unit) {
    return has(k) ? positive(k, unit) : (node(k), dflt);
  }
  int integer_or(const std::string& k, int dflt, int lo, int hi) {
    const toml::node* n = node(k);
    const std::string expected = fmt::format("an integer in [{}, {}]", lo, hi);
    if (!n) return dflt;
    if (!n->is_integer()) fail(k, "is not an integer", expected);
    const auto v = n->as_integer()->get();
    if (v < lo || v > hi) fail(k, fmt::format("out of range: {}", v), expected);
    return int(v);
  }
  bool boolean_or(const std::string& k, bool dflt) {
    const toml::node* n = node(k);
    if (!n) return dflt;
    if (!n->is_boolean()) fail(k, "is not a boolean", "true or false");
    return n->as_boolean()->get();
  }
  std::string string(const std::string& k, bool required, const std::string& dflt = {},
                     const std::vector<std::string>& allowed = {}) {
    const toml::node* n = node(k);
    std::string expected = "a string";
    if (!allowed.empty()) {
      expected = "one of";
      for (const auto& a : allowed) expected += " \"" + a + "\"";
    }
    if (!n) {
      if (required) fail(k, "missing", expected);
      return dflt;
    }
    if (!n->is_string()) fail(k, "is not a string", expected);
    std::string v = n->as_string()->get();
    if (!allowed.empty() && std::find(allowed.begin(), allowed.end(), v) == allowed.end())
      fail(k, "unknown value \"" + v + "\"", expected);
    return v;
  }
  std::vector<double> numbers(const std::string& k, const std::string& expected, bool required) {
    const toml::node* n = node(k);
    if (!n) {
      if (required) fail(k, "missing", expected);
      return {};
    }
    if (!n->is_array()) fail(k, "is not an array", expected);
    std::vector<double> out;
    for (const auto& e : *n->as_array()) out.push_back(to_number(k, e, expected));
    return out;
  }
  // An array of strings, each one of `allowed`, none repeated; `dflt` when absent.
  std::vector<std::string> strings(const std::string& k, const std::vector<std::string>& dflt,
                                   const std::vector<std::string>& allowed) {
    const toml::node* n = node(k);
    std::string expected = "a non-empty array of distinct strings, each one of";
    for (const auto& a : allowed) expected += " \"" + a + "\"";
    if (!n) return dflt;
    if (!n->is_array() || n->as_array()->empty()) fail(k, "is not a non-empty array", expected);
    std::vector<std::string> out;
    for (const auto& e : *n->as_array()) {
      if (!e.is_string()) fail(k, "holds a non-string entry", expected);
      const std::string v = e.as_string()->get();
      if (std::find(allowed.begin(), allowed.end(), v) == allowed.end()) fail(k, "unknown value \"" + v + "\"", expected);
      if (std::find(out.begin(), out.end(), v) != out.end()) fail(k, "repeats \"" + v + "\"", expected);
      out.push_back(v);
    }
    return out;
  }
  // Throws if the table holds a key that was never read.
  void reject_unknown(const std::vector<std::string>& also_allowed = {}) const {
    if (!t_) return;
    for (const auto& [k, v] : *t_) {
      const std::string name(k.str());
      if (!used_.count(name) && std::find(also_allowed.begin(), also_allowed.end(), name) == also_allowed.end())
        fail(name, "unknown key", "only the keys documented in docs/case-file.md");
    }
  }
  const std::string& file() const { return file_; }
  const toml::table* table() const { return t_; }

 private:
  double to_number(const std::string& k, const toml::node& n, const std::string& expected) const {
    double v;
    if (n.is_floating_point()) v = n.as_floating_point()->get();
    else if (n.is_integer()) v = double(n.as_integer()->get());
    else fail(k, "is not a number", expected);
    if (!std::isfinite(v)) fail(k, "is not finite", expected);
    return v;
  }
  const toml::table* t_;
  std::string file_, path_;
  std::set<std::string> used_;
};

Body parse_body(Section s) {
  Body b;
  b.mass = s.positive("mass_kg", "kg");
  b.length = s.positive("length_m", "m");
  b.width = s.positive("width_m", "m");
  b.height = s.positive("height_m", "m");
  b.drag_coefficient = s.number_or("drag_coefficient", 0.0, "a non-negative number");
  if (b.drag_coefficient < 0) s.fail("drag_coefficient", "must not be negative", "a non-negative number");
  b.inertia = b.ellipsoid_inertia();
  if (s.has("inertia_kg_m2")) {
    Section in = s.sub("inertia_kg_m2", true);
    const double xx = in.positive("xx", "kg m^2"), yy = in.positive("yy", "kg m^2"),
                 zz = in.positive("zz", "kg m^2"), xz = in.number_or("xz", 0.0, "a number in kg m^2");
    in.reject_unknown();
    b.inertia << xx, 0, -xz, 0, yy, 0, -xz, 0, zz;  // product of inertia Ixz = int x z dm
    if (Eigen::SelfAdjointEigenSolver<Mat3>(b.inertia).eigenvalues().minCoeff() <= 0)
      s.fail("inertia_kg_m2", "is not positive definite", "a physical inertia tensor");
  }
  s.reject_unknown();
  return b;
}

Wing parse_wing(Section s) {
  Wing w;
  w.length = s.positive("length_m", "m");
  w.mean_chord = s.positive("mean_chord_m", "m");
  const std::string pf =
      s.string("planform", false, "elliptic", {"elliptic", "rectangular", "tabulated", "polynomial"});
  w.planform = pf == "elliptic"      ? Planform::elliptic
               : pf == "rectangular" ? Planform::rectangular
               : pf == "tabulated"   ? Planform::tabulated
                                     : Planform::polynomial;
  if (w.planform == Planform::polynomial) {
    const std::string expected = "coefficients a_k of c(r) = sum_k a_k (r/R)^k, k = 0..n (n <= 20), c >= 0 on [0, 1]";
    w.poly = s.numbers("chord_coefficients", expected, true);
    if (w.poly.empty() || w.poly.size() > 21) s.fail("chord_coefficients", "needs 1 to 21 coefficients", expected);
    // Normalise so that the mean chord is exactly mean_chord_m (area = mean_chord_m R): int_0^1 sum a_k x^k = sum a_k/(k+1).
    double area = 0;
    for (std::size_t k = 0; k < w.poly.size(); ++k) area += w.poly[k] / double(k + 1);
    if (!(area > 0)) s.fail("chord_coefficients", fmt::format("encloses no area (integral {:.6g})", area), expected);
    for (double& a : w.poly) a /= area;
    const double lowest = polynomial_minimum_on_unit_interval(w.poly);
    if (lowest < -1e-12)
      s.fail("chord_coefficients",
             fmt::format("gives a negative chord on [0, 1] (c/c_bar = {:.6g} at its minimum)", lowest), expected);
  } else if (s.has("chord_coefficients")) {
    s.fail("chord_coefficients", "given for planform \"" + pf + "\"", "planform = \"polynomial\"");
  }
  if (w.planform == Planform::tabulated) {
    w.table_r = s.numbers("r_over_R", "an increasing array of r/R in [0, 1]", true);
    w.table_c = s.numbers("chord_over_mean", "an array of c/c_bar >= 0, as long as r_over_R", true);
    if (w.table_r.size() < 2 || w.table_r.size() != w.table_c.size())
      s.fail("chord_over_mean", "length differs from r_over_R or fewer than 2 points", "matching arrays");
    for (std::size_t i = 0; i < w.table_r.size(); ++i) {
      if (w.table_r[i] < 0 || w.table_r[i] > 1 || (i && w.table_r[i] <= w.table_r[i - 1]))
        s.fail("r_over_R", "not strictly increasing within [0, 1]", "an increasing array of r/R in [0, 1]");
      if (w.table_c[i] < 0) s.fail("chord_over_mean", "negative chord", "c/c_bar >= 0");
    }
    // Normalise the table so that its mean chord is exactly mean_chord_m.
    double area = 0;
    for (std::size_t i = 1; i < w.table_r.size(); ++i)
      area += 0.5 * (w.table_c[i] + w.table_c[i - 1]) * (w.table_r[i] - w.table_r[i - 1]);
    if (!(area > 0)) s.fail("chord_over_mean", "encloses no area", "a planform with positive area");
    for (double& c : w.table_c) c /= area;
  }
  w.pitch_axis = s.number_or("pitch_axis_chord_fraction", 0.25, "a fraction of chord in [0, 1]");
  if (w.pitch_axis < 0 || w.pitch_axis > 1)
    s.fail("pitch_axis_chord_fraction", "outside [0, 1]", "a fraction of chord in [0, 1]");
  w.mass = s.positive("mass_kg", "kg");
  const auto h = s.numbers("hinge_m", "[x, y, z] of the right-wing hinge in body axes (m)", true);
  if (h.size() != 3) s.fail("hinge_m", "does not have 3 components", "[x, y, z] in m");
  w.hinge = Vec3(h[0], h[1], h[2]);
  Vec3 centre;
  Mat3 ih;
  w.plate_mass_properties(centre, ih);
  if (s.has("mass_centre_m")) {
    const auto c = s.numbers("mass_centre_m", "[x_chord, r_span] in the wing frame (m)", true);
    if (c.size() != 2) s.fail("mass_centre_m", "does not have 2 components", "[x_chord, r_span] in m");
    centre = Vec3(c[0], c[1], 0);
  }
  if (s.has("inertia_hinge_kg_m2")) {
    Section in = s.sub("inertia_hinge_kg_m2", true);
    const double xx = in.positive("xx", "kg m^2"), yy = in.positive("yy", "kg m^2"),
                 zz = in.positive("zz", "kg m^2"), xy = in.number_or("xy", 0.0, "a number in kg m^2");
    in.reject_unknown();
    ih << xx, -xy, 0, -xy, yy, 0, 0, 0, zz;
  }
  w.mass_centre = centre;
  // Parallel-axis theorem: inertia about the wing CoM.
  w.inertia_cg = ih - w.mass * (centre.squaredNorm() * Mat3::Identity() - centre * centre.transpose());
  if (Eigen::SelfAdjointEigenSolver<Mat3>(w.inertia_cg).eigenvalues().minCoeff() < -1e-12 * ih.norm())
    s.fail("inertia_hinge_kg_m2", "inconsistent with the wing mass and mass centre (negative inertia about the CoM)",
           "an inertia about the hinge at least m |r_cg|^2");
  s.reject_unknown();
  return w;
}

AngleSeries parse_angle(Section s, const std::string& name, double default_mean_deg) {
  if (!s.present()) return FourierSeries{default_mean_deg * deg, {}, {}};
  const std::string type = s.string("type", false, "fourier", {"fourier", "hermite", "berman-wang"});
  AngleSeries out;
  if (type == "berman-wang") {
    // Berman & Wang (2007, J Fluid Mech 582:153); see core/series.hpp for the three forms.
    BermanWangSeries b;
    b.form = name == "stroke" ? BermanWangSeries::Form::stroke
             : name == "pitch" ? BermanWangSeries::Form::pitch : BermanWangSeries::Form::deviation;
    b.amplitude = s.number("amplitude_deg", "the amplitude in degrees (half the peak-to-peak excursion)") * deg;
    b.mean = s.number_or("mean_deg", default_mean_deg, "a number in degrees") * deg;
    b.phase = s.number_or("phase_deg", 0.0, "a phase in degrees of the wingbeat") * deg;
    if (b.form == BermanWangSeries::Form::stroke) {
      const std::string expected = "K in (0, 1) (K -> 0: a cosine, K -> 1: a triangle wave)";
      b.shape = s.number("shape_k", expected);
      if (!(b.shape > 0 && b.shape < 1)) s.fail("shape_k", fmt::format("out of range: {:.6g}", b.shape), expected);
    } else if (b.form == BermanWangSeries::Form::pitch) {
      const std::string expected = "C in (0, 1000] (C -> 0: a sine, large C: a square wave)";
      b.shape = s.number("shape_c", expected);
      if (!(b.shape > 0 && b.shape <= 1000)) s.fail("shape_c", fmt::format("out of range: {:.6g}", b.shape), expected);
    } else {
      if (!s.has("harmonic")) s.fail("harmonic", "missing", "the harmonic N of the deviation, an integer in [1, 16]");
      b.harmonic = s.integer_or("harmonic", 1, 1, 16);
    }
    out = b;
  } else if (type == "fourier") {
    FourierSeries f;
    f.mean = s.number_or("mean_deg", default_mean_deg, "a number in degrees") * deg;
    f.a = s.numbers("cos_deg", "an array of cosine coefficients in degrees", false);
    f.b = s.numbers("sin_deg", "an array of sine coefficients in degrees", false);
    if (f.a.empty() && !f.b.empty()) f.a.assign(f.b.size(), 0.0);
    if (f.b.empty() && !f.a.empty()) f.b.assign(f.a.size(), 0.0);
    if (f.a.size() != f.b.size()) s.fail("sin_deg", "length differs from cos_deg", "as many sine as cosine coefficients");
    for (double& x : f.a) x *= deg;
    for (double& x : f.b) x *= deg;
    out = f;
  } else {
    HermiteSeries h;
    h.values = s.numbers("values_deg", "an array of node values in degrees", true);
    h.slopes = s.numbers("slopes_deg_per_cycle", "an array of node slopes in degrees per cycle", true);
    if (h.values.size() < 2 || h.values.size() != h.slopes.size())
      s.fail("slopes_deg_per_cycle", "length differs from values_deg or fewer than 2 nodes", "matching arrays");
    for (double& x : h.values) x *= deg;
    for (double& x : h.slopes) x *= deg;
    out = h;
  }
  s.reject_unknown();
  return out;
}

// [abdomen]: the second body segment (core/insect.hpp Abdomen). The inertia is given about the joint, in the
// abdomen frame (A at zero relative pitch), and held about the abdomen's CoM.
Abdomen parse_abdomen(Section s) {
  Abdomen a;
  a.mass = s.positive("mass_kg", "kg");
  auto point = [&s](const char* key, const std::string& expected) {
    const auto v = s.numbers(key, expected, true);
    if (v.size() != 3) s.fail(key, fmt::format("has {} components", v.size()), expected);
    if (v[1] != 0) s.fail(key, fmt::format("y = {:.6g} is off the plane of symmetry", v[1]), expected);
    return Vec3(v[0], v[1], v[2]);
  };
  a.joint = point("joint_m", "[x, 0, z] of the thorax-abdomen joint in body axes A, from the thorax CoM (m)");
  a.centre = point("mass_centre_m", "[x, 0, z] of the abdomen CoM from the joint, abdomen axes (m)");
  if (!s.has("inertia_joint_kg_m2"))
    s.fail("inertia_joint_kg_m2", "missing", "{ xx, yy, zz, xz } about the joint, abdomen axes (kg m^2)");
  Section in = s.sub("inertia_joint_kg_m2", true);
  const double xx = in.positive("xx", "kg m^2"), yy = in.positive("yy", "kg m^2"), zz = in.positive("zz", "kg m^2"),
               xz = in.number_or("xz", 0.0, "a number in kg m^2");
  in.reject_unknown();
  Mat3 ij;
  ij << xx, 0, -xz, 0, yy, 0, -xz, 0, zz;  // product of inertia Ixz = int x z dm
  const Vec3& c = a.centre;
  a.inertia_cg = ij - a.mass * (c.squaredNorm() * Mat3::Identity() - c * c.transpose());
  const double lowest = Eigen::SelfAdjointEigenSolver<Mat3>(a.inertia_cg).eigenvalues().minCoeff();
  if (lowest < -1e-12 * ij.norm())
    s.fail("inertia_joint_kg_m2",
           fmt::format("inconsistent with the abdomen mass and mass centre (a principal inertia about its CoM of {:.4g} "
                       "kg m^2)", lowest),
           "an inertia about the joint at least m |r_cg|^2 about each axis");
  a.pitch = parse_angle(s.sub("pitch", false), "pitch", 0.0);
  // Optional drag: an ellipsoid of the given diameters centred at the abdomen CoM.
  a.drag_coefficient = s.number_or("drag_coefficient", 0.0, "a drag coefficient >= 0");
  if (a.drag_coefficient < 0 || a.drag_coefficient > 10)
    s.fail("drag_coefficient", fmt::format("{:.6g} outside [0, 10]", a.drag_coefficient), "a drag coefficient in [0, 10]");
  const char* dims[3] = {"length_m", "width_m", "height_m"};
  for (int i = 0; i < 3; ++i) {
    if (a.drag_coefficient > 0)
      a.diameters[i] = s.positive(dims[i], "m (a diameter of the abdomen's drag ellipsoid)");
    else if (s.has(dims[i]))
      s.fail(dims[i], "given without drag_coefficient (the ellipsoid is used for the abdomen's drag only)",
             "drag_coefficient > 0 with length_m, width_m, height_m, or none of them");
  }
  s.reject_unknown();
  return a;
}

WingAngles parse_wing_angles(Section& s, const std::string& dir, const WingAngles* fallback) {
  if (s.has("file")) {
    const std::string f = s.string("file", true);
    const std::filesystem::path p = std::filesystem::path(dir) / f;
    if (!std::filesystem::exists(p)) s.fail("file", "no such file: " + p.string(), "a FLUSI kinematics .ini file");
    for (const char* k : {"stroke", "deviation", "pitch"})
      if (s.has(k)) s.fail(k, "given together with 'file'", "either a kinematics file or angle series");
    return read_flusi_kinematics(p.string());
  }
  WingAngles w;
  if (fallback && !s.has("stroke") && !s.has("deviation") && !s.has("pitch")) return *fallback;
  if (!fallback && !s.has("stroke")) s.fail("stroke", "missing", "a table of stroke-angle coefficients");
  w.stroke = parse_angle(s.sub("stroke", false), "stroke", 0.0);
  w.deviation = parse_angle(s.sub("deviation", false), "deviation", 0.0);
  w.pitch = parse_angle(s.sub("pitch", false), "pitch", 90.0);
  if (!s.has("pitch") && !fallback) s.fail("pitch", "missing", "a table of pitch-angle coefficients");
  return w;
}

Kinematics parse_kinematics(Section s, const std::string& dir) {
  Kinematics k;
  k.frequency_hz = s.positive("frequency_hz", "Hz");
  k.stroke_plane = s.number_or("stroke_plane_deg", 0.0, "a number in degrees") * deg;
  k.body_angle = s.number("body_angle_deg", "a number in degrees") * deg;
  if (std::abs(k.stroke_plane) > 90 * deg) s.fail("stroke_plane_deg", "outside [-90, 90]", "an angle in [-90, 90] deg");
  if (std::abs(k.body_angle) > 90 * deg) s.fail("body_angle_deg", "outside [-90, 90]", "an angle in [-90, 90] deg");
  // "horizontal": stroke_plane_deg from the stability x-y plane (the stroke plane stays put when the body pitches);
  // "body": from the body long axis, the stroke plane fixed to the body.
  k.stroke_plane_on_body = s.string("stroke_plane_reference", false, "horizontal", {"horizontal", "body"}) == "body";
  if (s.string("type", false, "flapping", {"flapping", "revolving"}) == "revolving") {
    // Revolving wings: constant stroke velocity (one revolution per cycle, towards the head at the
    // lateral position), fixed pitch = incidence, no deviation; the left wing mirrors the right.
    for (const char* key : {"stroke", "deviation", "pitch", "file", "left"})
      if (s.has(key)) s.fail(key, "given for revolving wings", "only pitch_deg for type = \"revolving\"");
    const double pitch = s.number("pitch_deg", "the fixed incidence in degrees, in (0, 90]");
    if (!(pitch > 0 && pitch <= 90)) s.fail("pitch_deg", "outside (0, 90]", "the fixed incidence in degrees, in (0, 90]");
    k.right.stroke = FourierSeries{0.0, {}, {}, 2 * pi};
    k.right.deviation = FourierSeries{};
    k.right.pitch = FourierSeries{pitch * deg, {}, {}};
    k.left = k.right;
    s.reject_unknown();
    return k;
  }
  if (s.has("pitch_deg")) s.fail("pitch_deg", "given for flapping wings", "type = \"revolving\" (or a [kinematics.pitch] table)");
  k.right = parse_wing_angles(s, dir, nullptr);
  if (s.has("left")) {
    Section l = s.sub("left", true);
    k.left = parse_wing_angles(l, dir, &k.right);
    l.reject_unknown();
  } else {
    k.left = k.right;
  }
  if (s.has("hind")) {
    // [kinematics.hind]: the hind pair's angles (same keys as the fore pair's), phase_deg ahead of the fore pair,
    // [kinematics.hind.left] for an asymmetric hind pair.
    Section h = s.sub("hind", true);
    k.has_hind = true;
    k.hind_right = parse_wing_angles(h, dir, nullptr);
    k.hind_phase = h.number_or("phase_deg", 0.0, "the hind pair's phase lead in degrees of the wingbeat") / 360.0;
    if (h.has("left")) {
      Section l = h.sub("left", true);
      k.hind_left = parse_wing_angles(l, dir, &k.hind_right);
      l.reject_unknown();
    } else {
      k.hind_left = k.hind_right;
    }
    h.reject_unknown();
  }
  s.reject_unknown();
  return k;
}

// [aero.quasi_steady] constants of the translational coefficient sets (docs/theory/quasi-steady.md section 3):
// each set's own sub-table, refused for another set; the rotational coefficient and the centre of pressure.
void parse_coefficient_constants(Section& qs, QuasiSteadySettings& q) {
  for (const char* set : {"robofly", "berman-wang", "table"})
    if (qs.has(set) && q.coefficients != set)
      qs.fail(set, "given for coefficients = \"" + q.coefficients + "\"", std::string("coefficients = \"") + set + "\"");
  auto& k = q.constants;
  Section r = qs.sub("robofly", false);
  auto num = [](Section& s, const char* key, double& v) { v = s.number_or(key, v, "a number"); };
  num(r, "lift_mean", k.robofly.lift_mean);
  num(r, "lift_amplitude", k.robofly.lift_amplitude);
  num(r, "lift_rate", k.robofly.lift_rate);
  num(r, "lift_offset_deg", k.robofly.lift_offset_deg);
  num(r, "drag_mean", k.robofly.drag_mean);
  num(r, "drag_amplitude", k.robofly.drag_amplitude);
  num(r, "drag_rate", k.robofly.drag_rate);
  num(r, "drag_offset_deg", k.robofly.drag_offset_deg);
  r.reject_unknown();
  if (r.present()) {
    // A drag coefficient below zero somewhere in [0, 90] deg would push the wing along the flow.
    for (int a = 0; a <= 900; ++a) {
      const double d = k.robofly.drag_mean -
                       k.robofly.drag_amplitude * std::cos((k.robofly.drag_rate * a / 10.0 - k.robofly.drag_offset_deg) * deg);
      if (d < 0)
        r.fail("drag_mean", fmt::format("gives C_D = {:.4g} < 0 at alpha = {:g} deg", d, a / 10.0),
               "constants whose C_D(alpha) >= 0 on [0, 90] deg");
    }
  }
  Section b = qs.sub("berman-wang", false);
  auto coefficient = [](Section& s, const char* key, double& v, double lo, const char* what) {
    const std::string expected = fmt::format("{} in [{:g}, 10]", what, lo);
    v = s.number_or(key, v, expected);
    if (!(v >= lo && v <= 10)) s.fail(key, fmt::format("out of range: {:.6g}", v), expected);
  };
  coefficient(b, "c_t", k.berman_wang.c_t, 0, "C_T");
  coefficient(b, "c_d_0", k.berman_wang.c_d_0, 0, "C_D(0)");
  coefficient(b, "c_d_90", k.berman_wang.c_d_90, 0, "C_D(pi/2)");
  b.reject_unknown();
  Section t = qs.sub("table", q.coefficients == "table");
  if (t.present()) {
    const std::string ea = "angles of attack in deg, strictly increasing from 0 to 90, at least 4";
    k.table.alpha_deg = t.numbers("alpha_deg", ea, true);
    k.table.lift = t.numbers("lift", "C_L at each alpha_deg", true);
    k.table.drag = t.numbers("drag", "C_D >= 0 at each alpha_deg", true);
    const auto& al = k.table.alpha_deg;
    if (al.size() < 4) t.fail("alpha_deg", fmt::format("has {} points", al.size()), ea);
    if (al.front() != 0 || al.back() != 90) t.fail("alpha_deg", "does not run from 0 to 90", ea);
    for (std::size_t i = 1; i < al.size(); ++i)
      if (!(al[i] > al[i - 1])) t.fail("alpha_deg", "not strictly increasing", ea);
    if (k.table.lift.size() != al.size()) t.fail("lift", "length differs from alpha_deg", "C_L at each alpha_deg");
    if (k.table.drag.size() != al.size()) t.fail("drag", "length differs from alpha_deg", "C_D >= 0 at each alpha_deg");
    for (double d : k.table.drag)
      if (d < 0) t.fail("drag", fmt::format("negative value {:.6g}", d), "C_D >= 0 at each alpha_deg");
  }
  t.reject_unknown();
  if (qs.has("rotational_coefficient")) {
    const std::string expected = "C_R in [-10, 10] (thin-aerofoil theory: pi (3/4 - x0))";
    const double v = qs.number("rotational_coefficient", expected);
    if (!(v >= -10 && v <= 10)) qs.fail("rotational_coefficient", fmt::format("out of range: {:.6g}", v), expected);
    q.rotational_coefficient = v;
  }
  q.centre_of_pressure = qs.number_or("centre_of_pressure_chord_fraction", 0.25, "a fraction of chord in [0, 1]");
  if (!(q.centre_of_pressure >= 0 && q.centre_of_pressure <= 1))
    qs.fail("centre_of_pressure_chord_fraction", "outside [0, 1]", "a fraction of chord from the leading edge in [0, 1]");
}

FpmSettings parse_fpm(Section s) {
  FpmSettings f;
  if (!s.present()) return f;
  f.enabled = s.boolean_or("enabled", true);
  f.samples_per_cycle = s.integer_or("samples_per_cycle", f.samples_per_cycle, 1, 100000);
  f.components = s.strings("components", f.components, {"Fx", "Fy", "Fz", "Mx", "My", "Mz", "power"});
  f.parts = s.strings("parts", f.parts, {"body", "right", "left", "hind_right", "hind_left"});
  f.regions = s.strings("regions", f.regions, {"leading-edge", "trailing-edge", "tip"});
  f.region_size_chords = s.positive_in("region_size_chords", f.region_size_chords, 0.05, 10, "a distance in mean chords");
  f.fields_per_cycle = s.integer_or("fields_per_cycle", f.fields_per_cycle, 0, 100000);
  f.tolerance = s.positive_in("tolerance", f.tolerance, 1e-12, 1e-2, "a relative residual");
  f.body = s.string("body", false, f.body, {"surface", "forced-region"});
  s.reject_unknown();
  return f;
}

CfdSettings parse_cfd(Section s) {
  CfdSettings d;
  auto margin = [&](const char* k, double dflt) {
    const double v = s.number_or(k, dflt, "a margin >= 0 in wing lengths R");
    if (!(v >= 0) || v > 100) s.fail(k, fmt::format("out of range: {:.6g}", v), "a margin in [0, 100] wing lengths R");
    return v;
  };
  d.upstream_R = margin("upstream_R", d.upstream_R);
  d.downstream_R = margin("downstream_R", d.downstream_R);
  d.lateral_R = margin("lateral_R", d.lateral_R);
  d.above_R = margin("above_R", d.above_R);
  d.below_R = margin("below_R", d.below_R);
  d.fine_margin_R = margin("fine_margin_R", d.fine_margin_R);
  d.sponge_R = margin("sponge_R", d.sponge_R);
  const char* rate_expected = "a relaxation rate at the face, per wingbeat, in (0, 1000]";
  d.sponge_rate = s.number_or("sponge_rate", d.sponge_rate, rate_expected);
  if (!(d.sponge_rate > 0 && d.sponge_rate <= 1000))
    s.fail("sponge_rate", fmt::format("out of range: {:.6g}", d.sponge_rate), rate_expected);
  d.sponge_faces = s.strings("sponge_faces", d.sponge_faces, {"upstream", "downstream", "lateral", "above", "below"});
  if (s.has("cells_per_chord") && s.has("cells_per_wing_length"))
    s.fail("cells_per_wing_length", "given together with 'cells_per_chord'", "one of the two");
  auto resolution = [&](const char* k, double dflt) {
    const double v = s.number_or(k, dflt, "a number of cells in [1, 10000]");
    if (!(v >= 1) || v > 10000) s.fail(k, fmt::format("out of range: {:.6g}", v), "a number of cells in [1, 10000]");
    return v;
  };
  d.cells_per_chord = resolution("cells_per_chord", d.cells_per_chord);
  if (s.has("cells_per_wing_length")) d.cells_per_wing_length = resolution("cells_per_wing_length", 0);
  d.stretch_ratio = s.number_or("stretch_ratio", d.stretch_ratio, "a ratio in [1, 1.1]");
  if (!(d.stretch_ratio >= 1 && d.stretch_ratio <= 1.1))
    s.fail("stretch_ratio", fmt::format("out of range: {}", d.stretch_ratio),
           "a ratio in [1, 1.1] (multigrid degrades beyond about 1.08)");
  if (s.has("reynolds")) {
    d.reynolds = s.positive("reynolds", "(U_ref L_ref / nu, U_ref = 2 Phi f R, L_ref = mean chord)");
    if (d.reynolds > 1e7) s.fail("reynolds", fmt::format("out of range: {}", d.reynolds), "a Reynolds number in (0, 1e7]");
  }
  d.cycles = s.integer_or("cycles", d.cycles, 1, 100000);
  auto tolerance = [&](const char* k, double dflt) {
    const double v = s.number_or(k, dflt, "a fraction of the weight in (0, 1)");
    if (!(v > 0 && v < 1)) s.fail(k, fmt::format("out of range: {:.6g}", v), "a fraction of the weight in (0, 1)");
    return v;
  };
  d.hover_tolerance = tolerance("hover_tolerance", d.hover_tolerance);
  d.perturbation_tolerance = tolerance("perturbation_tolerance", d.perturbation_tolerance);
  d.max_cycles = s.integer_or("max_cycles", d.max_cycles, 2, 100000);
  d.trim_tolerance = tolerance("trim_tolerance", d.trim_tolerance);
  d.trim_iterations = s.integer_or("trim_iterations", d.trim_iterations, 0, 1000);
  if (s.has("steps_per_cycle") && s.has("cfl"))
    s.fail("cfl", "given together with 'steps_per_cycle'", "either a fixed step (steps_per_cycle) or a CFL number");
  d.steps_per_cycle = s.integer_or("steps_per_cycle", d.steps_per_cycle, 1, 100000000);
  d.cfl = s.number_or("cfl", d.cfl, "a CFL number in (0, 1.7]");
  if (!(d.cfl > 0 && d.cfl <= 1.7)) s.fail("cfl", fmt::format("out of range: {}", d.cfl), "a CFL number in (0, 1.7]");
  d.fields_per_cycle = s.integer_or("fields_per_cycle", d.fields_per_cycle, 0, 100000);
  d.surfaces_per_cycle = s.integer_or("surfaces_per_cycle", d.surfaces_per_cycle, 0, 100000);
  d.checkpoints_per_cycle = s.integer_or("checkpoints_per_cycle", d.checkpoints_per_cycle, 0, 100000);
  d.field_precision = s.string("field_precision", false, d.field_precision, {"float64", "float32"});
  d.field_files = s.string("field_files", false, d.field_files, {"whole", "per-rank"});
  d.loads = s.string("loads", false, d.loads, {"exchange", "surface"});
  d.pressure_solver = s.string("pressure_solver", false, d.pressure_solver, {"multigrid", "hypre"});
  // Mesh sizes: the level sets are built from the meshes before the first step, at a cost that grows with the
  // triangle count (body_divisions = 1000 took 11 min and 4 GB); far beyond what any grid resolves.
  d.body_divisions = s.integer_or("body_divisions", d.body_divisions, 2, 200);
  d.wing_span_stations = s.integer_or("wing_span_stations", d.wing_span_stations, 2, 1000);
  d.wing_chord_divisions = s.integer_or("wing_chord_divisions", d.wing_chord_divisions, 1, 200);
  d.threads = s.integer_or("threads", d.threads, 0, 4096);
  d.fpm = parse_fpm(s.sub("fpm", false));
  s.reject_unknown();
  return d;
}

}  // namespace

std::string TrimParameterSpec::label() const {
  return side == ParameterSide::both ? name : name + (side == ParameterSide::left ? "[left]" : "[right]");
}

const std::vector<std::string>& trim_parameter_names() {
  static const std::vector<std::string> names = {
      "frequency_hz",       "stroke_amplitude_deg", "stroke_mean_deg",  "pitch_mean_deg",
      "pitch_amplitude_deg", "deviation_mean_deg",  "stroke_plane_deg", "body_angle_deg",
      // Parameters of the Berman & Wang (2007) angle forms (type = "berman-wang" only, but deviation_amplitude_deg
      // also scales an oscillating Fourier or Hermite deviation).
      "stroke_shape_k", "pitch_shape_c", "pitch_phase_deg", "deviation_amplitude_deg", "deviation_phase_deg",
      // Added to the abdomen's relative pitch at every phase (an insect with an [abdomen]).
      "abdomen_flexion_deg"};
  return names;
}

void check_cfd_geometry(const Insect& insect, const std::string& path, const std::string& key) {
  // A hind pair ([hind_wing]) is in the CFD geometry (parts hind_right, hind_left); the abdomen is not.
  if (insect.abdomen)
    throw InputError(path, key.empty() ? "abdomen" : key,
                     "an insect with an [abdomen] is not in the CFD geometry (one rigid body)",
                     "model = \"quasi-steady\" for an abdomen");
}

void check_pitch_oscillation(const Case& c) {
  if (!c.derivatives.pitch_oscillation.enabled) return;
  if (c.aero.model != "cfd")
    throw InputError(c.path, "derivatives.pitch_oscillation",
                     "a forced pitch oscillation is a CFD run (the quasi-steady model has no wake to lag), but "
                     "[aero] model is \"" + c.aero.model + "\"",
                     "[aero] model = \"cfd\" (or remove [derivatives.pitch_oscillation])");
  if (c.derivatives.columns == "lateral")
    throw InputError(c.path, "derivatives.pitch_oscillation",
                     "a pitch oscillation completes a longitudinal table, but [derivatives] columns is \"lateral\"",
                     "columns = \"longitudinal\" or \"all\" (or remove [derivatives.pitch_oscillation])");
  if (c.aero.cfd.trim_iterations > 0)
    throw InputError(c.path, "derivatives.pitch_oscillation",
                     fmt::format("the oscillation runs about the kept hover's kinematics, which a CFD trim moves "
                                 "([aero.cfd] trim_iterations = {})", c.aero.cfd.trim_iterations),
                     "[aero.cfd] trim_iterations = 0 (or remove [derivatives.pitch_oscillation])");
}

Case load_case(const std::string& path) {
  if (!std::filesystem::exists(path)) throw InputError(path, "", "no such file", "a TOML case file");
  toml::table root;
  try {
    root = toml::parse_file(path);
  } catch (const toml::parse_error& e) {
    throw InputError(path, "", fmt::format("TOML syntax error at line {}, column {}: {}", e.source().begin.line,
                                           e.source().begin.column, e.description()),
                     "valid TOML");
  }
  Case c;
  c.path = path;
  const std::string dir = std::filesystem::path(path).parent_path().string();
  Section top(&root, path, "");

  Section insect = top.sub("insect", true);
  c.insect.name = insect.string("name", true);
  c.description = insect.string("description", false);
  const toml::node* src = insect.node("sources");
  if (!src || !src->is_array() || src->as_array()->empty())
    insect.fail("sources", src ? "is not a non-empty array" : "missing", "a non-empty array of citations (strings)");
  for (const auto& e : *src->as_array()) {
    if (!e.is_string()) insect.fail("sources", "holds a non-string entry", "an array of strings");
    c.sources.push_back(e.as_string()->get());
  }
  insect.reject_unknown();

  c.insect.body = parse_body(top.sub("body", true));
  c.insect.wing = parse_wing(top.sub("wing", true));
  if (top.has("hind_wing")) c.insect.hind_wing = parse_wing(top.sub("hind_wing", true));
  if (top.has("abdomen")) c.insect.abdomen = parse_abdomen(top.sub("abdomen", true));
  c.kinematics = parse_kinematics(top.sub("kinematics", true), dir);
  // A hind pair needs both its wing ([hind_wing]: planform, hinge, mass) and its kinematics ([kinematics.hind]).
  if (c.insect.hind_wing && !c.kinematics.has_hind)
    throw InputError(path, "kinematics.hind", "missing for the [hind_wing] pair",
                     "a [kinematics.hind] table with the hind pair's stroke and pitch");
  if (c.kinematics.has_hind && !c.insect.hind_wing)
    throw InputError(path, "hind_wing", "missing section for the [kinematics.hind] pair",
                     "a [hind_wing] table (length_m, mean_chord_m, planform, mass_kg, hinge_m, ...)");

  Section fluid = top.sub("fluid", false);
  c.fluid.density = fluid.positive_or("density_kg_m3", 1.225, "kg/m^3");
  c.fluid.kinematic_viscosity = fluid.positive_or("kinematic_viscosity_m2_s", 1.5e-5, "m^2/s");
  fluid.reject_unknown();

  // [environment]: gravity where the insect flies (weight in the trim, the equations of motion, the derivatives'
  // gravity terms, free flight). From Pluto's surface (0.62) and the Moon (1.62) to a 10 g centrifuge; outside
  // that range a value is a unit error.
  Section env = top.sub("environment", false);
  c.insect.gravity = env.positive_in("gravity_m_s2", standard_gravity, 0.1, 100.0, "an acceleration in m/s^2");
  env.reject_unknown();

  Section aero = top.sub("aero", false);
  c.aero.model = aero.string("model", false, "quasi-steady", {"quasi-steady", "cfd"});
  Section qs = aero.sub("quasi_steady", false);
  auto& q = c.aero.quasi_steady;
  q.coefficients = qs.string("coefficients", false, "robofly", {"robofly", "berman-wang", "table"});
  parse_coefficient_constants(qs, q);
  q.blade_elements = qs.integer_or("blade_elements", 40, 2, 10000);
  q.rotational = qs.boolean_or("rotational", true);
  q.added_mass = qs.boolean_or("added_mass", true);
  q.samples_per_cycle = qs.integer_or("samples_per_cycle", 128, 8, 1000000);
  qs.reject_unknown();
  c.aero.cfd = parse_cfd(aero.sub("cfd", false));
  aero.reject_unknown();
  if (c.aero.cfd.fpm.enabled && c.aero.model != "cfd")
    throw InputError(path, "aero.cfd.fpm", "force partitioning splits the loads of a CFD run, but [aero] model is \"" +
                                               c.aero.model + "\"",
                     "[aero] model = \"cfd\" (or remove [aero.cfd.fpm])");
  if (c.aero.model == "cfd") check_cfd_geometry(c.insect, path, "aero.model");
  // The hind pair's parts exist only in a four-winged insect's geometry.
  if (!c.insect.hind_wing)
    for (const auto& p : c.aero.cfd.fpm.parts)
      if (p == "hind_right" || p == "hind_left")
        throw InputError(path, "aero.cfd.fpm.parts",
                         "\"" + p + "\" is a wing of the hind pair, but the insect has none ([hind_wing])",
                         "parts among \"body\", \"right\", \"left\" (or a [hind_wing] pair)");

  Section trim = top.sub("trim", false);
  c.trim.solver = trim.string("solver", false, "ipopt", {"ipopt", "nlopt"});
  c.trim.objective = trim.string("objective", false, "least-change", {"least-change", "min-power"});
  c.trim.tolerance = trim.positive_in("tolerance", 1e-10, 1e-14, 0.1, "a relative residual");
  c.trim.max_iterations = trim.integer_or("max_iterations", 200, 1, 100000);
  c.trim.cyclic_attitude = trim.string("cyclic_attitude", false, "imposed", {"imposed", "free"});
  if (const toml::node* ps = trim.node("parameter")) {
    if (!ps->is_array_of_tables()) trim.fail("parameter", "is not an array of tables", "[[trim.parameter]] entries");
    int i = 0;
    for (const auto& e : *ps->as_array()) {
      Section p(e.as_table(), path, fmt::format("trim.parameter[{}]", i++));
      TrimParameterSpec spec;
      spec.name = p.string("name", true, {}, trim_parameter_names());
      spec.lower = p.number("lower", "a number (lower bound)");
      spec.upper = p.number("upper", "a number (upper bound)");
      if (!(spec.lower < spec.upper)) p.fail("upper", "not above 'lower'", "upper > lower");
      const std::string side = p.string("side", false, "both", {"both", "left", "right"});
      spec.side = side == "both" ? ParameterSide::both : side == "left" ? ParameterSide::left : ParameterSide::right;
      p.reject_unknown();
      for (const auto& o : c.trim.parameters)
        if (o.name == spec.name && (o.side == spec.side || o.side == ParameterSide::both || spec.side == ParameterSide::both))
          p.fail("name", "parameter \"" + spec.name + "\" given twice for the same wing", "each parameter once");
      c.trim.parameters.push_back(spec);
    }
  }
  if (c.trim.cyclic_attitude == "free" &&
      std::none_of(c.trim.parameters.begin(), c.trim.parameters.end(),
                   [](const TrimParameterSpec& p) { return p.name == "body_angle_deg"; }))
    trim.fail("cyclic_attitude",
              "\"free\" lets the orbit's mean pitch take the place of body_angle_deg in the cyclic trim, but "
              "body_angle_deg is not a [[trim.parameter]]",
              "a [[trim.parameter]] with name = \"body_angle_deg\" (the averaged trim's moment balance), or "
              "cyclic_attitude = \"imposed\"");
  trim.reject_unknown();

  Section der = top.sub("derivatives", false);
  c.derivatives.relative_step = der.positive_in("relative_step", 0.01, 1e-6, 0.5, "a step / reference speed");
  if (c.derivatives.relative_step > 0.5) der.fail("relative_step", "too large", "a relative step below 0.5");
  c.derivatives.columns = der.string("columns", false, c.derivatives.columns, {"all", "longitudinal", "lateral"});
  c.derivatives.relative_rate_step = der.positive_in("relative_rate_step", 0.0, 1e-6, 0.5, "a rate step x c / U");
  if (Section po = der.sub("pitch_oscillation", false); po.present()) {
    auto& o = c.derivatives.pitch_oscillation;
    o.enabled = true;
    o.amplitude_deg = po.positive_in("amplitude_deg", o.amplitude_deg, 0.01, 15, "an amplitude in degrees");
    o.period_wingbeats = po.integer_or("period_wingbeats", o.period_wingbeats, 3, 1000);
    o.periods = po.integer_or("periods", o.periods, 1, 100);
    o.transient_wingbeats = po.integer_or("transient_wingbeats", o.period_wingbeats, 0, 10000);
    po.reject_unknown();
    check_pitch_oscillation(c);
  }
  der.reject_unknown();

  Section fl = top.sub("flight", false);
  auto& f = c.flight;
  f.dof = fl.string("dof", false, f.dof, {"6dof", "longitudinal", "pitch", "translation"});
  f.wingbeats = fl.positive_in("wingbeats", f.wingbeats, 1e-3, 1e5, "a number of wingbeats");
  if (f.wingbeats > 1e5) fl.fail("wingbeats", fmt::format("too many: {}", f.wingbeats), "at most 100000 wingbeats");
  f.samples_per_wingbeat = fl.integer_or("samples_per_wingbeat", f.samples_per_wingbeat, 1, 100000);
  f.rtol = fl.positive_in("rtol", f.rtol, 1e-14, 1e-3, "a relative tolerance");
  if (f.rtol < 1e-14 || f.rtol > 1e-3) fl.fail("rtol", fmt::format("out of range: {}", f.rtol), "a tolerance in [1e-14, 1e-3]");
  f.start = fl.string("start", false, f.start, {"periodic-orbit", "rest"});
  f.cfd_residual = fl.string("cfd_residual", false, f.cfd_residual, {"cancel", "keep"});
  f.cfd_reference = fl.string("cfd_reference", false, f.cfd_reference, {"open-loop", "closed-loop"});
  f.cfd_replan = fl.boolean_or("cfd_replan", f.cfd_replan);
  Section pert = fl.sub("perturbation", false);
  static const std::vector<std::pair<std::string, double>> pkeys = {
      {"x_m", 1}, {"y_m", 1}, {"z_m", 1}, {"u_m_s", 1}, {"v_m_s", 1}, {"w_m_s", 1}, {"p_deg_s", deg}, {"q_deg_s", deg},
      {"r_deg_s", deg}, {"phi_deg", deg}, {"theta_deg", deg}, {"psi_deg", deg}};
  for (const auto& [k, unit] : pkeys)
    if (pert.has(k)) {
      const double v = pert.number(k, "a number");
      f.perturbation.emplace_back(k.substr(0, k.find('_')), v * unit);
    }
  f.mode = pert.string("mode", false, "", {"longitudinal", "lateral"});
  f.mode_amplitude = pert.positive_or("mode_amplitude", f.mode_amplitude, "(non-dimensional)");
  if (f.mode_amplitude > 0.5) pert.fail("mode_amplitude", "too large for a perturbation", "at most 0.5");
  pert.reject_unknown();
  fl.reject_unknown();

  Section ctl = top.sub("control", false);
  auto& k = c.control;
  k.type = ctl.string("type", false, k.type, {"none", "pitch", "state-feedback"});
  k.update = ctl.string("update", false, k.update, {"continuous", "wingbeat"});
  auto latency = [](Section& s, const std::string& key, double dflt) {
    const double v = s.number_or(key, dflt, "a latency >= 0 in s");
    if (v < 0) s.fail(key, fmt::format("must not be negative, got {:.6g}", v), "a latency >= 0 in s");
    if (v > 10) s.fail(key, fmt::format("implausibly long: {} s", v), "a latency below 10 s");
    return v;
  };
  Section pc = ctl.sub("pitch", false);
  k.actuator = pc.string("actuator", false, k.actuator, trim_parameter_names());
  k.pitch_gain = pc.number_or("pitch_gain", 0.0, "a number (deg of actuator per deg of pitch)");
  k.rate_gain_s = pc.number_or("rate_gain_s", 0.0, "a number (deg of actuator per deg/s of pitch rate)");
  k.pitch_latency_s = latency(pc, "pitch_latency_s", 0.0);
  k.rate_latency_s = latency(pc, "rate_latency_s", 0.0);
  k.filter_time_s = latency(pc, "filter_time_s", 0.0);
  k.limit_deg = pc.positive_or("limit_deg", k.limit_deg, "deg (actuator unit)");
  pc.reject_unknown();
  if (k.type == "pitch" && !pc.present()) ctl.fail("pitch", "missing section", "[control.pitch] for type = \"pitch\"");
  if (const toml::node* fb = ctl.node("feedback")) {
    if (!fb->is_array_of_tables()) ctl.fail("feedback", "is not an array of tables", "[[control.feedback]] entries");
    int i = 0;
    for (const auto& e : *fb->as_array()) {
      Section t(e.as_table(), path, fmt::format("control.feedback[{}]", i++));
      ControlSettings::Term term;
      term.state = t.string("state", true, {}, {"x", "y", "z", "u", "v", "w", "p", "q", "r", "phi", "theta", "psi"});
      term.actuator = t.string("actuator", true, {}, trim_parameter_names());
      term.gain = t.number("gain", "a number (actuator unit per SI unit of the state)");
      term.latency_s = latency(t, "latency_s", 0.0);
      term.filter_time_s = latency(t, "filter_time_s", 0.0);
      t.reject_unknown();
      k.feedback.push_back(term);
    }
  }
  if (const toml::node* ac = ctl.node("actuator")) {
    if (!ac->is_array_of_tables()) ctl.fail("actuator", "is not an array of tables", "[[control.actuator]] entries");
    int i = 0;
    for (const auto& e : *ac->as_array()) {
      Section a(e.as_table(), path, fmt::format("control.actuator[{}]", i++));
      TrimParameterSpec spec;
      spec.name = a.string("name", true, {}, trim_parameter_names());
      spec.lower = a.number("lower", "a number (lower limit, parameter unit)");
      spec.upper = a.number("upper", "a number (upper limit, parameter unit)");
      if (!(spec.lower < spec.upper)) a.fail("upper", "not above 'lower'", "upper > lower");
      a.reject_unknown();
      k.actuators.push_back(spec);
    }
  }
  if (k.type == "state-feedback") {
    if (k.feedback.empty()) ctl.fail("feedback", "missing", "[[control.feedback]] entries for type = \"state-feedback\"");
    for (std::size_t i = 0; i < k.feedback.size(); ++i)
      if (std::none_of(k.actuators.begin(), k.actuators.end(),
                       [&](const TrimParameterSpec& a) { return a.name == k.feedback[i].actuator; }))
        throw InputError(path, fmt::format("control.feedback[{}].actuator", i),
                         "\"" + k.feedback[i].actuator + "\" has no [[control.actuator]] entry with its limits",
                         "a [[control.actuator]] with name, lower, upper");
  }
  Section cm = ctl.sub("map", false);
  k.map_gain = cm.string("gain", false, k.map_gain, {"pitch", "rate"});
  k.map_gain_min = cm.number_or("gain_min", k.map_gain_min, "a number");
  k.map_gain_max = cm.number_or("gain_max", k.map_gain_max, "a number");
  if (!(k.map_gain_min < k.map_gain_max)) cm.fail("gain_max", "not above gain_min", "gain_max > gain_min");
  k.map_gains = cm.integer_or("gains", k.map_gains, 2, 2000);
  k.map_latency_max_s = latency(cm, "latency_max_s", 0.0);
  k.map_latencies = cm.integer_or("latencies", k.map_latencies, 2, 2000);
  k.map_periodic_gains = cm.integer_or("periodic_gains", k.map_periodic_gains, 0, 200);
  k.map_periodic_latencies = cm.integer_or("periodic_latencies", k.map_periodic_latencies, 0, 200);
  if ((k.map_periodic_gains == 0) != (k.map_periodic_latencies == 0) || k.map_periodic_gains == 1 ||
      k.map_periodic_latencies == 1)
    cm.fail(k.map_periodic_gains == 1 || k.map_periodic_gains == 0 ? "periodic_gains" : "periodic_latencies",
            "needs at least two points on both axes, or 0 on both", "both >= 2, or both 0 (no periodic map)");
  k.map_check_points = cm.integer_or("check_points", k.map_check_points, 0, 20);
  k.map_check_wingbeats = cm.positive_or("check_wingbeats", k.map_check_wingbeats, "wingbeats");
  cm.reject_unknown();
  ctl.reject_unknown();

  // [body_motion]: prescribed attitude and the translation-only model (docs/case-file.md).
  Section bm = top.sub("body_motion", false);
  if (bm.present()) {
    auto& b = c.body_motion;
    b.present = true;
    b.model = bm.string("model", true, {}, {"translation-only"});
    for (const auto& [key, series] : {std::pair{"roll", &b.roll}, std::pair{"pitch", &b.pitch}, std::pair{"yaw", &b.yaw}})
      *series = parse_angle(bm.sub(key, false), "pitch", 0.0);
    const std::string expected = "names of the case's [[trim.parameter]] entries, at least one, each once";
    const toml::node* tp = bm.node("trim_parameters");
    if (!tp || !tp->is_array() || tp->as_array()->empty())
      bm.fail("trim_parameters", tp ? "is not a non-empty array" : "missing", expected);
    for (const auto& e : *tp->as_array()) {
      if (!e.is_string()) bm.fail("trim_parameters", "holds a non-string entry", expected);
      const std::string name = e.as_string()->get();
      if (std::none_of(c.trim.parameters.begin(), c.trim.parameters.end(),
                       [&](const TrimParameterSpec& p) { return p.name == name && p.side == ParameterSide::both; }))
        bm.fail("trim_parameters", "\"" + name + "\" is not a [[trim.parameter]] acting on both wings", expected);
      if (std::count(b.trim_parameters.begin(), b.trim_parameters.end(), name))
        bm.fail("trim_parameters", "\"" + name + "\" given twice", expected);
      b.trim_parameters.push_back(name);
    }
    bm.reject_unknown();
    if (c.aero.model == "cfd")
      throw InputError(path, "aero.model", "the translation-only model ([body_motion]) needs instantaneous loads",
                       "model = \"quasi-steady\" with [body_motion]");
  }

  // abdomen_flexion_deg moves the abdomen: refused, naming the key, where there is none.
  if (!c.insect.abdomen) {
    const std::string flexion = "abdomen_flexion_deg";
    const std::string problem = "\"abdomen_flexion_deg\" flexes the abdomen, but the insect has no [abdomen]";
    const std::string expected = "an [abdomen] section, or another kinematic parameter";
    for (std::size_t i = 0; i < c.trim.parameters.size(); ++i)
      if (c.trim.parameters[i].name == flexion)
        throw InputError(path, fmt::format("trim.parameter[{}].name", i), problem, expected);
    if (c.control.actuator == flexion) throw InputError(path, "control.pitch.actuator", problem, expected);
    for (std::size_t i = 0; i < c.control.feedback.size(); ++i)
      if (c.control.feedback[i].actuator == flexion)
        throw InputError(path, fmt::format("control.feedback[{}].actuator", i), problem, expected);
    for (std::size_t i = 0; i < c.control.actuators.size(); ++i)
      if (c.control.actuators[i].name == flexion)
        throw InputError(path, fmt::format("control.actuator[{}].name", i), problem, expected);
  }

  Section out = top.sub("output", false);
  c.output_directory = out.string("directory", false, "out");
  if (c.output_directory.find_first_not_of(" \t") == std::string::npos)
    out.fail("directory", "is empty", "a directory path (relative paths are taken from the working directory)");
  out.reject_unknown();
  top.reject_unknown();
  return c;
}

}  // namespace flapstab
