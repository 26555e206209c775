// Tests for core/case_file, [aero.cfd]: defaults, every key's type and range checks, unknown keys.
#include <gtest/gtest.h>
#include "common/expect_error.hpp"
#include "common/case_text.hpp"
#include "core/case_file.hpp"
#include "core/errors.hpp"

namespace flapstab {
namespace {

using testing::replace;
using testing::valid_case_text;
using testing::write_temp;

std::string with_cfd(const std::string& keys) {
  return replace(valid_case_text(), "[trim]\n", "[aero.cfd]\n" + keys + "\n[trim]\n");
}

TEST(CaseFileCfd, DefaultsWhenTheTableIsAbsentOrEmpty) {
  for (const std::string& text : {valid_case_text(), with_cfd("")}) {
    const Case c = load_case(write_temp("cfd_default.toml", text));
    const CfdSettings& s = c.aero.cfd;
    EXPECT_EQ(s.cycles, 1);
    EXPECT_EQ(s.steps_per_cycle, 0);
    EXPECT_DOUBLE_EQ(s.cfl, 0.5);
    EXPECT_DOUBLE_EQ(s.cells_per_chord, 16);
    EXPECT_DOUBLE_EQ(s.cells_per_wing_length, 0);
    EXPECT_DOUBLE_EQ(s.stretch_ratio, 1.05);
    EXPECT_DOUBLE_EQ(s.reynolds, 0);
    EXPECT_EQ(s.field_precision, "float32");
    EXPECT_EQ(s.threads, 0);
    EXPECT_EQ(s.loads, "exchange");
  }
}

TEST(CaseFileCfd, EveryKeyIsRead) {
  const Case c = load_case(write_temp(
      "cfd_all.toml",
      with_cfd("upstream_R = 1.5\ndownstream_R = 2.5\nlateral_R = 2\nabove_R = 1\nbelow_R = 4\nfine_margin_R = 0.2\n"
               "cells_per_wing_length = 40\nstretch_ratio = 1.07\nreynolds = 1000\ncycles = 3\nsteps_per_cycle = 200\n"
               "fields_per_cycle = 2\nsurfaces_per_cycle = 5\ncheckpoints_per_cycle = 0\nfield_precision = \"float64\"\n"
               "body_divisions = 8\nwing_span_stations = 20\nwing_chord_divisions = 6\nthreads = 2\nloads = \"surface\"\n")));
  const CfdSettings& s = c.aero.cfd;
  EXPECT_DOUBLE_EQ(s.upstream_R, 1.5);
  EXPECT_DOUBLE_EQ(s.downstream_R, 2.5);
  EXPECT_DOUBLE_EQ(s.lateral_R, 2);
  EXPECT_DOUBLE_EQ(s.above_R, 1);
  EXPECT_DOUBLE_EQ(s.below_R, 4);
  EXPECT_DOUBLE_EQ(s.fine_margin_R, 0.2);
  EXPECT_DOUBLE_EQ(s.cells_per_wing_length, 40);
  EXPECT_DOUBLE_EQ(s.stretch_ratio, 1.07);
  EXPECT_DOUBLE_EQ(s.reynolds, 1000);
  EXPECT_EQ(s.cycles, 3);
  EXPECT_EQ(s.steps_per_cycle, 200);
  EXPECT_EQ(s.fields_per_cycle, 2);
  EXPECT_EQ(s.surfaces_per_cycle, 5);
  EXPECT_EQ(s.checkpoints_per_cycle, 0);
  EXPECT_EQ(s.field_precision, "float64");
  EXPECT_EQ(s.body_divisions, 8);
  EXPECT_EQ(s.wing_span_stations, 20);
  EXPECT_EQ(s.wing_chord_divisions, 6);
  EXPECT_EQ(s.threads, 2);
  EXPECT_EQ(s.loads, "surface");
  const Case d = load_case(write_temp("cfd_cfl.toml", with_cfd("cfl = 0.8\ncells_per_chord = 12.5\n")));
  EXPECT_DOUBLE_EQ(d.aero.cfd.cfl, 0.8);
  EXPECT_DOUBLE_EQ(d.aero.cfd.cells_per_chord, 12.5);
}

struct BadCfd {
  const char* label;
  const char* keys;
  const char* key;
};

class CaseFileCfdBad : public ::testing::TestWithParam<BadCfd> {};

TEST_P(CaseFileCfdBad, NamesFileAndKey) {
  const BadCfd b = GetParam();
  const std::string path = write_temp(std::string("cfd_") + b.label + ".toml", with_cfd(b.keys));
  const std::string what = testing::expect_input_error([&] { load_case(path); }, b.key, path);
  EXPECT_NE(what.find("expected"), std::string::npos) << b.label << ": " << what;
}

INSTANTIATE_TEST_SUITE_P(
    Inputs, CaseFileCfdBad,
    ::testing::Values(
        BadCfd{"upstream_type", "upstream_R = \"far\"", "aero.cfd.upstream_R"},
        BadCfd{"upstream_negative", "upstream_R = -1", "aero.cfd.upstream_R"},
        BadCfd{"downstream_negative", "downstream_R = -0.5", "aero.cfd.downstream_R"},
        BadCfd{"lateral_huge", "lateral_R = 1000", "aero.cfd.lateral_R"},
        BadCfd{"above_nan", "above_R = nan", "aero.cfd.above_R"},
        BadCfd{"below_type", "below_R = true", "aero.cfd.below_R"},
        BadCfd{"fine_margin_negative", "fine_margin_R = -0.1", "aero.cfd.fine_margin_R"},
        BadCfd{"cells_per_chord_low", "cells_per_chord = 0.5", "aero.cfd.cells_per_chord"},
        BadCfd{"cells_per_chord_type", "cells_per_chord = \"8\"", "aero.cfd.cells_per_chord"},
        BadCfd{"cells_per_wing_length_low", "cells_per_wing_length = 0", "aero.cfd.cells_per_wing_length"},
        BadCfd{"both_resolutions", "cells_per_chord = 8\ncells_per_wing_length = 30", "aero.cfd.cells_per_wing_length"},
        BadCfd{"stretch_low", "stretch_ratio = 0.95", "aero.cfd.stretch_ratio"},
        BadCfd{"stretch_high", "stretch_ratio = 1.15", "aero.cfd.stretch_ratio"},
        BadCfd{"reynolds_zero", "reynolds = 0", "aero.cfd.reynolds"},
        BadCfd{"reynolds_type", "reynolds = [1000]", "aero.cfd.reynolds"},
        BadCfd{"cycles_zero", "cycles = 0", "aero.cfd.cycles"},
        BadCfd{"cycles_float", "cycles = 1.5", "aero.cfd.cycles"},
        BadCfd{"steps_zero", "steps_per_cycle = 0", "aero.cfd.steps_per_cycle"},
        BadCfd{"steps_and_cfl", "steps_per_cycle = 100\ncfl = 0.5", "aero.cfd.cfl"},
        BadCfd{"cfl_high", "cfl = 2.0", "aero.cfd.cfl"},
        BadCfd{"cfl_zero", "cfl = 0", "aero.cfd.cfl"},
        BadCfd{"fields_negative", "fields_per_cycle = -1", "aero.cfd.fields_per_cycle"},
        BadCfd{"surfaces_type", "surfaces_per_cycle = \"many\"", "aero.cfd.surfaces_per_cycle"},
        BadCfd{"checkpoints_negative", "checkpoints_per_cycle = -2", "aero.cfd.checkpoints_per_cycle"},
        BadCfd{"precision", "field_precision = \"float16\"", "aero.cfd.field_precision"},
        BadCfd{"precision_type", "field_precision = 32", "aero.cfd.field_precision"},
        BadCfd{"loads", "loads = \"pressure\"", "aero.cfd.loads"},
        BadCfd{"loads_type", "loads = 1", "aero.cfd.loads"},
        BadCfd{"body_divisions", "body_divisions = 1", "aero.cfd.body_divisions"},
        BadCfd{"span_stations", "wing_span_stations = 1", "aero.cfd.wing_span_stations"},
        BadCfd{"chord_divisions", "wing_chord_divisions = 0", "aero.cfd.wing_chord_divisions"},
        BadCfd{"threads_negative", "threads = -1", "aero.cfd.threads"},
        BadCfd{"unknown", "cells_per_cord = 8", "aero.cfd.cells_per_cord"}),
    [](const ::testing::TestParamInfo<BadCfd>& i) { return std::string(i.param.label); });

// The hind pair of a four-winged insect is in the CFD geometry (parts hind_right, hind_left): model = "cfd" takes it
// (it was refused, key hind_wing, while the geometry held one pair), and force partitioning may name its wings. Naming
// a hind wing for an insect without a hind pair is bad input naming the file and aero.cfd.fpm.parts, not a run that
// fails later or partitions nothing.
TEST(CaseFileCfd, HindPairIsInTheCfdGeometry) {
  const std::string cfd = replace(valid_case_text(), "model = \"quasi-steady\"", "model = \"cfd\"");
  std::string four = replace(cfd, "[kinematics]\n",
                             "[hind_wing]\nlength_m = 0.040\nmean_chord_m = 0.012\nplanform = \"rectangular\"\n"
                             "mass_kg = 20e-6\nhinge_m = [-0.014, 0.004, -0.003]\n\n[kinematics]\n");
  four = replace(four, "[fluid]\n",
                 "[kinematics.hind]\nphase_deg = 90.0\n[kinematics.hind.stroke]\ncos_deg = [-50.0]\n"
                 "[kinematics.hind.pitch]\nmean_deg = 90.0\nsin_deg = [-50.0]\n\n[fluid]\n");
  const std::string fpm = "[aero.cfd.fpm]\nparts = [\"right\", \"hind_right\", \"hind_left\"]\n";
  const Case c = load_case(write_temp("cfd_four_wings.toml", replace(four, "[trim]\n", fpm + "\n[trim]\n")));
  ASSERT_TRUE(c.insect.hind_wing.has_value());
  EXPECT_EQ(c.aero.model, "cfd");
  EXPECT_EQ(c.aero.cfd.fpm.parts, (std::vector<std::string>{"right", "hind_right", "hind_left"}));
  EXPECT_NO_THROW(check_cfd_geometry(c.insect, c.path));

  const std::string path = write_temp("cfd_fpm_no_hind.toml", replace(cfd, "[trim]\n", fpm + "\n[trim]\n"));
  const std::string what = testing::expect_input_error([&] { load_case(path); }, "aero.cfd.fpm.parts", path);
  EXPECT_NE(what.find("hind_right"), std::string::npos) << what;
  EXPECT_NE(what.find("[hind_wing]"), std::string::npos) << what;
}

TEST(CaseFileCfd, TableMustBeATable) {
  const std::string path = write_temp("cfd_not_table.toml", replace(valid_case_text(), "model = \"quasi-steady\"",
                                                                     "model = \"cfd\"\ncfd = 3"));
  try {
    load_case(path);
    FAIL();
  } catch (const InputError& e) {
    EXPECT_EQ(e.key(), "aero.cfd");
  }
}

}  // namespace
}  // namespace flapstab
