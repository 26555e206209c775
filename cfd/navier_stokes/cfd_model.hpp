// The AeroModel over the CFD driver (trim, derivatives and analyze with [aero] model = "cfd").
#pragma once
#include <atomic>
#include <iostream>
#include <string>
#include "core/aero_model.hpp"
#include "core/case_file.hpp"

namespace flapstab::ns {

// Runs options.cycles wingbeats in memory and returns the last one. Every run is a whole CFD run (minutes): trim
// and derivatives call it tens of times, so each run announces itself and its wall time on `log` (std::cerr by
// default; nullptr: silent).
class CfdModel final : public AeroModel {
 public:
  explicit CfdModel(Case c, std::ostream* log = &std::cerr) : case_(std::move(c)), log_(log) {}
  std::string name() const override { return "navier-stokes-ib"; }
  WrenchHistory run(const Insect& insect, const Kinematics& kin, const BodyMotion& motion,
                    const AeroRunOptions& options) const override;

 private:
  Case case_;
  std::ostream* log_;
  mutable std::atomic<int> runs_{0};
};

}  // namespace flapstab::ns
