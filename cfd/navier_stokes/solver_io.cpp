// Whole-grid checkpoints and fields of a decomposed solver (see solver_io.hpp).
#include "cfd/navier_stokes/solver_io.hpp"
#include <algorithm>
#include <array>
#include <cmath>
#include <stdexcept>
#include <fmt/format.h>
#include "cfd/navier_stokes/multigrid.hpp"
#include "cfd/navier_stokes/observers.hpp"
#include "core/errors.hpp"

namespace flapstab::ns {

namespace {

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
  gather_flow(s, st.u, st.p);
  if (D.rank() == 0) st.phi = VectorField(s.whole_grid().shape());
  for (int d = 0; d < 3; ++d) D.gather_field(s.pressure_increments()[d], slabs, st.phi[d]);
  return st;
}

SimulationState transfer_state_over_ranks(const SimulationState& whole, const Grid& from, const Solver& to) {
  const Decomposition& D = to.decomposition();
  if (!D.distributed()) return transfer_state(whole, from, to.whole_grid());
  const std::vector<Slab>& slabs = to.slabs();
  constexpr int tag = 100;
  auto fields = [](SimulationState& st) { return std::array<Field*, 4>{&st.u[0], &st.u[1], &st.u[2], &st.p}; };
  if (D.rank() != 0) {
    SimulationState mine;  // time, step and last dt: the same on every rank (the run's own)
    mine.time = whole.time;
    mine.step = whole.step;
    mine.dt_last = whole.dt_last;
    const Shape sh = to.grid().shape();
    mine.u = VectorField(sh);
    mine.phi = VectorField(sh);
    mine.p = Field(sh);
    for (Field* f : fields(mine)) D.receive_from(0, f->data(), f->shape().size(), tag);
    return mine;
  }
  // Rank 0: each other rank's slab of the new grid (its ghost planes included) computed from the whole old state and
  // sent, one slab at a time; its own last.
  for (int r = 1; r < D.size(); ++r) {
    SimulationState theirs = transfer_state(whole, from, to.whole_grid().slice_z(slabs[std::size_t(r)]));
    for (Field* f : fields(theirs)) D.send_to(r, f->data(), f->shape().size(), tag);
  }
  return transfer_state(whole, from, to.grid());
}

void RootInbox::next(std::vector<double>& out) {
  if (taken_ >= queue_.size()) throw std::logic_error("RootInbox: no message expected");
  const Message& m = queue_[taken_++];
  out.resize(m.count);
  D_.receive_from(m.from, out.data(), m.count, m.tag);
}

void RootInbox::drain() {
  std::vector<double> sink;
  while (taken_ < queue_.size()) next(sink);
}

SimulationState read_state_over_ranks(const CheckpointReader& ck, const Grid& whole, const Decomposition& ranks) {
  return ranks.distributed() ? read_state(ck, whole.shape(), Multigrid::rank_slab(whole, ranks))
                             : read_state(ck, whole.shape());
}

void write_state_over_ranks(const std::string& path, const Solver& s, long step, double dt_last,
                            std::map<std::string, double> values, std::map<std::string, std::string> text) {
  const Decomposition& D = s.decomposition();
  const std::vector<Slab>& slabs = s.slabs();
  const std::array<const Field*, 7> fields = {&s.velocity()[0],           &s.velocity()[1],
                                              &s.velocity()[2],           &s.pressure(),
                                              &s.pressure_increments()[0], &s.pressure_increments()[1],
                                              &s.pressure_increments()[2]};
  const char* names[7] = {"u0", "u1", "u2", "p", "phi0", "phi1", "phi2"};
  const Shape local = s.grid().shape(), whole = s.whole_grid().shape();
  const std::size_t plane = std::size_t(local.sz);
  const int P = D.size();
  // Rank r's planes of the whole array: the first rank's from its ghost plane 0, the last rank's up to its ghost
  // plane n + 1 (as gather_field takes them).
  auto first_plane = [&](int r) { return r == 0 ? 0 : 1; };
  auto count = [&](int r) {
    return std::size_t(slabs[std::size_t(r)].n + (r + 1 == P ? 1 : 0) - first_plane(r) + 1) * plane;
  };
  constexpr int tag = 90;
  if (D.rank() != 0)
    for (int f = 0; f < 7; ++f)
      D.send_to(0, fields[std::size_t(f)]->data() + std::size_t(first_plane(D.rank())) * plane, count(D.rank()), tag);
  from_root(D, [&] {
    RootInbox inbox(D);  // array f's slabs in rank order, the arrays in turn
    for (int f = 0; f < 7; ++f)
      for (int r = 1; r < P; ++r) inbox.expect(r, count(r), tag);
    std::vector<double> buffer;
    std::vector<CheckpointRowArray> arrays;
    const std::vector<std::size_t> shape = {std::size_t(whole.nz + 2), std::size_t(whole.ny + 2),
                                            std::size_t(whole.nx + 2)};
    for (int f = 0; f < 7; ++f)
      arrays.push_back({names[f], shape, [&, f, r = 0]() mutable -> std::span<const double> {
                          if (r++ == 0) return {fields[std::size_t(f)]->data(), count(0)};
                          inbox.next(buffer);
                          return buffer;
                        }});
    try {
      write_checkpoint(path, state_header(s.time(), step, dt_last, s.has_guess(), values, text), arrays);
    } catch (...) {
      inbox.drain();
      throw;
    }
    return std::string();
  });
}

void write_solver_checkpoint(const std::string& path, const Solver& s, long step, double dt_last,
                             std::map<std::string, double> values, std::map<std::string, std::string> text) {
  values["ranks"] = s.decomposition().size();
  write_state_over_ranks(path, s, step, dt_last, std::move(values), std::move(text));
}

std::string slab_planes_text(const Solver& s) {
  std::string planes;
  for (const Slab& sl : s.slabs()) planes += (planes.empty() ? "" : " + ") + std::to_string(sl.n);
  return planes;
}

SimulationState own_planes(const SimulationState& whole, const Solver& s) {
  const Shape local = s.grid().shape(), sh = s.whole_grid().shape();
  if (!s.decomposition().distributed() || !(whole.u[0].shape() == sh) || local == sh) return whole;
  SimulationState r;
  r.time = whole.time;
  r.step = whole.step;
  r.dt_last = whole.dt_last;
  r.guess = whole.guess;
  r.u = VectorField(local);
  r.phi = VectorField(local);
  r.p = Field(local);
  for (int d = 0; d < 3; ++d) {
    copy_planes(whole.u[d], s.slab(), r.u[d]);
    if (whole.phi[d].shape() == whole.u[d].shape()) copy_planes(whole.phi[d], s.slab(), r.phi[d]);
  }
  copy_planes(whole.p, s.slab(), r.p);
  return r;
}

std::vector<double> gather_cells(const Solver& s, std::vector<double> own) {
  const Decomposition& D = s.decomposition();
  if (!D.distributed()) return own;
  const Shape ls = s.grid().shape();
  if (own.size() != std::size_t(ls.nx) * std::size_t(ls.ny) * std::size_t(ls.nz))
    throw std::invalid_argument("navier_stokes gather_cells: not the slab's cells");
  Field local(ls), whole;
  std::size_t n = 0;
  for (int k = 1; k <= ls.nz; ++k)
    for (int j = 1; j <= ls.ny; ++j)
      for (int i = 1; i <= ls.nx; ++i) local(i, j, k) = real(own[n++]);
  const Shape sh = s.whole_grid().shape();
  if (D.rank() == 0) whole = Field(sh);
  D.gather_field(local, s.slabs(), whole);
  std::vector<double> out;
  if (D.rank() != 0) return out;
  out.reserve(sh.cells());
  for (int k = 1; k <= sh.nz; ++k)
    for (int j = 1; j <= sh.ny; ++j)
      for (int i = 1; i <= sh.nx; ++i) out.push_back(double(whole(i, j, k)));
  return out;
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
  const SimulationState w = read_state_over_ranks(ck, s.whole_grid(), s.decomposition());
  s.restore(w.time, w.u, w.p, w.phi, w.guess);
  SimulationState r;
  r.time = w.time;
  r.step = w.step;
  r.dt_last = w.dt_last;
  r.guess = w.guess;
  return r;
}

void gather_flow(const Solver& s, VectorField& u, Field& p) {
  const Decomposition& D = s.decomposition();
  const Shape sh = s.whole_grid().shape();
  if (D.rank() == 0) {
    u = VectorField(sh);
    p = Field(sh);
  }
  for (int d = 0; d < 3; ++d) D.gather_field(s.velocity()[d], s.slabs(), u[d]);
  D.gather_field(s.pressure(), s.slabs(), p);
}

std::string write_solver_fields(FieldWriter* writer, const Solver& s, double density, long step) {
  const Decomposition& D = s.decomposition();
  const Grid& g = s.whole_grid();
  VectorField u;
  Field p;
  gather_flow(s, u, p);
  std::string out;
  on_root(D, [&] {
    if (!writer) throw std::invalid_argument("navier_stokes fields: rank 0 needs a field writer");
    const FlowFields ff = flow_fields(g, u, p, density);  // the fields of flapstab cfd's files, less the solid mask
    out = writer->write(s.time(), step, ff.fields());
  });
  return out;
}

}  // namespace flapstab::ns
