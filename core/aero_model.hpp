// The AeroModel seam: prescribed body motion in, per-part wrench history out (quasi-steady or CFD).
#pragma once
#include <memory>
#include <string>
#include <vector>
#include "core/insect.hpp"
#include "core/kinematics.hpp"

namespace flapstab {

// Body velocity and angular velocity in stability axes (m/s, rad/s), relative to still air.
// For `run` it is a steady motion added to the hover state (u, v, w, p, q, r of the literature).
struct BodyMotion {
  Vec3 velocity = Vec3::Zero();  // u, v, w
  Vec3 rate = Vec3::Zero();      // p, q, r
};

// Aerodynamic loads at one instant, per part, about the reference point O in stability axes.
struct WrenchSample {
  double time = 0;      // s
  Wrench body, right, left;
  double power = 0;     // W: aerodynamic power, the rate at which the wings do work on the air
                        // (loads times wing velocities relative to the body)
  Wrench total() const { return body + right + left; }
};

struct WrenchHistory {
  std::vector<WrenchSample> samples;  // equally spaced over the last cycle, periodic (no duplicate end point)
  // Cycle mean of the total wrench (trapezoid rule on the periodic samples).
  Wrench mean() const;
  WrenchSample mean_sample() const;
  double mean_power() const;
};

struct AeroRunOptions {
  int cycles = 1;               // cycles run; the last is returned (1 suffices for the quasi-steady model)
  int samples_per_cycle = 0;    // 0: the model's own default
  // A model whose runs are shared between processes (the CFD model's run cache): a run another process is computing
  // throws RunHeldElsewhere (core/errors.hpp) instead of waiting for it. Other models ignore it.
  bool defer_held = false;
};

class AeroModel {
 public:
  virtual ~AeroModel() = default;
  virtual std::string name() const = 0;
  // Loads over the last of N cycles for the insect flying with `kin` and a steady body motion.
  virtual WrenchHistory run(const Insect& insect, const Kinematics& kin, const BodyMotion& motion,
                            const AeroRunOptions& options) const = 0;
  // True if the model's loads depend only on the instantaneous state (quasi-steady models):
  // then `instantaneous` is available for Floquet analysis and free flight.
  virtual bool is_instantaneous() const { return false; }
  // Loads at time t for the given instantaneous body velocity and rates.
  virtual WrenchSample instantaneous(const Insect& insect, const Kinematics& kin, double t,
                                     const BodyMotion& motion) const;
};

}  // namespace flapstab
