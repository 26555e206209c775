// Derivative-table I/O (TOML, docs/derivative-table.md): a strict reader and an exact writer.
#include "core/derivative_table.hpp"

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <fmt/format.h>
#include <stdexcept>
#include <toml++/toml.h>

#include "core/atomic_write.hpp"
#include "core/case_file.hpp"
#include "core/errors.hpp"

namespace flapstab {

namespace {

constexpr const char* kRows = "XYZLMN";
constexpr const char* kCols = "uvwpqr";
constexpr const char* kDoc = "docs/derivative-table.md";

int row_index(char c) {
  for (int i = 0; i < 6; ++i)
    if (kRows[i] == c) return i;
  return -1;
}
int col_index(char c) {
  for (int i = 0; i < 6; ++i)
    if (kCols[i] == c) return i;
  return -1;
}

std::pair<int, int> index_of(const std::string& name) {
  const int r = name.size() == 2 ? row_index(name[0]) : -1;
  const int c = name.size() == 2 ? col_index(name[1]) : -1;
  if (r < 0 || c < 0)
    throw std::out_of_range("derivative name '" + name + "' is not of the form <X|Y|Z|L|M|N><u|v|w|p|q|r>");
  return {r, c};
}

bool contains(const std::vector<std::string>& v, const std::string& s) {
  return std::find(v.begin(), v.end(), s) != v.end();
}

// One TOML table of the file, with the dotted path used in error messages.
class Section {
 public:
  Section(const toml::table* t, std::string file, std::string path)
      : t_(t), file_(std::move(file)), path_(std::move(path)) {}

  bool present() const { return t_ != nullptr; }
  const toml::table* table() const { return t_; }
  std::string key(const std::string& k) const { return path_.empty() ? k : path_ + "." + k; }
  [[noreturn]] void fail(const std::string& k, const std::string& problem, const std::string& expected) const {
    throw InputError(file_, key(k), problem, expected);
  }

  Section sub(const std::string& k) {
    const toml::node* n = t_ ? t_->get(k) : nullptr;
    if (!n) return Section(nullptr, file_, key(k));
    if (!n->is_table()) fail(k, "is not a table", "a table [" + key(k) + "]");
    return Section(n->as_table(), file_, key(k));
  }

  // A finite number (TOML integer or float); absent -> nullopt.
  std::optional<double> optional_number(const std::string& k, const std::string& expected) {
    const toml::node* n = t_ ? t_->get(k) : nullptr;
    if (!n) return std::nullopt;
    double v = 0;
    if (n->is_floating_point()) v = n->as_floating_point()->get();
    else if (n->is_integer()) v = double(n->as_integer()->get());
    else fail(k, fmt::format("is not a number (found a TOML {})", type_name(*n)), expected);
    if (!std::isfinite(v)) fail(k, fmt::format("is not finite ({})", v), expected);
    return v;
  }
  double number(const std::string& k, const std::string& expected) {
    const auto v = optional_number(k, expected);
    if (!v) fail(k, present() ? "missing" : "missing (the whole section [" + path_ + "] is absent)", expected);
    return *v;
  }
  double positive(const std::string& k, const std::string& unit) {
    const std::string expected = "a positive number in " + unit;
    const double v = number(k, expected);
    if (!(v > 0)) fail(k, fmt::format("must be positive, got {:.6g}", v), expected);
    return v;
  }
  std::optional<double> optional_positive(const std::string& k, const std::string& unit) {
    const std::string expected = "a positive number in " + unit;
    const auto v = optional_number(k, expected);
    if (v && !(*v > 0)) fail(k, fmt::format("must be positive, got {:.6g}", *v), expected);
    return v;
  }
  std::optional<std::string> optional_string(const std::string& k) {
    const toml::node* n = t_ ? t_->get(k) : nullptr;
    if (!n) return std::nullopt;
    if (!n->is_string()) fail(k, "is not a string", "a string");
    return n->as_string()->get();
  }

  // Throws on the first key not in `known` (checked before reading, so that a typo is reported as
  // the unknown key it is rather than as the missing key it replaced); `hint` may say where it belongs.
  template <class Hint>
  void reject_unknown(const std::vector<std::string>& known, Hint hint) const {
    if (!t_) return;
    for (const auto& [k, v] : *t_) {
      const std::string name(k.str());
      if (!contains(known, name))
        fail(name, "unknown key" + hint(name), "only the keys documented in " + std::string(kDoc));
    }
  }
  void reject_unknown(const std::vector<std::string>& known) const {
    reject_unknown(known, [](const std::string&) { return std::string(); });
  }

 private:
  static const char* type_name(const toml::node& n) {
    switch (n.type()) {
      case toml::node_type::string: return "string";
      case toml::node_type::boolean: return "boolean";
      case toml::node_type::array: return "array";
      case toml::node_type::table: return "table";
      case toml::node_type::date: return "date";
      case toml::node_type::time: return "time";
      case toml::node_type::date_time: return "date-time";
      default: return "value";
    }
  }
  const toml::table* t_;
  std::string file_, path_;
};

// Where a misplaced derivative name belongs, for the "unknown key" message.
std::string placement_hint(const std::string& name) {
  if (contains(longitudinal_derivative_names(), name)) return " here: it belongs in [derivatives.longitudinal]";
  if (contains(lateral_derivative_names(), name)) return " here: it belongs in [derivatives.lateral]";
  if (contains(coupling_derivative_names(), name)) return " here: it belongs in [derivatives.coupling]";
  return {};
}

void read_section(Section s, const std::vector<std::string>& names, bool all_required, DerivativeTable& t) {
  s.reject_unknown(names, placement_hint);
  for (const auto& n : names) {
    const std::string expected = "a finite non-dimensional derivative (" + std::string(kDoc) + ")";
    const auto v = all_required ? std::optional<double>(s.number(n, expected)) : s.optional_number(n, expected);
    // Published non-dimensional derivatives of hovering insects are O(0.01-10); |D| > 1e4 is a typing error (a
    // dimensional value, a wrong exponent) that would otherwise end in eigenvalues of absurd size.
    if (v && std::abs(*v) > 1e4)
      s.fail(n, fmt::format("{:.6g} is outside the physically sensible range", *v),
             "a non-dimensional derivative with |value| <= 1e4 (" + std::string(kDoc) + ")");
    t.at(n) = v.value_or(0.0);
  }
}

// Shortest decimal text that reads back as exactly v (fmt's "{}" is round-trip exact), always a
// TOML float.
std::string toml_number(double v) {
  std::string s = fmt::format("{}", v);
  if (s.find_first_of(".eEn") == std::string::npos) s += ".0";
  return s;
}

std::string toml_string(const std::string& s) {
  std::string out = "\"";
  for (unsigned char ch : s) {
    switch (ch) {
      case '"': out += "\\\""; break;
      case '\\': out += "\\\\"; break;
      case '\n': out += "\\n"; break;
      case '\t': out += "\\t"; break;
      case '\r': out += "\\r"; break;
      default:
        if (ch < 0x20 || ch == 0x7f) out += fmt::format("\\u{:04X}", int(ch));
        else out += char(ch);
    }
  }
  return out + "\"";
}

// The reference time of a file's rate derivatives and non-dimensional mass properties ([reference] time).
enum class TimeReference { chord, wingbeat };

constexpr const char* kTimeExpected =
    "\"chord\" (t+ = t U / c, rates p c / U; the default) or \"wingbeat\" (t+ = t / T = t n, rates p T)";
constexpr const char* kMassSets =
    "either the SI set ([mass] m, Iyy, Ixx, Izz, Ixz in kg and kg m^2; g in [reference]) or the non-dimensional set "
    "([mass] m_plus, Iyy_plus, Ixx_plus, Izz_plus, Ixz_plus, g_plus), not both";

const std::vector<std::string>& si_mass_keys() {
  static const std::vector<std::string> k{"m", "Ixx", "Iyy", "Izz", "Ixz"};
  return k;
}
const std::vector<std::string>& nd_mass_keys() {
  static const std::vector<std::string> k{"m_plus", "Ixx_plus", "Iyy_plus", "Izz_plus", "Ixz_plus", "g_plus"};
  return k;
}
std::vector<std::string> mass_keys() {
  std::vector<std::string> k = si_mass_keys();
  k.insert(k.end(), nd_mass_keys().begin(), nd_mass_keys().end());
  return k;
}

// The first of `keys` (in that order) present in s; "" when none is.
std::string first_present(const Section& s, const std::vector<std::string>& keys) {
  if (!s.present()) return {};
  for (const auto& k : keys)
    if (s.table()->get(k)) return k;
  return {};
}

TimeReference read_time_reference(const Section& ref) {
  const toml::node* n = ref.table()->get("time");
  if (!n) return TimeReference::chord;
  if (!n->is_string()) ref.fail("time", "is not a string", kTimeExpected);
  const std::string v = n->as_string()->get();
  if (v == "chord") return TimeReference::chord;
  if (v == "wingbeat") return TimeReference::wingbeat;
  ref.fail("time", "unknown time convention \"" + v + "\"", kTimeExpected);
}

// Converts what the reader took from the file to the internal convention (docs/derivative-table.md, "Time
// conventions"): SI mass properties and g, and rate derivatives per q c / U. With k = c / (U T) = c n / U:
//   rate derivatives (columns p, q, r)  D_chord = D_wingbeat / k      (q+_chord = k q+_wingbeat)
//   m = m+ (1/2 rho S_t c),   I = I+ (1/2 rho S_t c^3),   g = g+ U^2 / c          (chord)
//   m = m+ (1/2 rho U S_t T), I = I+ (1/2 rho U^2 S_t c T^2), g = g+ U / T        (wingbeat)
// Velocity derivatives and control derivatives (per unit of a kinematic parameter) hold no time and are unchanged.
void to_internal_convention(DerivativeTable& t, TimeReference time, bool nondimensional_mass, double g_plus) {
  const auto& r = t.reference;
  const double T = 1.0 / r.frequency;
  if (time == TimeReference::wingbeat) {
    const double k = r.c / (r.U * T);
    t.nd.rightCols(3) /= k;
  }
  if (!nondimensional_mass) return;
  const bool wingbeat = time == TimeReference::wingbeat;
  const double mass_scale = wingbeat ? 0.5 * r.rho * r.U * r.S_t * T : 0.5 * r.rho * r.S_t * r.c;
  const double inertia_scale =
      wingbeat ? 0.5 * r.rho * r.U * r.U * r.S_t * r.c * T * T : 0.5 * r.rho * r.S_t * r.c * r.c * r.c;
  t.mass.m *= mass_scale;
  t.mass.Ixx *= inertia_scale;
  t.mass.Iyy *= inertia_scale;
  t.mass.Izz *= inertia_scale;
  t.mass.Ixz *= inertia_scale;
  t.reference.g = wingbeat ? g_plus * r.U / T : g_plus * r.U * r.U / r.c;
}

}  // namespace

std::string derivative_name(int row, int col) {
  if (row < 0 || row > 5 || col < 0 || col > 5) throw std::out_of_range("derivative index out of range");
  return std::string{kRows[row], kCols[col]};
}

const std::vector<std::string>& longitudinal_derivative_names() {
  static const std::vector<std::string> n{"Xu", "Xw", "Xq", "Zu", "Zw", "Zq", "Mu", "Mw", "Mq"};
  return n;
}
const std::vector<std::string>& lateral_derivative_names() {
  static const std::vector<std::string> n{"Yv", "Yp", "Yr", "Lv", "Lp", "Lr", "Nv", "Np", "Nr"};
  return n;
}
const std::vector<std::string>& coupling_derivative_names() {
  static const std::vector<std::string> n = [] {
    std::vector<std::string> out;
    for (int r = 0; r < 6; ++r)
      for (int c = 0; c < 6; ++c) {
        const std::string name = derivative_name(r, c);
        if (!contains(longitudinal_derivative_names(), name) && !contains(lateral_derivative_names(), name))
          out.push_back(name);
      }
    return out;
  }();
  return n;
}

double& DerivativeTable::at(const std::string& name) {
  const auto [r, c] = index_of(name);
  return nd(r, c);
}
double DerivativeTable::at(const std::string& name) const {
  const auto [r, c] = index_of(name);
  return nd(r, c);
}

DerivativeTable read_derivative_table(const std::string& path) {
  namespace fs = std::filesystem;
  const std::string what = "a derivative table in TOML (" + std::string(kDoc) + ")";
  std::error_code ec;
  if (!fs::exists(path, ec)) throw InputError(path, "", "file not found", what);
  if (fs::is_directory(path, ec)) throw InputError(path, "", "is a directory", what);

  toml::table root;
  try {
    root = toml::parse_file(path);
  } catch (const toml::parse_error& e) {
    const auto& b = e.source().begin;
    throw InputError(path, "", fmt::format("TOML syntax error at line {}, column {}: {}", b.line, b.column,
                                           e.description()),
                     "valid TOML");
  }

  DerivativeTable t;
  Section top(&root, path, "");
  top.reject_unknown({"source", "reference", "mass", "derivatives"}, [](const std::string&) {
    return std::string(": the top level holds only source, [reference], [mass] and [derivatives]");
  });
  t.source = top.optional_string("source").value_or(path);

  Section ref = top.sub("reference");
  ref.reject_unknown({"time", "U", "c", "S_t", "rho", "frequency", "g"});
  Section mass = top.sub("mass");
  mass.reject_unknown(mass_keys(), [](const std::string& k) {
    return k == "g" ? std::string(": g belongs in [reference] (or give g_plus here with the non-dimensional set)")
                    : std::string();
  });
  if (!ref.present()) top.fail("reference", "missing section", "[reference] with U, c, S_t, rho, frequency");
  const TimeReference time = read_time_reference(ref);

  // Which mass set the file gives: SI ([mass] m, I.., [reference] g) or non-dimensional ([mass] *_plus).
  const std::string nd_key = first_present(mass, nd_mass_keys());
  const bool nondimensional = !nd_key.empty();
  if (nondimensional) {
    if (const std::string si = first_present(mass, si_mass_keys()); !si.empty())
      mass.fail(nd_key, "given together with the SI entry mass." + si, kMassSets);
    if (ref.table()->get("g"))
      ref.fail("g", "given together with the non-dimensional mass set (mass." + nd_key + ")",
               "g_plus in [mass] instead of g (" + std::string(kMassSets) + ")");
  }

  // Every reference quantity is required; the note says what it does in this file (U, c and n also convert the
  // rate derivatives of a wingbeat table).
  std::string note, rate_note;
  if (nondimensional && time == TimeReference::wingbeat)
    note = "; it turns the non-dimensional mass set into SI: m = m_plus (1/2 rho U S_t T), I = I_plus (1/2 rho U^2 S_t c "
           "T^2), g = g_plus U / T with T = 1/frequency";
  else if (nondimensional)
    note = "; it turns the non-dimensional mass set into SI: m = m_plus (1/2 rho S_t c), I = I_plus (1/2 rho S_t c^3), "
           "g = g_plus U^2 / c";
  if (time == TimeReference::wingbeat)
    rate_note = "; in the wingbeat convention the rate derivatives are converted with c n / U";
  t.reference.U = ref.positive("U", "m/s (reference speed 2 Phi n r2)" + note + rate_note);
  t.reference.c = ref.positive("c", "m (mean chord)" + note + rate_note);
  t.reference.S_t = ref.positive("S_t", "m^2 (area of both wings)" + note);
  t.reference.rho = ref.positive("rho", "kg/m^3" + note);
  t.reference.frequency = ref.positive("frequency", "Hz (wingbeat frequency n = 1/T)" + note + rate_note);
  if (!nondimensional) t.reference.g = ref.optional_positive("g", "m/s^2").value_or(standard_gravity);

  Section der = top.sub("derivatives");
  der.reject_unknown({"longitudinal", "lateral", "coupling", "control"}, [](const std::string&) {
    return std::string(": [derivatives] holds only the tables longitudinal, lateral, coupling and control");
  });
  Section lon = der.sub("longitudinal"), lat = der.sub("lateral"), cpl = der.sub("coupling");
  t.has_longitudinal = lon.present();
  t.has_lateral = lat.present();
  t.has_coupling = cpl.present();

  // Roll and yaw inertia are needed (and so required) only where lateral motion is analysed.
  const bool need_lateral_inertia = t.has_lateral || t.has_coupling;
  if (!mass.present())
    top.fail("mass", "missing section",
             "[mass] with m, Iyy (and Ixx, Izz, Ixz for lateral), or m_plus, Iyy_plus, g_plus (and Ixx_plus, "
             "Izz_plus, Ixz_plus)");
  // Key names and units of the set given; the non-dimensional values are read as such and scaled to SI below.
  const std::string sfx = nondimensional ? "_plus" : "";
  const std::string mass_unit = nondimensional ? "units of the mass scale (" + std::string(kDoc) + ")" : "kg";
  const std::string inertia_unit = nondimensional ? "units of the inertia scale (" + std::string(kDoc) + ")" : "kg m^2";
  const std::string Ixx = "Ixx" + sfx, Iyy = "Iyy" + sfx, Izz = "Izz" + sfx, Ixz = "Ixz" + sfx;
  t.mass.m = mass.positive("m" + sfx, mass_unit);
  t.mass.Iyy = mass.positive(Iyy, inertia_unit);
  if (need_lateral_inertia) {
    t.mass.Ixx = mass.positive(Ixx, inertia_unit);
    t.mass.Izz = mass.positive(Izz, inertia_unit);
    t.mass.Ixz = mass.number(Ixz, "a finite number in " + inertia_unit + " (int x z dm)");
  } else {
    t.mass.Ixx = mass.optional_positive(Ixx, inertia_unit).value_or(0.0);
    t.mass.Izz = mass.optional_positive(Izz, inertia_unit).value_or(0.0);
    t.mass.Ixz = mass.optional_number(Ixz, "a finite number in " + inertia_unit).value_or(0.0);
  }
  // Both checks are independent of the scale, so they hold for either set.
  if (t.mass.Ixx > 0 && t.mass.Izz > 0 && !(t.mass.Ixx * t.mass.Izz > t.mass.Ixz * t.mass.Ixz))
    mass.fail(Ixz, fmt::format("makes the inertia matrix not positive definite ({} {} = {} <= {}^2 = {})", Ixx, Izz,
                               t.mass.Ixx * t.mass.Izz, Ixz, t.mass.Ixz * t.mass.Ixz),
              Ixz + "^2 < " + Ixx + " " + Izz);
  if ((t.mass.Ixx > 0) != (t.mass.Izz > 0))
    mass.fail(t.mass.Ixx > 0 ? Izz : Ixx, "missing while its partner is given", "both " + Ixx + " and " + Izz + ", or neither");
  if (t.mass.Ixz != 0 && !(t.mass.Ixx > 0))
    mass.fail(Ixz, "given without " + Ixx + " and " + Izz, Ixx + " and " + Izz + " as well");
  const double g_plus = nondimensional ? mass.positive("g_plus", "units of the gravity scale (" + std::string(kDoc) + ")") : 0.0;

  if (t.has_longitudinal) read_section(lon, longitudinal_derivative_names(), true, t);
  if (t.has_lateral) read_section(lat, lateral_derivative_names(), true, t);
  if (t.has_coupling) read_section(cpl, coupling_derivative_names(), false, t);
  Section ctl = der.sub("control");
  if (const toml::table* ct = ctl.table()) {
    static const std::vector<std::string> rows{"X", "Y", "Z", "L", "M", "N"};
    for (const auto& [k, v] : *ct) {
      const std::string name(k.str());
      const auto& known = trim_parameter_names();
      if (std::find(known.begin(), known.end(), name) == known.end())
        ctl.fail(name, "unknown kinematic parameter", "a trim parameter name, e.g. stroke_plane_deg or frequency_hz");
      Section col = ctl.sub(name);
      if (!col.present()) ctl.fail(name, "is not a table", "[derivatives.control." + name + "] with X Y Z L M N");
      col.reject_unknown(rows);
      ControlDerivative cd;
      cd.parameter = name;
      cd.unit = name.size() > 3 && name.substr(name.size() - 3) == "_hz" ? "Hz" : "deg";
      for (int i = 0; i < 6; ++i)
        cd.nd(i) = col.optional_number(rows[std::size_t(i)], "a finite number (per " + cd.unit + ")").value_or(0.0);
      t.control.push_back(cd);
    }
  }
  to_internal_convention(t, time, nondimensional, g_plus);
  return t;
}

std::string derivative_table_toml(const DerivativeTable& t) {
  std::string s;
  s += "# flapstab derivative table (format: " + std::string(kDoc) + ")\n";
  s += "# Axes: hover stability axes, body-fixed and coinciding at trim with the inertial axes:\n";
  s += "#   x forward (horizontal), y right, z down; origin at the centre of mass; gravity +z.\n";
  s += "# Units: [reference] U m/s (2 Phi n r2), c m (mean chord), S_t m^2 (both wings), rho kg/m^3,\n";
  s += "#   frequency Hz (wingbeat), g m/s^2; [mass] m kg, Ixx Iyy Izz Ixz kg m^2 about the centre of\n";
  s += "#   mass in these axes, Ixz = int x z dm (Etkin; the inertia tensor holds -Ixz).\n";
  s += "# Derivatives: non-dimensional, e.g. Xu = dX+/du+, Mq = dM+/dq+, with forces / (1/2 rho U^2 S_t),\n";
  s += "#   moments / (1/2 rho U^2 S_t c), velocities / U, rates * c / U, time t+ = t U / c: the chord\n";
  s += "#   convention, [reference] time = \"chord\" (the other, \"wingbeat\", has rates * T and t+ = t / T).\n";
  s += "# State orders: longitudinal [u, w, q, theta]; lateral [v, p, r, phi];\n";
  s += "#   6DoF [u, v, w, p, q, r, phi, theta].\n";
  if (!t.source.empty()) s += "source = " + toml_string(t.source) + "\n";

  const auto& r = t.reference;
  s += "\n[reference]\n";
  s += "time = \"chord\"\n";
  s += "U = " + toml_number(r.U) + "\n";
  s += "c = " + toml_number(r.c) + "\n";
  s += "S_t = " + toml_number(r.S_t) + "\n";
  s += "rho = " + toml_number(r.rho) + "\n";
  s += "frequency = " + toml_number(r.frequency) + "\n";
  s += "g = " + toml_number(r.g) + "\n";

  const auto& m = t.mass;
  s += "\n[mass]\n";
  s += "m = " + toml_number(m.m) + "\n";
  if (m.Ixx > 0 || m.Izz > 0 || m.Ixz != 0) s += "Ixx = " + toml_number(m.Ixx) + "\n";
  s += "Iyy = " + toml_number(m.Iyy) + "\n";
  if (m.Ixx > 0 || m.Izz > 0 || m.Ixz != 0) {
    s += "Izz = " + toml_number(m.Izz) + "\n";
    s += "Ixz = " + toml_number(m.Ixz) + "\n";
  }

  auto section = [&](const char* header, const std::vector<std::string>& names) {
    s += std::string("\n[") + header + "]\n";
    for (const auto& n : names) s += n + " = " + toml_number(t.at(n)) + "\n";
  };
  if (t.has_longitudinal) section("derivatives.longitudinal", longitudinal_derivative_names());
  if (t.has_lateral) section("derivatives.lateral", lateral_derivative_names());
  bool any_coupling = t.has_coupling;
  for (const auto& n : coupling_derivative_names()) any_coupling = any_coupling || t.at(n) != 0;
  if (any_coupling) section("derivatives.coupling", coupling_derivative_names());
  if (!t.control.empty())
    s += "\n# Control derivatives: d[X Y Z L M N]+ per unit of the named kinematic parameter (deg or Hz), moments\n"
         "#   about the trimmed reference point, with the gravitational moment of the centre of mass it moves.\n";
  static const char* rows[6] = {"X", "Y", "Z", "L", "M", "N"};
  for (const auto& c : t.control) {
    s += "\n[derivatives.control." + c.parameter + "]\n";
    for (int i = 0; i < 6; ++i) s += std::string(rows[i]) + " = " + toml_number(c.nd(i)) + "\n";
  }
  return s;
}

void write_derivative_table(const DerivativeTable& table, const std::string& path) {
  write_file_atomic(path, derivative_table_toml(table));
}

}  // namespace flapstab
