// Whole-grid checkpoints and fields of a decomposed solver (see solver_io.hpp).
#include "cfd/navier_stokes/solver_io.hpp"
#include <algorithm>
#include <stdexcept>
#include <fmt/format.h>
#include "cfd/navier_stokes/observers.hpp"
#include "core/errors.hpp"

namespace flapstab::ns {

namespace {

// Runs fn on rank 0; its exception's message, if any, is rethrown on every rank (the others would otherwise wait).
template <class Fn>
void on_root(const Decomposition& D, Fn&& fn) {
  std::string error;
  if (D.rank() == 0) try {
      fn();
    } catch (const std::exception& e) {
      error = e.what();
    }
  if (D.max(error.empty() ? 0.0 : 1.0) > 0)
    throw std::runtime_error(D.rank() == 0 ? error : "navier_stokes: rank 0 failed to write (see its message)");
}

void copy_planes(const Field& whole, const Slab& sl, Field& local) {
  const Shape& s = local.shape();
  std::copy_n(whole.data() + whole.shape()(0, 0, sl.offset), s.size(), local.data());
}

}  // namespace

SimulationState gather_state(const Solver& s, long step, double dt_last) {
  const Decomposition& D = s.decomposition();
  const std::vector<Slab>& slabs = s.slabs();
  SimulationState st;
  st.time = s.time();
  st.step = step;
  st.dt_last = dt_last;
  st.guess = s.has_guess();
  const Shape whole = s.whole_grid().shape();
  if (D.rank() == 0) {
    st.u = VectorField(whole);
    st.phi = VectorField(whole);
    st.p = Field(whole);
  }
  for (int d = 0; d < 3; ++d) {
    D.gather_field(s.velocity()[d], slabs, st.u[d]);
    D.gather_field(s.pressure_increments()[d], slabs, st.phi[d]);
  }
  D.gather_field(s.pressure(), slabs, st.p);
  return st;
}

void write_solver_checkpoint(const std::string& path, const Solver& s, long step, double dt_last,
                             std::map<std::string, double> values, std::map<std::string, std::string> text) {
  const SimulationState st = gather_state(s, step, dt_last);
  values["ranks"] = s.decomposition().size();
  on_root(s.decomposition(), [&] { write_state(path, st, values, text); });
}

SimulationState read_solver_checkpoint(const std::string& path, Solver& s) {
  const CheckpointReader ck(path);
  const Shape whole = s.whole_grid().shape();
  for (const char* name : {"u0", "p"})
    if (ck.contains(name) &&
        ck.shape(name) != std::vector<std::size_t>{std::size_t(whole.nz + 2), std::size_t(whole.ny + 2),
                                                   std::size_t(whole.nx + 2)})
      throw InputError(path, name, "array of another grid's shape",
                       fmt::format("{} x {} x {} cells (with ghosts)", whole.nx + 2, whole.ny + 2, whole.nz + 2));
  SimulationState w = read_state(ck, whole);
  const Shape local = s.grid().shape();
  VectorField u(local), phi(local);
  Field p(local);
  for (int d = 0; d < 3; ++d) {
    copy_planes(w.u[d], s.slab(), u[d]);
    copy_planes(w.phi[d], s.slab(), phi[d]);
  }
  copy_planes(w.p, s.slab(), p);
  s.restore(w.time, u, p, phi, w.guess);
  SimulationState r;
  r.time = w.time;
  r.step = w.step;
  r.dt_last = w.dt_last;
  r.guess = w.guess;
  return r;
}

std::string write_solver_fields(FieldWriter* writer, const Solver& s, double density, long step) {
  const Decomposition& D = s.decomposition();
  const std::vector<Slab>& slabs = s.slabs();
  const Grid& g = s.whole_grid();
  const Shape sh = g.shape();
  VectorField u;
  Field p;
  if (D.rank() == 0) {
    u = VectorField(sh);
    p = Field(sh);
  }
  for (int d = 0; d < 3; ++d) D.gather_field(s.velocity()[d], slabs, u[d]);
  D.gather_field(s.pressure(), slabs, p);
  std::string out;
  on_root(D, [&] {
    if (!writer) throw std::invalid_argument("navier_stokes fields: rank 0 needs a field writer");
    const FlowFields ff = flow_fields(g, u, p, density);  // the fields of flapstab cfd's files, less the solid mask
    out = writer->write(s.time(), step, ff.fields());
  });
  return out;
}

}  // namespace flapstab::ns
