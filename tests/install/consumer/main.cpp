// Uses three layers of the installed flapstab: loads the shipped hawkmoth case (core), trims its hover with the
// quasi-steady model (cfd, trim: Ipopt) and integrates a monodromy matrix (stability: CVODE). Exit 0 when all agree.
#include <cmath>
#include <cstdio>
#include <string>

#include "cfd/aero_factory.hpp"
#include "core/case_file.hpp"
#include "stability/floquet.hpp"
#include "trim/trim.hpp"

int main() {
  int failures = 0;
  auto check = [&](bool ok, const char* what) {
    std::printf("%s: %s\n", ok ? "ok" : "FAILED", what);
    if (!ok) ++failures;
  };

  const flapstab::Case c = flapstab::load_case(std::string(FLAPSTAB_SHARE_DIR) + "/insects/hawkmoth.toml");
  const double m = c.insect.total_mass();
  std::printf("hawkmoth total mass %.6g kg\n", m);
  check(std::abs(m - 1.648e-3) < 1e-9, "the installed hawkmoth case loads (total mass 1.648 g)");

  const auto model = flapstab::make_aero_model(c);
  const flapstab::TrimResult t = flapstab::trim_hover(c, *model);
  std::printf("trim: %s, relative force residual %.3g\n", t.converged ? "converged" : "not converged",
              t.relative_force_residual);
  check(t.converged && t.relative_force_residual < 1e-6, "the quasi-steady hover trims");

  // Phi' = -Phi on [0, 1]: Phi(1) = exp(-1).
  const auto r = flapstab::monodromy([](double) { return Eigen::MatrixXd::Constant(1, 1, -1.0); }, 1, 1.0);
  std::printf("monodromy %.12f (exp(-1) = %.12f)\n", r.monodromy(0, 0), std::exp(-1.0));
  check(std::abs(r.monodromy(0, 0) - std::exp(-1.0)) < 1e-8, "CVODE integrates the monodromy");
  return failures == 0 ? 0 : 1;
}
