// Tests for cfd/derivatives: step-size insensitivity, the hawkmoth-like longitudinal sign pattern,
// symmetry of the decoupled table, and the non-dimensional scaling.
#include <algorithm>
#include <gtest/gtest.h>
#include "cfd/aero_factory.hpp"
#include "cfd/derivatives.hpp"
#include "common/case_text.hpp"
#include "core/errors.hpp"
#include "trim/trim.hpp"

namespace flapstab {
namespace {

struct Trimmed {
  Case c;
  std::unique_ptr<AeroModel> model;
  TrimResult t;
};

const Trimmed& trimmed_case() {
  static const Trimmed tr = [] {
    Trimmed x;
    x.c = load_case(testing::write_temp("der.toml", testing::valid_case_text()));
    x.model = make_aero_model(x.c);
    x.t = trim_hover(x.c, *x.model);
    return x;
  }();
  return tr;
}

// Step-size study: relative steps from 1e-3 to 3e-2 of U give the same derivatives. The quasi-steady
// loads are smooth in the body velocities (continuous coefficients and a Kutta-Joukowski rotational
// force), so central differences have O(h^2) truncation error: within 1e-3 of the row's largest
// derivative for h <= 0.01 (the default), and within 5e-3 at h = 0.03 (nine times the h = 0.01 error).
TEST(Derivatives, InsensitiveToStepSize) {
  const Trimmed& tr = trimmed_case();
  ASSERT_TRUE(tr.t.converged);
  const auto ref = cycle_averaged_derivatives(*tr.model, tr.c.insect, tr.t.kinematics, tr.c.fluid, 0.003);
  for (auto [h, tol] : {std::pair{0.001, 1e-3}, std::pair{0.01, 1e-3}, std::pair{0.03, 5e-3}}) {
    const auto d = cycle_averaged_derivatives(*tr.model, tr.c.insect, tr.t.kinematics, tr.c.fluid, h);
    for (int i = 0; i < 6; ++i) {
      const double scale = ref.table.nd.row(i).cwiseAbs().maxCoeff();
      for (int j = 0; j < 6; ++j)
        EXPECT_NEAR(d.table.nd(i, j), ref.table.nd(i, j), tol * scale) << "h=" << h << " (" << i << "," << j << ")";
    }
  }
}

// Sun's group (e.g. Sun & Xiong 2005, J Exp Biol 208:447; hovering insects incl. the hawkmoth): X_u < 0, M_u > 0, Z_w < 0, M_q < 0.
TEST(Derivatives, HawkmothLikeLongitudinalPattern) {
  const Trimmed& tr = trimmed_case();
  const auto d = cycle_averaged_derivatives(*tr.model, tr.c.insect, tr.t.kinematics, tr.c.fluid, 0.01);
  const DerivativeTable& t = d.table;
  EXPECT_LT(t.at("Xu"), 0.0);
  EXPECT_GT(t.at("Mu"), 0.0);
  EXPECT_LT(t.at("Zw"), 0.0);
  EXPECT_LT(t.at("Mq"), 0.0);
  // Symmetric flyer: longitudinal forces do not depend on lateral motion and vice versa.
  for (const char* n : {"Xv", "Xp", "Xr", "Zv", "Zp", "Zr", "Mv", "Mp", "Mr", "Yu", "Yw", "Yq", "Lu", "Lw", "Lq", "Nu",
                        "Nw", "Nq"})
    EXPECT_NEAR(t.at(n), 0.0, 1e-10) << n;
}

// [derivatives] columns: the longitudinal (u w q) or lateral (v p r) columns alone are the same numbers as in the
// whole table, with half the model runs; the other columns stay zero and the table says which planes it holds.
TEST(Derivatives, ColumnSubsetsMatchTheWholeTableWithHalfTheRuns) {
  const Trimmed& tr = trimmed_case();
  const auto all = cycle_averaged_derivatives(*tr.model, tr.c.insect, tr.t.kinematics, tr.c.fluid, 0.01);
  EXPECT_EQ(all.model_runs, 13);
  for (const std::string set : {"longitudinal", "lateral"}) {
    const std::vector<int> cols = derivative_columns(set);
    const auto d = cycle_averaged_derivatives(*tr.model, tr.c.insect, tr.t.kinematics, tr.c.fluid, 0.01, {}, cols);
    EXPECT_EQ(d.model_runs, 7) << set;
    EXPECT_EQ(d.table.has_longitudinal, set == "longitudinal");
    EXPECT_EQ(d.table.has_lateral, set == "lateral");
    EXPECT_FALSE(d.table.has_coupling);
    for (int j = 0; j < 6; ++j) {
      const bool in = std::find(cols.begin(), cols.end(), j) != cols.end();
      for (int i = 0; i < 6; ++i)
        EXPECT_EQ(d.table.nd(i, j), in ? all.table.nd(i, j) : 0.0) << set << " (" << i << "," << j << ")";
    }
  }
  EXPECT_THROW(derivative_columns("diagonal"), SolveError);
  EXPECT_THROW(cycle_averaged_derivatives(*tr.model, tr.c.insect, tr.t.kinematics, tr.c.fluid, 0.01, {}, {}),
               SolveError);
}

// [derivatives] relative_rate_step: the rate columns take their own step (h_r U / c), the velocity columns keep
// theirs; the quasi-steady loads are smooth, so the rate derivatives agree with the default step's to the
// truncation error of InsensitiveToStepSize (1e-3 of the row's largest derivative at h = 0.003 vs 0.01).
TEST(Derivatives, RateColumnsTakeTheirOwnStep) {
  const Trimmed& tr = trimmed_case();
  const auto d0 = cycle_averaged_derivatives(*tr.model, tr.c.insect, tr.t.kinematics, tr.c.fluid, 0.01);
  const auto d = cycle_averaged_derivatives(*tr.model, tr.c.insect, tr.t.kinematics, tr.c.fluid, 0.01, {},
                                            {0, 1, 2, 3, 4, 5}, 0.003);
  EXPECT_DOUBLE_EQ(d.velocity_step, d0.velocity_step);
  EXPECT_NEAR(d.rate_step, 0.3 * d0.rate_step, 1e-12 * d0.rate_step);
  for (int i = 0; i < 6; ++i) {
    const double scale = d0.table.nd.row(i).cwiseAbs().maxCoeff();
    for (int j = 0; j < 6; ++j) {
      if (j < 3) {
        EXPECT_EQ(d.table.nd(i, j), d0.table.nd(i, j)) << i << "," << j;
      } else {
        EXPECT_NEAR(d.table.nd(i, j), d0.table.nd(i, j), 1e-3 * scale) << i << "," << j;
      }
    }
  }
  // The phase-resolved derivatives from the runs use the same steps.
  const PhaseDerivatives ph = phase_resolved_from_runs(*tr.model, tr.c.insect, tr.t.kinematics, d.table.reference, 0.01,
                                                       std::nullopt, {0, 1, 2, 3, 4, 5}, 0.003);
  EXPECT_NEAR(ph.rate_step, d.rate_step, 1e-12 * d.rate_step);
}

// with_pitch_columns (the forced pitch oscillation's phase-resolved columns in the A(t)): the runs' own q column with
// no attitude derivative gives the A(t) back; an attitude derivative dM/dtheta enters the theta column of A(t) through
// the mass matrix exactly as the same dM/dq enters the q column; the lateral rows of the q column stay the runs'.
TEST(Derivatives, PitchColumnsReplaceTheRateColumnAndAddTheAttitudeColumn) {
  const Trimmed& tr = trimmed_case();
  const auto d = cycle_averaged_derivatives(*tr.model, tr.c.insect, tr.t.kinematics, tr.c.fluid, 0.01);
  const PhaseDerivatives ph =
      phase_resolved_from_runs(*tr.model, tr.c.insect, tr.t.kinematics, d.table.reference, 0.01);
  const std::size_t N = ph.samples.size();
  ASSERT_GE(N, 3u);
  std::vector<WrenchColumn> rate(N), zero(N, WrenchColumn::Zero()), bump(N, WrenchColumn::Zero());
  for (std::size_t k = 0; k < N; ++k) {
    rate[k] = ph.samples[k].wrench_si.col(4);
    bump[k](4) = 1e-3 * (1 + 0.5 * std::sin(6.283185307179586 * double(k) / double(N)));  // dM, N m per rad or s
  }
  const PhaseDerivatives same = with_pitch_columns(ph, *tr.model, tr.c.insect, tr.t.kinematics, rate, zero);
  ASSERT_EQ(same.samples.size(), N);
  for (std::size_t k = 0; k < N; ++k)
    EXPECT_LT((same.samples[k].system_si - ph.samples[k].system_si).norm(), 1e-12 * ph.samples[k].system_si.norm())
        << k;
  std::vector<WrenchColumn> moved = rate;
  for (std::size_t k = 0; k < N; ++k) moved[k](4) += bump[k](4);
  const PhaseDerivatives by_rate = with_pitch_columns(ph, *tr.model, tr.c.insect, tr.t.kinematics, moved, zero);
  const PhaseDerivatives by_attitude = with_pitch_columns(ph, *tr.model, tr.c.insect, tr.t.kinematics, rate, bump);
  for (std::size_t k = 0; k < N; ++k) {
    const Eigen::VectorXd dq = by_rate.samples[k].system_si.col(4) - ph.samples[k].system_si.col(4);
    const Eigen::VectorXd dtheta = by_attitude.samples[k].system_si.col(7) - ph.samples[k].system_si.col(7);
    ASSERT_GT(dq.norm(), 0.0);
    EXPECT_LT((dq - dtheta).norm(), 1e-9 * dq.norm()) << k;
    EXPECT_EQ(by_attitude.samples[k].system_si.col(4), ph.samples[k].system_si.col(4)) << k;
    EXPECT_EQ(by_attitude.samples[k].attitude_si(4, 1), bump[k](4));
  }
  std::vector<WrenchColumn> lateral = rate;
  lateral[0](3) += 1.0;  // an L row: not used
  EXPECT_EQ(with_pitch_columns(ph, *tr.model, tr.c.insect, tr.t.kinematics, lateral, zero).samples[0].system_si,
            same.samples[0].system_si);
  EXPECT_THROW(with_pitch_columns(ph, *tr.model, tr.c.insect, tr.t.kinematics, std::vector<WrenchColumn>(N - 1), zero),
               SolveError);
}

// A model whose w+ run fails (as a CFD run that diverges): make_derivative_runs goes on with the other runs, in
// table order, and reports the one failure; the derivatives of the finished columns then come from runs the model
// has already made (here: the quasi-steady model's answers, the same numbers as in the whole table).
class FailingRun final : public AeroModel {
 public:
  explicit FailingRun(const AeroModel& inner) : inner_(inner) {}
  std::string name() const override { return "failing"; }
  WrenchHistory run(const Insect& insect, const Kinematics& kin, const BodyMotion& motion,
                    const AeroRunOptions& options) const override {
    calls.push_back(motion);
    if (motion.velocity.z() > 0) throw SolveError("run w+ diverged");
    return inner_.run(insect, kin, motion, options);
  }
  mutable std::vector<BodyMotion> calls;

 private:
  const AeroModel& inner_;
};

TEST(Derivatives, AFailedRunDoesNotStopTheOthers) {
  const Trimmed& tr = trimmed_case();
  const FailingRun model(*tr.model);
  const std::vector<int> cols = derivative_columns("longitudinal");
  const auto failures = make_derivative_runs(model, tr.c.insect, tr.t.kinematics, tr.c.fluid, 0.01, 0.003, cols);
  ASSERT_EQ(model.calls.size(), 6u);
  ASSERT_EQ(failures.size(), 1u);
  EXPECT_EQ(failures[0].column, 2);
  EXPECT_EQ(failures[0].sign, +1);
  EXPECT_EQ(failures[0].message, "run w+ diverged");
  // The runs are the ones cycle_averaged_derivatives makes (same motions, bit for bit, so a model that keeps its
  // runs finds them again): u+, u-, w+, w-, q+, q-.
  const auto d = cycle_averaged_derivatives(*tr.model, tr.c.insect, tr.t.kinematics, tr.c.fluid, 0.01, {}, cols, 0.003);
  const double hv = d.velocity_step, hr = d.rate_step;
  const Vec3 v[6] = {Vec3(hv, 0, 0), Vec3(-hv, 0, 0), Vec3(0, 0, hv), Vec3(0, 0, -hv), Vec3::Zero(), Vec3::Zero()};
  const Vec3 w[6] = {Vec3::Zero(), Vec3::Zero(), Vec3::Zero(), Vec3::Zero(), Vec3(0, hr, 0), Vec3(0, -hr, 0)};
  for (int k = 0; k < 6; ++k) {
    EXPECT_EQ(model.calls[std::size_t(k)].velocity, v[k]) << k;
    EXPECT_EQ(model.calls[std::size_t(k)].rate, w[k]) << k;
  }
  model.calls.clear();
  EXPECT_THROW(cycle_averaged_derivatives(model, tr.c.insect, tr.t.kinematics, tr.c.fluid, 0.01, {}, cols, 0.003),
               SolveError);
  const auto part = cycle_averaged_derivatives(model, tr.c.insect, tr.t.kinematics, tr.c.fluid, 0.01, {}, {0, 4}, 0.003);
  EXPECT_EQ(part.table.at("Xu"), d.table.at("Xu"));
  EXPECT_EQ(part.table.at("Mq"), d.table.at("Mq"));
}

TEST(Derivatives, NondimensionalScaling) {
  const Trimmed& tr = trimmed_case();
  const auto d = cycle_averaged_derivatives(*tr.model, tr.c.insect, tr.t.kinematics, tr.c.fluid, 0.01);
  const ReferenceQuantities& r = d.table.reference;
  EXPECT_NEAR(d.table.at("Xu"), d.si(0, 0) * r.U / (0.5 * r.rho * r.U * r.U * r.S_t), 1e-14);
  EXPECT_NEAR(d.table.at("Mq"), d.si(4, 4) * (r.U / r.c) / (0.5 * r.rho * r.U * r.U * r.S_t * r.c), 1e-14);
  // U = 2 Phi n r2 with Phi the trimmed amplitude.
  EXPECT_NEAR(r.U, 2 * tr.t.kinematics.stroke_amplitude() * r.frequency * tr.c.insect.wing.radius_of_moment(2), 1e-12);
  EXPECT_NEAR(d.table.mass.m, tr.c.insect.total_mass(), 1e-15);
  EXPECT_GT(d.table.mass.Iyy, 0.0);
}

}  // namespace
}  // namespace flapstab
