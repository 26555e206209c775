// Observers of a Simulation (observers.hpp).
#include "cfd/navier_stokes/observers.hpp"

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <ostream>
#include <regex>
#include <fmt/format.h>

#include "cfd/navier_stokes/diagnostics.hpp"
#include "cfd/navier_stokes/solver_io.hpp"
#include "core/atomic_write.hpp"
#include "core/errors.hpp"

namespace flapstab::ns {

namespace fs = std::filesystem;

bool crossed(int per_cycle, double period, double ta, double tb) {
  if (per_cycle <= 0) return false;
  const double n = per_cycle / period;
  return std::floor(tb * n + 1e-6) > std::floor(ta * n + 1e-6);
}

std::string fmt_seconds(double s) {
  if (!std::isfinite(s)) return "?";
  if (s < 120) return fmt::format("{:.1f} s", s);
  if (s < 7200) return fmt::format("{:.1f} min", s / 60);
  return fmt::format("{:.2f} h", s / 3600);
}

// ---- forces.csv ------------------------------------------------------------------------------------------------

void ForcesCsv::keep_earlier(const std::string& file, long step, long first_step) {
  std::ifstream in(file);
  if (!in)
    throw InputError(file, "", "missing or unreadable: a restart from step " + std::to_string(step) +
                                   " needs the rows of the interrupted run up to that step",
                     "the forces.csv of the interrupted run");
  std::string line;
  long expect = first_step, number = 0;
  while (std::getline(in, line)) {
    ++number;
    if (line.empty() || line[0] == '#' || line.rfind("time_s", 0) == 0) continue;
    CfdLoadRow r;
    try {
      r = parse_forces_csv_row(line);
      // a row cut short by a kill can still be one of fewer parts
      if (r.parts != parts_)
        throw std::invalid_argument(fmt::format("{} parts where this geometry has {}", r.parts, parts_));
    } catch (const std::exception& e) {
      if (expect > step) break;  // rows past the checkpoint are dropped anyway (a kill while they were written)
      throw InputError(file, "line " + std::to_string(number), std::string("damaged row: ") + e.what(),
                       "a complete row of step " + std::to_string(expect));
    }
    if (r.step > step) break;
    if (r.step != expect)
      throw InputError(file, "line " + std::to_string(number),
                       "holds step " + std::to_string(r.step) + " where step " + std::to_string(expect) + " belongs",
                       "the rows of steps " + std::to_string(first_step) + " to " + std::to_string(step) + " in order");
    lines_.push_back(line + "\n");
    earlier_.push_back(r);
    ++expect;
  }
  if (expect <= step)
    throw InputError(file, "line " + std::to_string(number + 1),
                     "ends at step " + std::to_string(expect - 1) + ", before the checkpoint's step " +
                         std::to_string(step) + " (rows were lost)",
                     "the rows of steps " + std::to_string(first_step) + " to " + std::to_string(step) +
                         "; restart from an earlier checkpoint or run again");
}

void ForcesCsv::on_step(const Simulation&, const StepReport& r) {
  rows_.push_back(r.row);
  if (!path_.empty()) lines_.push_back(forces_csv_row(r.row));
}

void ForcesCsv::flush() const {
  auto write = [&] {
    if (path_.empty()) return;
    std::string text = forces_csv_header(parts_);
    for (const auto& l : lines_) text += l;
    write_file_atomic(path_, text);
  };
  if (dec_) on_root(*dec_, write);
  else write();
}

std::vector<CfdLoadRow> ForcesCsv::since(double t, double period) const {
  std::vector<CfdLoadRow> out;
  for (const auto* rows : {&earlier_, &rows_})
    for (const auto& r : *rows)
      if (r.time > t - 1e-9 * period) out.push_back(r);
  return out;
}

// ---- checkpoints -----------------------------------------------------------------------------------------------

namespace {

long checkpoint_step(const std::string& file) {
  static const std::regex re(R"(checkpoint_(\d+)\.h5)");
  std::smatch m;
  return std::regex_match(file, m, re) ? std::stol(m[1].str()) : -1;
}

}  // namespace

std::vector<std::pair<long, std::string>> checkpoints_in(const std::string& dir) {
  std::vector<std::pair<long, std::string>> out;
  if (!fs::is_directory(dir)) return out;
  for (const auto& e : fs::directory_iterator(dir)) {
    const long s = checkpoint_step(e.path().filename().string());
    if (s >= 0 && e.is_regular_file()) out.emplace_back(s, e.path().string());
  }
  std::sort(out.begin(), out.end());
  return out;
}

void Checkpointer::write(const Simulation& sim) {
  const std::string path = fmt::format("{}/checkpoint_{:09d}.h5", dir_, sim.step());
  const Decomposition& D = sim.solver().decomposition();
  on_root(D, [&] {
    std::error_code ec;
    fs::create_directories(dir_, ec);
    if (ec) throw OutputError(output_failure("create directory", dir_, ec.value()));
  });
  // forces.csv first: a kill between the two leaves rows beyond the newest checkpoint (dropped on restart), never
  // a checkpoint beyond the rows.
  if (csv_) csv_->flush();
  for (const auto& f : flush_) f();
  std::map<std::string, double> values = values_;
  if (D.distributed()) values["ranks"] = D.size();
  write_state(path, sim, values, text_);  // over ranks rank 0 writes it, taking the slabs one at a time
  on_root(D, [&] {
    auto list = checkpoints_in(dir_);  // keep the newest
    for (std::size_t i = 0; i + std::size_t(keep_) < list.size(); ++i) fs::remove(list[i].second);
  });
  last_ = path;
  last_step_ = sim.step();
}

void Checkpointer::on_step(const Simulation& sim, const StepReport& r) {
  if (crossed(per_cycle_, sim.plan().period, r.t_before, r.time)) write(sim);
}

// ---- fields and surfaces ---------------------------------------------------------------------------------------

RectilinearAxes rectilinear(const Grid& g) {
  RectilinearAxes a;
  std::vector<double>* out[3] = {&a.x, &a.y, &a.z};
  for (int d = 0; d < 3; ++d) out[d]->assign(g.axis[d].xf.begin() + 1, g.axis[d].xf.begin() + g.axis[d].n + 2);
  return a;
}

namespace {

// This rank's planes of the field output: the fields computed on its slab widened by one plane at each cut (the
// vorticity's central differences at the slab's end planes read the cell beyond, whose centred w reads the face
// beyond that: the window's ghost plane), so that they are the whole grid's file's planes; the arrays start at the
// slab's first plane.
struct OwnPlanes {
  FlowFields flow;
  std::vector<double> solid;
  std::vector<CellField> fields;  // velocity, pressure, vorticity, q_criterion, solid
};

OwnPlanes own_field_planes(const Simulation& sim) {
  const Solver& sv = sim.solver();
  const Decomposition& D = sv.decomposition();
  const Slab& sl = sv.slab();
  const int depth = 1, lo = sl.cut_lo ? depth : 0;
  const Slab ws{sl.offset - lo, sl.n + depth * (int(sl.cut_lo) + int(sl.cut_hi)), sl.cut_lo, sl.cut_hi};
  const Grid wg = sim.whole_grid().slice_z(ws);
  VectorField wu(wg.shape());
  Field wp(wg.shape());
  for (int d = 0; d < 3; ++d) D.widen(sv.velocity()[d], sl, depth, wu[d]);
  D.widen(sv.pressure(), sl, depth, wp);
  OwnPlanes o;
  o.flow = flow_fields(wg, wu, wp, sim.plan().rho);
  o.solid = sim.solid_mask();  // the slab's own cells
  const std::ptrdiff_t skip = std::ptrdiff_t(lo) * wg.shape().nx * wg.shape().ny;  // the window's plane below
  o.fields = o.flow.fields();
  for (CellField& f : o.fields)
    for (CellArray& a : f.components) a.data += skip;
  o.fields.push_back(CellField{"solid", "1", {CellArray{o.solid.data()}}});
  return o;
}

}  // namespace

void FieldOutput::write_pieces(const Simulation& sim) {
  const Solver& sv = sim.solver();
  const Decomposition& D = sv.decomposition();
  const OwnPlanes own = own_field_planes(sim);
  // Every rank writes its piece; a failure on any is every rank's (none goes on into the next collective call).
  FieldWriter::Record mine;
  std::string why;
  try {
    RectilinearAxes axes = rectilinear(sv.grid());  // the slab's planes
    if (!writer_ || axes.x != axes_.x || axes.y != axes_.y || axes.z != axes_.z) {
      writer_.emplace(dir_, "fields", axes, precision_, D.rank() == 0);  // rank 0 keeps the series
      axes_ = std::move(axes);
    }
    mine = writer_->write_piece(sim.time(), sim.step(), own.fields, D.rank());
  } catch (const std::exception& e) {
    why = e.what();
  }
  if (const int failed = int(D.max(why.empty() ? 0.0 : D.rank() + 1.0)); failed > 0)
    throw OutputError(why.empty() ? fmt::format("rank {} could not write its piece of the field output at step {}",
                                                failed - 1, sim.step())
                                  : why);
  on_root(D, [&] {
    std::vector<FieldWriter::Record> pieces;
    for (int r = 0; r < D.size(); ++r) {
      FieldWriter::Record p = mine;
      p.file = FieldWriter::piece_file_name("fields", sim.step(), r);
      p.cells[2] = std::size_t(sv.slabs()[std::size_t(r)].n);
      pieces.push_back(std::move(p));
    }
    writer_->add_pieces(std::move(pieces));
  });
}

void FieldOutput::write_streamed(const Simulation& sim) {
  const Solver& sv = sim.solver();
  const Decomposition& D = sv.decomposition();
  const OwnPlanes own = own_field_planes(sim);
  const Shape ls = sv.grid().shape();
  const std::size_t plane = std::size_t(ls.nx) * std::size_t(ls.ny);
  const std::vector<Slab>& slabs = sv.slabs();
  const int P = D.size();
  constexpr int tag = 110;
  if (D.rank() != 0)  // each field's components in turn, rank 0 taking them in the same order
    for (const CellField& f : own.fields)
      for (const CellArray& a : f.components) D.send_to(0, a.data, plane * std::size_t(ls.nz), tag);
  from_root(D, [&] {
    RootInbox inbox(D);  // field f's components of rank r = 1 .. P - 1 in turn, the fields in turn
    for (const CellField& f : own.fields)
      for (int r = 1; r < P; ++r)
        for (std::size_t c = 0; c < f.components.size(); ++c)
          inbox.expect(r, plane * std::size_t(slabs[std::size_t(r)].n), tag);
    std::vector<std::vector<double>> held;  // the components of the slab now being written
    int held_field = -1, held_rank = 0;
    std::vector<CellField> fields = own.fields;
    for (std::size_t fi = 0; fi < fields.size(); ++fi) {
      CellField& f = fields[fi];
      const int nc = int(f.components.size());
      for (CellArray& a : f.components) a.data = nullptr;
      f.plane = [&, fi, nc](std::size_t k, int c) -> const double* {
        int r = 0;
        while (std::size_t(slabs[std::size_t(r)].offset + slabs[std::size_t(r)].n) <= k) ++r;
        const std::size_t local = k - std::size_t(slabs[std::size_t(r)].offset);
        if (r == 0) return own.fields[fi].components[std::size_t(c)].data + local * plane;
        if (held_field != int(fi) || held_rank != r) {  // the next slab: rank r's components of field fi
          held.resize(std::size_t(nc));
          for (auto& v : held) inbox.next(v);
          held_field = int(fi);
          held_rank = r;
        }
        return held[std::size_t(c)].data() + local * plane;
      };
    }
    try {
      // A new grid (a free flight's re-planned fine box) starts a new writer: the series (one grid per file) goes on.
      RectilinearAxes axes = rectilinear(sim.whole_grid());
      if (!writer_ || axes.x != axes_.x || axes.y != axes_.y || axes.z != axes_.z) {
        writer_.emplace(dir_, "fields", axes, precision_);
        axes_ = std::move(axes);
      }
      writer_->write(sim.time(), sim.step(), fields);
    } catch (...) {  // the slabs still on their way are taken in, so that the other ranks' sends complete
      inbox.drain();
      throw;
    }
    return std::string();
  });
}

void FieldOutput::write(const Simulation& sim) {
  const Solver& sv = sim.solver();
  const Decomposition& D = sv.decomposition();
  if (D.distributed() && !sim.whole_grid().axis[2].periodic) {
    if (per_rank_)
      write_pieces(sim);
    else
      write_streamed(sim);
    return;
  }
  VectorField gathered_u;  // over ranks: the whole grid's fields on rank 0
  Field gathered_p;
  if (D.distributed()) gather_flow(sv, gathered_u, gathered_p);
  const std::vector<double> solid = gather_cells(sv, sim.solid_mask());
  on_root(D, [&] {
    const Grid& grid = sim.whole_grid();
    // A new grid (a free flight's re-planned fine box) starts a new writer: the series (one grid per file) goes on.
    RectilinearAxes axes = rectilinear(grid);
    if (!writer_ || axes.x != axes_.x || axes.y != axes_.y || axes.z != axes_.z) {
      writer_.emplace(dir_, "fields", axes, precision_);
      axes_ = std::move(axes);
    }
    const FlowFields ff = flow_fields(grid, D.distributed() ? gathered_u : sv.velocity(),
                                      D.distributed() ? gathered_p : sv.pressure(), sim.plan().rho);
    std::vector<CellField> fields = ff.fields();
    fields.push_back(CellField{"solid", "1", {CellArray{solid.data()}}});
    writer_->write(sim.time(), sim.step(), fields);
  });
}

FlowFields flow_fields(const Grid& g, const VectorField& u, const Field& p, double density) {
  FlowFields f;
  f.centre = centre_fields(g, u);
  const Shape sh = g.shape();
  f.pressure.resize(sh.cells());
  std::size_t n = 0;
  for (int k = 1; k <= sh.nz; ++k)
    for (int j = 1; j <= sh.ny; ++j)
      for (int i = 1; i <= sh.nx; ++i) f.pressure[n++] = density * p(i, j, k);
  return f;
}

std::vector<CellField> FlowFields::fields() const {
  auto arr = [](const std::vector<double>& v) { return CellArray{v.data()}; };
  const CentreFields& c = centre;
  return {CellField{"velocity", "m/s", {arr(c.u[0]), arr(c.u[1]), arr(c.u[2])}},
          CellField{"pressure", "Pa", {arr(pressure)}},
          CellField{"vorticity", "1/s", {arr(c.w[0]), arr(c.w[1]), arr(c.w[2])}},
          CellField{"q_criterion", "1/s^2", {arr(c.q)}}};
}

void SurfaceOutput::write(const Simulation& sim) {
  if (!sim.has_bodies()) return;
  std::vector<TriangleMesh> meshes;
  std::vector<SurfacePart> parts;
  const int n = sim.part_count();
  for (int i = 0; i < n; ++i) meshes.push_back(sim.surface(i));
  for (int i = 0; i < n; ++i) {
    const SurfacePressure sp = sim.surface_pressure(i);
    SurfacePart part{&meshes[std::size_t(i)], {}};
    part.data.cell_data.push_back({"pressure", "Pa", 1, sp.front});
    if (!sp.back.empty()) part.data.cell_data.push_back({"pressure_back", "Pa", 1, sp.back});
    parts.push_back(std::move(part));
  }
  on_root(sim.solver().decomposition(), [&] {
    if (!writer_) writer_.emplace(dir_, "surfaces");
    writer_->write(sim.time(), sim.step(), parts);
  });
}

// ---- progress --------------------------------------------------------------------------------------------------

void ProgressLog::on_start(const Simulation&) {
  start_ = last_log_ = after_warmup_ = clock::now();
}

double ProgressLog::steps_left(const Simulation& sim, double dt) const {
  if (end_step_ > 0) return double(end_step_ - sim.step());
  return dt > 0 ? std::max(0.0, (end_time_ - sim.time()) / dt) : 0.0;
}

double ProgressLog::seconds_per_step() const {
  if (warm_steps_ > 2)
    return std::chrono::duration<double>(clock::now() - after_warmup_).count() / double(warm_steps_ - 2);
  return estimate_;
}

void ProgressLog::on_step(const Simulation& sim, const StepReport& r) {
  const bool last = end_step_ > 0 ? sim.step() >= end_step_ : r.time >= end_time_ * (1 - 1e-12);
  if (++warm_steps_ == 2 || (last && warm_steps_ < 2)) {
    after_warmup_ = clock::now();
    estimate_ = std::chrono::duration<double>(after_warmup_ - start_).count() / double(warm_steps_);
    if (log_)
      *log_ << fmt::format("  estimate (timed on the first {} steps): {:.3g} s per step = {:.0f} ns per cell per step; "
                           "{} for the {:.0f} steps left\n",
                           warm_steps_, estimate_, 1e9 * estimate_ / double(sim.cells()),
                           fmt_seconds(estimate_ * steps_left(sim, r.dt)), steps_left(sim, r.dt));
  }
  const auto now = clock::now();
  if (log_ && (std::chrono::duration<double>(now - last_log_).count() >= seconds_ || last ||
               crossed(1, sim.plan().period, r.t_before, r.time))) {
    last_log_ = now;
    int iters = 0;
    for (const auto& st : sim.solver().poisson_stats()) iters += st.cycles;
    const double per = std::chrono::duration<double>(now - start_).count() / double(std::max<long>(1, warm_steps_));
    const double T = sim.plan().period;
    const long bad = sim.solver().unconverged_pressure_solves();
    const std::string unconverged =
        bad > 0 ? fmt::format("  ({} pressure solves above tolerance so far, worst {:.3g} x)", bad,
                              sim.solver().worst_pressure_residual())
                : std::string();
    *log_ << fmt::format("  step {:>7}  t/T {:8.4f}  cycle {:>3}  dt {:.3e} s  CFL {:.3f}  Poisson {:>2} it  ETA {}{}\n",
                         sim.step(), r.time / T, std::max(1, int(std::ceil(r.time / T - 1e-9))), r.dt, r.cfl, iters,
                         fmt_seconds(per * steps_left(sim, r.dt)), unconverged);
  }
}

}  // namespace flapstab::ns
