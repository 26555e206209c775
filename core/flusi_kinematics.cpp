// Reads FLUSI-format wing-kinematics .ini files and maps their angles to flapstab's convention.
#include "core/flusi_kinematics.hpp"

#include <algorithm>
#include <cctype>
#include <charconv>
#include <cmath>
#include <fstream>
#include <map>
#include <string_view>
#include <vector>

#include "core/errors.hpp"
#include "core/types.hpp"

namespace flapstab {
namespace {

constexpr const char* number_form = "numbers such as 63.2, -1.5d0 or 2.1e-5, separated by blanks";

std::string_view trim(std::string_view s) {
  const auto b = s.find_first_not_of(" \t\r\n");
  if (b == std::string_view::npos) return {};
  return s.substr(b, s.find_last_not_of(" \t\r\n") - b + 1);
}

std::string lower(std::string_view s) {
  std::string r(s);
  for (char& c : r) c = char(std::tolower(static_cast<unsigned char>(c)));
  return r;
}

bool is_separator(char c) { return std::isspace(static_cast<unsigned char>(c)) || c == ','; }

// The items of a value, separated by blanks or commas as Fortran list-directed input reads them.
std::vector<std::string_view> items(std::string_view s) {
  std::vector<std::string_view> out;
  std::size_t i = 0;
  while (i < s.size()) {
    while (i < s.size() && is_separator(s[i])) ++i;
    std::size_t j = i;
    while (j < s.size() && !is_separator(s[j])) ++j;
    if (j > i) out.push_back(s.substr(i, j - i));
    i = j;
  }
  return out;
}

enum class Parse { ok, not_number, not_finite };

// One Fortran real: 63.2, -1.5d0, 2.1D-5, +.5 (Fortran writes double-precision exponents with d).
Parse to_real(std::string_view item, double& x) {
  std::string t(item);
  if (!t.empty() && t[0] == '+') {
    t.erase(0, 1);
    if (t.empty() || t[0] == '-' || t[0] == '+') return Parse::not_number;
  }
  std::replace_if(t.begin(), t.end(), [](char c) { return c == 'd' || c == 'D'; }, 'e');
  const auto [end, ec] = std::from_chars(t.data(), t.data() + t.size(), x);
  if (end != t.data() + t.size() || t.empty()) return Parse::not_number;
  if (ec == std::errc::result_out_of_range) return Parse::not_finite;
  if (ec != std::errc()) return Parse::not_number;
  return std::isfinite(x) ? Parse::ok : Parse::not_finite;
}

bool to_int(std::string_view item, int& n) {
  if (!item.empty() && item[0] == '+') item.remove_prefix(1);
  const auto [end, ec] = std::from_chars(item.data(), item.data() + item.size(), n);
  return ec == std::errc() && end == item.data() + item.size() && !item.empty();
}

// FLUSI's kinematics_loader input (src/insects/kineloader.f90): wingbeat period, wing length and
// row count on the first three lines, then rows of 13 numbers (time, angles, body motion, rates).
bool is_kineloader(const std::vector<std::string>& lines) {
  std::vector<std::vector<std::string_view>> rows;
  for (const auto& l : lines) {
    if (!trim(l).empty()) rows.push_back(items(trim(l)));
    if (rows.size() == 4) break;
  }
  const std::size_t expected_sizes[] = {1, 1, 1, 13};
  for (std::size_t r = 0; r < 4; ++r) {
    if (r >= rows.size() || rows[r].size() != expected_sizes[r]) return false;
    for (auto item : rows[r]) {
      double x;
      if (to_real(item, x) != Parse::ok) return false;
    }
  }
  return true;
}

bool known_key(const std::string& key) {
  if (key == "type" || key == "units" || key == "convention" || key == "format") return true;
  for (const char* prefix : {"nfft_", "a0_", "ai_", "bi_"}) {
    for (const char* angle : {"phi", "alpha", "theta"}) {
      if (key == std::string(prefix) + angle) return true;
    }
  }
  return false;
}

// The [kinematics] section of one file: key -> value (text after '=' up to the first ';').
class Section {
 public:
  explicit Section(std::string path) : path_(std::move(path)) {
    std::ifstream in(path_);
    if (!in) throw InputError(path_, "", "cannot open the file", "a readable FLUSI kinematics .ini file");
    std::vector<std::string> lines;
    for (std::string l; std::getline(in, l);) lines.push_back(std::move(l));
    bool found = false, inside = false;
    std::map<std::string, int> line_of;
    for (std::size_t i = 0; i < lines.size(); ++i) {
      const std::string_view l = trim(lines[i]);
      if (l.empty() || std::string_view(";#!%").find(l[0]) != std::string_view::npos) continue;
      if (l[0] == '[') {
        inside = l.substr(0, l.find(']') + 1) == "[kinematics]";
        found = found || inside;
        continue;
      }
      if (!inside) continue;
      const std::string_view text = trim(l.substr(0, l.find(';')));
      const auto eq = text.find('=');
      const std::string line = "line " + std::to_string(i + 1);
      if (eq == std::string_view::npos) {
        fail("[kinematics]", line + " ('" + std::string(text) + "') is not of the form key=value",
             "key=value; with the whole value on one line");
      }
      const std::string key(trim(text.substr(0, eq)));
      if (!known_key(key)) {
        fail(key, "unknown key in [kinematics] (" + line + ")",
             "type, units, convention, format, nfft_*, a0_*, ai_*, bi_* with * = phi, alpha or theta");
      }
      if (line_of.count(key)) {
        fail(key, "given twice (line " + std::to_string(line_of[key]) + " and " + line + ")", "each key once");
      }
      line_of[key] = int(i + 1);
      values_[key] = std::string(trim(text.substr(eq + 1)));
    }
    if (!found && is_kineloader(lines)) {
      fail("[kinematics]",
           "this is a FLUSI kinematics_loader file (period, wing length, row count, then rows of 13 "
           "columns), a non-periodic time-series format flapstab does not read",
           "a periodic FLUSI .ini file with a [kinematics] section, type=fourier or type=hermite");
    }
    if (!found) fail("[kinematics]", "section not found", "a FLUSI kinematics .ini file with a [kinematics] section");
  }

  [[noreturn]] void fail(const std::string& key, const std::string& problem, const std::string& expected) const {
    throw InputError(path_, key, problem, expected);
  }

  const std::string* find(const std::string& key) const {
    const auto it = values_.find(key);
    return it == values_.end() ? nullptr : &it->second;
  }

  const std::string& require(const std::string& key, const std::string& expected) const {
    if (const std::string* v = find(key)) return *v;
    fail(key, "missing", expected);
  }

  // A keyword, case-insensitive (FLUSI accepts e.g. Fourier, fourier, FOURIER).
  std::string word(const std::string& key, const std::string& fallback) const {
    const std::string* v = find(key);
    return v ? lower(*v) : fallback;
  }

  int count(const std::string& key, int min, const std::string& expected) const {
    const std::string& v = require(key, expected);
    int n = 0;
    if (!to_int(v, n)) fail(key, "'" + v + "' is not an integer", expected);
    if (n < min) fail(key, "is " + v + ", less than " + std::to_string(min), expected);
    return n;
  }

  std::vector<double> reals(const std::string& key) const {
    std::vector<double> out;
    const auto list = items(require(key, number_form));
    for (std::size_t k = 0; k < list.size(); ++k) {
      const std::string where = "item " + std::to_string(k + 1) + " '" + std::string(list[k]) + "'";
      std::string_view item = list[k];
      int repeat = 1;  // Fortran list-directed r*c: r copies of c
      if (const auto star = item.find('*'); star != std::string_view::npos) {
        if (!to_int(item.substr(0, star), repeat) || repeat < 1 || repeat > 1000000) {
          fail(key, where + " has no valid repeat count", "r*c with a count r from 1 to 1000000");
        }
        item.remove_prefix(star + 1);
      }
      double x = 0;
      const Parse p = to_real(item, x);
      if (p == Parse::not_number) fail(key, where + " is not a number", number_form);
      if (p == Parse::not_finite) fail(key, where + " is not a finite number", "finite " + std::string(number_form));
      out.insert(out.end(), std::size_t(repeat), x);
    }
    return out;
  }

  // Exactly n numbers; an absent key reads as none when none are due.
  std::vector<double> reals(const std::string& key, int n, const std::string& nfft_key) const {
    if (n == 0 && !find(key)) return {};
    const std::vector<double> v = reals(key);
    if (int(v.size()) != n) {
      fail(key, "has " + std::to_string(v.size()) + " values but " + nfft_key + " = " + std::to_string(n),
           "exactly " + std::to_string(n) + " values");
    }
    return v;
  }

 private:
  std::string path_;
  std::map<std::string, std::string> values_;
};

// flapstab angle = sign * FLUSI angle + offset (rad): FLUSI's stroke frame has its normal x_s on the
// dorsal side and phi, alpha, theta right-handed about x_s, z_w, y_w (docs/flusi-kinematics.md).
struct AngleMap {
  const char* name;
  double sign, offset;
};

AngleSeries read_angle(const Section& s, const AngleMap& m, bool fourier, double unit) {
  const std::string n = m.name;
  const std::string nfft_key = "nfft_" + n;
  const int nfft = s.count(nfft_key, fourier ? 0 : 1,
                           fourier ? "the number of Fourier modes of " + n + " (0 or more)"
                                   : "the number of Hermite nodes of " + n + " (1 or more)");
  const std::vector<double> ai = s.reals("ai_" + n, nfft, nfft_key), bi = s.reals("bi_" + n, nfft, nfft_key);
  const double k = m.sign * unit;
  auto mapped = [k](std::vector<double> v, double offset) {
    for (double& x : v) x = k * x + offset;
    return v;
  };
  if (fourier) {
    const std::string a0_key = "a0_" + n;
    const std::vector<double> a0 = s.reals(a0_key, 1, "one value (a0_" + n + " = 2 x mean)");
    // FLUSI's series is a0/2 + sum ...: the mean is half of a0.
    return FourierSeries{k * a0[0] / 2 + m.offset, mapped(ai, 0), mapped(bi, 0)};
  }
  return HermiteSeries{mapped(ai, m.offset), mapped(bi, 0)};
}

}  // namespace

WingAngles read_flusi_kinematics(const std::string& path) {
  const Section s(path);
  const std::string type = lower(s.require("type", "type=fourier or type=hermite"));
  if (type != "fourier" && type != "hermite") s.fail("type", "unknown series type '" + type + "'", "fourier or hermite");
  const std::string units = s.word("units", "degree");
  if (units != "degree" && units != "radiant") s.fail("units", "unknown units '" + units + "'", "degree or radiant");
  const std::string convention = s.word("convention", "flusi");
  const bool sisc = convention == "sisc" || convention == "siam-sisc";
  if (!sisc && convention != "flusi") s.fail("convention", "unknown convention '" + convention + "'", "flusi or sisc");

  const bool fourier = type == "fourier";
  const double unit = units == "degree" ? deg : 1.0;
  // sisc differs from flusi only by the sign of theta, which makes it flapstab's theta.
  return WingAngles{read_angle(s, {"phi", -1.0, 0.0}, fourier, unit),
                    read_angle(s, {"theta", sisc ? 1.0 : -1.0, 0.0}, fourier, unit),
                    read_angle(s, {"alpha", -1.0, pi / 2}, fourier, unit)};
}

}  // namespace flapstab
