// Figures for reports, drawn by gnuplot (Debian gnuplot-nox) as SVG text; absent gnuplot is reported, not fatal.
#pragma once
#include <optional>
#include <string>
#include <vector>

namespace flapstab {

bool gnuplot_available();

struct Series {
  std::string title;
  std::vector<double> x, y;
};

struct LinePlot {
  std::string title, xlabel, ylabel;
  std::vector<Series> series;
  bool points_only = false;     // scatter (eigenvalue maps) instead of lines
  bool zero_axes = false;       // draw the x = 0 and y = 0 axes
};

// Renders the plot as an SVG document; std::nullopt (and a reason in `why`) if gnuplot is missing or fails.
std::optional<std::string> render_svg(const LinePlot& plot, std::string& why);

struct BarGroup {                 // one group per mode; one bar per category (state)
  std::string title;
  std::vector<double> values;
};
struct BarPlot {
  std::string title, ylabel;
  std::vector<std::string> categories;
  std::vector<BarGroup> groups;
  double ymin = 0, ymax = 0;   // fixed y range when ymax > ymin, else [0, auto]
};
std::optional<std::string> render_svg(const BarPlot& plot, std::string& why);

// A colour map z(x_i, y_j) with lines and marked points over it (e.g. a stability map with its boundary).
struct MapPlot {
  std::string title, xlabel, ylabel, cblabel;
  std::vector<double> x, y;
  std::vector<std::vector<double>> z;  // z[i][j] at (x[i], y[j])
  double zlimit = 0;                   // colour range [-zlimit, zlimit] (diverging; 0: from the data)
  std::vector<Series> lines, points;
  std::vector<Series> dots;            // small black dots (e.g. refined boundary points)
};
std::optional<std::string> render_svg(const MapPlot& plot, std::string& why);

}  // namespace flapstab
