// Body surfaces for ParaView: VTK XML PolyData (.vtp) with per-vertex and per-triangle arrays, and a
// ParaView data collection (.pvd) that strings them into a time series. Written atomically.
#pragma once
#include <cstdint>
#include <limits>
#include <string>
#include <vector>
#include "cfd/navier_stokes/geometry.hpp"

namespace flapstab::ns {

struct SurfaceArray {
  std::string name;            // ParaView array name, e.g. "pressure"
  std::string units;           // SI, listed in the file's header comment
  int components = 1;          // 1 (scalar) or 3 (vector, stability axes)
  std::vector<double> values;  // one tuple per vertex (point data) or per triangle (cell data), interleaved
};

struct SurfaceData {
  std::vector<SurfaceArray> point_data;  // per vertex
  std::vector<SurfaceArray> cell_data;   // per triangle
  double time = std::numeric_limits<double>::quiet_NaN();  // s; written as the TimeValue field when finite
};

enum class VtkEncoding { ascii, base64 };

// Writes the mesh (points in m) and its arrays; std::invalid_argument when an array's length does not
// match the mesh.
void write_vtp(const std::string& path, const TriangleMesh& mesh, const SurfaceData& data = {},
               VtkEncoding encoding = VtkEncoding::base64);

struct PvdEntry {
  double time = 0;   // s
  int part = 0;      // several parts (body, wings) at one time carry different part numbers
  std::string file;  // relative to the .pvd file
  std::string name;  // the part's name (body, right, left): ParaView names the blocks by it
};

// s with & < > " replaced by XML entities (for attribute values and text; also used by the XDMF writer).
std::string xml_escape(const std::string& s);

// Writes a ParaView collection file over .vtp (or any VTK XML) files.
void write_pvd(const std::string& path, const std::vector<PvdEntry>& entries);

// One part's surface and arrays at an output time.
struct SurfacePart {
  const TriangleMesh* mesh = nullptr;  // its label names the file
  SurfaceData data;                    // data.time is set by the writer
};

// Writes <directory>/<name>_<label>_<step>.vtp per part and output time, and keeps the collection
// <directory>/<name>.pvd over every output current (part numbers in the order given).
class SurfaceWriter {
 public:
  // An existing collection (a run being restarted) is read and continued.
  SurfaceWriter(std::string directory, std::string name = "surfaces");
  // Entries an earlier run left at this time or later leave the collection (a restart has overtaken them).
  void write(double time, std::int64_t step, const std::vector<SurfacePart>& parts);
  std::string collection_path() const;

 private:
  std::string directory_, name_;
  std::vector<PvdEntry> entries_;
};

}  // namespace flapstab::ns
