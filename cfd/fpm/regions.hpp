// Named regions of the flow around each wing, for attributing the vortex-induced force in space ("the leading-edge
// region gives x % of the lift"). Defined in each wing's frame (core/insect.hpp: x along the chord towards the leading
// edge from the pitch axis, y along the span from the hinge, z normal to the planform), with d = the region size:
//   leading-edge   0 <= y <= R, |z| <= d, between the local mid-chord and d ahead of the leading edge
//   trailing-edge  0 <= y <= R, |z| <= d, between d behind the trailing edge and the local mid-chord
//   tip            R < y <= R + d, |z| <= d, between d behind the wing's aftmost and d ahead of its foremost chord point
//   wake           the rest of the flow (all cells outside the chosen wing regions)
// The regions of one wing do not overlap; a cell inside the regions of both wings (near the body at a dorsal
// reversal) belongs to the first wing listed (right before left). docs/theory/force-partitioning.md.
#pragma once
#include <string>
#include <vector>
#include "cfd/navier_stokes/geometry.hpp"
#include "cfd/navier_stokes/grid.hpp"
#include "core/insect.hpp"

namespace flapstab::fpm {

using ns::Grid;
using ns::Shape;

enum class WingRegion { leading_edge = 0, trailing_edge = 1, tip = 2 };

// The name of a region in case files and outputs: "leading-edge", "trailing-edge", "tip"; std::invalid_argument for
// another name.
WingRegion wing_region(const std::string& name);
const char* region_name(WingRegion r);

struct RegionSet {
  std::vector<std::string> names;  // label 0 is "wake"; then "<wing>.<region>" for each wing and chosen region
  std::vector<int> labels;         // per interior cell (x fastest): index into names
  int count() const { return int(names.size()); }
};

struct RegionWing {
  std::string name;                // "right", "left"
  const Wing* wing = nullptr;      // planform
  ns::RigidTransform pose;         // wing frame -> grid axes
};

// Labels the cell centres of `g` by the chosen regions (`regions`, in order) of each wing; d in metres.
RegionSet label_regions(const Grid& g, const std::vector<RegionWing>& wings, const std::vector<WingRegion>& regions,
                        double d);

}  // namespace flapstab::fpm
