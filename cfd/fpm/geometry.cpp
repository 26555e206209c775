// Cut-cell geometry of the fluid region (geometry.hpp).
#include "cfd/fpm/geometry.hpp"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <limits>
#include <stdexcept>
#include <string>
#include <unordered_map>

namespace flapstab::fpm {

namespace {

// A part's solid share of one face.
struct FaceSolid {
  int d;
  int I[3];  // face index (the lower face of cell I along d)
  int part;
  double fraction;
  Vec3 centroid;
};

// Lowest level over the parts at x: (value, part).
std::pair<double, int> lowest(const LevelFunction& level, int parts, const Vec3& x, double h) {
  double v = std::numeric_limits<double>::infinity();
  int who = -1;
  for (int p = 0; p < parts; ++p) {
    const double l = level(p, x, h);
    if (l < v) v = l, who = p;
  }
  return {v, who};
}

}  // namespace

std::vector<int> owners_of(const Grid& g, int parts, const LevelFunction& level) {
  const Shape s = g.shape();
  std::vector<int> o(s.cells(), -1);
  std::size_t m = 0;
  for (int k = 1; k <= s.nz; ++k)
    for (int j = 1; j <= s.ny; ++j)
      for (int i = 1; i <= s.nx; ++i, ++m) {
        const Vec3 x(g.axis[0].xc[std::size_t(i)], g.axis[1].xc[std::size_t(j)], g.axis[2].xc[std::size_t(k)]);
        const double h = std::max({g.axis[0].dc[std::size_t(i)], g.axis[1].dc[std::size_t(j)], g.axis[2].dc[std::size_t(k)]});
        const auto [v, who] = lowest(level, parts, x, h);
        if (v < 0) o[m] = who;
      }
  return o;
}

void copy_periodic_faces(Field& f, const Shape& s, int d) {
  const int n = s.n(d);
  for (int k = 1; k <= s.nz; ++k)
    for (int j = 1; j <= s.ny; ++j)
      for (int i = 1; i <= s.nx; ++i) {
        const int I[3] = {i, j, k};
        if (I[d] != 1) continue;
        int J[3] = {i, j, k};
        J[d] = n + 1;
        f(J[0], J[1], J[2]) = f(i, j, k);
      }
}

FluidGeometry fluid_geometry(const Grid& g, int parts, const LevelFunction& level, const std::vector<int>& owners,
                             int samples, FpmBody body, const std::vector<int>* seeds) {
  const Shape s = g.shape();
  if (owners.size() != s.cells())
    throw std::invalid_argument("force partitioning: cell owners of " + std::to_string(owners.size()) +
                                " cells for a grid of " + std::to_string(s.cells()));
  if (samples < 1) throw std::invalid_argument("force partitioning: face samples must be >= 1");
  if (seeds && seeds->size() != s.cells())
    throw std::invalid_argument("force partitioning: near cells of " + std::to_string(seeds->size()) +
                                " cells for a grid of " + std::to_string(s.cells()));
  const std::vector<int>& seed = seeds ? *seeds : owners;
  FluidGeometry G;
  G.shape = s;
  G.parts = parts;
  for (auto& a : G.aperture) a = Field(s);
  for (auto& f : G.forced) f.assign(s.size(), 0);
  G.volume_fraction = Field(s);
  auto flat = [&](int i, int j, int k) { return (std::size_t(k - 1) * s.ny + std::size_t(j - 1)) * s.nx + std::size_t(i - 1); };
  // the periodic image of an index along axis a (ghosts 0 and n+1), or -1 outside a walled axis
  auto image = [&](int a, int I) {
    const int n = s.n(a);
    if (I >= 1 && I <= n) return I;
    if (!g.axis[std::size_t(a)].periodic) return -1;
    return I < 1 ? I + n : I - n;
  };
  // cells within one cell of a seed cell (a solid cell, or one of `near`): the seeds dilated by one along x, then y,
  // then z (the 27 around)
  std::vector<char> near(s.cells(), 0);
  {
    std::vector<char> next(s.cells(), 0);
#pragma omp parallel for schedule(static) if (ns::threaded(s))
    for (std::ptrdiff_t m = 0; m < std::ptrdiff_t(s.cells()); ++m) near[std::size_t(m)] = seed[std::size_t(m)] >= 0;
    for (int a = 0; a < 3; ++a) {
#pragma omp parallel for schedule(static) if (ns::threaded(s))
      for (int k = 1; k <= s.nz; ++k)
        for (int j = 1; j <= s.ny; ++j)
          for (int i = 1; i <= s.nx; ++i) {
            int I[3] = {i, j, k};
            const int c = I[a];
            bool any = near[flat(i, j, k)];
            for (const int o : {-1, 1}) {
              I[a] = image(a, c + o);
              any = any || (I[a] > 0 && near[flat(I[0], I[1], I[2])]);
            }
            next[flat(i, j, k)] = any;
          }
      near.swap(next);
    }
  }
  std::vector<FaceSolid> solids;
  for (int d = 0; d < 3; ++d) {
    const ns::Axis& ad = g.axis[std::size_t(d)];
    const int e = (d + 1) % 3, f = (d + 2) % 3;
    const ns::Axis &ae = g.axis[std::size_t(e)], &af = g.axis[std::size_t(f)];
    Field& ap = G.aperture[std::size_t(d)];
    std::vector<char>& forced = G.forced[std::size_t(d)];
    // Planes in parallel; each keeps its solid shares, joined in plane order afterwards (the same list as serially).
    const int planes = s.nz + (d == 2);
    std::vector<std::vector<FaceSolid>> plane_solids(std::size_t(planes) + 1);
    std::vector<std::vector<FluidGeometry::Face>> plane_forced(std::size_t(planes) + 1);
    std::size_t sampled = 0;
#pragma omp parallel reduction(+ : sampled)
    {
      std::vector<int> count(std::size_t(parts), 0);
      std::vector<Vec3> sum(std::size_t(parts), Vec3::Zero());
#pragma omp for schedule(dynamic, 1)
      for (int k = 1; k <= planes; ++k) {
        std::vector<FaceSolid>& mine = plane_solids[std::size_t(k)];
        std::vector<FluidGeometry::Face>& mine_forced = plane_forced[std::size_t(k)];
        for (int j = 1; j <= s.ny + (d == 1); ++j)
          for (int i = 1; i <= s.nx + (d == 0); ++i) {
            const int I[3] = {i, j, k};
            if (I[e] > s.n(e) || I[f] > s.n(f)) continue;
            const int F = I[d];
            if (F == s.n(d) + 1 || (!ad.periodic && F == 1)) continue;  // the domain's faces (periodic: face 1 below)
            int L[3] = {i, j, k};
            L[d] = image(d, F - 1);
            const bool tested = near[flat(i, j, k)] || near[flat(L[0], L[1], L[2])];
            if (!tested) {
              ap(i, j, k) = 1;
              continue;
            }
            const double we = ae.dc[std::size_t(I[e])], wf = af.dc[std::size_t(I[f])];
            const double h = std::max({we, wf, ad.dc[std::size_t(F)], ad.dc[std::size_t(std::max(F - 1, 1))]});
            Vec3 centre;
            centre[d] = ad.xf[std::size_t(F)];
            centre[e] = ae.xc[std::size_t(I[e])];
            centre[f] = af.xc[std::size_t(I[f])];
            const double reach = 0.5 * std::hypot(we, wf);
            const auto [v, who] = lowest(level, parts, centre, h);
            const bool forced_face = v < h;  // the forcing's solid or band face
            if (forced_face) forced[std::size_t(s(i, j, k))] = 1;
            if (forced_face && body == FpmBody::forced_region) {  // closed whole; its surface piece at the centre
              ap(i, j, k) = 0;
              mine.push_back({d, {i, j, k}, who, 1.0, centre});
              continue;
            }
            if (v > reach) {
              ap(i, j, k) = 1;
              if (forced_face) mine_forced.push_back({d, {i, j, k}});
              continue;
            }
            if (v < -reach) {
              mine.push_back({d, {i, j, k}, who, 1.0, centre});
              continue;
            }
            ++sampled;
            std::fill(count.begin(), count.end(), 0);
            std::fill(sum.begin(), sum.end(), Vec3::Zero());
            int fluid = 0;
            for (int b = 0; b < samples; ++b)
              for (int a = 0; a < samples; ++a) {
                Vec3 x = centre;
                x[e] += ((a + 0.5) / samples - 0.5) * we;
                x[f] += ((b + 0.5) / samples - 0.5) * wf;
                const auto [lv, lp] = lowest(level, parts, x, h);
                if (lv < 0) {
                  ++count[std::size_t(lp)];
                  sum[std::size_t(lp)] += x;
                } else {
                  ++fluid;
                }
              }
            const double n2 = double(samples) * samples;
            ap(i, j, k) = fluid / n2;
            if (forced_face && fluid > 0) mine_forced.push_back({d, {i, j, k}});
            for (int p = 0; p < parts; ++p)
              if (count[std::size_t(p)] > 0)
                mine.push_back({d, {i, j, k}, p, count[std::size_t(p)] / n2, sum[std::size_t(p)] / count[std::size_t(p)]});
          }
      }
    }
    G.sampled_faces += sampled;
    for (const auto& v : plane_solids) solids.insert(solids.end(), v.begin(), v.end());
    for (const auto& v : plane_forced) G.forced_open.insert(G.forced_open.end(), v.begin(), v.end());
    if (ad.periodic) {
      copy_periodic_faces(ap, s, d);
      for (int k = 1; k <= s.nz; ++k)
        for (int j = 1; j <= s.ny; ++j)
          for (int i = 1; i <= s.nx; ++i) {
            int J[3] = {i, j, k};
            if (J[d] != 1) continue;
            J[d] = s.n(d) + 1;
            forced[std::size_t(s(J[0], J[1], J[2]))] = forced[std::size_t(s(i, j, k))];
          }
    }
  }
  // fluid volume fraction: the mean aperture of the cell's faces inside the domain
#pragma omp parallel for schedule(static) if (ns::threaded(s))
  for (int k = 1; k <= s.nz; ++k)
    for (int j = 1; j <= s.ny; ++j)
      for (int i = 1; i <= s.nx; ++i) {
        double sum = 0;
        int n = 0;
        const int I[3] = {i, j, k};
        for (int d = 0; d < 3; ++d) {
          const bool per = g.axis[std::size_t(d)].periodic;
          int U[3] = {i, j, k};
          ++U[d];
          if (per || I[d] > 1) sum += G.aperture[std::size_t(d)](i, j, k), ++n;
          if (per || I[d] < s.n(d)) sum += G.aperture[std::size_t(d)](U[0], U[1], U[2]), ++n;
        }
        // a cell whose faces are all on the domain's boundary keeps its centre's status
        G.volume_fraction(i, j, k) = n > 0 ? sum / n : (owners[flat(i, j, k)] < 0 ? 1.0 : 0.0);
      }
  // Pockets: fluid cells cut off from the domain's faces by the parts (a wing root against the body). A Neumann
  // problem there has a solution only if the part's fluxes into the pocket cancel, which they need not on a grid, so
  // the pockets are taken out of the fluid (no potential, no surface pieces: their area is counted in pocket_cells).
  // Kept: every component of open cells that reaches a non-periodic domain face (the largest one in a fully periodic
  // box).
  {
    const std::size_t cells = std::size_t(s.nx) * s.ny * s.nz;
    const std::ptrdiff_t stride[3] = {1, s.nx, std::ptrdiff_t(s.nx) * s.ny};
    // Per cell: bit 2 d + side, the face towards the neighbour along d (side 0 below) is open and the neighbour is
    // active; bit 8 + 2 d + side, that neighbour is a periodic image (across the domain); bit 6, the cell lies on a
    // non-periodic domain face.
    std::vector<std::uint16_t> link(cells, 0);
#pragma omp parallel for schedule(static) if (ns::threaded(s))
    for (int k = 1; k <= s.nz; ++k)
      for (int j = 1; j <= s.ny; ++j)
        for (int i = 1; i <= s.nx; ++i) {
          const std::ptrdiff_t n = s(i, j, k);
          if (!G.active(n)) continue;
          const int I[3] = {i, j, k};
          std::uint16_t m = 0;
          for (int d = 0; d < 3; ++d) {
            const bool per = g.axis[std::size_t(d)].periodic;
            const int nd = s.n(d);
            const std::ptrdiff_t st = s.stride(d);
            const Field& ap = G.aperture[std::size_t(d)];
            if (!per && (I[d] == 1 || I[d] == nd)) m |= 1u << 6;
            // below: face I[d] (face 1 of a periodic axis leads to cell nd); above: face I[d] + 1 (face nd + 1, the
            // periodic copy of face 1, leads to cell 1)
            if (I[d] > 1 || per) {
              const bool wraps = I[d] == 1;
              if (ap[n] > 0 && G.active(wraps ? n + (nd - 1) * st : n - st))
                m |= std::uint16_t((1u << (2 * d)) | (wraps ? 1u << (8 + 2 * d) : 0u));
            }
            if (I[d] < nd || per) {
              const bool wraps = I[d] == nd;
              if (ap[n + st] > 0 && G.active(wraps ? n - (nd - 1) * st : n + st))
                m |= std::uint16_t((1u << (2 * d + 1)) | (wraps ? 1u << (8 + 2 * d + 1) : 0u));
            }
          }
          link[flat(i, j, k)] = m;
        }
    // connected components of the active cells through the open faces
    std::vector<int> comp(cells, -1);
    std::vector<std::size_t> size;
    std::vector<char> outer;
    std::vector<std::ptrdiff_t> stack;
    for (int k = 1; k <= s.nz; ++k)
      for (int j = 1; j <= s.ny; ++j)
        for (int i = 1; i <= s.nx; ++i) {
          const std::size_t start = flat(i, j, k);
          if (!G.active(s(i, j, k)) || comp[start] >= 0) continue;
          const int c = int(size.size());
          size.push_back(0);
          outer.push_back(0);
          comp[start] = c;
          stack.push_back(std::ptrdiff_t(start));
          while (!stack.empty()) {
            const std::ptrdiff_t n = stack.back();
            stack.pop_back();
            ++size[std::size_t(c)];
            const std::uint16_t m = link[std::size_t(n)];
            if (m & (1u << 6)) outer[std::size_t(c)] = 1;
            for (int d = 0; d < 3; ++d)
              for (int side = 0; side < 2; ++side) {
                const int bit = 2 * d + side;
                if (!(m & (1u << bit))) continue;
                const std::ptrdiff_t step = side == 0 ? -stride[d] : stride[d];
                const std::ptrdiff_t nb = (m & (1u << (8 + bit))) ? n - step * (s.n(d) - 1) : n + step;
                if (comp[std::size_t(nb)] >= 0) continue;
                comp[std::size_t(nb)] = c;
                stack.push_back(nb);
              }
          }
        }
    auto idx = [&](int i, int j, int k) { return flat(i, j, k); };
    bool any_outer = false;
    for (char o : outer) any_outer = any_outer || o;
    if (!any_outer && !size.empty()) {
      std::size_t largest = 0;
      for (std::size_t c = 1; c < size.size(); ++c)
        if (size[c] > size[largest]) largest = c;
      outer[largest] = 1;
    }
    for (int k = 1; k <= s.nz; ++k)
      for (int j = 1; j <= s.ny; ++j)
        for (int i = 1; i <= s.nx; ++i) {
          const int c = comp[idx(i, j, k)];
          if (c < 0 || outer[std::size_t(c)]) continue;
          ++G.pocket_cells;
          G.volume_fraction(i, j, k) = 0;
          for (int d = 0; d < 3; ++d) {
            int U[3] = {i, j, k};
            ++U[d];
            G.aperture[std::size_t(d)](i, j, k) = 0;
            G.aperture[std::size_t(d)](U[0], U[1], U[2]) = 0;
          }
        }
    for (int d = 0; d < 3; ++d)
      if (g.axis[std::size_t(d)].periodic) copy_periodic_faces(G.aperture[std::size_t(d)], s, d);
  }
  // the surface pieces: each solid share closes the part's solid in the cells on both sides of the face
  std::unordered_map<std::size_t, std::size_t> index;  // (cell * parts + part) -> cuts
  std::vector<double> weight;
  auto add = [&](std::ptrdiff_t cell, int part, const Vec3& area, const Vec3& moment, const Vec3& x, double w) {
    if (!G.active(cell)) return;
    const std::size_t key = std::size_t(cell) * std::size_t(parts) + std::size_t(part);
    auto it = index.find(key);
    if (it == index.end()) {
      it = index.emplace(key, G.cuts.size()).first;
      G.cuts.push_back({cell, part});
      weight.push_back(0);
    }
    auto& c = G.cuts[it->second];
    c.area += area;
    c.moment += moment;
    c.centroid += w * x;
    weight[it->second] += w;
  };
  for (const FaceSolid& fs : solids) {
    const int d = fs.d, e = (d + 1) % 3, f = (d + 2) % 3;
    const double A = g.axis[std::size_t(e)].dc[std::size_t(fs.I[e])] * g.axis[std::size_t(f)].dc[std::size_t(fs.I[f])];
    Vec3 ed = Vec3::Zero();
    ed[d] = 1;
    const double sA = fs.fraction * A;
    // upper cell (this is its lower face, outward normal -e_d): area -= sA (-e_d)
    add(s(fs.I[0], fs.I[1], fs.I[2]), fs.part, sA * ed, sA * fs.centroid.cross(ed), fs.centroid, sA);
    int L[3] = {fs.I[0], fs.I[1], fs.I[2]};
    L[d] = image(d, L[d] - 1);
    if (L[d] > 0) add(s(L[0], L[1], L[2]), fs.part, -sA * ed, -sA * fs.centroid.cross(ed), fs.centroid, sA);
  }
  for (std::size_t c = 0; c < G.cuts.size(); ++c)
    if (weight[c] > 0) G.cuts[c].centroid /= weight[c];
  return G;
}

}  // namespace flapstab::fpm
