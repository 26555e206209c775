// flapstab subcommands: trim-hover and derivatives.
#include "apps/commands.hpp"

#include <chrono>
#include <fmt/format.h>

#include "apps/results_json.hpp"
#include "cfd/aero_factory.hpp"
#include "cfd/derivatives.hpp"
#include "core/atomic_write.hpp"
#include "core/errors.hpp"
#include "trim/trim.hpp"

namespace flapstab {

namespace {

double seconds_since(std::chrono::steady_clock::time_point t0) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
}

TrimResult trimmed(const Case& c, const AeroModel& model) {
  TrimResult t = trim_hover(c, model);
  if (!t.converged)
    throw SolveError(fmt::format(
        "{}: trim did not converge ({}); residuals: force {:.3e} of weight, moment {:.3e} of weight x wing "
        "length (tolerance {:.1e}). Widen the [[trim.parameter]] bounds or choose other parameters.",
        c.path, t.message, t.relative_force_residual, t.relative_moment_residual, c.trim.tolerance));
  return t;
}

void print_trim(const Case& c, const TrimResult& t, double seconds) {
  fmt::print("{}: hover trim of '{}' with {} ({}), {:.3f} s, {} iterations, {} model runs\n", c.path, c.insect.name,
             t.solver, t.objective, seconds, t.iterations, t.model_runs);
  for (const auto& p : t.parameters)
    fmt::print("  {:<24} {:>12.6f} {:<3}  (initial {:.6g}, bounds [{:g}, {:g}])\n", p.label, p.value, p.unit, p.initial,
               p.lower, p.upper);
  fmt::print("  residual: force {:.2e} x weight, moment {:.2e} x weight x R; mean aerodynamic power {:.4g} W\n",
             t.relative_force_residual, t.relative_moment_residual, t.mean_power);
}

}  // namespace

int run_trim_hover(const CommandOptions& o) {
  const auto t0 = std::chrono::steady_clock::now();
  const Case c = load_case(o.case_path);
  const auto model = make_aero_model(c);
  const TrimResult t = trimmed(c, *model);
  const double secs = seconds_since(t0);
  nlohmann::json j = metadata_json(c, "trim-hover");
  j["trim"] = trim_json(t);
  j["wall_time_s"] = secs;
  const std::string text = j.dump(2) + "\n";
  if (!o.json_path.empty()) write_file_atomic(o.json_path, text);
  if (!o.output_dir.empty()) write_file_atomic(o.output_dir + "/trim.json", text);
  if (!o.quiet) print_trim(c, t, secs);
  return 0;
}

int run_derivatives(const CommandOptions& o) {
  const auto t0 = std::chrono::steady_clock::now();
  const Case c = load_case(o.case_path);
  const auto model = make_aero_model(c);
  const TrimResult t = trimmed(c, *model);
  const DerivativeResult d =
      cycle_averaged_derivatives(*model, c.insect, t.kinematics, c.fluid, c.derivatives.relative_step);
  const double secs = seconds_since(t0);
  nlohmann::json j = metadata_json(c, "derivatives");
  j["trim"] = trim_json(t);
  j["derivatives"] = derivatives_json(d);
  j["wall_time_s"] = secs;
  const std::string text = j.dump(2) + "\n";
  DerivativeTable table = d.table;
  table.source = c.path + " (" + d.table.source + ")";
  const std::string toml = derivative_table_toml(table);
  if (!o.json_path.empty()) write_file_atomic(o.json_path, text);
  if (!o.output_dir.empty()) {
    write_file_atomic(o.output_dir + "/derivatives.json", text);
    write_file_atomic(o.output_dir + "/derivatives.toml", toml);
  }
  if (!o.quiet) {
    print_trim(c, t, secs);
    fmt::print("cycle-averaged derivatives (non-dimensional, hover stability axes; rows X Y Z L M N, "
               "columns u v w p q r):\n");
    for (int i = 0; i < 6; ++i) {
      fmt::print("  {}", "XYZLMN"[i]);
      for (int k = 0; k < 6; ++k) fmt::print(" {:>11.4e}", d.table.nd(i, k));
      fmt::print("\n");
    }
  }
  return 0;
}

}  // namespace flapstab
