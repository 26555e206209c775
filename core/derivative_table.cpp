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
    if (!(v > 0)) fail(k, fmt::format("must be positive, got {}", v), expected);
    return v;
  }
  std::optional<double> optional_positive(const std::string& k, const std::string& unit) {
    const std::string expected = "a positive number in " + unit;
    const auto v = optional_number(k, expected);
    if (v && !(*v > 0)) fail(k, fmt::format("must be positive, got {}", *v), expected);
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
  ref.reject_unknown({"U", "c", "S_t", "rho", "frequency", "g"});
  if (!ref.present()) top.fail("reference", "missing section", "[reference] with U, c, S_t, rho, frequency");
  t.reference.U = ref.positive("U", "m/s (reference speed 2 Phi n r2)");
  t.reference.c = ref.positive("c", "m (mean chord)");
  t.reference.S_t = ref.positive("S_t", "m^2 (area of both wings)");
  t.reference.rho = ref.positive("rho", "kg/m^3");
  t.reference.frequency = ref.positive("frequency", "Hz (wingbeat frequency)");
  t.reference.g = ref.optional_positive("g", "m/s^2").value_or(standard_gravity);

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
  Section mass = top.sub("mass");
  mass.reject_unknown({"m", "Ixx", "Iyy", "Izz", "Ixz"});
  if (!mass.present()) top.fail("mass", "missing section", "[mass] with m, Iyy (and Ixx, Izz, Ixz for lateral)");
  t.mass.m = mass.positive("m", "kg");
  t.mass.Iyy = mass.positive("Iyy", "kg m^2");
  if (need_lateral_inertia) {
    t.mass.Ixx = mass.positive("Ixx", "kg m^2");
    t.mass.Izz = mass.positive("Izz", "kg m^2");
    t.mass.Ixz = mass.number("Ixz", "a finite number in kg m^2 (int x z dm)");
  } else {
    t.mass.Ixx = mass.optional_positive("Ixx", "kg m^2").value_or(0.0);
    t.mass.Izz = mass.optional_positive("Izz", "kg m^2").value_or(0.0);
    t.mass.Ixz = mass.optional_number("Ixz", "a finite number in kg m^2").value_or(0.0);
  }
  if (t.mass.Ixx > 0 && t.mass.Izz > 0 && !(t.mass.Ixx * t.mass.Izz > t.mass.Ixz * t.mass.Ixz))
    mass.fail("Ixz", fmt::format("makes the inertia matrix not positive definite (Ixx Izz = {} <= Ixz^2 = {})",
                                 t.mass.Ixx * t.mass.Izz, t.mass.Ixz * t.mass.Ixz),
              "Ixz^2 < Ixx Izz");
  if ((t.mass.Ixx > 0) != (t.mass.Izz > 0))
    mass.fail(t.mass.Ixx > 0 ? "Izz" : "Ixx", "missing while its partner is given", "both Ixx and Izz, or neither");
  if (t.mass.Ixz != 0 && !(t.mass.Ixx > 0))
    mass.fail("Ixz", "given without Ixx and Izz", "Ixx and Izz as well");

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
  s += "#   moments / (1/2 rho U^2 S_t c), velocities / U, rates * c / U, time t+ = t U / c.\n";
  s += "# State orders: longitudinal [u, w, q, theta]; lateral [v, p, r, phi];\n";
  s += "#   6DoF [u, v, w, p, q, r, phi, theta].\n";
  if (!t.source.empty()) s += "source = " + toml_string(t.source) + "\n";

  const auto& r = t.reference;
  s += "\n[reference]\n";
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
