// The flapping hawkmoth of the step benchmarks (bench_immersed.cpp, bench_mpi_scaling.cpp): the default hawkmoth
// (body and two membrane wings, prescribed hover kinematics) at rest in a box at Re = 1000, fine spacing c_bar / 16
// over the swept volume plus half a chord, stretching 1.06 to 3 R beyond it on every side (4.3 M cells).
#pragma once
#include <array>
#include <memory>
#include <string>
#include "cfd/navier_stokes/immersed.hpp"
#include "core/case_file.hpp"
#include "core/configuration.hpp"

namespace flapstab::bench {

using namespace flapstab::ns;

struct FlappingCase {
  flapstab::Case c;
  std::unique_ptr<flapstab::Configuration> config;
  std::unique_ptr<InsectSurfaces> surfaces;
  std::unique_ptr<Solver> solver;
  std::unique_ptr<ImmersedBoundary> ib;
};

// The hawkmoth at rest in a box: fine spacing c_bar / 16 over the swept volume plus half a chord, stretching 1.06
// to 3 R beyond it on every side.
// Over MPI ranks (dec): the solver's slabs, the immersed boundary on its window.
inline std::unique_ptr<FlappingCase> hawkmoth(const PoissonOptions& poisson = SolverOptions{}.poisson,
                                              std::shared_ptr<const Decomposition> dec = {}) {
  auto f = std::make_unique<FlappingCase>();
  f->c = flapstab::load_case(std::string(FLAPSTAB_SOURCE_DIR) + "/data/insects/hawkmoth.toml");
  f->config = std::make_unique<flapstab::Configuration>(f->c.insect, f->c.kinematics);
  MeshResolution res;
  f->surfaces = std::make_unique<InsectSurfaces>(*f->config, res);
  const double R = f->c.insect.wing.length, cbar = f->c.insect.wing.mean_chord, T = f->c.kinematics.period();
  BoundingBox swept;
  for (int n = 0; n < 32; ++n)
    for (const auto& part : f->surfaces->at(T * n / 32)) {
      const BoundingBox b = part.mesh.bounding_box();
      swept.add(b.lo);
      swept.add(b.hi);
    }
  std::array<Axis, 3> axes{Axis::uniform(0, 1, 8, false), Axis::uniform(0, 1, 8, false), Axis::uniform(0, 1, 8, false)};
  for (int a = 0; a < 3; ++a) {
    StretchedAxis s;
    s.box_lo = swept.lo[a] - 0.5 * cbar;
    s.box_hi = swept.hi[a] + 0.5 * cbar;
    s.lo = s.box_lo - 3 * R;
    s.hi = s.box_hi + 3 * R;
    s.h = cbar / 16;
    s.max_ratio = 1.06;
    s.multiple_of = 16;
    axes[a] = Axis::stretched(s, false);
  }
  // Re = U c_bar / nu = 1000 with U the mean wingtip speed 2 Phi f R.
  const double U = 2 * f->c.kinematics.stroke_amplitude() * f->c.kinematics.frequency_hz * R;
  SolverOptions opt;
  opt.nu = U * cbar / 1000;
  opt.cfl = 0.8;
  opt.poisson = poisson;
  Boundaries bc = Boundaries::all(BC::velocity);
  bc.face[face(2, 0)].type = BC::outflow;  // the downwash leaves through the bottom
  f->solver = std::make_unique<Solver>(Grid(axes[0], axes[1], axes[2]), bc, opt, std::move(dec));
  f->solver->initialise([](double, double, double) { return Vec3::Zero(); });
  ImmersedOptions io;
  io.density = f->c.fluid.density;
  f->ib = std::make_unique<ImmersedBoundary>(f->solver->hook_grid(), io);
  for (int k = 0; k < 3; ++k) {
    const flapstab::Configuration* config = f->config.get();
    f->ib->add_part(f->surfaces->reference()[std::size_t(k)], [config, k](double t) {
      const PartPose p = insect_part_poses(*config, t)[std::size_t(k)];
      return PartState{p.pose, p.motion};
    });
  }
  f->ib->attach(*f->solver);
  return f;
}

}  // namespace flapstab::bench
