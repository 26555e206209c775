// Flow-field output (HDF5 + XDMF for ParaView) and exact checkpoints (HDF5), on a rectilinear grid.
//
// Layouts, units and how to open the files: docs/cfd-files.md. Every file is written under a temporary
// name and renamed into place, so a run that fails leaves either the old file or the new one.
#pragma once
#include <array>
#include <cstdint>
#include <limits>
#include <functional>
#include <map>
#include <span>
#include <string>
#include <vector>

namespace flapstab::ns {

// Cell-face (node) coordinates of a rectilinear grid (m), strictly increasing: x.size() = nx + 1 for
// nx cells. Non-uniform spacing is the general case.
struct RectilinearAxes {
  std::vector<double> x, y, z;
  std::array<std::size_t, 3> cells() const;  // nx, ny, nz
  // Throws std::invalid_argument unless each axis has >= 2 strictly increasing finite values.
  void check() const;
};

// A cell-centred array: the value of cell (i, j, k) is data[i sx + j sy + k sz]. Strides 0 mean
// contiguous with x fastest (sx = 1, sy = nx, sz = nx ny). For an array with ghost layers, point data
// at the first interior cell and give the padded strides.
struct CellArray {
  const double* data = nullptr;
  std::ptrdiff_t sx = 1, sy = 0, sz = 0;
};

// A named cell-centred field: one component (scalar) or three (vector, x y z in stability axes).
struct CellField {
  std::string name;   // letters, digits, '_', '-', '.'; the HDF5 dataset and the ParaView array name
  std::string units;  // SI, e.g. "m/s", "Pa", "1/s"
  std::vector<CellArray> components;
  // Instead of the components' data (left null; their sx and sy still apply): the field handed over plane by plane,
  // plane(k, c) giving component c's values at z plane k (0-based), asked for k = 0, 1, ... in order, the fields in
  // turn (e.g. planes received from MPI ranks as the writer goes). The pointer need stay valid only until the next
  // call.
  std::function<const double*(std::size_t k, int c)> plane{};
};

enum class FieldPrecision { float64, float32 };

// Writes one HDF5 file and one XDMF file per output time, <directory>/<name>_<step>.h5/.xmf, and keeps
// the time series <directory>/<name>.xmf (an XDMF temporal collection over every output) current.
class FieldWriter {
 public:
  // Outputs of an earlier run already in the directory join the series (restarts append to it).
  // read_series false: the earlier outputs are not read (a writer that only writes pieces, write_piece, for a series
  // another writer keeps).
  FieldWriter(std::string directory, std::string name, RectilinearAxes axes,
              FieldPrecision precision = FieldPrecision::float64, bool read_series = true);
  // Writes the fields at one time (s) and step; returns the .h5 path. Outputs an earlier run left at
  // later steps leave the series (a restart has overtaken them).
  std::string write(double time, std::int64_t step, const std::vector<CellField>& fields);
  std::string series_path() const;

  // One output in pieces (a grid split over MPI ranks, each rank writing its own planes): each piece's writer, on
  // its own axes, writes <name>_<step>.p<piece>.h5 (write_piece, no XDMF); then one writer adds the pieces' records
  // (the piece files' names, their cells) to the series as one output (add_pieces): its XDMF is a spatial
  // collection of the pieces, which ParaView opens as one data set (a multiblock).
  struct Record;
  Record write_piece(double time, std::int64_t step, const std::vector<CellField>& fields, int piece);
  void add_pieces(std::vector<Record> pieces);
  static std::string piece_file_name(const std::string& name, std::int64_t step, int piece);

  // What one output file holds; public for the tests and the docs' examples.
  struct Record {
    std::string file;  // .h5 file name, relative to the directory
    double time = 0;
    std::int64_t step = 0;
    std::array<std::size_t, 3> cells{};
    int precision_bytes = 8;
    struct Field {
      std::string name, units;
      int components = 1;
    };
    std::vector<Field> fields;
  };

 private:
  std::string directory_, name_;
  RectilinearAxes axes_;
  FieldPrecision precision_;
  Record write_file(const std::string& file, double time, std::int64_t step, const std::vector<CellField>& fields);
  void add_output(std::vector<Record> pieces);  // one record, or the pieces of one output
  std::map<std::int64_t, std::vector<Record>> series_;  // by step: the output's file, or its pieces
};

// One field read back from a field file (post-processing and tests), as float64 in the file's layout:
// index ((k ny + j) nx + i) components + c.
struct StoredField {
  std::array<std::size_t, 3> cells{};  // nx, ny, nz
  int components = 1;
  std::string units;
  std::vector<double> values;
};
// InputError(path, name, ...) for a missing file, dataset or a file that is not a flapstab field file.
StoredField read_field(const std::string& path, const std::string& name);
RectilinearAxes read_axes(const std::string& path);

// The XDMF text for one output (a Uniform 3DRectMesh grid with cell-centred attributes) or for a
// temporal collection of outputs.
std::string xdmf_output(const FieldWriter::Record& r);
std::string xdmf_series(const std::vector<FieldWriter::Record>& records);
// The same for outputs in pieces (FieldWriter::write_piece): one piece is the output itself, several a spatial
// collection of them.
std::string xdmf_output(const std::vector<FieldWriter::Record>& pieces);
std::string xdmf_series(const std::vector<std::vector<FieldWriter::Record>>& outputs);

// ---- Checkpoints ---------------------------------------------------------------------------------

constexpr int checkpoint_format_version = 1;

struct CheckpointHeader {
  double time = 0;        // s
  std::int64_t step = 0;
  std::map<std::string, double> values;     // scalar state (time step, Reynolds number, ...)
  std::map<std::string, std::string> text;  // descriptions (case hash, grid summary, ...)
};

struct CheckpointArray {
  std::string name;                  // letters, digits, '_', '-', '.'
  std::span<const double> data;
  std::vector<std::size_t> shape;    // optional; empty: one-dimensional. Product must equal data.size()
};

// FNV-1a over the arrays' 64-bit words (the bit patterns of the doubles): the checksum stored with each array.
std::uint64_t checkpoint_checksum(std::span<const double> data);

// Writes every array bit for bit (IEEE float64) and the header into one HDF5 file, atomically.
void write_checkpoint(const std::string& path, const CheckpointHeader& header,
                      const std::vector<CheckpointArray>& arrays);

// An array handed over in whole rows (along its first dimension) by a source: `next()` returns the following rows
// (a whole number of them, at least one) until all shape[0] rows are given; the span need stay valid only until the
// next call. The file is the same as write_checkpoint's of the whole array, checksum included.
struct CheckpointRowArray {
  std::string name;
  std::vector<std::size_t> shape;  // at least one dimension
  std::function<std::span<const double>()> next;
};
// Writes the header and the arrays, each streamed through from its source in order (only one piece held at a time),
// atomically; std::invalid_argument for a source whose rows do not add up to the shape.
void write_checkpoint(const std::string& path, const CheckpointHeader& header,
                      const std::vector<CheckpointRowArray>& arrays);

// Opens a checkpoint; InputError for a missing or unreadable file, one that is not a flapstab
// checkpoint, or one of a newer format version.
class CheckpointReader {
 public:
  explicit CheckpointReader(const std::string& path);
  ~CheckpointReader();
  CheckpointReader(const CheckpointReader&) = delete;
  CheckpointReader& operator=(const CheckpointReader&) = delete;

  const CheckpointHeader& header() const { return header_; }
  const std::string& path() const { return path_; }
  std::vector<std::string> names() const;
  bool contains(const std::string& name) const;
  std::vector<std::size_t> shape(const std::string& name) const;
  // Reads an array into `out`, whose size must match; InputError(path, name, ...) when the array is
  // missing or its size differs.
  // Arrays carry a checksum (checkpoint_checksum); a mismatch is an InputError naming the array.
  void read(const std::string& name, std::span<double> out) const;
  std::vector<double> read(const std::string& name) const;
  // Rows first, first + 1, ... of an array along its first dimension (z planes of a padded field: a rank's slab with
  // its ghost planes) into `out`, a whole number of rows. The array is streamed in chunks of whole rows of about
  // `chunk_values` values (8 MB by default) and its whole checksum checked, so only `out` and one chunk are held: a
  // rank restarts without the whole grid in memory.
  void read_rows(const std::string& name, std::size_t first, std::span<double> out,
                 std::size_t chunk_values = std::size_t(1) << 20) const;
  // Reads every array and checks its checksum (InputError for the first damaged one).
  void verify() const;

 private:
  std::string path_;
  std::int64_t file_ = -1;  // hid_t
  CheckpointHeader header_;
};

}  // namespace flapstab::ns
