// Regions of the flow around the wings (regions.hpp).
#include "cfd/fpm/regions.hpp"

#include <algorithm>
#include <cmath>
#include <stdexcept>

namespace flapstab::fpm {

WingRegion wing_region(const std::string& name) {
  if (name == "leading-edge") return WingRegion::leading_edge;
  if (name == "trailing-edge") return WingRegion::trailing_edge;
  if (name == "tip") return WingRegion::tip;
  throw std::invalid_argument("unknown wing region \"" + name + "\" (leading-edge, trailing-edge, tip)");
}

const char* region_name(WingRegion r) {
  switch (r) {
    case WingRegion::leading_edge: return "leading-edge";
    case WingRegion::trailing_edge: return "trailing-edge";
    case WingRegion::tip: return "tip";
  }
  return "?";
}

namespace {

// The region of a point in one wing's frame, or -1 outside the wing's regions.
int region_of(const Wing& w, const Vec3& xi, double d, double x_fore, double x_aft) {
  const double R = w.length, x0 = w.pitch_axis;
  if (std::abs(xi.z()) > d || xi.y() < 0 || xi.y() > R + d) return -1;
  if (xi.y() > R) return xi.x() <= x_fore + d && xi.x() >= x_aft - d ? int(WingRegion::tip) : -1;
  const double c = w.chord(xi.y());
  const double le = x0 * c, te = -(1 - x0) * c, mid = 0.5 * (le + te);
  if (xi.x() > le + d || xi.x() < te - d) return -1;
  return xi.x() >= mid ? int(WingRegion::leading_edge) : int(WingRegion::trailing_edge);
}

}  // namespace

RegionSet label_regions(const Grid& g, const std::vector<RegionWing>& wings, const std::vector<WingRegion>& regions,
                        double d) {
  RegionSet out;
  out.names.push_back("wake");
  // label of (wing, region) or 0 where the region is not chosen
  std::vector<std::array<int, 3>> label(wings.size(), {0, 0, 0});
  for (std::size_t w = 0; w < wings.size(); ++w)
    for (WingRegion r : regions) {
      label[w][std::size_t(r)] = out.count();
      out.names.push_back(wings[w].name + "." + region_name(r));
    }
  // the chordwise extent of each planform (for the tip region)
  std::vector<std::pair<double, double>> extent;
  for (const auto& rw : wings) {
    double fore = 0, aft = 0;
    const Wing& w = *rw.wing;
    for (int i = 0; i <= 200; ++i) {
      const double c = w.chord(w.length * i / 200.0);
      fore = std::max(fore, w.pitch_axis * c);
      aft = std::min(aft, -(1 - w.pitch_axis) * c);
    }
    extent.emplace_back(fore, aft);
  }
  const Shape s = g.shape();
  out.labels.assign(s.cells(), 0);
#pragma omp parallel for schedule(static)
  for (int k = 1; k <= s.nz; ++k)
    for (int j = 1; j <= s.ny; ++j)
      for (int i = 1; i <= s.nx; ++i) {
        const Vec3 x(g.axis[0].xc[std::size_t(i)], g.axis[1].xc[std::size_t(j)], g.axis[2].xc[std::size_t(k)]);
        const std::size_t n = (std::size_t(k - 1) * s.ny + std::size_t(j - 1)) * s.nx + std::size_t(i - 1);
        for (std::size_t w = 0; w < wings.size(); ++w) {
          const int r = region_of(*wings[w].wing, wings[w].pose.apply_inverse(x), d, extent[w].first, extent[w].second);
          if (r >= 0 && label[w][std::size_t(r)] > 0) {
            out.labels[n] = label[w][std::size_t(r)];
            break;
          }
        }
      }
  return out;
}

}  // namespace flapstab::fpm
