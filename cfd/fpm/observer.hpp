// Force partitioning during a CFD run ([aero.cfd.fpm], docs/case-file.md): at `samples_per_cycle` phases of every
// wingbeat the influence potentials of the chosen parts and load components are solved for the parts' current
// positions (warm-started from the previous sample) and the run's loads are split into their kinematic (added mass
// and centripetal acceleration reaction), vortex-induced (by region of the flow), viscous and outer-boundary parts
// (partition.hpp; docs/theory/force-partitioning.md).
//
// Files (docs/cfd-files.md): fpm.csv (one row per sample, part and component), the potentials and the vortex-induced
// force densities as fields/fpm_STEP.h5 + fields/fpm.xmf (fields_per_cycle), and the wingbeat means in run.json.
#pragma once
#include <chrono>
#include <optional>
#include <string>
#include <vector>
#include <nlohmann/json_fwd.hpp>
#include "cfd/fpm/partition.hpp"
#include "cfd/fpm/regions.hpp"
#include "cfd/navier_stokes/observers.hpp"
#include "core/case_file.hpp"

namespace flapstab::fpm {

// Load components by name: "Fx" "Fy" "Fz" "Mx" "My" "Mz" are 0 .. 5 (stability axes, moments about O); "power" is 6:
// the part's rate of work on the air, partitioned through its own potential (one Laplace problem per part; without
// "power" but with all six components, power rows are formed from them).
constexpr int power_component = 6;
const char* component_name(int k);
int component_index(const std::string& name);  // std::invalid_argument for another name

// One partitioned load component of one part at one sample: a row of fpm.csv. N for forces, N m for moments, W for
// power (the part's rate of work on the fluid).
struct FpmRow {
  double time = 0;   // s
  long step = 0;
  double phase = 0;  // t / T modulo 1
  int part = 0;      // 0 body, 1 right wing, 2 left wing
  int component = 0;
  double pressure = 0;       // -oint p g dS on the cut-cell surface (what the partition sums to)
  double kinematic = 0;      // added mass + centripetal acceleration reaction
  double centripetal = 0;    // the centripetal acceleration reaction (CAR)
  double vortex = 0, viscous = 0, outer = 0;
  double solver_pressure = 0, solver_viscous = 0;  // the run's own pressure and skin-friction loads (forces.csv)
  double pressure_forced = 0;  // the share of `pressure` on the faces the immersed boundary forces (PartPartition)
  std::vector<double> regions;  // the vortex-induced part by region (FpmObserver::region_names)
  double added_mass() const { return kinematic - centripetal; }
  double sum() const { return kinematic + vortex + viscous + outer; }
};

std::string fpm_csv_header(const std::vector<std::string>& region_names);
std::string fpm_csv_row(const FpmRow& r);
// The inverse of fpm_csv_row for a file with `regions` region columns; std::invalid_argument for a malformed row.
FpmRow parse_fpm_csv_row(const std::string& line, std::size_t regions);

// Memory force partitioning holds during a run of `plan` (bytes, an upper estimate): the potentials asked for (parts x
// components), the Laplace solver's levels and work fields, the cut-cell geometry, Q, the Laplacian of u, the labels.
std::size_t fpm_estimated_bytes(const ns::CfdPlan& plan, const FpmSettings& settings);
// Refuses a run whose solver and partitioning together do not fit in `available` bytes (0: the memory the system
// reports available): InputError naming the case file and aero.cfd.fpm, with both estimates and what would fit.
void check_fpm_memory(const ns::CfdPlan& plan, const FpmSettings& settings, const std::string& case_path,
                      std::size_t available = 0);

class FpmObserver final : public ns::StepObserver {
 public:
  // `directory` "": everything in memory. InputError naming the case file and aero.cfd.fpm for a simulation the
  // partition does not apply to (no bodies, a turning grid frame).
  FpmObserver(const ns::Simulation& sim, const FpmSettings& settings, std::string directory);
  // A restart from `step`: the rows of the interrupted run's fpm.csv up to that step come first (InputError naming the
  // file and line for a damaged file or one with other columns).
  void keep_earlier(const std::string& file, long step);

  void on_step(const ns::Simulation& sim, const ns::StepReport& r) override;
  void on_end(const ns::Simulation&) override { flush(); }
  // Partitions the loads now (the observer does it at its cadence); returns the new rows.
  std::vector<FpmRow> sample(const ns::Simulation& sim);
  // Writes the potential and vortex-force-density fields now (fields/fpm_STEP.h5).
  void write_fields(const ns::Simulation& sim);
  void flush() const;  // fpm.csv, atomically

  const std::vector<FpmRow>& rows() const { return rows_; }  // the interrupted run's and this run's
  const std::vector<std::string>& region_names() const { return region_names_; }
  const std::vector<int>& components() const { return components_; }
  const FpmSettings& settings() const { return settings_; }
  double seconds() const { return seconds_; }  // wall time spent partitioning in this run
  long samples() const { return samples_; }
  double mean_potential_iterations() const { return samples_ > 0 ? double(iterations_) / solves_ : 0; }
  long unconverged_solves() const { return unconverged_; }  // potential solves that failed even from zero

  // Wingbeat means of every part and component over the samples with from_s < t <= to_s (run.json "fpm").
  nlohmann::json means(double from_s, double to_s, double period, double weight) const;
  // One paragraph for the terminal: the wings' lift (-F_z) by mechanism and region over the window, as shares.
  std::string summary(double from_s, double to_s, double period) const;

 private:
  FpmSettings settings_;
  std::string dir_;
  std::vector<int> components_, parts_;  // as listed; power_component for "power"
  bool power_potential_ = false, power_rows_ = false;
  std::vector<WingRegion> regions_;
  std::vector<std::string> region_names_;
  double region_size_ = 0;  // m
  double rho_ = 0;
  std::optional<ForcePartition> partition_;
  std::optional<ns::FieldWriter> writer_;
  std::vector<int> last_labels_;  // the last sample's region of each cell
  std::vector<FpmRow> rows_;
  std::vector<std::string> lines_;
  long samples_ = 0, solves_ = 0, iterations_ = 0, unconverged_ = 0;
  std::size_t pockets_max_ = 0;
  double seconds_ = 0;
  long last_sample_step_ = -1;
};

}  // namespace flapstab::fpm
