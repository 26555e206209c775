// Cycle-averaged stability derivatives by central differences over any AeroModel.
#include "cfd/derivatives.hpp"
#include "core/configuration.hpp"

namespace flapstab {

ReferenceQuantities reference_quantities(const Insect& insect, const Kinematics& kin, const FluidProperties& fluid) {
  ReferenceQuantities r;
  r.U = 2 * kin.stroke_amplitude() * kin.frequency_hz * insect.wing.radius_of_moment(2);
  r.c = insect.wing.mean_chord;
  r.S_t = 2 * insect.wing.area();
  r.rho = fluid.density;
  r.frequency = kin.frequency_hz;
  return r;
}

MassProperties mass_properties(const Insect& insect, const Kinematics& kin) {
  const Configuration config(insect, kin);
  constexpr int n = 128;
  Mat3 J = Mat3::Zero();
  for (int i = 0; i < n; ++i) {
    const MassState ms = config.mass_state(kin.period() * i / n);
    for (const PartMass* p : {&ms.body, &ms.right, &ms.left})
      J += p->mass * (p->r.squaredNorm() * Mat3::Identity() - p->r * p->r.transpose()) + p->inertia;
  }
  J /= n;
  MassProperties m;
  m.m = insect.total_mass();
  m.Ixx = J(0, 0);
  m.Iyy = J(1, 1);
  m.Izz = J(2, 2);
  m.Ixz = -J(0, 2);  // product of inertia int x z dm (the tensor holds -Ixz)
  return m;
}

DerivativeResult cycle_averaged_derivatives(const AeroModel& model, const Insect& insect, const Kinematics& kin,
                                            const FluidProperties& fluid, double relative_step,
                                            const AeroRunOptions& run) {
  DerivativeResult out;
  DerivativeTable& t = out.table;
  t.reference = reference_quantities(insect, kin, fluid);
  t.mass = mass_properties(insect, kin);
  t.has_longitudinal = t.has_lateral = t.has_coupling = true;
  t.source = "flapstab cycle-averaged derivatives, " + model.name();
  const ReferenceQuantities& ref = t.reference;
  out.velocity_step = relative_step * ref.U;
  out.rate_step = relative_step * ref.U / ref.c;
  auto mean = [&](const BodyMotion& m) {
    ++out.model_runs;
    const Wrench w = model.run(insect, kin, m, run).mean();
    Eigen::Matrix<double, 6, 1> v;
    v << w.force, w.moment;
    return v;
  };
  {
    const auto w0 = mean(BodyMotion{});
    out.mean_at_trim.force = w0.head<3>();
    out.mean_at_trim.moment = w0.tail<3>();
  }
  for (int j = 0; j < 6; ++j) {
    const double h = j < 3 ? out.velocity_step : out.rate_step;
    BodyMotion plus, minus;
    Vec3& p = j < 3 ? plus.velocity : plus.rate;
    Vec3& q = j < 3 ? minus.velocity : minus.rate;
    p(j % 3) = h;
    q(j % 3) = -h;
    out.si.col(j) = (mean(plus) - mean(minus)) / (2 * h);
  }
  // Non-dimensional: d(F/(q S_t)) / d(u/U) and d(F/(q S_t)) / d(q c/U); moments also / c.
  for (int i = 0; i < 6; ++i) {
    const double load = i < 3 ? ref.force_scale() : ref.moment_scale();
    for (int j = 0; j < 6; ++j) {
      const double var = j < 3 ? ref.U : ref.U / ref.c;
      t.nd(i, j) = out.si(i, j) * var / load;
    }
  }
  return out;
}

}  // namespace flapstab
