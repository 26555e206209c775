// HDF5 + XDMF flow-field files and HDF5 checkpoints (serial HDF5 1.10, hand-written XDMF 2).
#include "cfd/navier_stokes/io_hdf5.hpp"
#include <hdf5.h>
#include <unistd.h>
#include <algorithm>
#include <cerrno>
#include <cctype>
#include <cmath>
#include <cstring>
#include <filesystem>
#include <fmt/format.h>
#include <numeric>
#include <regex>
#include <stdexcept>
#include "cfd/navier_stokes/io_vtk.hpp"
#include "core/atomic_write.hpp"
#include "core/errors.hpp"
#include "core/hash.hpp"

namespace flapstab::ns {

static_assert(sizeof(hid_t) == sizeof(std::int64_t), "CheckpointReader stores a hid_t as int64");

namespace {

namespace fs = std::filesystem;

// HDF5 prints its error stack to stderr by default; flapstab reports errors by exception instead.
class QuietErrors {
 public:
  QuietErrors() {
    H5Eget_auto2(H5E_DEFAULT, &func_, &data_);
    H5Eset_auto2(H5E_DEFAULT, nullptr, nullptr);
  }
  ~QuietErrors() { H5Eset_auto2(H5E_DEFAULT, func_, data_); }
  QuietErrors(const QuietErrors&) = delete;
  QuietErrors& operator=(const QuietErrors&) = delete;

 private:
  H5E_auto2_t func_ = nullptr;
  void* data_ = nullptr;
};

// An HDF5 identifier closed on scope exit.
class Id {
 public:
  Id(hid_t id, herr_t (*close)(hid_t)) : id_(id), close_(close) {}
  ~Id() {
    if (id_ >= 0) close_(id_);
  }
  Id(const Id&) = delete;
  Id& operator=(const Id&) = delete;
  operator hid_t() const { return id_; }
  bool ok() const { return id_ >= 0; }

 private:
  hid_t id_;
  herr_t (*close_)(hid_t);
};

[[noreturn]] void fail(const std::string& path, const std::string& what) {
  throw std::runtime_error(path + ": HDF5 error: " + what);
}

hid_t checked(hid_t id, const std::string& path, const std::string& what) {
  if (id < 0) fail(path, what);
  return id;
}

void checked_status(herr_t status, const std::string& path, const std::string& what) {
  if (status < 0) fail(path, what);
}

void check_name(const std::string& name, const char* what) {
  const bool ok = !name.empty() && name != "." && name != ".." &&
                  std::all_of(name.begin(), name.end(), [](char c) {
                    return std::isalnum(static_cast<unsigned char>(c)) || c == '_' || c == '-' || c == '.';
                  });
  if (!ok)
    throw std::invalid_argument(std::string(what) + " name '" + name +
                                "' must be non-empty letters, digits, '_', '-' or '.'");
}

void write_string_attribute(hid_t obj, const char* name, const std::string& value, const std::string& path) {
  Id type(H5Tcopy(H5T_C_S1), H5Tclose);
  checked_status(H5Tset_size(type, std::max<std::size_t>(1, value.size())), path, "string type");
  checked_status(H5Tset_strpad(type, H5T_STR_NULLPAD), path, "string type");
  Id space(H5Screate(H5S_SCALAR), H5Sclose);
  Id attr(checked(H5Acreate2(obj, name, type, space, H5P_DEFAULT, H5P_DEFAULT), path, std::string("attribute ") + name),
          H5Aclose);
  std::string padded = value;
  padded.resize(std::max<std::size_t>(1, value.size()), '\0');
  checked_status(H5Awrite(attr, type, padded.data()), path, std::string("attribute ") + name);
}

template <class T>
void write_number_attribute(hid_t obj, const char* name, T value, const std::string& path) {
  const hid_t file_type = std::is_floating_point_v<T> ? H5T_IEEE_F64LE : H5T_STD_I64LE;
  const hid_t mem_type = std::is_floating_point_v<T> ? H5T_NATIVE_DOUBLE : H5T_NATIVE_INT64;
  Id space(H5Screate(H5S_SCALAR), H5Sclose);
  Id attr(checked(H5Acreate2(obj, name, file_type, space, H5P_DEFAULT, H5P_DEFAULT), path,
                  std::string("attribute ") + name),
          H5Aclose);
  checked_status(H5Awrite(attr, mem_type, &value), path, std::string("attribute ") + name);
}

bool has_attribute(hid_t obj, const char* name) { return H5Aexists(obj, name) > 0; }

std::string read_string_attribute(hid_t obj, const char* name, const std::string& path) {
  Id attr(checked(H5Aopen(obj, name, H5P_DEFAULT), path, std::string("attribute ") + name), H5Aclose);
  Id type(H5Aget_type(attr), H5Tclose);
  if (H5Tget_class(type) != H5T_STRING || H5Tis_variable_str(type) > 0)
    fail(path, std::string("attribute ") + name + " is not a fixed-length string");
  std::string s(H5Tget_size(type), '\0');
  Id mem(H5Tcopy(type), H5Tclose);
  checked_status(H5Aread(attr, mem, s.data()), path, std::string("attribute ") + name);
  s.erase(std::find(s.begin(), s.end(), '\0'), s.end());
  return s;
}

double read_double_attribute(hid_t obj, const char* name, const std::string& path) {
  Id attr(checked(H5Aopen(obj, name, H5P_DEFAULT), path, std::string("attribute ") + name), H5Aclose);
  double v = 0;
  checked_status(H5Aread(attr, H5T_NATIVE_DOUBLE, &v), path, std::string("attribute ") + name);
  return v;
}

std::int64_t read_int_attribute(hid_t obj, const char* name, const std::string& path) {
  Id attr(checked(H5Aopen(obj, name, H5P_DEFAULT), path, std::string("attribute ") + name), H5Aclose);
  std::int64_t v = 0;
  checked_status(H5Aread(attr, H5T_NATIVE_INT64, &v), path, std::string("attribute ") + name);
  return v;
}

std::vector<std::string> attribute_names(hid_t obj) {
  std::vector<std::string> names;
  H5Aiterate2(
      obj, H5_INDEX_NAME, H5_ITER_INC, nullptr,
      [](hid_t, const char* name, const H5A_info_t*, void* out) -> herr_t {
        static_cast<std::vector<std::string>*>(out)->emplace_back(name);
        return 0;
      },
      &names);
  return names;
}

std::vector<std::string> link_names(hid_t group) {
  std::vector<std::string> names;
  H5Literate(
      group, H5_INDEX_NAME, H5_ITER_INC, nullptr,
      [](hid_t, const char* name, const H5L_info_t*, void* out) -> herr_t {
        static_cast<std::vector<std::string>*>(out)->emplace_back(name);
        return 0;
      },
      &names);
  return names;
}

// A 1-D float64 dataset with a units attribute.
void write_vector(hid_t loc, const char* name, const std::vector<double>& v, const char* units,
                  const char* description, const std::string& path) {
  const hsize_t n = v.size();
  Id space(H5Screate_simple(1, &n, nullptr), H5Sclose);
  Id set(checked(H5Dcreate2(loc, name, H5T_IEEE_F64LE, space, H5P_DEFAULT, H5P_DEFAULT, H5P_DEFAULT), path,
                 std::string("dataset ") + name),
         H5Dclose);
  checked_status(H5Dwrite(set, H5T_NATIVE_DOUBLE, H5S_ALL, H5S_ALL, H5P_DEFAULT, v.data()), path,
                 std::string("dataset ") + name);
  write_string_attribute(set, "units", units, path);
  write_string_attribute(set, "description", description, path);
}

// Creates `path` through a temporary file beside it: `fill` writes the content into the open file.
template <class F>
void write_hdf5_atomic(const std::string& path, F fill) {
  const fs::path target(path);
  std::error_code ec;
  if (target.has_parent_path()) fs::create_directories(target.parent_path(), ec);
  if (ec) throw OutputError(output_failure("create directory", target.parent_path().string(), ec.value()));
  const std::string tmp = path + ".tmp." + std::to_string(::getpid());
  errno = 0;
  try {
    {
      Id file(checked(H5Fcreate(tmp.c_str(), H5F_ACC_TRUNC, H5P_DEFAULT, H5P_DEFAULT), path, "cannot create " + tmp),
              H5Fclose);
      fill(hid_t(file));
      checked_status(H5Fflush(file, H5F_SCOPE_GLOBAL), path, "flush");
    }
    fs::rename(tmp, target, ec);
    if (ec) throw OutputError(output_failure("rename into place", path, ec.value()));
  } catch (const std::invalid_argument&) {
    fs::remove(tmp, ec);
    throw;
  } catch (const std::runtime_error& e) {
    // HDF5 writes through POSIX calls: a full disk or a refused write leaves errno set. Name the system's reason.
    const int err = errno;
    fs::remove(tmp, ec);
    if (dynamic_cast<const OutputError*>(&e)) throw;
    if (err == ENOSPC || err == EDQUOT || err == EROFS || err == EACCES || err == EPERM || err == EIO || err == EFBIG)
      throw OutputError(output_failure("write", path, err) + " (" + e.what() + ")");
    throw;
  }
}

std::string output_file_name(const std::string& name, std::int64_t step) { return fmt::format("{}_{:06d}.h5", name, step); }

// Copies one field into the file plane by plane (constant z), in the file's precision.
template <class T>
void write_field(hid_t loc, const CellField& f, const std::array<std::size_t, 3>& n, hid_t file_type,
                 hid_t mem_type, const std::string& path) {
  const int nc = int(f.components.size());
  const int rank = nc == 1 ? 3 : 4;
  const hsize_t dims[4] = {n[2], n[1], n[0], hsize_t(nc)};
  Id space(H5Screate_simple(rank, dims, nullptr), H5Sclose);
  Id set(checked(H5Dcreate2(loc, f.name.c_str(), file_type, space, H5P_DEFAULT, H5P_DEFAULT, H5P_DEFAULT), path,
                 "dataset " + f.name),
         H5Dclose);
  const hsize_t plane[4] = {1, n[1], n[0], hsize_t(nc)};
  Id mem(H5Screate_simple(rank, plane, nullptr), H5Sclose);
  std::vector<T> buf(n[0] * n[1] * std::size_t(nc));
  for (std::size_t k = 0; k < n[2]; ++k) {
    for (int c = 0; c < nc; ++c) {
      const CellArray& a = f.components[std::size_t(c)];
      const std::ptrdiff_t sy = a.sy ? a.sy : std::ptrdiff_t(n[0]), sz = a.sz ? a.sz : std::ptrdiff_t(n[0] * n[1]);
      const double* first = f.plane ? f.plane(k, c) : a.data + std::ptrdiff_t(k) * sz;  // the plane's cell (0, 0)
      for (std::size_t j = 0; j < n[1]; ++j) {
        const double* row = first + std::ptrdiff_t(j) * sy;
        T* out = buf.data() + (j * n[0]) * std::size_t(nc) + std::size_t(c);
        for (std::size_t i = 0; i < n[0]; ++i) out[i * std::size_t(nc)] = T(row[std::ptrdiff_t(i) * a.sx]);
      }
    }
    const hsize_t start[4] = {k, 0, 0, 0};
    checked_status(H5Sselect_hyperslab(space, H5S_SELECT_SET, start, nullptr, plane, nullptr), path, "hyperslab");
    checked_status(H5Dwrite(set, mem_type, mem, space, H5P_DEFAULT, buf.data()), path, "dataset " + f.name);
  }
  write_string_attribute(set, "units", f.units, path);
  write_string_attribute(set, "centering", "cell", path);
  write_number_attribute<std::int64_t>(set, "components", nc, path);
  write_string_attribute(set, "layout",
                         nc == 1 ? "[z][y][x], C order (x fastest)" : "[z][y][x][component], C order (x fastest)",
                         path);
}

std::vector<double> centres(const std::vector<double>& faces) {
  std::vector<double> c(faces.size() - 1);
  for (std::size_t i = 0; i + 1 < faces.size(); ++i) c[i] = 0.5 * (faces[i] + faces[i + 1]);
  return c;
}

constexpr const char* axes_note =
    "stability axes S: x forward, y right, z down; origin at the wingbeat-mean centre of mass; m";

// Reads back what a field file holds, for the series.
FieldWriter::Record read_record(const std::string& dir, const std::string& file) {
  const std::string path = (fs::path(dir) / file).string();
  Id f(checked(H5Fopen(path.c_str(), H5F_ACC_RDONLY, H5P_DEFAULT), path, "cannot open"), H5Fclose);
  if (!has_attribute(f, "format") || read_string_attribute(f, "format", path) != "flapstab-fields")
    fail(path, "not a flapstab field file");
  FieldWriter::Record r;
  r.file = file;
  r.time = read_double_attribute(f, "time", path);
  r.step = read_int_attribute(f, "step", path);
  const char* axis_names[3] = {"/grid/x", "/grid/y", "/grid/z"};
  for (int a = 0; a < 3; ++a) {
    Id set(checked(H5Dopen2(f, axis_names[a], H5P_DEFAULT), path, axis_names[a]), H5Dclose);
    Id space(H5Dget_space(set), H5Sclose);
    r.cells[std::size_t(a)] = std::size_t(H5Sget_simple_extent_npoints(space)) - 1;
  }
  std::string list = read_string_attribute(f, "fields", path);
  Id group(checked(H5Gopen2(f, "fields", H5P_DEFAULT), path, "group fields"), H5Gclose);
  for (std::size_t b = 0; b < list.size();) {
    std::size_t e = list.find(',', b);
    if (e == std::string::npos) e = list.size();
    FieldWriter::Record::Field fld;
    fld.name = list.substr(b, e - b);
    Id set(checked(H5Dopen2(group, fld.name.c_str(), H5P_DEFAULT), path, "dataset " + fld.name), H5Dclose);
    Id type(H5Dget_type(set), H5Tclose);
    r.precision_bytes = int(H5Tget_size(type));
    fld.units = read_string_attribute(set, "units", path);
    fld.components = int(read_int_attribute(set, "components", path));
    r.fields.push_back(fld);
    b = e + 1;
  }
  return r;
}

std::string xdmf_grid(const FieldWriter::Record& r, const std::string& indent) {
  const auto [nx, ny, nz] = r.cells;
  std::string s;
  auto out = std::back_inserter(s);
  fmt::format_to(out, "{}<Grid Name=\"{}\" GridType=\"Uniform\">\n", indent, xml_escape(r.file));
  fmt::format_to(out, "{}  <Time Value=\"{}\"/>\n", indent, r.time);
  fmt::format_to(out, "{}  <Topology TopologyType=\"3DRectMesh\" Dimensions=\"{} {} {}\"/>\n", indent, nz + 1, ny + 1,
                 nx + 1);
  fmt::format_to(out, "{}  <Geometry GeometryType=\"VXVYVZ\">\n", indent);
  const char* names[3] = {"x", "y", "z"};
  for (int a = 0; a < 3; ++a)
    fmt::format_to(out,
                   "{}    <DataItem Name=\"{}\" Dimensions=\"{}\" NumberType=\"Float\" Precision=\"8\" "
                   "Format=\"HDF\">{}:/grid/{}</DataItem>\n",
                   indent, names[a], r.cells[std::size_t(a)] + 1, xml_escape(r.file), names[a]);
  fmt::format_to(out, "{}  </Geometry>\n", indent);
  for (const auto& f : r.fields) {
    fmt::format_to(out, "{}  <Attribute Name=\"{}\" AttributeType=\"{}\" Center=\"Cell\">\n", indent,
                   xml_escape(f.name), f.components == 3 ? "Vector" : "Scalar");
    fmt::format_to(out, "{}    <Information Name=\"units\" Value=\"{}\"/>\n", indent, xml_escape(f.units));
    const std::string dims =
        f.components == 3 ? fmt::format("{} {} {} 3", nz, ny, nx) : fmt::format("{} {} {}", nz, ny, nx);
    fmt::format_to(out,
                   "{}    <DataItem Dimensions=\"{}\" NumberType=\"Float\" Precision=\"{}\" "
                   "Format=\"HDF\">{}:/fields/{}</DataItem>\n",
                   indent, dims, r.precision_bytes, xml_escape(r.file), xml_escape(f.name));
    fmt::format_to(out, "{}  </Attribute>\n", indent);
  }
  fmt::format_to(out, "{}</Grid>\n", indent);
  return s;
}

constexpr const char* xdmf_head =
    "<?xml version=\"1.0\" ?>\n"
    "<!-- flapstab flow field: cell-centred values on a rectilinear grid; coordinates in stability axes S\n"
    "     (x forward, y right, z down, origin at the wingbeat-mean centre of mass), SI units. -->\n"
    "<Xdmf Version=\"2.0\">\n"
    "  <Domain>\n";
constexpr const char* xdmf_tail =
    "  </Domain>\n"
    "</Xdmf>\n";

}  // namespace

std::array<std::size_t, 3> RectilinearAxes::cells() const {
  return {x.empty() ? 0 : x.size() - 1, y.empty() ? 0 : y.size() - 1, z.empty() ? 0 : z.size() - 1};
}

void RectilinearAxes::check() const {
  const std::vector<double>* axes[3] = {&x, &y, &z};
  const char* names = "xyz";
  for (int a = 0; a < 3; ++a) {
    const auto& v = *axes[a];
    if (v.size() < 2)
      throw std::invalid_argument(std::string("grid axis ") + names[a] + " needs at least 2 face coordinates");
    for (std::size_t i = 0; i < v.size(); ++i)
      if (!std::isfinite(v[i]) || (i > 0 && !(v[i] > v[i - 1])))
        throw std::invalid_argument(std::string("grid axis ") + names[a] +
                                    " face coordinates must be finite and strictly increasing (index " +
                                    std::to_string(i) + ")");
  }
}

std::string xdmf_output(const FieldWriter::Record& r) { return xdmf_head + xdmf_grid(r, "    ") + xdmf_tail; }

std::string xdmf_series(const std::vector<FieldWriter::Record>& records) {
  std::vector<std::vector<FieldWriter::Record>> outputs;
  for (const auto& r : records) outputs.push_back({r});
  return xdmf_series(outputs);
}

namespace {
// One output: its grid, or the spatial collection of its pieces.
std::string xdmf_pieces(const std::vector<FieldWriter::Record>& pieces, const std::string& indent) {
  if (pieces.size() == 1) return xdmf_grid(pieces.front(), indent);
  std::string s;
  auto out = std::back_inserter(s);
  fmt::format_to(out, "{}<Grid Name=\"step_{}\" GridType=\"Collection\" CollectionType=\"Spatial\">\n", indent,
                 pieces.front().step);
  fmt::format_to(out, "{}  <Time Value=\"{}\"/>\n", indent, pieces.front().time);
  for (const auto& r : pieces) s += xdmf_grid(r, indent + "  ");
  fmt::format_to(out, "{}</Grid>\n", indent);
  return s;
}
}  // namespace

std::string xdmf_output(const std::vector<FieldWriter::Record>& pieces) {
  return xdmf_head + xdmf_pieces(pieces, "    ") + xdmf_tail;
}

std::string xdmf_series(const std::vector<std::vector<FieldWriter::Record>>& outputs) {
  std::string s = xdmf_head;
  s += "    <Grid Name=\"time_series\" GridType=\"Collection\" CollectionType=\"Temporal\">\n";
  for (const auto& o : outputs) s += xdmf_pieces(o, "      ");
  s += "    </Grid>\n";
  return s + xdmf_tail;
}

FieldWriter::FieldWriter(std::string directory, std::string name, RectilinearAxes axes, FieldPrecision precision,
                         bool read_series)
    : directory_(std::move(directory)), name_(std::move(name)), axes_(std::move(axes)), precision_(precision) {
  check_name(name_, "field output");
  axes_.check();
  std::error_code ec;
  fs::create_directories(directory_, ec);
  if (ec) throw OutputError(output_failure("create directory", directory_, ec.value()));
  // Whole outputs (<name>_<step>.h5) and pieces (<name>_<step>.p<piece>.h5, a run over MPI ranks); a step written
  // both ways (restarts with other settings) keeps its whole file. A writer of one piece of a run over ranks whose
  // series another rank keeps reads nothing (read_series false).
  if (!read_series) return;
  const std::regex pattern(std::regex_replace(name_, std::regex(R"([.\-])"), R"(\$&)") + R"(_(\d+)(\.p(\d+))?\.h5)");
  std::map<std::int64_t, std::map<int, Record>> pieces;
  QuietErrors quiet;
  for (const auto& entry : fs::directory_iterator(directory_)) {
    const std::string file = entry.path().filename().string();
    std::smatch m;
    if (!entry.is_regular_file() || !std::regex_match(file, m, pattern)) continue;
    try {
      Record r = read_record(directory_, file);
      if (m[2].matched) pieces[r.step][std::stoi(m[3].str())] = std::move(r);
      else series_[r.step] = {std::move(r)};
    } catch (const std::exception&) {
      // Not one of ours (or unreadable): it stays out of the series.
    }
  }
  for (auto& [step, by_piece] : pieces) {
    if (series_.count(step)) continue;
    std::vector<Record> v;
    for (auto& [k, r] : by_piece) v.push_back(std::move(r));
    series_[step] = std::move(v);
  }
}

std::string FieldWriter::piece_file_name(const std::string& name, std::int64_t step, int piece) {
  return fmt::format("{}_{:06d}.p{:04d}.h5", name, step, piece);
}

std::string FieldWriter::series_path() const { return (fs::path(directory_) / (name_ + ".xmf")).string(); }

std::string FieldWriter::write(double time, std::int64_t step, const std::vector<CellField>& fields) {
  Record r = write_file(output_file_name(name_, step), time, step, fields);
  add_output({r});
  return (fs::path(directory_) / r.file).string();
}

FieldWriter::Record FieldWriter::write_piece(double time, std::int64_t step, const std::vector<CellField>& fields,
                                             int piece) {
  return write_file(piece_file_name(name_, step, piece), time, step, fields);
}

void FieldWriter::add_pieces(std::vector<Record> pieces) {
  if (pieces.empty()) throw std::invalid_argument("FieldWriter::add_pieces: no pieces");
  add_output(std::move(pieces));
}

FieldWriter::Record FieldWriter::write_file(const std::string& file, double time, std::int64_t step,
                                            const std::vector<CellField>& fields) {
  const auto n = axes_.cells();
  Record r;
  r.file = file;
  r.time = time;
  r.step = step;
  r.cells = n;
  r.precision_bytes = precision_ == FieldPrecision::float64 ? 8 : 4;
  std::string list;
  for (const CellField& f : fields) {
    check_name(f.name, "field");
    if (f.components.size() != 1 && f.components.size() != 3)
      throw std::invalid_argument("field '" + f.name + "' must have 1 or 3 components");
    for (const CellArray& a : f.components)
      if (!a.data && !f.plane) throw std::invalid_argument("field '" + f.name + "' has a null component");
    if (std::any_of(r.fields.begin(), r.fields.end(), [&](const Record::Field& g) { return g.name == f.name; }))
      throw std::invalid_argument("field '" + f.name + "' given twice");
    r.fields.push_back({f.name, f.units, int(f.components.size())});
    list += (list.empty() ? "" : ",") + f.name;
  }

  const std::string path = (fs::path(directory_) / r.file).string();
  QuietErrors quiet;
  write_hdf5_atomic(path, [&](hid_t file) {
    write_string_attribute(file, "format", "flapstab-fields", path);
    write_number_attribute<std::int64_t>(file, "format_version", 1, path);
    write_number_attribute(file, "time", time, path);
    write_string_attribute(file, "time_units", "s", path);
    write_number_attribute<std::int64_t>(file, "step", step, path);
    write_string_attribute(file, "axes", axes_note, path);
    write_string_attribute(file, "fields", list, path);
    Id grid(checked(H5Gcreate2(file, "grid", H5P_DEFAULT, H5P_DEFAULT, H5P_DEFAULT), path, "group grid"), H5Gclose);
    write_vector(grid, "x", axes_.x, "m", "cell-face (node) x coordinates", path);
    write_vector(grid, "y", axes_.y, "m", "cell-face (node) y coordinates", path);
    write_vector(grid, "z", axes_.z, "m", "cell-face (node) z coordinates", path);
    write_vector(grid, "x_centres", centres(axes_.x), "m", "cell-centre x coordinates", path);
    write_vector(grid, "y_centres", centres(axes_.y), "m", "cell-centre y coordinates", path);
    write_vector(grid, "z_centres", centres(axes_.z), "m", "cell-centre z coordinates", path);
    Id group(checked(H5Gcreate2(file, "fields", H5P_DEFAULT, H5P_DEFAULT, H5P_DEFAULT), path, "group fields"),
             H5Gclose);
    for (const CellField& f : fields) {
      if (precision_ == FieldPrecision::float64)
        write_field<double>(group, f, n, H5T_IEEE_F64LE, H5T_NATIVE_DOUBLE, path);
      else
        write_field<float>(group, f, n, H5T_IEEE_F32LE, H5T_NATIVE_FLOAT, path);
    }
  });

  return r;
}

void FieldWriter::add_output(std::vector<Record> pieces) {
  const std::int64_t step = pieces.front().step;
  const std::string xmf = (fs::path(directory_) / output_file_name(name_, step)).replace_extension(".xmf").string();
  write_file_atomic(xmf, xdmf_output(pieces));
  series_.erase(series_.upper_bound(step), series_.end());
  series_[step] = std::move(pieces);
  std::vector<std::vector<Record>> all;
  for (const auto& [s, output] : series_) all.push_back(output);
  write_file_atomic(series_path(), xdmf_series(all));
}

namespace {
// Opens a field file for reading, with InputError for what a user can fix.
hid_t open_field_file(const std::string& path) {
  if (!fs::exists(path)) throw InputError(path, "", "no such file", "a flapstab field file (.h5)");
  const hid_t f = H5Fopen(path.c_str(), H5F_ACC_RDONLY, H5P_DEFAULT);
  if (f < 0) throw InputError(path, "", "cannot open as HDF5", "a flapstab field file (.h5)");
  if (!has_attribute(f, "format") || read_string_attribute(f, "format", path) != "flapstab-fields") {
    H5Fclose(f);
    throw InputError(path, "format", "not a flapstab field file", "format = flapstab-fields");
  }
  return f;
}

std::vector<double> read_all(hid_t loc, const std::string& name, const std::string& path,
                             std::vector<hsize_t>& dims) {
  if (H5Lexists(loc, name.c_str(), H5P_DEFAULT) <= 0)
    throw InputError(path, name, "no such dataset", "a dataset the field writer made");
  Id set(checked(H5Dopen2(loc, name.c_str(), H5P_DEFAULT), path, "dataset " + name), H5Dclose);
  Id space(H5Dget_space(set), H5Sclose);
  dims.resize(std::size_t(std::max(0, H5Sget_simple_extent_ndims(space))));
  H5Sget_simple_extent_dims(space, dims.data(), nullptr);
  std::vector<double> v(std::size_t(H5Sget_simple_extent_npoints(space)));
  if (!v.empty())
    checked_status(H5Dread(set, H5T_NATIVE_DOUBLE, H5S_ALL, H5S_ALL, H5P_DEFAULT, v.data()), path, "dataset " + name);
  return v;
}
}  // namespace

StoredField read_field(const std::string& path, const std::string& name) {
  QuietErrors quiet;
  Id f(open_field_file(path), H5Fclose);
  Id group(checked(H5Gopen2(f, "fields", H5P_DEFAULT), path, "group fields"), H5Gclose);
  StoredField out;
  std::vector<hsize_t> dims;
  out.values = read_all(group, name, path, dims);
  if (dims.size() < 3) throw InputError(path, name, "is not a 3-D field", "dimensions [z][y][x](,3)");
  out.cells = {std::size_t(dims[2]), std::size_t(dims[1]), std::size_t(dims[0])};
  out.components = dims.size() == 4 ? int(dims[3]) : 1;
  Id set(checked(H5Dopen2(group, name.c_str(), H5P_DEFAULT), path, "dataset " + name), H5Dclose);
  out.units = read_string_attribute(set, "units", path);
  return out;
}

RectilinearAxes read_axes(const std::string& path) {
  QuietErrors quiet;
  Id f(open_field_file(path), H5Fclose);
  Id grid(checked(H5Gopen2(f, "grid", H5P_DEFAULT), path, "group grid"), H5Gclose);
  std::vector<hsize_t> dims;
  RectilinearAxes a;
  a.x = read_all(grid, "x", path, dims);
  a.y = read_all(grid, "y", path, dims);
  a.z = read_all(grid, "z", path, dims);
  return a;
}

// ---- Checkpoints ---------------------------------------------------------------------------------

namespace {
// FNV-1a over the words of `data`, continuing from h (the checksum of what came before).
std::uint64_t checksum_continued(std::uint64_t h, std::span<const double> data) {
  for (double v : data) {
    std::uint64_t w;
    std::memcpy(&w, &v, sizeof w);
    h = (h ^ w) * 1099511628211ull;
  }
  return h;
}
}  // namespace

std::uint64_t checkpoint_checksum(std::span<const double> data) { return checksum_continued(fnv1a64_basis, data); }

namespace {

// The checkpoint's header and its groups; returns the group the arrays go in.
Id write_checkpoint_header(hid_t file, const std::string& path, const CheckpointHeader& header) {
  write_string_attribute(file, "format", "flapstab-checkpoint", path);
  write_number_attribute<std::int64_t>(file, "format_version", checkpoint_format_version, path);
  write_number_attribute(file, "time", header.time, path);
  write_string_attribute(file, "time_units", "s", path);
  write_number_attribute<std::int64_t>(file, "step", header.step, path);
  Id values(checked(H5Gcreate2(file, "values", H5P_DEFAULT, H5P_DEFAULT, H5P_DEFAULT), path, "group values"),
            H5Gclose);
  for (const auto& [k, v] : header.values) write_number_attribute(values, k.c_str(), v, path);
  Id text(checked(H5Gcreate2(file, "text", H5P_DEFAULT, H5P_DEFAULT, H5P_DEFAULT), path, "group text"), H5Gclose);
  for (const auto& [k, v] : header.text) write_string_attribute(text, k.c_str(), v, path);
  return Id(checked(H5Gcreate2(file, "arrays", H5P_DEFAULT, H5P_DEFAULT, H5P_DEFAULT), path, "group arrays"),
            H5Gclose);
}

void check_header_names(const CheckpointHeader& header) {
  for (const auto& [k, v] : header.values) check_name(k, "checkpoint value");
  for (const auto& [k, v] : header.text) check_name(k, "checkpoint text");
}

}  // namespace

void write_checkpoint(const std::string& path, const CheckpointHeader& header,
                      const std::vector<CheckpointRowArray>& arrays) {
  for (const auto& a : arrays) {
    check_name(a.name, "checkpoint array");
    if (a.shape.empty() || !a.next) throw std::invalid_argument("checkpoint array '" + a.name + "': no rows");
  }
  check_header_names(header);
  QuietErrors quiet;
  write_hdf5_atomic(path, [&](hid_t file) {
    const Id group = write_checkpoint_header(file, path, header);
    for (const auto& a : arrays) {
      const std::vector<hsize_t> dims(a.shape.begin(), a.shape.end());
      const std::size_t rows = a.shape[0],
                        row = std::accumulate(a.shape.begin() + 1, a.shape.end(), std::size_t(1), std::multiplies<>());
      Id space(H5Screate_simple(int(dims.size()), dims.data(), nullptr), H5Sclose);
      Id set(checked(H5Dcreate2(group, a.name.c_str(), H5T_IEEE_F64LE, space, H5P_DEFAULT, H5P_DEFAULT, H5P_DEFAULT),
                     path, "dataset " + a.name),
             H5Dclose);
      std::uint64_t h = fnv1a64_basis;
      for (std::size_t r0 = 0; r0 < rows;) {
        const std::span<const double> piece = a.next();
        if (piece.empty() || piece.size() % row != 0 || r0 + piece.size() / row > rows)
          throw std::invalid_argument("checkpoint array '" + a.name + "': its rows do not add up to its shape");
        std::vector<hsize_t> start(dims.size(), 0), count(dims.begin(), dims.end());
        start[0] = r0;
        count[0] = piece.size() / row;
        checked_status(H5Sselect_hyperslab(space, H5S_SELECT_SET, start.data(), nullptr, count.data(), nullptr), path,
                       "hyperslab");
        const hsize_t m = piece.size();
        Id mem(H5Screate_simple(1, &m, nullptr), H5Sclose);
        checked_status(H5Dwrite(set, H5T_NATIVE_DOUBLE, mem, space, H5P_DEFAULT, piece.data()), path,
                       "dataset " + a.name);
        h = checksum_continued(h, piece);
        r0 += count[0];
      }
      write_string_attribute(set, "checksum", fnv1a64_hex_of(h), path);
    }
  });
}

void write_checkpoint(const std::string& path, const CheckpointHeader& header,
                      const std::vector<CheckpointArray>& arrays) {
  for (const auto& a : arrays) {
    check_name(a.name, "checkpoint array");
    if (!a.shape.empty() &&
        std::accumulate(a.shape.begin(), a.shape.end(), std::size_t(1), std::multiplies<>()) != a.data.size())
      throw std::invalid_argument("checkpoint array '" + a.name + "': shape does not match its size");
  }
  check_header_names(header);
  QuietErrors quiet;
  write_hdf5_atomic(path, [&](hid_t file) {
    const Id group = write_checkpoint_header(file, path, header);
    for (const auto& a : arrays) {
      std::vector<hsize_t> dims(a.shape.begin(), a.shape.end());
      if (dims.empty()) dims.push_back(a.data.size());
      Id space(H5Screate_simple(int(dims.size()), dims.data(), nullptr), H5Sclose);
      Id set(checked(H5Dcreate2(group, a.name.c_str(), H5T_IEEE_F64LE, space, H5P_DEFAULT, H5P_DEFAULT, H5P_DEFAULT),
                     path, "dataset " + a.name),
             H5Dclose);
      if (!a.data.empty())
        checked_status(H5Dwrite(set, H5T_NATIVE_DOUBLE, H5S_ALL, H5S_ALL, H5P_DEFAULT, a.data.data()), path,
                       "dataset " + a.name);
      write_string_attribute(set, "checksum", fnv1a64_hex_of(checkpoint_checksum(a.data)), path);
    }
  });
}

CheckpointReader::CheckpointReader(const std::string& path) : path_(path) {
  if (!fs::exists(path)) throw InputError(path, "", "no such file", "a checkpoint written by flapstab");
  QuietErrors quiet;
  if (H5Fis_hdf5(path.c_str()) <= 0) throw InputError(path, "", "not an HDF5 file", "a checkpoint written by flapstab");
  file_ = H5Fopen(path.c_str(), H5F_ACC_RDONLY, H5P_DEFAULT);
  if (file_ < 0) throw InputError(path, "", "cannot open the HDF5 file", "a readable checkpoint");
  try {
    if (!has_attribute(file_, "format") || read_string_attribute(file_, "format", path) != "flapstab-checkpoint")
      throw InputError(path, "format", "not a flapstab checkpoint", "format = flapstab-checkpoint");
    const std::int64_t version = read_int_attribute(file_, "format_version", path);
    if (version > checkpoint_format_version)
      throw InputError(path, "format_version",
                       "format version " + std::to_string(version) + " is newer than this flapstab reads",
                       "version <= " + std::to_string(checkpoint_format_version));
    header_.time = read_double_attribute(file_, "time", path);
    header_.step = read_int_attribute(file_, "step", path);
    Id values(checked(H5Gopen2(file_, "values", H5P_DEFAULT), path, "group values"), H5Gclose);
    for (const auto& k : attribute_names(values)) header_.values[k] = read_double_attribute(values, k.c_str(), path);
    Id text(checked(H5Gopen2(file_, "text", H5P_DEFAULT), path, "group text"), H5Gclose);
    for (const auto& k : attribute_names(text)) header_.text[k] = read_string_attribute(text, k.c_str(), path);
    if (H5Lexists(file_, "arrays", H5P_DEFAULT) <= 0) fail(path, "group arrays missing");
  } catch (const std::runtime_error& e) {
    H5Fclose(file_);
    if (dynamic_cast<const InputError*>(&e)) throw;
    throw InputError(path, "", e.what(), "a complete flapstab checkpoint");
  }
}

CheckpointReader::~CheckpointReader() {
  if (file_ >= 0) H5Fclose(file_);
}

std::vector<std::string> CheckpointReader::names() const {
  QuietErrors quiet;
  Id group(checked(H5Gopen2(file_, "arrays", H5P_DEFAULT), path_, "group arrays"), H5Gclose);
  return link_names(group);
}

bool CheckpointReader::contains(const std::string& name) const {
  QuietErrors quiet;
  Id group(checked(H5Gopen2(file_, "arrays", H5P_DEFAULT), path_, "group arrays"), H5Gclose);
  return H5Lexists(group, name.c_str(), H5P_DEFAULT) > 0;
}

std::vector<std::size_t> CheckpointReader::shape(const std::string& name) const {
  if (!contains(name)) {
    std::string list;
    for (const auto& n : names()) list += (list.empty() ? "" : ", ") + n;
    throw InputError(path_, name, "no such array in the checkpoint", "one of: " + list);
  }
  QuietErrors quiet;
  Id set(checked(H5Dopen2(file_, ("arrays/" + name).c_str(), H5P_DEFAULT), path_, "dataset " + name), H5Dclose);
  Id space(H5Dget_space(set), H5Sclose);
  const int rank = H5Sget_simple_extent_ndims(space);
  std::vector<hsize_t> dims(std::size_t(std::max(rank, 0)));
  H5Sget_simple_extent_dims(space, dims.data(), nullptr);
  return {dims.begin(), dims.end()};
}

void CheckpointReader::read(const std::string& name, std::span<double> out) const {
  const auto dims = shape(name);
  const std::size_t n = std::accumulate(dims.begin(), dims.end(), std::size_t(1), std::multiplies<>());
  if (n != out.size())
    throw InputError(path_, name, "holds " + std::to_string(n) + " values",
                     std::to_string(out.size()) + " values (the grid of the run being restarted)");
  QuietErrors quiet;
  Id set(checked(H5Dopen2(file_, ("arrays/" + name).c_str(), H5P_DEFAULT), path_, "dataset " + name), H5Dclose);
  Id type(H5Dget_type(set), H5Tclose);
  if (H5Tget_class(type) != H5T_FLOAT || H5Tget_size(type) != 8)
    throw InputError(path_, name, "is not a float64 array", "IEEE float64 values");
  if (n > 0)
    checked_status(H5Dread(set, H5T_NATIVE_DOUBLE, H5S_ALL, H5S_ALL, H5P_DEFAULT, out.data()), path_,
                   "dataset " + name);
  // Checkpoints of format 1 written before the checksum was added have none; every newer array carries one.
  if (has_attribute(set, "checksum")) {
    const std::string stored = read_string_attribute(set, "checksum", path_);
    const std::string now = fnv1a64_hex_of(checkpoint_checksum(out));
    if (stored != now)
      throw InputError(path_, name, "damaged: its data hash " + now + " differs from the checksum stored with it (" +
                                        stored + ")",
                       "an intact checkpoint");
  }
}

void CheckpointReader::read_rows(const std::string& name, std::size_t first, std::span<double> out,
                                 std::size_t chunk_values) const {
  const auto dims = shape(name);
  const std::size_t n = std::accumulate(dims.begin(), dims.end(), std::size_t(1), std::multiplies<>());
  const std::size_t rows = dims.empty() ? 0 : dims[0], row = rows > 0 ? n / rows : 1;
  if (out.size() % row != 0 || first + out.size() / row > rows)
    throw InputError(path_, name, fmt::format("holds {} rows of {} values", rows, row),
                     fmt::format("rows {} to {} (the grid of the run being restarted)", first,
                                 first + out.size() / row));
  QuietErrors quiet;
  Id set(checked(H5Dopen2(file_, ("arrays/" + name).c_str(), H5P_DEFAULT), path_, "dataset " + name), H5Dclose);
  Id type(H5Dget_type(set), H5Tclose);
  if (H5Tget_class(type) != H5T_FLOAT || H5Tget_size(type) != 8)
    throw InputError(path_, name, "is not a float64 array", "IEEE float64 values");
  const bool summed = has_attribute(set, "checksum");
  const std::size_t last = first + out.size() / row;  // one past
  const std::size_t chunk = std::max<std::size_t>(1, chunk_values / row);
  Id file_space(H5Dget_space(set), H5Sclose);
  std::vector<double> buf;
  std::uint64_t h = fnv1a64_basis;
  for (std::size_t r0 = 0; r0 < rows; r0 += chunk) {
    const std::size_t nr = std::min(chunk, rows - r0);
    if (!summed && (r0 + nr <= first || r0 >= last)) continue;  // nothing to check, nothing wanted
    buf.resize(nr * row);
    std::vector<hsize_t> start(dims.size(), 0), count(dims.begin(), dims.end());
    start[0] = r0;
    count[0] = nr;
    checked_status(H5Sselect_hyperslab(file_space, H5S_SELECT_SET, start.data(), nullptr, count.data(), nullptr),
                   path_, "hyperslab");
    const hsize_t m = buf.size();
    Id mem(H5Screate_simple(1, &m, nullptr), H5Sclose);
    checked_status(H5Dread(set, H5T_NATIVE_DOUBLE, mem, file_space, H5P_DEFAULT, buf.data()), path_,
                   "dataset " + name);
    if (summed) h = checksum_continued(h, buf);
    const std::size_t a = std::max(r0, first), b = std::min(r0 + nr, last);
    if (a < b) std::copy_n(buf.data() + (a - r0) * row, (b - a) * row, out.data() + (a - first) * row);
  }
  if (summed) {
    const std::string stored = read_string_attribute(set, "checksum", path_), now = fnv1a64_hex_of(h);
    if (stored != now)
      throw InputError(path_, name, "damaged: its data hash " + now + " differs from the checksum stored with it (" +
                                        stored + ")",
                       "an intact checkpoint");
  }
}

void CheckpointReader::verify() const {
  for (const auto& name : names()) read(name);
}

std::vector<double> CheckpointReader::read(const std::string& name) const {
  const auto dims = shape(name);
  std::vector<double> v(std::accumulate(dims.begin(), dims.end(), std::size_t(1), std::multiplies<>()));
  read(name, v);
  return v;
}

}  // namespace flapstab::ns
