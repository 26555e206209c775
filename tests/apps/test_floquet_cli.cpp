// Periodic hover of the data/ insects: the two monodromy routes agree, the exponents converge with the number
// of phase samples, the dronefly's Floquet exponents are close to its averaged LTI eigenvalues while the
// hawkmoth's differ more (Wu & Sun 2012, J R Soc Interface 9:2033), JSON keys and bad input.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <fmt/format.h>

#include "apps/floquet_command.hpp"
#include "cfd/aero_factory.hpp"
#include "common/case_text.hpp"
#include "core/errors.hpp"

namespace flapstab {
namespace {

Case insect_case(const std::string& name) {
  return load_case(std::string(FLAPSTAB_SOURCE_DIR) + "/data/insects/" + name + ".toml");
}

// Longitudinal multipliers of route 1 with N phase samples and the given relative derivative step.
std::vector<std::complex<double>> route1_multipliers(const Case& c, const AeroModel& model, const CyclicTrimResult& ct,
                                                     const ReferenceQuantities& ref, int N, double step) {
  const InstantaneousAero aero(model, c.insect, ct.kinematics);
  const PhaseDerivatives pd = phase_resolved_derivatives(aero, periodic_orbit(aero, ct.initial_state, N), ref, step);
  const PeriodicMatrixSpline A(ct.period, pd.system_samples({0, 2, 4, 7}));
  const MonodromyResult m = monodromy([&](double t) { return A(t); }, 4, ct.period);
  const std::vector<std::string> order{"u", "w", "q", "theta"};
  return floquet_analysis("lon", order, m.monodromy, ct.period, nondimensional_state_scale(order, ref), ref).multipliers;
}

double max_difference(const std::vector<std::complex<double>>& a, const std::vector<std::complex<double>>& b) {
  double d = 0;
  for (std::size_t i = 0; i < a.size(); ++i) d = std::max(d, std::abs(a[i] - b[i]));
  return d;
}

// Route 1 (A(t) from phase-resolved derivatives, spline over N phases) against route 2 (exact CVODES
// sensitivities of the nonlinear flow). Route 1's errors: the derivative step (central differences,
// O(h^2)) and the spline (O(N^-4) for smooth data; the loads' kinks at stroke reversal slow it). With
// h = 1e-4 and N = 256 the multipliers agree to 2e-6 (measured 7e-7);
// with the case's h = 0.01 the step error dominates (~1e-4). The table is printed for the record.
TEST(FloquetHover, HawkmothRoutesAgreeAndConvergeWithPhases) {
  const Case c = insect_case("hawkmoth");
  const auto model = make_aero_model(c);
  const TrimResult avg = trim_hover(c, *model);
  ASSERT_TRUE(avg.converged);
  const CyclicTrimResult ct = cyclic_trim(c, *model, avg);
  ASSERT_TRUE(ct.converged);
  const ReferenceQuantities ref = reference_quantities(c.insect, ct.kinematics, c.fluid);
  const std::vector<std::string> order{"u", "w", "q", "theta"};
  Eigen::MatrixXd m2(4, 4);
  for (int i = 0; i < 4; ++i)
    for (int j = 0; j < 4; ++j) m2(i, j) = ct.monodromy(std::vector<int>{0, 2, 4, 7}[std::size_t(i)], std::vector<int>{0, 2, 4, 7}[std::size_t(j)]);
  const auto mu2 = floquet_analysis("lon", order, m2, ct.period, nondimensional_state_scale(order, ref), ref).multipliers;
  std::printf("N     step    |mu1 - mu2|max   lambda_nd(unstable)\n");
  double previous = 1e300;
  for (int N : {16, 32, 64, 128, 256}) {
    const auto mu1 = route1_multipliers(c, *model, ct, ref, N, 1e-4);
    const double d = max_difference(mu1, mu2);
    const std::complex<double> lam = std::log(mu1[0]) / (ct.period * ref.U / ref.c);
    std::printf("%-5d 1e-4    %.3e        %+.6f %+.6fi\n", N, d, lam.real(), lam.imag());
    if (N >= 64) {
      EXPECT_LT(d, previous * 1.01) << "N = " << N;  // no worse as N doubles
    }
    previous = d;
    if (N == 256) {
      EXPECT_LT(d, 2e-6);
    }
  }
  const auto mu_case = route1_multipliers(c, *model, ct, ref, 128, c.derivatives.relative_step);
  std::printf("128   %.0e    %.3e\n", c.derivatives.relative_step, max_difference(mu_case, mu2));
  EXPECT_LT(max_difference(mu_case, mu2), 1e-3);
}

// The averaged model is a good approximation when the wingbeat is fast compared with the body's
// motion and the wings are light (dronefly, 164 Hz), less so for the slow, heavy-winged hawkmoth
// (26 Hz): Wu & Sun 2012. Measured (quasi-steady model): the dronefly's longitudinal exponents lie
// within 1 % of |lambda| of the LTI eigenvalues; the hawkmoth's differ by several per cent, and its
// lateral divergence by tens of per cent.
double relative_gap(const FloquetSubsystem& f) {
  double gap = 0;
  for (std::size_t i = 0; i < f.lti->modes.size(); ++i) {
    const auto lf = f.phase_resolved.modes.modes.at(i).eigenvalue_nd, ll = f.lti->modes[i].eigenvalue_nd;
    gap = std::max(gap, std::abs(lf - ll) / std::abs(ll));
  }
  return gap;
}

TEST(FloquetHover, DroneflyCloseToAveragedHawkmothLess) {
  const Case d = insect_case("dronefly"), h = insect_case("hawkmoth");
  const FloquetStudy sd = floquet_study(d, *make_aero_model(d));
  const FloquetStudy sh = floquet_study(h, *make_aero_model(h));
  for (const FloquetStudy* s : {&sd, &sh})
    for (const FloquetSubsystem* f : {&s->longitudinal, &s->lateral}) {
      ASSERT_TRUE(f->lti.has_value());
      ASSERT_EQ(f->phase_resolved.modes.modes.size(), f->lti->modes.size());
      for (std::size_t i = 0; i < f->lti->modes.size(); ++i)  // same mode structure, same labels
        EXPECT_EQ(f->phase_resolved.modes.modes[i].label, f->lti->modes[i].label);
    }
  const double gd = relative_gap(sd.longitudinal), gh = relative_gap(sh.longitudinal);
  const double gdl = relative_gap(sd.lateral), ghl = relative_gap(sh.lateral);
  std::printf("relative gap Floquet vs LTI: dronefly lon %.4f lat %.4f; hawkmoth lon %.4f lat %.4f\n", gd, gdl, gh, ghl);
  EXPECT_LT(gd, 0.02);
  EXPECT_GT(gh, 2 * gd);
  EXPECT_GT(ghl, 2 * gdl);
}

TEST(FloquetHover, JsonCarriesTheRequiredKeys) {
  const Case c = insect_case("dronefly");
  const nlohmann::json j = floquet_json(c, floquet_study(c, *make_aero_model(c)));
  for (const char* k : {"multipliers", "exponents_nd", "exponents_per_s", "lti_eigenvalues_nd", "modes", "cyclic_trim",
                        "routes", "lateral", "conventions"})
    EXPECT_TRUE(j.contains(k)) << k;
  EXPECT_TRUE(j["cyclic_trim"]["converged"].get<bool>());
  EXPECT_LE(j["cyclic_trim"]["residual"].get<double>(), 1e-10);
  EXPECT_EQ(j["multipliers"].size(), 4u);
  EXPECT_EQ(j["multipliers"][0].size(), 2u);
  EXPECT_TRUE(j["routes"].contains("flow_sensitivity"));
}

// An asymmetric case is refused with an InputError naming the key, and no file is written.
TEST(FloquetHover, OneSidedParameterIsRefused) {
  std::string text = testing::valid_case_text();
  text += "\n[[trim.parameter]]\nname = \"pitch_amplitude_deg\"\nside = \"right\"\nlower = 20.0\nupper = 80.0\n";
  const std::string path = testing::write_temp("one_sided.toml", text);
  const std::string out = testing::write_temp("floquet_out.json", "");
  std::remove(out.c_str());
  CommandOptions o;
  o.case_path = path;
  o.json_path = out;
  o.quiet = true;
  try {
    run_floquet(o);
    ADD_FAILURE() << "expected an error";
  } catch (const InputError& e) {
    EXPECT_EQ(e.key(), "trim.parameter");
    EXPECT_NE(std::string(e.what()).find("symmetric"), std::string::npos) << e.what();
  } catch (const std::exception& e) {
    ADD_FAILURE() << "unexpected error: " << e.what();
  }
  EXPECT_FALSE(std::filesystem::exists(out));
}

}  // namespace
}  // namespace flapstab
