// STL surface files: read ASCII or binary (detected from the content), write binary or ASCII.
//
// STL carries no units; flapstab writes metres and reads with a scale factor. Binary STL stores
// float32 coordinates, so a binary round trip is exact for float-representable coordinates; the
// ASCII writer prints each double as the shortest decimal that reads back to it, so its round trip is
// exact for any mesh.
#pragma once
#include <string>
#include "cfd/navier_stokes/geometry.hpp"

namespace flapstab::ns {

struct StlReadOptions {
  double scale = 1;            // coordinates are multiplied by this (1e-3 for a file in millimetres)
  double weld_tolerance = -1;  // m; vertices closer than this merge. Negative: 1e-7 x the bounding-box diagonal
  bool membrane = false;       // an open surface (wing) rather than a closed one
};

// Reads an STL file: binary when its size is 84 + 50 n for the n in its header and it does not parse as
// ASCII, ASCII when it starts with "solid". Duplicate vertices are merged and triangles that collapse
// are dropped; the facet normals in the file are ignored (the vertex order defines orientation). Throws
// InputError(path, "", problem, expected) for a missing, truncated, garbled or empty file.
TriangleMesh read_stl(const std::string& path, const StlReadOptions& options = {});

enum class StlFormat { binary, ascii };

// Writes the mesh (coordinates in m) atomically.
void write_stl(const std::string& path, const TriangleMesh& mesh, StlFormat format = StlFormat::binary);

}  // namespace flapstab::ns
