// gnuplot-drawn SVG figures: data and script go to a temporary directory, gnuplot writes the SVG.
#include "apps/plots.hpp"

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <fmt/format.h>
#include <fstream>
#include <sstream>
#include <unistd.h>

namespace flapstab {

namespace {
std::string quote(const std::string& s) {
  std::string o;
  for (char c : s) o += (c == '"' ? '\'' : c);
  return "\"" + o + "\"";
}

std::optional<std::string> run_gnuplot(const std::string& script, const std::vector<std::string>& data,
                                       std::string& why) {
  if (!gnuplot_available()) {
    why = "gnuplot not found (install Debian's gnuplot-nox for figures)";
    return std::nullopt;
  }
  namespace fs = std::filesystem;
  static int counter = 0;
  const fs::path dir = fs::temp_directory_path() / fmt::format("flapstab_plot_{}_{}", ::getpid(), counter++);
  fs::create_directories(dir);
  for (std::size_t i = 0; i < data.size(); ++i) std::ofstream(dir / fmt::format("d{}.dat", i)) << data[i];
  const fs::path svg = dir / "out.svg";
  std::ofstream(dir / "plot.gp") << "set terminal svg size 720,420 dynamic enhanced font 'sans,12' background rgb 'white'\n"
                                 << "set output " << quote(svg.string()) << "\ncd " << quote(dir.string()) << "\n"
                                 << script;
  const std::string cmd = "gnuplot " + quote((dir / "plot.gp").string()) + " > " + quote((dir / "log.txt").string()) + " 2>&1";
  const int rc = std::system(cmd.c_str());
  std::optional<std::string> out;
  if (rc == 0 && fs::exists(svg)) {
    std::ifstream in(svg);
    std::stringstream ss;
    ss << in.rdbuf();
    out = ss.str();
  } else {
    std::ifstream in(dir / "log.txt");
    std::stringstream ss;
    ss << in.rdbuf();
    why = "gnuplot failed: " + ss.str();
  }
  std::error_code ec;
  fs::remove_all(dir, ec);
  return out;
}
}  // namespace

bool gnuplot_available() {
  static const bool ok = std::system("command -v gnuplot > /dev/null 2>&1") == 0;
  return ok;
}

std::optional<std::string> render_svg(const LinePlot& p, std::string& why) {
  std::string script = fmt::format("set title {}\nset xlabel {}\nset ylabel {}\nset grid\nset key outside right\n",
                                   quote(p.title), quote(p.xlabel), quote(p.ylabel));
  if (p.zero_axes) script += "set xzeroaxis lt -1\nset yzeroaxis lt -1\nset offsets graph 0.1, graph 0.1, graph 0.1, graph 0.1\n";
  if (p.equal_axes) script += "set size ratio -1\n";
  if (!p.y2label.empty()) script += fmt::format("set y2label {}\nset y2tics\nset ytics nomirror\n", quote(p.y2label));
  for (std::size_t i = 0; i < p.labels.size(); ++i) {
    const PlotLabel& l = p.labels[i];
    script += fmt::format("set label {} {} at {:.10g},{:.10g} rotate by {:g} offset 0.6,{} noenhanced font ',9'\n", i + 1,
                          quote(l.text), l.x, l.y, l.angle_deg, l.angle_deg < 0 ? "-0.6" : "0.6");
  }
  std::vector<std::string> data;
  std::string plot = "plot ";
  for (std::size_t i = 0; i < p.series.size(); ++i) {
    const Series& s = p.series[i];
    std::string d;
    for (std::size_t k = 0; k < s.x.size(); ++k) d += fmt::format("{:.10g} {:.10g}\n", s.x[k], s.y[k]);
    data.push_back(d.empty() ? "nan nan\n" : d);
    const std::string style = !s.style.empty() ? s.style : p.points_only ? "points pt 7 ps 1.2" : "lines";
    plot += fmt::format("{}'d{}.dat' using 1:2{} with {} lw 2 title {}", i ? ", " : "", i,
                        s.right_axis ? " axes x1y2" : "", style, quote(s.title));
  }
  return run_gnuplot(script + plot + "\n", data, why);
}

void stagger_axis_labels(std::vector<PlotLabel>& labels, double tol) {
  std::vector<PlotLabel*> axis;
  for (auto& l : labels)
    if (std::abs(l.y) <= tol) axis.push_back(&l);
  std::stable_sort(axis.begin(), axis.end(), [](const PlotLabel* a, const PlotLabel* b) { return a->x < b->x; });
  for (std::size_t i = 0; i < axis.size(); ++i) axis[i]->angle_deg = i % 2 ? -50 : 50;
}

std::optional<std::string> render_svg(const BarPlot& p, std::string& why) {
  std::string d = "state";
  for (const auto& g : p.groups) {
    d += ' ';
    d += quote(g.title);
  }
  d += "\n";
  for (std::size_t c = 0; c < p.categories.size(); ++c) {
    d += quote(p.categories[c]);
    for (const auto& g : p.groups) d += fmt::format(" {:.10g}", c < g.values.size() ? g.values[c] : 0.0);
    d += "\n";
  }
  std::string script = fmt::format(
      "set title {}\nset ylabel {}\nset style data histograms\nset style histogram clustered gap 1\n"
      "set style fill solid 0.8 border -1\nset grid ytics\nset key outside right\n",
      quote(p.title), quote(p.ylabel));
  script += p.ymax > p.ymin ? fmt::format("set yrange [{}:{}]\nset ytics 45\nset xzeroaxis lt -1\n", p.ymin, p.ymax)
                            : std::string("set yrange [0:*]\n");
  std::string plot = "plot ";
  for (std::size_t i = 0; i < p.groups.size(); ++i)
    plot += fmt::format("{}'d0.dat' using {}:xtic(1) title columnheader", i ? ", " : "", i + 2);
  return run_gnuplot(script + plot + "\n", {d}, why);
}

namespace {
// Bilinear resampling of a map onto an n x n grid over the same ranges, so coarse maps do not draw as large
// pixels spilling half a cell over the axes.
MapPlot resampled(const MapPlot& p, std::size_t n) {
  MapPlot r = p;
  auto locate = [](const std::vector<double>& v, double t, std::size_t& i, double& f) {
    i = std::min<std::size_t>(std::upper_bound(v.begin(), v.end(), t) - v.begin(), v.size() - 1);
    i = i == 0 ? 0 : i - 1;
    f = v[i + 1] > v[i] ? std::clamp((t - v[i]) / (v[i + 1] - v[i]), 0.0, 1.0) : 0.0;
  };
  r.x.clear();
  r.y.clear();
  for (std::size_t k = 0; k < n; ++k) {
    r.x.push_back(p.x.front() + (p.x.back() - p.x.front()) * double(k) / double(n - 1));
    r.y.push_back(p.y.front() + (p.y.back() - p.y.front()) * double(k) / double(n - 1));
  }
  r.z.assign(n, std::vector<double>(n, 0.0));
  for (std::size_t a = 0; a < n; ++a)
    for (std::size_t b = 0; b < n; ++b) {
      std::size_t i, j;
      double fx, fy;
      locate(p.x, r.x[a], i, fx);
      locate(p.y, r.y[b], j, fy);
      r.z[a][b] = (1 - fx) * (1 - fy) * p.z[i][j] + fx * (1 - fy) * p.z[i + 1][j] + (1 - fx) * fy * p.z[i][j + 1] +
                  fx * fy * p.z[i + 1][j + 1];
    }
  return r;
}
}  // namespace

std::optional<std::string> render_svg(const MapPlot& given, std::string& why) {
  if (given.x.size() < 2 || given.y.size() < 2) {
    why = "a map needs at least two points on each axis";
    return std::nullopt;
  }
  const MapPlot p = given.x.size() < 100 || given.y.size() < 100 ? resampled(given, 100) : given;
  // gnuplot's nonuniform matrix: first row n, x_1..x_n; then y_j, z(x_1, y_j) .. z(x_n, y_j).
  std::string d = fmt::format("{}", p.x.size());
  for (double x : p.x) d += fmt::format(" {:.10g}", x);
  d += "\n";
  double zmax = p.zlimit;
  for (std::size_t j = 0; j < p.y.size(); ++j) {
    d += fmt::format("{:.10g}", p.y[j]);
    for (std::size_t i = 0; i < p.x.size(); ++i) {
      d += fmt::format(" {:.10g}", p.z[i][j]);
      if (p.zlimit <= 0 && std::isfinite(p.z[i][j])) zmax = std::max(zmax, std::abs(p.z[i][j]));
    }
    d += "\n";
  }
  if (!(zmax > 0)) zmax = 1;
  std::vector<std::string> data{d};
  std::string script = fmt::format(
      "set title {}\nset xlabel {}\nset ylabel {}\nset cblabel {}\nset key below\n"
      "set palette defined (-1 '#2166ac', 0 '#f7f7f7', 1 '#b2182b')\nset cbrange [{}:{}]\n"
      "set xrange [{}:{}]\nset yrange [{}:{}]\n",
      quote(p.title), quote(p.xlabel), quote(p.ylabel), quote(p.cblabel), -zmax, zmax, p.x.front(), p.x.back(),
      p.y.front(), p.y.back());
  std::string plot = "plot 'd0.dat' nonuniform matrix with image notitle";
  auto add = [&](const Series& s, const char* style) {
    std::string e;
    for (std::size_t k = 0; k < s.x.size(); ++k)
      if (std::isfinite(s.x[k]) && std::isfinite(s.y[k])) e += fmt::format("{:.10g} {:.10g}\n", s.x[k], s.y[k]);
    if (e.empty()) e = "nan nan\n";
    data.push_back(e);
    plot += fmt::format(", 'd{}.dat' using 1:2 with {} title {}", data.size() - 1, style, quote(s.title));
  };
  for (const auto& s : p.lines) add(s, "lines lw 2 lc rgb 'black'");
  for (const auto& s : p.dots) add(s, "points pt 7 ps 0.4 lc rgb 'black'");
  int pt = 7;
  for (const auto& s : p.points) {
    add(s, fmt::format("points pt {} ps 1.4", pt).c_str());
    pt += 2;
  }
  return run_gnuplot(script + plot + "\n", data, why);
}

}  // namespace flapstab
