// flapstab grid-convergence (grid_convergence_command.hpp).
#include "apps/grid_convergence_command.hpp"

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <fmt/format.h>
#include <nlohmann/json.hpp>

#include "core/atomic_write.hpp"
#include "core/errors.hpp"
#include "core/derivative_table.hpp"
#include "core/grid_convergence.hpp"

namespace flapstab {

namespace fs = std::filesystem;
using nlohmann::json;

namespace {

struct Input {
  std::string path;
  json j;
  double h = 0, cells_per_chord = 0, reynolds = 0;
  std::string insect;
};

// A result file, or the first of derivatives.json, results.json, stability.json in a directory.
Input read_input(const std::string& given) {
  Input in;
  in.path = given;
  if (fs::is_directory(given)) {
    in.path.clear();
    for (const char* name : {"derivatives.json", "results.json", "stability.json"})
      if (fs::exists(fs::path(given) / name)) {
        in.path = (fs::path(given) / name).string();
        break;
      }
    if (in.path.empty())
      throw InputError(given, "", "holds none of derivatives.json, results.json, stability.json",
                       "the output directory of flapstab derivatives, stability or analyze");
  }
  std::ifstream f(in.path);
  if (!f) throw InputError(in.path, "", "cannot be read", "a readable JSON file");
  try {
    in.j = json::parse(f);
  } catch (const std::exception& e) {
    throw InputError(in.path, "", std::string("is not valid JSON: ") + e.what(), "a flapstab result file");
  }
  if (!in.j.contains("cfd") || !in.j["cfd"].contains("grid"))
    throw InputError(in.path, "cfd", "missing: not the result of a CFD stability study",
                     "a result of flapstab derivatives / stability / analyze with [aero] model = \"cfd\"");
  if (!in.j.contains("derivatives") || !in.j["derivatives"].contains("nondimensional"))
    throw InputError(in.path, "derivatives", "missing", "a derivative table (derivatives.nondimensional)");
  const json& g = in.j["cfd"]["grid"];
  try {
    in.h = g.at("fine_spacing_m").get<double>();
    in.cells_per_chord = g.at("cells_per_mean_chord").get<double>();
    in.reynolds = g.at("reynolds").get<double>();
    in.insect = in.j.value("insect", std::string());
  } catch (const std::exception& e) {
    throw InputError(in.path, "cfd.grid", std::string("incomplete: ") + e.what(),
                     "fine_spacing_m, cells_per_mean_chord and reynolds");
  }
  if (!(in.h > 0)) throw InputError(in.path, "cfd.grid.fine_spacing_m", "not positive", "a grid spacing in m");
  return in;
}

bool plane(const Input& in, const char* name) {
  const json& d = in.j["derivatives"];
  // Tables written before the planes were recorded hold both.
  return !d.contains("planes") || d["planes"].value(name, false);
}

double rel_diff(double a, double b) { return std::abs(a - b) / std::max(std::abs(a), std::abs(b)); }

}  // namespace

int run_grid_convergence(const GridConvergenceOptions& o) {
  if (o.inputs.size() < 2 || o.inputs.size() > 3)
    throw InputError("", "inputs", fmt::format("{} results given", o.inputs.size()),
                     "two or three results of the same case on different grids");
  if (!(o.order > 0 && o.order <= 4))
    throw InputError("", "--order", fmt::format("{:g} is out of range", o.order), "an order in (0, 4]");
  std::vector<Input> in;
  for (const auto& p : o.inputs) in.push_back(read_input(p));
  std::sort(in.begin(), in.end(), [](const Input& a, const Input& b) { return a.h < b.h; });
  // The same flow on every grid: the insect, the reference quantities and the Reynolds number.
  const json& ref0 = in[0].j["derivatives"]["reference"];
  for (std::size_t k = 1; k < in.size(); ++k) {
    const json& ref = in[k].j["derivatives"]["reference"];
    if (in[k].insect != in[0].insect)
      throw InputError(in[k].path, "insect", fmt::format("\"{}\", but {} has \"{}\"", in[k].insect, in[0].path,
                                                         in[0].insect), "results of the same case");
    // The geometry and the fluid must agree; U and the frequency may differ where each grid has its own CFD trim
    // (the derivatives at each grid's trimmed hover are then what converges).
    for (const char* key : {"c_m", "S_t_m2", "rho_kg_m3"})
      if (rel_diff(ref.at(key).get<double>(), ref0.at(key).get<double>()) > 1e-9)
        throw InputError(in[k].path, std::string("derivatives.reference.") + key,
                         fmt::format("{:.8g}, but {:.8g} in {}", ref.at(key).get<double>(), ref0.at(key).get<double>(),
                                     in[0].path),
                         "results of the same insect in the same fluid");
    if (rel_diff(in[k].reynolds, in[0].reynolds) > 1e-9)
      throw InputError(in[k].path, "cfd.grid.reynolds", fmt::format("{:g}, but {:g} in {}", in[k].reynolds,
                                                                    in[0].reynolds, in[0].path),
                       "the same Reynolds number on every grid");
    if (rel_diff(in[k].h, in[k - 1].h) < 1e-6)
      throw InputError(in[k].path, "cfd.grid.fine_spacing_m",
                       fmt::format("the same spacing as {} ({:g} m)", in[k - 1].path, in[k].h), "different grids");
  }
  const bool lon = std::all_of(in.begin(), in.end(), [](const Input& x) { return plane(x, "longitudinal"); });
  const bool lat = std::all_of(in.begin(), in.end(), [](const Input& x) { return plane(x, "lateral"); });
  if (!lon && !lat)
    throw InputError(in[0].path, "derivatives.planes", "the results share no plane of the table",
                     "the same [derivatives] columns on every grid");

  json table = json::array();
  std::string md = fmt::format(
      "# Grid convergence of the CFD derivative table: {}\n\nGrids (finest first):\n\n| result | cells per mean chord | "
      "fine spacing (m) |\n|---|---|---|\n",
      in[0].insect);
  for (const auto& x : in) md += fmt::format("| {} | {:.2f} | {:.4g} |\n", x.path, x.cells_per_chord, x.h);
  md += fmt::format(
      "\nPer derivative (non-dimensional): the value on each grid, finest first; the Richardson-extrapolated value; the "
      "order ({}); the fine-grid GCI (Celik et al. 2008, J Fluids Eng 130:078001; two grids: Roache 1994, safety factor "
      "3 and order {:g} assumed); and the finest grid's statistical standard error from its runs. \"scatter\" marks a "
      "grid-to-grid change within twice the runs' combined standard errors: there the grid error is not resolved by "
      "the runs.\n\n| derivative | values | extrapolated | order | GCI | standard error | note |\n|---|---|---|---|---|---|---|\n",
      in.size() == 3 ? "apparent, from the three grids" : "assumed", o.order);
  std::vector<std::string> names;
  if (lon) names = longitudinal_derivative_names();
  if (lat) names.insert(names.end(), lateral_derivative_names().begin(), lateral_derivative_names().end());
  for (const std::string& name : names) {
    std::vector<GridValue> v;
    std::vector<double> se;
    for (const auto& x : in) {
      const json& d = x.j["derivatives"];
      const json& value = d["nondimensional"].value(name, json());
      if (!value.is_number())
        throw InputError(x.path, "derivatives.nondimensional." + name, "missing or not a number",
                         "the derivative on every grid");
      v.push_back({x.h, value.get<double>()});
      const json& s = d.value("standard_error_nondimensional", json::object());
      se.push_back(s.contains(name) ? s.at(name).get<double>() : -1.0);
    }
    const GridConvergence g = grid_convergence(v, o.order);
    const bool have_se = se[0] >= 0 && se[1] >= 0;
    const bool scatter = have_se && std::abs(v[0].value - v[1].value) <= 2 * std::hypot(se[0], se[1]);
    json vals = json::array();
    for (const auto& x : v) vals.push_back(x.value);
    table.push_back({{"derivative", name},
                     {"values_finest_first", vals},
                     {"extrapolated", g.extrapolated},
                     {"convergence", to_string(g.kind)},
                     {"order", g.order},
                     {"order_assumed", g.order_assumed},
                     {"relative_change_fine", g.relative_error},
                     {"gci_fine", g.gci_fine},
                     {"gci_fine_absolute", g.gci_fine * std::abs(g.finest)},
                     {"standard_error_finest", se[0] >= 0 ? json(se[0]) : json(nullptr)},
                     {"within_run_scatter", scatter},
                     {"note", g.note}});
    std::string values;
    for (const auto& x : v) values += fmt::format("{}{:+.4f}", values.empty() ? "" : ", ", x.value);
    md += fmt::format("| {} | {} | {:+.4f} | {:.2f}{} ({}) | {:.1f} % (± {:.4f}) | {} | {}{} |\n", name, values,
                      g.extrapolated, g.order, g.order_assumed ? " assumed" : "", to_string(g.kind),
                      100 * g.gci_fine, g.gci_fine * std::abs(g.finest),
                      se[0] >= 0 ? fmt::format("{:.4f}", se[0]) : std::string("-"), scatter ? "scatter" : "",
                      g.note.empty() ? "" : (scatter ? "; " : "") + g.note);
  }
  json j = {{"program", "flapstab"},
            {"command", "grid-convergence"},
            {"insect", in[0].insect},
            {"method", in.size() == 3 ? "Celik et al. 2008 (J Fluids Eng 130:078001): apparent order, Richardson "
                                        "extrapolation, GCI with safety factor 1.25"
                                      : "Roache 1994 (J Fluids Eng 116:405): two-grid GCI, safety factor 3, assumed order"},
            {"assumed_order", o.order},
            {"grids", json::array()},
            {"derivatives", table}};
  for (const auto& x : in)
    j["grids"].push_back({{"result", x.path}, {"cells_per_mean_chord", x.cells_per_chord}, {"fine_spacing_m", x.h},
                          {"reynolds", x.reynolds}});
  const std::string text = j.dump(2) + "\n";
  std::vector<std::pair<std::string, std::string>> out;
  if (!o.json_path.empty()) out.emplace_back(o.json_path, text);
  if (!o.output_dir.empty()) {
    out.emplace_back(o.output_dir + "/grid_convergence.json", text);
    out.emplace_back(o.output_dir + "/grid_convergence.md", md);
  }
  write_files_atomic(out);
  if (!o.quiet) fmt::print("{}", md);
  return 0;
}

}  // namespace flapstab
