// Free flight coupled to the Navier-Stokes solver (cfd_flight.hpp).
#include "flight/cfd_flight.hpp"

#include <cmath>
#include <fmt/format.h>

#include "core/rotation.hpp"

namespace flapstab {

namespace {
// Body-state integration sub-steps from the step's start to a stage time (classical Runge-Kutta; the body moves
// by a small fraction of a cell per fluid step, so this error is far below the coupling's lag).
constexpr int body_substeps = 2;
}  // namespace

CfdFlight::CfdFlight(const Case& c, const FlightDynamics& dynamics, const ns::CfdPlan& plan)
    : dyn_(dynamics), plan_(plan) {
  if (plan.steps_per_cycle <= 0)
    throw InputError(c.path, "aero.cfd.steps_per_cycle", "free flight coupled to the solver needs a fixed time step",
                     "steps_per_cycle > 0");
  sim_ = std::make_unique<ns::Simulation>(c, dynamics.trimmed(), BodyMotion{}, plan);
  rho_ = plan.rho;
  g_ = dynamics.gravity();
  for (int i = 0; i < sim_->part_count(); ++i) {
    Vec3 cen;
    volume_.push_back(sim_->part_volume(i, &cen));
    centroid_.push_back(cen);
  }
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

BodyStateVector CfdFlight::rhs(double t, const BodyStateVector& x, const Wrench& held) const {
  const Wrench b = buoyancy(x);
  return dyn_.derivative(t, x, {}, Wrench{held.force + b.force + offset_.force, held.moment + b.moment + offset_.moment})
      .dx;
}

BodyStateVector CfdFlight::body_at(double t) const {
  return ns::integrate_body([this](double s, const BodyStateVector& y) { return rhs(s, y, base_aero_); }, base_time_,
                            base_x_, t, body_substeps);
}

std::vector<ns::PartState> CfdFlight::parts_at(double t) const {
  const BodyStateVector x = body_at(t);
  const ns::BodyFrame b = ns::body_frame(x, rhs(t, x, base_aero_));
  std::vector<ns::PartState> out;
  for (const ns::PartState& rel : sim_->prescribed_parts(t)) out.push_back(ns::part_in_grid(b, rel));
  return out;
}

CfdFlightStep CfdFlight::observe(long step, double cfl) const {
  CfdFlightStep s;
  s.step = step;
  s.time = sim_->time();
  s.cfl = cfl;
  s.x = x_;
  const ns::CfdLoadRow row = sim_->loads();
  const Wrench total = row.total();
  s.aero = ns::wrench_on_body(ns::body_frame(x_, BodyStateVector::Zero()), total.force, total.moment);
  s.buoyancy = buoyancy(x_);
  s.power = row.wing_power;
  return s;
}

void CfdFlight::start(const ns::SimulationState* flow, const BodyStateVector& x0) {
  if (flow) sim_->restore(*flow);
  x_ = dyn_.held(x0);
  base_time_ = sim_->time();
  base_x_ = x_;
  base_aero_ = Wrench{};
  // Set once: the source reads the members, which each step moves on (re-attaching would re-mark the flags).
  sim_->set_part_source([this](double t) { return parts_at(t); });
  cur_ = observe(sim_->step(), 0);
  base_aero_ = cur_.aero;
  check_inside();
}

void CfdFlight::restore(const ns::SimulationState& flow, const BodyStateVector& x, const Wrench& aero) {
  x_ = dyn_.held(x);
  base_time_ = flow.time;
  base_x_ = x_;
  base_aero_ = aero;
  sim_->set_part_source([this](double t) { return parts_at(t); });
  sim_->restore(flow);
  cur_ = observe(sim_->step(), 0);
  cur_.aero = aero;  // the wrench held over the next step, as the run that wrote the state had it
}

CfdFlightStep CfdFlight::advance() {
  base_time_ = sim_->time();
  base_x_ = x_;
  base_aero_ = cur_.aero;
  const ns::StepReport r = sim_->advance();
  x_ = body_at(r.time);
  if (!x_.allFinite()) throw SolveError(fmt::format("free flight: the body state is not finite at t = {:.6g} s", r.time));
  cur_ = observe(r.step, r.cfl);
  check_inside();
  return cur_;
}

void CfdFlight::check_inside() const {
  const ns::ImmersedBoundary* ib = sim_->immersed();
  if (!ib) return;
  for (int i = 0; i < int(ib->parts()); ++i) {
    const ns::BoundingBox bb = ib->surface(i, sim_->time()).bounding_box();  // the surface's own extent
    for (int a = 0; a < 3; ++a)
      if (bb.lo(a) < plan_.fine_lo(a) || bb.hi(a) > plan_.fine_hi(a))
        throw BodyLeftGrid(fmt::format(
            "free flight: the {} left the grid's uniform fine box at t = {:.6g} s (step {}): it spans [{:.4g}, {:.4g}] "
            "m along {}, the fine box [{:.4g}, {:.4g}] m; the body is at ({:.4g}, {:.4g}, {:.4g}) m, pitch {:.2f} "
            "deg; give it more room with [aero.cfd] fine_margin_R or fly fewer wingbeats",
            ib->label(i), sim_->time(), sim_->step(), bb.lo(a), bb.hi(a), "xyz"[a], plan_.fine_lo(a),
            plan_.fine_hi(a), x_(0), x_(1), x_(2), x_(10) * 180 / M_PI));
  }
}

}  // namespace flapstab
