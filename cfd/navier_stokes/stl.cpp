// STL reader (ASCII and binary, detected from the content) and writer.
#include "cfd/navier_stokes/stl.hpp"
#include <algorithm>
#include <bit>
#include <cctype>
#include <charconv>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <filesystem>
#include <fmt/format.h>
#include <fstream>
#include <sstream>
#include <string_view>
#include "core/atomic_write.hpp"
#include "core/errors.hpp"

namespace flapstab::ns {

static_assert(std::endian::native == std::endian::little, "binary STL I/O assumes a little-endian host");

namespace {

constexpr std::size_t header_bytes = 80, count_bytes = 4, facet_bytes = 50;

bool iequal(std::string_view a, std::string_view b) {
  return a.size() == b.size() &&
         std::equal(a.begin(), a.end(), b.begin(), [](char x, char y) { return std::tolower(x) == std::tolower(y); });
}

bool starts_with_solid(const std::string& s) {
  std::size_t i = s.find_first_not_of(" \t\r\n");
  return i != std::string::npos && iequal(std::string_view(s).substr(i, 5), "solid");
}

// Whitespace-separated tokens with line numbers.
class Tokens {
 public:
  Tokens(const std::string& path, std::string_view text) : path_(path), s_(text) {}
  bool done() {
    skip();
    return i_ >= s_.size();
  }
  std::string_view next(const char* expected) {
    skip();
    if (i_ >= s_.size()) fail("unexpected end of file", expected);
    const std::size_t b = i_;
    while (i_ < s_.size() && !std::isspace(static_cast<unsigned char>(s_[i_]))) ++i_;
    return s_.substr(b, i_ - b);
  }
  void expect(std::string_view word) {
    const std::string quoted = fmt::format("'{}'", word);
    const std::string_view t = next(quoted.c_str());
    if (!iequal(t, word)) fail(fmt::format("found '{}'", t), quoted);
  }
  double number(const char* what) {
    const std::string_view t = next(what);
    double v = 0;
    const char* first = t.data();
    if (*first == '+') ++first;
    const auto [end, ec] = std::from_chars(first, t.data() + t.size(), v);
    if (ec != std::errc() || end != t.data() + t.size() || !std::isfinite(v))
      fail(fmt::format("'{}' is not a finite number", t), what);
    return v;
  }
  std::string rest_of_line() {
    const std::size_t b = i_;
    while (i_ < s_.size() && s_[i_] != '\n') ++i_;
    std::string r(s_.substr(b, i_ - b));
    r.erase(0, std::min(r.size(), r.find_first_not_of(" \t\r")));
    r.erase(r.find_last_not_of(" \t\r") + 1);
    return r;
  }
  [[noreturn]] void fail(const std::string& problem, const std::string& expected) const {
    throw InputError(path_, "", "ASCII STL line " + std::to_string(line_) + ": " + problem, expected);
  }

 private:
  void skip() {
    while (i_ < s_.size() && std::isspace(static_cast<unsigned char>(s_[i_]))) {
      if (s_[i_] == '\n') ++line_;
      ++i_;
    }
  }
  const std::string& path_;
  std::string_view s_;
  std::size_t i_ = 0;
  int line_ = 1;
};

// Triangle soup: three vertices per triangle, welded afterwards.
TriangleMesh parse_ascii(const std::string& path, const std::string& text) {
  TriangleMesh m;
  Tokens tok(path, text);
  tok.expect("solid");
  m.label = tok.rest_of_line();
  while (true) {
    const std::string_view t = tok.next("'facet' or 'endsolid'");
    if (iequal(t, "endsolid")) {
      tok.rest_of_line();
      if (tok.done()) break;
      tok.expect("solid");  // several solids in one file
      tok.rest_of_line();
      continue;
    }
    if (!iequal(t, "facet")) tok.fail(fmt::format("found '{}'", t), "'facet' or 'endsolid'");
    tok.expect("normal");
    for (int k = 0; k < 3; ++k) tok.number("a normal component");
    tok.expect("outer");
    tok.expect("loop");
    const int first = int(m.vertices.size());
    for (int v = 0; v < 3; ++v) {
      tok.expect("vertex");
      Vec3 p;
      for (int k = 0; k < 3; ++k) p[k] = tok.number("a vertex coordinate");
      m.vertices.push_back(p);
    }
    tok.expect("endloop");
    tok.expect("endfacet");
    m.triangles.push_back({first, first + 1, first + 2});
  }
  return m;
}

template <class T>
T get(const std::string& s, std::size_t at) {
  T v;
  std::memcpy(&v, s.data() + at, sizeof v);
  return v;
}

TriangleMesh parse_binary(const std::string& path, const std::string& data) {
  const std::uint32_t n = get<std::uint32_t>(data, header_bytes);
  TriangleMesh m;
  m.vertices.reserve(3 * std::size_t(n));
  m.triangles.reserve(n);
  for (std::size_t t = 0; t < n; ++t) {
    const std::size_t at = header_bytes + count_bytes + t * facet_bytes + 12;  // skip the normal
    const int first = int(m.vertices.size());
    for (int v = 0; v < 3; ++v) {
      Vec3 p;
      for (int k = 0; k < 3; ++k) {
        const float x = get<float>(data, at + std::size_t(12 * v + 4 * k));
        if (!std::isfinite(x))
          throw InputError(path, "", "binary STL triangle " + std::to_string(t) + " has a non-finite coordinate",
                           "finite float32 coordinates");
        p[k] = x;
      }
      m.vertices.push_back(p);
    }
    m.triangles.push_back({first, first + 1, first + 2});
  }
  return m;
}

}  // namespace

TriangleMesh read_stl(const std::string& path, const StlReadOptions& options) {
  std::ifstream in(path, std::ios::binary);
  if (!in) throw InputError(path, "", "cannot open the file", "a readable STL file");
  std::ostringstream ss;
  ss << in.rdbuf();
  const std::string data = ss.str();

  const bool binary_size = data.size() >= header_bytes + count_bytes &&
                           data.size() == header_bytes + count_bytes +
                                              facet_bytes * std::size_t(get<std::uint32_t>(data, header_bytes));
  TriangleMesh m;
  if (starts_with_solid(data)) {
    // Some binary writers also begin their header with "solid": fall back on the size check.
    try {
      m = parse_ascii(path, data);
    } catch (const InputError&) {
      if (!binary_size) throw;
      m = parse_binary(path, data);
    }
  } else if (data.size() < header_bytes + count_bytes) {
    throw InputError(path, "", "truncated: " + std::to_string(data.size()) + " bytes",
                     "a binary STL of at least 84 bytes or an ASCII STL starting with 'solid'");
  } else if (!binary_size) {
    const std::uint32_t n = get<std::uint32_t>(data, header_bytes);
    throw InputError(path, "",
                     "binary STL header declares " + std::to_string(n) + " triangles (" +
                         std::to_string(header_bytes + count_bytes + facet_bytes * std::size_t(n)) +
                         " bytes) but the file has " + std::to_string(data.size()) + " bytes",
                     "a complete binary STL (84 + 50 n bytes)");
  } else {
    m = parse_binary(path, data);
  }
  if (m.triangles.empty()) throw InputError(path, "", "no triangles", "at least one facet");

  for (Vec3& p : m.vertices) p *= options.scale;
  const BoundingBox box = m.bounding_box();
  m.weld(options.weld_tolerance >= 0 ? options.weld_tolerance : 1e-7 * (box.hi - box.lo).norm());
  if (m.triangles.empty()) throw InputError(path, "", "every triangle has zero size", "non-degenerate facets");
  if (m.label.empty()) m.label = std::filesystem::path(path).stem().string();
  m.membrane = options.membrane;
  return m;
}

namespace {
template <class T>
void put(std::string& s, T v) {
  char b[sizeof v];
  std::memcpy(b, &v, sizeof v);
  s.append(b, sizeof v);
}
}  // namespace

void write_stl(const std::string& path, const TriangleMesh& mesh, StlFormat format) {
  std::string out;
  if (format == StlFormat::ascii) {
    const std::string name = mesh.label.empty() ? "flapstab" : mesh.label;
    fmt::format_to(std::back_inserter(out), "solid {}\n", name);
    for (std::size_t t = 0; t < mesh.size(); ++t) {
      const Vec3 n = mesh.normal(t);
      fmt::format_to(std::back_inserter(out), "  facet normal {} {} {}\n    outer loop\n", n.x(), n.y(),
                     n.z());
      for (int k = 0; k < 3; ++k) {
        const Vec3& p = mesh.vertex(t, k);
        fmt::format_to(std::back_inserter(out), "      vertex {} {} {}\n", p.x(), p.y(), p.z());
      }
      out += "    endloop\n  endfacet\n";
    }
    fmt::format_to(std::back_inserter(out), "endsolid {}\n", name);
  } else {
    // The header must not begin with "solid", or readers take the file for ASCII.
    std::string header = "flapstab binary STL, units m: " + mesh.label;
    header.resize(header_bytes, '\0');
    out = header;
    out.reserve(header_bytes + count_bytes + facet_bytes * mesh.size());
    put(out, std::uint32_t(mesh.size()));
    for (std::size_t t = 0; t < mesh.size(); ++t) {
      const Vec3 n = mesh.normal(t);
      for (int k = 0; k < 3; ++k) put(out, float(n[k]));
      for (int v = 0; v < 3; ++v)
        for (int k = 0; k < 3; ++k) put(out, float(mesh.vertex(t, v)[k]));
      put(out, std::uint16_t(0));
    }
  }
  write_file_atomic(path, out);
}

}  // namespace flapstab::ns
