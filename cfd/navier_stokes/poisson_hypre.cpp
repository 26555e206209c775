// hypre back end of the pressure solver (poisson_hypre.hpp).
#include "cfd/navier_stokes/poisson_hypre.hpp"
#include "cfd/navier_stokes/mpi_start.hpp"

#include <stdexcept>
#include <string>
#include <vector>

#ifdef FLAPSTAB_HAVE_HYPRE
#define OMPI_SKIP_MPICXX 1  // the C interface only (no libmpi_cxx)
#define MPICH_SKIP_MPICXX 1
#include <mpi.h>
#include <HYPRE_struct_ls.h>
#include <HYPRE_utilities.h>
#endif

namespace flapstab::ns {

#ifdef FLAPSTAB_HAVE_HYPRE

bool hypre_available() { return true; }

namespace {
// MPI (mpi_start.hpp) and hypre once per process.
void start_hypre() {
  static const bool started = [] {
    start_mpi();
    HYPRE_Init();
    return true;
  }();
  (void)started;
}
}  // namespace

struct HyprePoisson::Impl {
  Shape s;
  std::vector<double> volume;  // per cell, x fastest
  HYPRE_StructGrid grid = nullptr;
  HYPRE_StructStencil stencil = nullptr;
  HYPRE_StructMatrix A = nullptr;
  HYPRE_StructVector b = nullptr, x = nullptr;
  HYPRE_StructSolver pcg = nullptr, pfmg = nullptr;
  int lo[3] = {1, 1, 1}, hi[3] = {1, 1, 1};
  MPI_Comm comm = MPI_COMM_SELF;
  std::vector<double> values;

  ~Impl() {
    if (pcg) HYPRE_StructPCGDestroy(pcg);
    if (pfmg) HYPRE_StructSMGDestroy(pfmg);
    if (x) HYPRE_StructVectorDestroy(x);
    if (b) HYPRE_StructVectorDestroy(b);
    if (A) HYPRE_StructMatrixDestroy(A);
    if (stencil) HYPRE_StructStencilDestroy(stencil);
    if (grid) HYPRE_StructGridDestroy(grid);
  }
};

HyprePoisson::HyprePoisson(const Stencil<real>& L, const Slab* slab, int whole_nz, bool z_periodic, const void* comm)
    : impl_(std::make_unique<Impl>()) {
  for (int a = 0; a < 3; ++a) {
    const bool periodic = a == 2 && slab ? z_periodic : L.periodic[a];
    const int n = a == 2 && slab ? whole_nz : L.s.n(a);
    if (periodic && (n & (n - 1)) != 0)
      throw std::invalid_argument("the hypre pressure solver needs a power-of-two cell count on a periodic axis (axis " +
                                  std::to_string(a) + " has " + std::to_string(n) +
                                  " cells; hypre's structured multigrid gave a wrong solution on a 56-cell period)");
  }
  start_hypre();
  Impl& m = *impl_;
  m.s = L.s;
  const Shape& s = m.s;
  // A slab's box in the whole grid's indices; hypre couples the boxes of the ranks itself.
  const int z0 = slab ? slab->offset : 0;
  m.lo[2] = 1 + z0;
  m.hi[0] = s.nx, m.hi[1] = s.ny, m.hi[2] = s.nz + z0;
  m.comm = !slab ? MPI_COMM_SELF : comm ? *static_cast<const MPI_Comm*>(comm) : MPI_COMM_WORLD;
  HYPRE_StructGridCreate(m.comm, 3, &m.grid);
  HYPRE_StructGridSetExtents(m.grid, m.lo, m.hi);
  int period[3] = {L.periodic[0] ? s.nx : 0, L.periodic[1] ? s.ny : 0,
                   slab ? (z_periodic ? whole_nz : 0) : L.periodic[2] ? s.nz : 0};
  HYPRE_StructGridSetPeriodic(m.grid, period);
  HYPRE_StructGridAssemble(m.grid);
  int offsets[7][3] = {{0, 0, 0}, {-1, 0, 0}, {1, 0, 0}, {0, -1, 0}, {0, 1, 0}, {0, 0, -1}, {0, 0, 1}};
  HYPRE_StructStencilCreate(3, 7, &m.stencil);
  for (int e = 0; e < 7; ++e) HYPRE_StructStencilSetElement(m.stencil, e, offsets[e]);
  HYPRE_StructMatrixCreate(m.comm, m.grid, m.stencil, &m.A);
  HYPRE_StructMatrixInitialize(m.A);
  const std::size_t cells = s.cells();
  m.values.assign(7 * cells, 0.0);
  m.volume.assign(cells, 0.0);
  std::size_t c = 0;
  for (int k = 1; k <= s.nz; ++k)
    for (int j = 1; j <= s.ny; ++j)
      for (int i = 1; i <= s.nx; ++i, ++c) {
        const double V = L.volume(i, j, k);
        m.volume[c] = V;
        double* v = &m.values[7 * c];
        v[0] = -V * L.diag(i, j, k);
        v[1] = -V * L.cl[0][i], v[2] = -V * L.ch[0][i];
        v[3] = -V * L.cl[1][j], v[4] = -V * L.ch[1][j];
        v[5] = -V * L.cl[2][k], v[6] = -V * L.ch[2][k];
      }
  int entries[7] = {0, 1, 2, 3, 4, 5, 6};
  HYPRE_StructMatrixSetBoxValues(m.A, m.lo, m.hi, 7, entries, m.values.data());
  HYPRE_StructMatrixAssemble(m.A);
  HYPRE_StructVectorCreate(m.comm, m.grid, &m.b);
  HYPRE_StructVectorCreate(m.comm, m.grid, &m.x);
  HYPRE_StructVectorInitialize(m.b);
  HYPRE_StructVectorInitialize(m.x);
  m.values.assign(cells, 0.0);
  HYPRE_StructVectorSetBoxValues(m.b, m.lo, m.hi, m.values.data());
  HYPRE_StructVectorSetBoxValues(m.x, m.lo, m.hi, m.values.data());
  HYPRE_StructVectorAssemble(m.b);
  HYPRE_StructVectorAssemble(m.x);
  HYPRE_StructPCGCreate(m.comm, &m.pcg);
  HYPRE_StructPCGSetTwoNorm(m.pcg, 1);
  HYPRE_StructSMGCreate(m.comm, &m.pfmg);
  HYPRE_StructSMGSetMemoryUse(m.pfmg, 0);
  HYPRE_StructSMGSetMaxIter(m.pfmg, 1);
  HYPRE_StructSMGSetTol(m.pfmg, 0.0);
  HYPRE_StructSMGSetZeroGuess(m.pfmg);
  HYPRE_StructSMGSetNumPreRelax(m.pfmg, 1);
  HYPRE_StructSMGSetNumPostRelax(m.pfmg, 1);
  HYPRE_StructPCGSetPrecond(m.pcg, HYPRE_StructSMGSolve, HYPRE_StructSMGSetup, m.pfmg);
  HYPRE_StructPCGSetup(m.pcg, m.A, m.b, m.x);
}

HyprePoisson::~HyprePoisson() = default;

int HyprePoisson::solve(Field& x, const Field& b, double rtol, int max_iterations, bool guess) {
  Impl& m = *impl_;
  const Shape& s = m.s;
  std::size_t c = 0;
  m.values.resize(s.cells());
  for (int k = 1; k <= s.nz; ++k)
    for (int j = 1; j <= s.ny; ++j)
      for (int i = 1; i <= s.nx; ++i, ++c) m.values[c] = -m.volume[c] * b(i, j, k);
  HYPRE_StructVectorSetBoxValues(m.b, m.lo, m.hi, m.values.data());
  c = 0;
  for (int k = 1; k <= s.nz; ++k)
    for (int j = 1; j <= s.ny; ++j)
      for (int i = 1; i <= s.nx; ++i, ++c) m.values[c] = guess ? x(i, j, k) : 0.0;
  HYPRE_StructVectorSetBoxValues(m.x, m.lo, m.hi, m.values.data());
  HYPRE_StructPCGSetTol(m.pcg, rtol);
  HYPRE_StructPCGSetMaxIter(m.pcg, max_iterations);
  HYPRE_StructPCGSolve(m.pcg, m.A, m.b, m.x);
  HYPRE_ClearAllErrors();  // non-convergence is reported by the caller's own residual
  int iterations = 0;
  HYPRE_StructPCGGetNumIterations(m.pcg, &iterations);
  HYPRE_StructVectorGetBoxValues(m.x, m.lo, m.hi, m.values.data());
  c = 0;
  for (int k = 1; k <= s.nz; ++k)
    for (int j = 1; j <= s.ny; ++j)
      for (int i = 1; i <= s.nx; ++i, ++c) x(i, j, k) = m.values[c];
  return iterations;
}

#else

bool hypre_available() { return false; }
struct HyprePoisson::Impl {};
HyprePoisson::HyprePoisson(const Stencil<real>&, const Slab*, int, bool, const void*) {
  throw std::invalid_argument("the hypre pressure solver is not built in (CMake did not find hypre and MPI: install "
                              "libhypre-dev and libopenmpi-dev and reconfigure)");
}
HyprePoisson::~HyprePoisson() = default;
int HyprePoisson::solve(Field&, const Field&, double, int, bool) { return 0; }

#endif

}  // namespace flapstab::ns
