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
  std::string style = {};       // gnuplot "with" clause (e.g. "lines dt 2"); empty: the plot's default
  bool right_axis = false;      // against the y2 axis (LinePlot::y2label)
};

struct PlotLabel {              // a text beside a point, in data coordinates
  double x = 0, y = 0;
  std::string text;
  double angle_deg = 0;         // rotated about the point: > 0 rises to the right (above it), < 0 falls (below)
};

// Labels for points of which some lie on the x axis (real roots on the complex plane): those are rotated by
// +-50 deg, alternately above and below the axis in order of x, so that neighbours do not overwrite each other.
void stagger_axis_labels(std::vector<PlotLabel>& labels, double axis_tolerance);

struct LinePlot {
  std::string title, xlabel, ylabel;
  std::vector<Series> series;
  bool points_only = false;     // scatter (eigenvalue maps) instead of lines
  bool zero_axes = false;       // draw the x = 0 and y = 0 axes
  std::vector<PlotLabel> labels = {};
  bool equal_axes = false;      // one unit is as long on both axes (a circle stays round)
  std::string y2label = {};     // the right axis, for series with right_axis
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
