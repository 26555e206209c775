// Free flight coupled to the Navier-Stokes solver (cfd_flight.hpp).
#include "flight/cfd_flight.hpp"

#include <chrono>
#include <cmath>
#include <limits>
#include <optional>
#include <tuple>
#include <fmt/format.h>

#include <algorithm>
#include "cfd/navier_stokes/decomposition.hpp"
#include "cfd/navier_stokes/insect_motion.hpp"
#include "cfd/navier_stokes/solver_io.hpp"
#include "core/body_state.hpp"
#include "core/errors.hpp"
#include "core/rotation.hpp"

namespace flapstab {

namespace {
// Body-state integration sub-steps from the step's start to a stage time (classical Runge-Kutta; the body moves
// by a small fraction of a cell per fluid step, so this error is far below the coupling's lag).
constexpr int body_substeps = 2;
}  // namespace

// The feedback law on the sensed deviation history (cfd_flight.hpp, "Closed loop").
class CfdFlight::Feedback {
 public:
  Feedback(const FlightDynamics& dyn, const ControllerSpec& c, std::function<BodyStateVector(double)> reference)
      : spec_(c), bound_(dyn, c), ref_(std::move(reference)), period_(dyn.trimmed().period()) {}

  // The flight starts at time t0 in state x0.
  void start(double t0, const BodyStateVector& x0) {
    t0_ = t0;
    hs_.clear();
    hd_.clear();
    hs_.push_back(0);
    hd_.push_back(x0 - ref_(0));
    filt_.assign(std::size_t(bound_.filters), 0.0);
    raw_last_.assign(std::size_t(bound_.filters), 0.0);
    for (const Term& t : bound_.terms)
      if (t.filter >= 0) filt_[std::size_t(t.filter)] = raw_last_[std::size_t(t.filter)] = raw(t, 0, 0, hd_.back());
    held_ = spec_.update == ControlUpdate::wingbeat ? law(0, hd_.back()) : std::vector<double>(bound_.lower.size(), 0.0);
  }
  // A fluid step accepted at time t with the body at x.
  void accept(double t, const BodyStateVector& x) {
    const double s = t - t0_;
    const BodyStateVector d = x - ref_(s);
    std::vector<double> f(filt_.size()), r(filt_.size());
    for (const Term& term : bound_.terms)
      if (term.filter >= 0) {
        f[std::size_t(term.filter)] = filtered(term, s, d);
        r[std::size_t(term.filter)] = raw(term, s, s, d);
      }
    hs_.push_back(s);
    hd_.push_back(d);
    filt_ = std::move(f);
    raw_last_ = std::move(r);
    if (spec_.update == ControlUpdate::wingbeat) {
      const double k = std::round(s / period_);
      if (k > 0 && std::abs(s - k * period_) < 1e-9 * period_) held_ = law(s, d);
    }
  }
  std::vector<double> command(double t, const BodyStateVector& x) const {
    if (spec_.update == ControlUpdate::wingbeat) return held_;
    const double s = t - t0_;
    return law(s, x - ref_(s));
  }

 private:
  using Term = BoundController::Term;
  // The deviation at flight time s: zero before the start, the stored history up to its newest point, then linear
  // to the current deviation d_now at s_now.
  BodyStateVector deviation(double s, double s_now, const BodyStateVector& d_now) const {
    if (s < 0) return BodyStateVector::Zero();
    if (s >= hs_.back()) {
      const double span = s_now - hs_.back();
      if (!(span > 0)) return hd_.back();
      const double w = std::min(1.0, (s - hs_.back()) / span);
      return (1 - w) * hd_.back() + w * d_now;
    }
    const std::size_t j = std::size_t(std::upper_bound(hs_.begin(), hs_.end(), s) - hs_.begin());  // hs_[j-1] <= s
    if (j == 0) return hd_.front();
    const double w = (s - hs_[j - 1]) / (hs_[j] - hs_[j - 1]);
    return (1 - w) * hd_[j - 1] + w * hd_[j];
  }
  double raw(const Term& t, double s, double s_now, const BodyStateVector& d_now) const {
    return deviation(s - t.spec.latency_s, s_now, d_now)(t.state);
  }
  // The filter state at s inside the current step: T f' = u - f exactly for u linear from its value at the newest
  // stored point to its value now.
  double filtered(const Term& t, double s, const BodyStateVector& d_now) const {
    const double h = s - hs_.back(), T = t.spec.filter_time_s;
    const double f0 = filt_[std::size_t(t.filter)], a = raw_last_[std::size_t(t.filter)];
    if (!(h > 0)) return f0;
    const double b = raw(t, s, s, d_now), E = std::exp(-h / T);
    return E * f0 + (1 - E) * a + (b - a) * (1 - T * (1 - E) / h);
  }
  std::vector<double> law(double s, const BodyStateVector& d_now) const {
    return bound_.law([&](const Term& t) { return t.filter >= 0 ? filtered(t, s, d_now) : raw(t, s, s, d_now); });
  }
  ControllerSpec spec_;
  BoundController bound_;
  std::function<BodyStateVector(double)> ref_;
  double period_ = 0, t0_ = 0;
  std::vector<double> held_, filt_, raw_last_;
  std::vector<double> hs_;
  std::vector<BodyStateVector> hd_;
};

namespace {

ns::SimulationOptions over(const std::shared_ptr<const ns::Decomposition>& ranks) {
  ns::SimulationOptions o;
  o.decomposition = ranks;
  return o;
}

}  // namespace

CfdFlight::CfdFlight(const Case& c, const FlightDynamics& dynamics, const ns::CfdPlan& plan,
                     std::shared_ptr<const ns::Decomposition> ranks)
    : dyn_(dynamics), case_(c), ranks_(ranks && ranks->distributed() ? std::move(ranks) : nullptr), base_plan_(plan),
      plan_(plan) {
  if (plan.steps_per_cycle <= 0)
    throw InputError(c.path, "aero.cfd.steps_per_cycle", "free flight coupled to the solver needs a fixed time step",
                     "steps_per_cycle > 0");
  sim_ = std::make_unique<ns::Simulation>(c, dynamics.trimmed(), BodyMotion{}, plan, over(ranks_));
  rho_ = plan.rho;
  g_ = dynamics.gravity();
  for (int i = 0; i < sim_->part_count(); ++i) {
    Vec3 cen;
    volume_.push_back(sim_->part_volume(i, &cen));
    centroid_.push_back(cen);
  }
  if (const auto i = dynamics.actuator_index("frequency_hz")) freq_ = *i;
  f0_ = dynamics.trimmed().frequency_hz;
  room_ = std::numeric_limits<double>::infinity();
  for (int d = 0; d < 3; ++d)
    room_ = std::min({room_, plan.swept_lo[d] - plan.fine_lo[d], plan.fine_hi[d] - plan.swept_hi[d]});
}

CfdFlight::~CfdFlight() = default;

double CfdFlight::body_mass() const { return dyn_.insect().total_mass(); }

double CfdFlight::forced_fluid_mass() const {
  double v = 0;
  for (int i = 0; i < sim_->part_count(); ++i) {
    const double closed = sim_->part_volume(i);
    v += closed > 0 ? closed : sim_->surface(i).area() * 2 * ns::ImmersedOptions{}.membrane_half_thickness * plan_.h_actual;
  }
  return rho_ * v;
}

Wrench CfdFlight::buoyancy(const BodyStateVector& x) const {
  // rho_f V g upwards (-z in the grid) on each closed part, at its centroid; body axes, about O.
  Wrench w;
  const Mat3 Rt = euler321(x(9), x(10), x(11)).transpose();
  for (std::size_t i = 0; i < volume_.size(); ++i) {
    if (volume_[i] <= 0) continue;
    const Vec3 F = Rt * Vec3(0, 0, -rho_ * volume_[i] * g_);
    w.force += F;
    w.moment += centroid_[i].cross(F);
  }
  return w;
}

double CfdFlight::kinematic_time(double t, double psi, const std::vector<double>& cmd) const {
  if (freq_ < 0) return t;
  return psi / (f0_ + cmd[std::size_t(freq_)]);
}

BodyStateVector CfdFlight::rhs(double t, const BodyStateVector& x, double psi, const Wrench& held) const {
  const Wrench b = buoyancy(x);
  const std::vector<double> cmd = command(t, x);
  return dyn_.derivative(kinematic_time(t, psi, cmd), x, cmd,
                         Wrench{held.force + b.force + offset_.force, held.moment + b.moment + offset_.moment})
      .dx;
}

std::pair<BodyStateVector, double> CfdFlight::body_at(double t) const {
  if (freq_ < 0)
    return {ns::integrate_body([this](double s, const BodyStateVector& y) { return rhs(s, y, 0, base_aero_); },
                               base_time_, base_x_, t, body_substeps),
            0.0};
  // The body and the phase together (classical Runge-Kutta, as ns::integrate_body): dpsi/dt = f_trim + command_f.
  using State = Eigen::Matrix<double, 13, 1>;
  auto f = [this](double s, const State& y) {
    const BodyStateVector x = y.head<12>();
    State d;
    d.head<12>() = rhs(s, x, y(12), base_aero_);
    d(12) = f0_ + command(s, x)[std::size_t(freq_)];
    return d;
  };
  State y0;
  y0.head<12>() = base_x_;
  y0(12) = base_psi_;
  const State y = ns::runge_kutta(f, base_time_, y0, t, body_substeps);
  return {y.head<12>(), y(12)};
}

std::vector<ns::PartState> CfdFlight::parts_at(double t) const {
  const auto [x, psi] = body_at(t);
  const std::vector<double> cmd = command(t, x);
  const ns::BodyFrame b = ns::body_frame(x, rhs(t, x, psi, base_aero_));
  std::vector<ns::PartState> out;
  for (const ns::PartState& rel : relative_parts(kinematic_time(t, psi, cmd), cmd))
    out.push_back(ns::part_in_grid(b, rel));
  return out;
}

std::vector<ns::PartState> CfdFlight::relative_parts(double t, const std::vector<double>& cmd) const {
  if (std::none_of(cmd.begin(), cmd.end(), [](double v) { return v != 0; })) return sim_->prescribed_parts(t);
  const Kinematics kin = dyn_.kinematics(cmd);
  const Configuration config(dyn_.insect(), kin, dyn_.configuration().reference_point());
  return ns::InsectMotion(config, BodyMotion{}).parts(t);
}

void CfdFlight::set_controller(const ControllerSpec& controller, std::function<BodyStateVector(double)> reference) {
  feedback_ = controller.empty() ? nullptr : std::make_unique<Feedback>(dyn_, controller, std::move(reference));
}

bool CfdFlight::closed_loop() const { return feedback_ != nullptr; }

std::vector<double> CfdFlight::command(double t, const BodyStateVector& x) const {
  if (!feedback_) return std::vector<double>(dyn_.actuators().size(), 0.0);
  return feedback_->command(t, x);
}

CfdFlightStep CfdFlight::observe(long step, double cfl) const {
  CfdFlightStep s;
  s.step = step;
  s.time = sim_->time();
  s.cfl = cfl;
  s.x = x_;
  const ns::CfdLoadRow row = sim_->loads();
  Wrench total = row.total();
  s.power = row.wing_power;
  if (ranks_) {  // rank 0's: every rank then moves the body alike, whatever order a reduction summed the loads in
    double v[7] = {total.force.x(), total.force.y(), total.force.z(), total.moment.x(), total.moment.y(),
                   total.moment.z(), s.power};
    ranks_->broadcast(v, 7);
    total = Wrench{Vec3(v[0], v[1], v[2]), Vec3(v[3], v[4], v[5])};
    s.power = v[6];
  }
  s.aero = ns::wrench_on_body(ns::body_frame(x_, BodyStateVector::Zero()), total.force, total.moment);
  s.buoyancy = buoyancy(x_);
  s.command = command(s.time, x_);
  s.phase = freq_ < 0 ? s.time * f0_ : psi_;
  return s;
}

void CfdFlight::start(const ns::SimulationState* flow, const BodyStateVector& x0) {
  if (flow) sim_->restore(*flow);
  x_ = dyn_.held(x0);
  base_time_ = sim_->time();
  base_x_ = x_;
  psi_ = base_psi_ = base_time_ * f0_;  // the flow state's wings: the trimmed kinematics at its time
  base_aero_ = Wrench{};
  if (feedback_) feedback_->start(base_time_, x_);
  // Set once: the source reads the members, which each step moves on (re-attaching would re-mark the flags).
  sim_->set_part_source([this](double t) { return parts_at(t); });
  cur_ = observe(sim_->step(), 0);
  base_aero_ = cur_.aero;
  check_room();  // a body started near a face of the fine box is re-planned at once
}

void CfdFlight::restore(const ns::SimulationState& flow, const BodyStateVector& x, const Wrench& aero,
                        const std::vector<CfdFlightStep>& past, const ns::FineBoxShift& shift,
                        std::optional<double> phase) {
  if (!(shift == shift_)) rebuild(shift);
  if (feedback_) {
    if (past.empty() || past.back().time != flow.time)
      throw SolveError("free flight: a closed-loop flight continues only with its steps up to the restored one");
    feedback_->start(past.front().time, dyn_.held(past.front().x));
    for (std::size_t i = 1; i < past.size(); ++i) feedback_->accept(past[i].time, past[i].x);
  }
  x_ = dyn_.held(x);
  base_time_ = flow.time;
  base_x_ = x_;
  psi_ = base_psi_ = phase ? *phase : flow.time * f0_;
  base_aero_ = aero;
  sim_->set_part_source([this](double t) { return parts_at(t); });
  sim_->restore(flow);
  cur_ = observe(sim_->step(), 0);
  cur_.aero = aero;  // the wrench held over the next step, as the run that wrote the state had it
}

CfdFlightStep CfdFlight::advance() {
  base_time_ = sim_->time();
  base_x_ = x_;
  base_psi_ = psi_;
  base_aero_ = cur_.aero;
  const ns::StepReport r = sim_->advance();
  std::tie(x_, psi_) = body_at(r.time);
  if (!x_.allFinite()) throw SolveError(fmt::format("free flight: the body state is not finite at t = {:.6g} s", r.time));
  if (feedback_) feedback_->accept(r.time, x_);
  cur_ = observe(r.step, r.cfl);
  check_room();
  return cur_;
}

std::vector<ns::BoundingBox> CfdFlight::part_boxes() const {
  const ns::ImmersedBoundary* ib = sim_->immersed();
  if (!ib) return {};
  const std::vector<ns::PartState> states = sim_->part_states();
  std::vector<ns::BoundingBox> out;
  for (int i = 0; i < int(ib->parts()); ++i) out.push_back(ib->surface(i, states[std::size_t(i)]).bounding_box());
  return out;
}

void CfdFlight::check_room() {
  const std::vector<ns::BoundingBox> boxes = part_boxes();
  if (replan_) maybe_replan(boxes);  // the parts stay where they are: the same boxes on the new grid
  check_inside(boxes);
}

double CfdFlight::gap(const std::vector<ns::BoundingBox>& boxes) const {
  double g = std::numeric_limits<double>::infinity();
  for (const ns::BoundingBox& bb : boxes)
    for (int a = 0; a < 3; ++a) g = std::min({g, bb.lo(a) - plan_.fine_lo(a), plan_.fine_hi(a) - bb.hi(a)});
  return g;
}

void CfdFlight::rebuild(const ns::FineBoxShift& shift) {
  const ns::CfdPlan p = ns::shifted_plan(base_plan_, shift);
  sim_.reset();  // its memory first: the new grid may be larger
  sim_ = std::make_unique<ns::Simulation>(case_, dyn_.trimmed(), BodyMotion{}, p, over(ranks_));
  plan_ = p;
  shift_ = shift;
}

void CfdFlight::maybe_replan(const std::vector<ns::BoundingBox>& boxes) {
  const double g = gap(boxes);
  if (!(g < 0.5 * room_)) return;
  const auto t0 = std::chrono::steady_clock::now();
  // The planned swept volume (body axes; the body at rest at O) carried to the body's pose: the box of its corners,
  // with the parts' current extents (a wing outside the planned volume), plus the room on every side.
  const ns::BodyFrame b = ns::body_frame(x_, BodyStateVector::Zero());
  ns::BoundingBox box;
  for (int k = 0; k < 8; ++k) {
    const Vec3 corner(k & 1 ? base_plan_.swept_hi.x() : base_plan_.swept_lo.x(),
                      k & 2 ? base_plan_.swept_hi.y() : base_plan_.swept_lo.y(),
                      k & 4 ? base_plan_.swept_hi.z() : base_plan_.swept_lo.z());
    box.add(b.origin + b.rotation * corner);
  }
  for (const ns::BoundingBox& bb : boxes) {
    box.add(bb.lo);
    box.add(bb.hi);
  }
  const ns::FineBoxShift shift =
      ns::fine_box_shift(base_plan_, box.lo - Vec3::Constant(room_), box.hi + Vec3::Constant(room_));
  if (shift == shift_) return;  // the box cannot move further: check_inside decides
  const ns::CfdPlan next = ns::shifted_plan(base_plan_, shift);
  const ns::Decomposition one;
  ns::from_root(ranks_ ? *ranks_ : one, [&] {  // over ranks rank 0 decides for all
    if (const std::size_t free = ns::available_memory_bytes(); free > 0)
      ns::check_memory(next, case_.path, free + sim_->bytes());  // the old grid's memory is released first
    return std::string();
  });
  // Over ranks the flow is carried over on rank 0 (the old grid gathered there), which sends each rank its planes of
  // the new grid, one slab at a time: the same values as in one process.
  ns::SimulationState flow = sim_->whole_state();
  const ns::Grid from = sim_->whole_grid();
  rebuild(shift);
  ns::SimulationState moved = ns::transfer_state_over_ranks(flow, from, sim_->solver());
  flow = ns::SimulationState{};
  sim_->set_part_source([this](double t) { return parts_at(t); });
  sim_->restore(moved);
  CfdReplan r;
  r.step = sim_->step();
  r.time = sim_->time();
  r.shift = shift;
  r.fine_lo = plan_.fine_lo;
  r.fine_hi = plan_.fine_hi;
  r.cells = sim_->cells();
  r.gap = g;
  r.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  replans_.push_back(r);
}

void CfdFlight::check_inside(const std::vector<ns::BoundingBox>& boxes) const {
  const ns::ImmersedBoundary* ib = sim_->immersed();
  if (!ib) return;
  for (int i = 0; i < int(boxes.size()); ++i) {
    const ns::BoundingBox& bb = boxes[std::size_t(i)];  // the surface's own extent
    for (int a = 0; a < 3; ++a)
      if (bb.lo(a) < plan_.fine_lo(a) || bb.hi(a) > plan_.fine_hi(a))
        throw BodyLeftGrid(fmt::format(
            "free flight: the {} left the grid's uniform fine box at t = {:.6g} s (step {}): it spans [{:.4g}, {:.4g}] "
            "m along {}, the fine box [{:.4g}, {:.4g}] m; the body is at ({:.4g}, {:.4g}, {:.4g}) m, pitch {:.2f} "
            "deg; {}",
            ib->label(i), sim_->time(), sim_->step(), bb.lo(a), bb.hi(a), "xyz"[a], plan_.fine_lo(a),
            plan_.fine_hi(a), x_(0), x_(1), x_(2), x_(10) * 180 / M_PI,
            replan_ ? "the re-planned box could not hold it: give it more room with [aero.cfd] fine_margin_R"
                    : "give it more room with [aero.cfd] fine_margin_R, let the box follow it ([flight] cfd_replan = "
                      "true) or fly fewer wingbeats"));
  }
}

}  // namespace flapstab
