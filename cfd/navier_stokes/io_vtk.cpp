// VTK XML PolyData writer (ASCII or inline base64) and ParaView .pvd collections.
#include "cfd/navier_stokes/io_vtk.hpp"
#include <bit>
#include <cctype>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <filesystem>
#include <fmt/format.h>
#include <fstream>
#include <regex>
#include <sstream>
#include <stdexcept>
#include "core/atomic_write.hpp"

namespace flapstab::ns {

static_assert(std::endian::native == std::endian::little, "the .vtp writer declares LittleEndian");

namespace {

std::string base64(const std::vector<unsigned char>& in) {
  static constexpr char table[] = "ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";
  std::string out;
  out.reserve((in.size() + 2) / 3 * 4);
  std::size_t i = 0;
  for (; i + 2 < in.size(); i += 3) {
    const std::uint32_t v = std::uint32_t(in[i]) << 16 | std::uint32_t(in[i + 1]) << 8 | in[i + 2];
    out += table[v >> 18 & 63];
    out += table[v >> 12 & 63];
    out += table[v >> 6 & 63];
    out += table[v & 63];
  }
  if (i < in.size()) {
    const bool two = i + 1 < in.size();
    const std::uint32_t v = std::uint32_t(in[i]) << 16 | (two ? std::uint32_t(in[i + 1]) << 8 : 0);
    out += table[v >> 18 & 63];
    out += table[v >> 12 & 63];
    out += two ? table[v >> 6 & 63] : '=';
    out += '=';
  }
  return out;
}

// One <DataArray>. Base64: a UInt64 byte count followed by the values, encoded as one stream (VTK's
// inline "binary" format, header_type="UInt64").
template <class T>
void data_array(std::string& s, const char* type, const std::string& name, int components, const std::vector<T>& v,
                VtkEncoding enc, const char* indent) {
  auto out = std::back_inserter(s);
  fmt::format_to(out, "{}<DataArray type=\"{}\" Name=\"{}\" NumberOfComponents=\"{}\" format=\"{}\">\n", indent, type,
                 xml_escape(name), components, enc == VtkEncoding::ascii ? "ascii" : "binary");
  if (enc == VtkEncoding::ascii) {
    s += indent;
    s += "  ";
    for (std::size_t i = 0; i < v.size(); ++i) {
      if constexpr (std::is_floating_point_v<T>)
        fmt::format_to(out, "{}", v[i]);  // shortest form that reads back exactly
      else
        fmt::format_to(out, "{}", v[i]);
      s += (i + 1) % 9 == 0 && i + 1 < v.size() ? "\n  " + std::string(indent) : " ";
    }
    s += "\n";
  } else {
    const std::uint64_t bytes = v.size() * sizeof(T);
    std::vector<unsigned char> raw(sizeof bytes + bytes);
    std::memcpy(raw.data(), &bytes, sizeof bytes);
    if (bytes) std::memcpy(raw.data() + sizeof bytes, v.data(), bytes);
    fmt::format_to(out, "{}  {}\n", indent, base64(raw));
  }
  fmt::format_to(out, "{}</DataArray>\n", indent);
}

void check_array(const SurfaceArray& a, std::size_t tuples, const char* where, const TriangleMesh& mesh) {
  if (a.components != 1 && a.components != 3)
    throw std::invalid_argument("surface array '" + a.name + "' must have 1 or 3 components");
  if (a.values.size() != tuples * std::size_t(a.components))
    throw std::invalid_argument("surface array '" + a.name + "' has " + std::to_string(a.values.size()) +
                                " values; mesh '" + mesh.label + "' needs " +
                                std::to_string(tuples * std::size_t(a.components)) + " (" + where + ")");
}

}  // namespace

std::string xml_escape(const std::string& s) {
  std::string r;
  for (char c : s) {
    switch (c) {
      case '&': r += "&amp;"; break;
      case '<': r += "&lt;"; break;
      case '>': r += "&gt;"; break;
      case '"': r += "&quot;"; break;
      default: r += c;
    }
  }
  return r;
}


void write_vtp(const std::string& path, const TriangleMesh& mesh, const SurfaceData& data, VtkEncoding encoding) {
  for (const auto& a : data.point_data) check_array(a, mesh.vertices.size(), "one tuple per vertex", mesh);
  for (const auto& a : data.cell_data) check_array(a, mesh.size(), "one tuple per triangle", mesh);

  std::string note = "flapstab surface '" + mesh.label + "' (" + (mesh.membrane ? "membrane" : "closed") +
                     "): points in m, stability axes S (x forward, y right, z down, origin at the wingbeat-mean "
                     "centre of mass)";
  for (const auto* set : {&data.point_data, &data.cell_data})
    for (const auto& a : *set) note += "; " + a.name + " in " + (a.units.empty() ? "1" : a.units);
  for (std::size_t i; (i = note.find("--")) != std::string::npos;) note.replace(i, 2, "- -");  // not allowed in comments
  std::string s = "<?xml version=\"1.0\"?>\n<!-- " + xml_escape(note) + " -->\n";
  s += "<VTKFile type=\"PolyData\" version=\"1.0\" byte_order=\"LittleEndian\" header_type=\"UInt64\">\n";
  s += "  <PolyData>\n";
  if (std::isfinite(data.time)) {
    s += "    <FieldData>\n";
    data_array(s, "Float64", "TimeValue", 1, std::vector<double>{data.time}, encoding, "      ");
    s += "    </FieldData>\n";
  }
  fmt::format_to(std::back_inserter(s),
                 "    <Piece NumberOfPoints=\"{}\" NumberOfVerts=\"0\" NumberOfLines=\"0\" NumberOfStrips=\"0\" "
                 "NumberOfPolys=\"{}\">\n",
                 mesh.vertices.size(), mesh.size());
  s += "      <Points>\n";
  std::vector<double> xyz;
  xyz.reserve(3 * mesh.vertices.size());
  for (const Vec3& p : mesh.vertices) xyz.insert(xyz.end(), {p.x(), p.y(), p.z()});
  data_array(s, "Float64", "Points", 3, xyz, encoding, "        ");
  s += "      </Points>\n";
  s += "      <Polys>\n";
  std::vector<std::int64_t> connectivity, offsets;
  connectivity.reserve(3 * mesh.size());
  for (std::size_t t = 0; t < mesh.size(); ++t) {
    for (int k = 0; k < 3; ++k) connectivity.push_back(mesh.triangles[t][k]);
    offsets.push_back(std::int64_t(3 * (t + 1)));
  }
  data_array(s, "Int64", "connectivity", 1, connectivity, encoding, "        ");
  data_array(s, "Int64", "offsets", 1, offsets, encoding, "        ");
  s += "      </Polys>\n";
  for (const auto& [tag, set] : {std::pair{"PointData", &data.point_data}, std::pair{"CellData", &data.cell_data}}) {
    if (set->empty()) continue;
    fmt::format_to(std::back_inserter(s), "      <{}>\n", tag);
    for (const auto& a : *set) data_array(s, "Float64", a.name, a.components, a.values, encoding, "        ");
    fmt::format_to(std::back_inserter(s), "      </{}>\n", tag);
  }
  s += "    </Piece>\n";
  s += "  </PolyData>\n";
  s += "</VTKFile>\n";
  write_file_atomic(path, s);
}

void write_pvd(const std::string& path, const std::vector<PvdEntry>& entries) {
  std::string s = "<?xml version=\"1.0\"?>\n<VTKFile type=\"Collection\" version=\"0.1\" byte_order=\"LittleEndian\">\n";
  s += "  <Collection>\n";
  for (const auto& e : entries)
    fmt::format_to(std::back_inserter(s), "    <DataSet timestep=\"{}\" group=\"\" part=\"{}\" name=\"{}\" file=\"{}\"/>\n",
                   e.time, e.part, xml_escape(e.name), xml_escape(e.file));
  s += "  </Collection>\n</VTKFile>\n";
  write_file_atomic(path, s);
}

SurfaceWriter::SurfaceWriter(std::string directory, std::string name)
    : directory_(std::move(directory)), name_(std::move(name)) {
  std::ifstream in(collection_path());
  if (!in) return;
  std::stringstream ss;
  ss << in.rdbuf();
  const std::string text = ss.str();
  // Our own write_pvd output, one DataSet per line (files of earlier versions have no name attribute).
  const std::regex entry(R"re(<DataSet timestep="([^"]*)" group="" part="(\d+)"(?: name="([^"]*)")? file="([^"]*)"/>)re");
  for (std::sregex_iterator it(text.begin(), text.end(), entry), end; it != end; ++it)
    entries_.push_back({std::stod((*it)[1].str()), std::stoi((*it)[2].str()), (*it)[4].str(), (*it)[3].str()});
}

std::string SurfaceWriter::collection_path() const {
  return (std::filesystem::path(directory_) / (name_ + ".pvd")).string();
}

void SurfaceWriter::write(double time, std::int64_t step, const std::vector<SurfacePart>& parts) {
  std::erase_if(entries_, [&](const PvdEntry& e) { return e.time >= time; });
  for (std::size_t i = 0; i < parts.size(); ++i) {
    if (!parts[i].mesh) throw std::invalid_argument("surface part " + std::to_string(i) + " has no mesh");
    const std::string name = parts[i].mesh->label.empty() ? "part" + std::to_string(i) : parts[i].mesh->label;
    std::string label = name;
    for (char& c : label)
      if (!std::isalnum(static_cast<unsigned char>(c)) && c != '-') c = '_';
    const std::string file = fmt::format("{}_{}_{:06d}.vtp", name_, label, step);
    SurfaceData data = parts[i].data;
    data.time = time;
    write_vtp((std::filesystem::path(directory_) / file).string(), *parts[i].mesh, data);
    entries_.push_back({time, int(i), file, name});
  }
  write_pvd(collection_path(), entries_);
}

}  // namespace flapstab::ns
