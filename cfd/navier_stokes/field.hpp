// Storage for the Navier-Stokes solver: a 3D array of reals on the cells of a box, one ghost layer deep.
#pragma once
#include <algorithm>
#include <cstddef>
#include <cstdlib>
#include <memory>
#include <new>

namespace flapstab::ns {

// The solver's floating-point type; FP64 today, one place to change for FP32 or a device build.
using real = double;

// Padded index space: cell (i, j, k) of an nx x ny x nz box has i in 1..nx (0 and nx+1 are ghosts),
// stored i-fastest. A staggered component stores at (i, j, k) the value on the LOWER face of cell i
// in its own direction, so index nx+1 is the upper boundary face (WaterLily's convention).
struct Shape {
  int nx = 0, ny = 0, nz = 0;
  std::ptrdiff_t sy = 0, sz = 0;  // strides of j and k (the stride of i is 1)
  Shape() = default;
  Shape(int nx_, int ny_, int nz_) : nx(nx_), ny(ny_), nz(nz_), sy(nx_ + 2), sz(std::ptrdiff_t(nx_ + 2) * (ny_ + 2)) {}
  std::ptrdiff_t operator()(int i, int j, int k) const { return i + sy * j + sz * k; }
  std::size_t size() const { return std::size_t(sz) * (nz + 2); }
  std::size_t cells() const { return std::size_t(nx) * ny * nz; }
  std::ptrdiff_t stride(int axis) const { return axis == 0 ? 1 : axis == 1 ? sy : sz; }
  int n(int axis) const { return axis == 0 ? nx : axis == 1 ? ny : nz; }
  bool operator==(const Shape&) const = default;
};

// Marks a kernel (a function whose loops do the per-cell work, called from an OpenMP loop) to be compiled for
// AVX-512, AVX2 and baseline x86-64, the best chosen at run time; the build itself stays portable.
#if defined(__GNUC__) && defined(__x86_64__) && !defined(__clang__)
#define FLAPSTAB_KERNEL __attribute__((target_clones("arch=x86-64-v4", "arch=x86-64-v3", "default")))
#else
#define FLAPSTAB_KERNEL
#endif

// Loops over fewer cells than this run on one thread: a parallel region costs more than it saves, and far more
// when the other core is busy (threads wait at the barrier for a time slice).
constexpr std::size_t min_parallel_cells = 16384;
inline bool threaded(const Shape& s) { return s.cells() >= min_parallel_cells; }

// One scalar (or one velocity component) on a Shape: contiguous, 64-byte aligned, zero-initialised.
class Field {
 public:
  Field() = default;
  explicit Field(const Shape& s) : shape_(s), data_(allocate(s.size())) {}
  Field(const Field& o) : Field(o.shape_) { std::copy(o.begin(), o.end(), begin()); }
  Field& operator=(const Field& o) {
    if (this != &o) { if (!(shape_ == o.shape_)) *this = Field(o.shape_); std::copy(o.begin(), o.end(), begin()); }
    return *this;
  }
  Field(Field&&) noexcept = default;
  Field& operator=(Field&&) noexcept = default;

  const Shape& shape() const { return shape_; }
  real* data() { return data_.get(); }
  const real* data() const { return data_.get(); }
  real* begin() { return data_.get(); }
  real* end() { return data_.get() + shape_.size(); }
  const real* begin() const { return data_.get(); }
  const real* end() const { return data_.get() + shape_.size(); }
  real& operator()(int i, int j, int k) { return data_[shape_(i, j, k)]; }
  real operator()(int i, int j, int k) const { return data_[shape_(i, j, k)]; }
  real& operator[](std::ptrdiff_t n) { return data_[n]; }
  real operator[](std::ptrdiff_t n) const { return data_[n]; }
  void fill(real v) { std::fill(begin(), end(), v); }

 private:
  struct Free { void operator()(real* p) const { std::free(p); } };
  static std::unique_ptr<real[], Free> allocate(std::size_t n) {
    const std::size_t bytes = ((n * sizeof(real) + 63) / 64) * 64;
    auto* p = static_cast<real*>(std::aligned_alloc(64, bytes == 0 ? 64 : bytes));
    if (!p) throw std::bad_alloc();
    std::fill(p, p + n, real(0));
    return std::unique_ptr<real[], Free>(p);
  }
  Shape shape_;
  std::unique_ptr<real[], Free> data_;
};

// The three staggered velocity components (structure of arrays).
struct VectorField {
  Field c[3];
  VectorField() = default;
  explicit VectorField(const Shape& s) : c{Field(s), Field(s), Field(s)} {}
  Field& operator[](int d) { return c[d]; }
  const Field& operator[](int d) const { return c[d]; }
};

}  // namespace flapstab::ns
