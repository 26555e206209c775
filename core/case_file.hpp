// Case files (TOML): the insect, its kinematics, the fluid, the aerodynamic model, trim and outputs.
// Every field is validated; errors name the file, the key and what was expected (docs/case-file.md).
#pragma once
#include <optional>
#include <string>
#include <vector>
#include "core/aero_coefficients.hpp"
#include "core/insect.hpp"
#include "core/kinematics.hpp"

namespace flapstab {

struct FluidProperties {
  double density = 1.225;                // kg/m^3
  double kinematic_viscosity = 1.5e-5;   // m^2/s
};

struct QuasiSteadySettings {
  std::string coefficients = "robofly";  // "robofly" | "berman-wang" | "table"
  CoefficientConstants constants;        // [aero.quasi_steady.robofly], [...berman-wang], [...table]
  std::optional<double> rotational_coefficient;  // C_R; unset: pi (3/4 - x0)
  double centre_of_pressure = 0.25;      // chord fraction from the leading edge
  int blade_elements = 40;
  bool rotational = true;
  bool added_mass = true;
  int samples_per_cycle = 128;
};

// [aero.cfd.fpm]: force partitioning of the CFD loads during a run (cfd/fpm/, docs/theory/force-partitioning.md).
struct FpmSettings {
  bool enabled = false;          // the table [aero.cfd.fpm] is present and its `enabled` is not false
  int samples_per_cycle = 40;    // partitions per wingbeat (at the ends of the steps that cross these phases)
  // Load components partitioned, of "Fx" "Fy" "Fz" "Mx" "My" "Mz" (stability axes S, moments about O) and "power" (the
  // part's rate of work on the air); one influence potential per part and component is solved at every sample.
  std::vector<std::string> components = {"Fx", "Fz"};
  std::vector<std::string> parts = {"body", "right", "left"};  // also "hind_right" "hind_left" with a hind pair
  // Regions of the flow around each wing, in the wing's frame, over which the vortex-induced force is integrated
  // ("leading-edge" "trailing-edge" "tip"); the rest of the flow is "wake". Definitions: docs/theory/force-partitioning.md.
  std::vector<std::string> regions = {"leading-edge", "trailing-edge", "tip"};
  double region_size_chords = 1.0;  // how far the wing regions reach off the wing surface and beyond the tip (mean chords)
  int fields_per_cycle = 0;         // potential and vortex-force-density field outputs per wingbeat (0: none)
  double tolerance = 1e-4;          // potential solves: max residual / max right-hand side (the terms to ~1e-5)
  // The region the influence potentials treat as the parts: "surface", the parts as their surfaces give them (cut
  // cells; the pressure on the faces the immersed boundary forces is left over as pressure_forced), or
  // "forced-region", the parts widened to every forced face, with the fluid's acceleration on that body's faces in
  // the kinematic part and every term in the form of the solver's last Runge-Kutta stage (closes each sample to the
  // solvers' tolerances where "surface" leaves ~half on the forced faces, but holds the added mass of a body about a
  // cell larger; the solver keeps two more velocity fields). docs/theory/force-partitioning.md, "The forced region as
  // the body".
  std::string body = "surface";
};

// [aero.cfd]: the Navier-Stokes immersed-boundary run (cfd/navier_stokes/run.hpp, docs/case-file.md).
// Lengths are in wing lengths R; the grid lives in stability axes S with its origin at O.
struct CfdSettings {
  // Domain: distance from the fine box to each face of the computational box (x forward, y right, z down).
  double upstream_R = 3.0;    // ahead of the insect (+x)
  double downstream_R = 3.0;  // behind (-x)
  double lateral_R = 3.0;     // to each side (+-y)
  double above_R = 3.0;       // above (-z)
  double below_R = 5.0;       // below (+z), where the downwash leaves through the outflow face
  double fine_margin_R = 0.1; // uniform fine box = swept volume of body and wings over the run + this margin
  // Sponge layer: within sponge_R wing lengths of every face the flow is relaxed towards the far field (-V, or
  // -V - Omega x r on a turning grid) at a rate growing as the square of the depth to sponge_rate at the face (per
  // wingbeat: sigma = sponge_rate f). 0: none. It must stay outside the fine box (sponge_R <= every margin above).
  double sponge_R = 0;
  double sponge_rate = 10;
  // The faces it lines, by their margin's name: "upstream" (x+), "downstream" (x-), "lateral" (y-, y+), "above" (z-),
  // "below" (z+, the outflow face).
  std::vector<std::string> sponge_faces = {"upstream", "downstream", "lateral", "above", "below"};
  double cells_per_chord = 16;      // fine spacing h = mean chord / this ...
  double cells_per_wing_length = 0; // ... or, when > 0, h = R / this (the two are exclusive)
  double stretch_ratio = 1.05;      // geometric growth of the cell widths outside the fine box
  double reynolds = 0;              // > 0: viscosity set to U_ref L_ref / Re (U_ref = 2 Phi f R, L_ref = mean chord)
  int cycles = 1;                   // wingbeats run (flapstab cfd); the least a hover from rest runs (AeroModel path)
  // The AeroModel path (trim, derivatives, analyze): a hover run from rest until the cycle-to-cycle change of its
  // mean loads is below hover_tolerance, then every perturbed run from that state until the change of its
  // difference from the continued hover is below perturbation_tolerance; at most max_cycles wingbeats each.
  // Tolerances are fractions of the weight (forces) and of weight x mean chord (moments).
  double hover_tolerance = 0.02;
  double perturbation_tolerance = 0.005;
  int max_cycles = 12;
  // CFD trim: Broyden iterations on the CFD cycle means from the quasi-steady trim (trim/refine.hpp), until every
  // residual is below trim_tolerance (fraction of the weight; moments of weight x wing length).
  double trim_tolerance = 0.02;
  int trim_iterations = 6;
  int steps_per_cycle = 0;          // > 0: fixed dt = T / steps_per_cycle (phase-locked); 0: adaptive from cfl
  double cfl = 0.5;                 // adaptive step's CFL number
  int fields_per_cycle = 4;         // flow-field outputs per wingbeat (0: none)
  int surfaces_per_cycle = 8;       // surface outputs per wingbeat (0: none)
  int checkpoints_per_cycle = 1;    // checkpoints per wingbeat (0: only at the end)
  std::string field_precision = "float32";  // "float64" | "float32"
  // Over MPI ranks: "whole" (rank 0 gathers the grid into one file per output) | "per-rank" (each rank writes its own
  // planes, rank 0 the XDMF over them; for grids too large for one node's memory)
  std::string field_files = "whole";
  std::string loads = "exchange";   // "exchange" (momentum exchange of the forcing) | "surface" (surface integral)
  std::string pressure_solver = "multigrid";  // "multigrid" (the project's) | "hypre" (hypre's PCG + SMG, if built)
  int body_divisions = 16;          // body mesh: cube-sphere divisions per face edge (12 n^2 triangles)
  int wing_span_stations = 40;      // wing mesh: spanwise stations
  int wing_chord_divisions = 10;    // wing mesh: chordwise divisions
  int threads = 0;                  // OpenMP threads (0: the OpenMP default)
  FpmSettings fpm;                  // [aero.cfd.fpm]
};

struct AeroSettings {
  std::string model = "quasi-steady";    // "quasi-steady" | "cfd"
  QuasiSteadySettings quasi_steady;
  CfdSettings cfd;
};

enum class ParameterSide { both, right, left };

struct TrimParameterSpec {
  std::string name;     // e.g. "stroke_amplitude_deg"
  double lower = 0, upper = 0;  // in the parameter's unit (deg or Hz)
  ParameterSide side = ParameterSide::both;
  std::string label() const;    // name with the side appended when not "both"
};

struct TrimSettings {
  std::string solver = "ipopt";          // "ipopt" | "nlopt"
  std::string objective = "least-change";  // "least-change" | "min-power"
  double tolerance = 1e-10;
  int max_iterations = 200;
  std::vector<TrimParameterSpec> parameters;
  // The cyclic trim's mean attitude: "imposed" (the orbit's wingbeat-mean pitch is the averaged trim's attitude,
  // a [trim] parameter balancing it) or "free" (the orbit finds its own mean pitch, which is reported; the body
  // angle is held at the averaged trim's value and body_angle_deg leaves the cyclic trim's unknowns).
  std::string cyclic_attitude = "imposed";
};

struct DerivativeSettings {
  double relative_step = 0.01;
  // Which columns of the table are computed: "all" (u v w p q r), "longitudinal" (u w q: the X Z M rows' inputs)
  // or "lateral" (v p r). The others are left out of the table (its has_lateral / has_longitudinal flags), which
  // halves the number of CFD runs of a stability study that needs one plane only.
  std::string columns = "all";
  // The rate step / (U / c); 0: relative_step. A steady rate turns the body by (rate step) x T per wingbeat
  // (rate_step c / U x 2 Phi r2 / c rad): in a CFD run that lasts several wingbeats a smaller rate step than the
  // velocity step keeps the rotation small (the CFD study prints it and warns above 5 deg per wingbeat).
  double relative_rate_step = 0;
  // [derivatives.pitch_oscillation] (CFD model only): a forced pitch oscillation about the kept hover, whose fit gives
  // the pitch-rate and pitch-attitude derivatives at one frequency (cfd/navier_stokes/oscillation.hpp). Present =
  // enabled.
  struct PitchOscillation {
    bool enabled = false;
    double amplitude_deg = 2;       // theta0
    int period_wingbeats = 10;      // wingbeats per oscillation period
    int periods = 2;                // periods fitted
    int transient_wingbeats = -1;   // wingbeats left out of the fit first (-1: one period)
  } pitch_oscillation;
};

// [flight]: nonlinear free flight (flapstab fly; flight/free_flight.hpp).
struct FlightSettings {
  std::string dof = "longitudinal";   // "6dof" | "longitudinal" | "pitch" | "translation"
  double wingbeats = 20;
  int samples_per_wingbeat = 40;
  double rtol = 1e-9;
  std::string start = "periodic-orbit";  // "periodic-orbit" (cyclic trim) | "rest" (the perturbation alone)
  // With [aero] model = "cfd": "cancel" holds minus the tethered CFD hover's cycle-mean residual (its mean force and
  // moment with the weight, body axes) as a constant wrench, so that the hover is an equilibrium on average when the
  // grid's lift falls short of the weight; "keep" flies the residual (the insect sinks and pitches).
  std::string cfd_residual = "cancel";
  // With [aero] model = "cfd", a perturbation and a [control] table: "open-loop" flies the unperturbed reference
  // flight open loop and the controller senses the deviation from it; "closed-loop" flies the reference under the
  // same controller, and both flights' controllers sense the deviation from the tethered hover (body at rest at O),
  // the quasi-steady free flight's periodic orbit's counterpart.
  std::string cfd_reference = "open-loop";
  // With [aero] model = "cfd": the grid's fine box is re-planned around the body when a part has used half of the
  // room [aero.cfd] fine_margin_R gave it (the flow carried over to the new grid); false stops the flight with a
  // checkpoint when a part leaves the fine box.
  bool cfd_replan = true;
  // [flight.perturbation]: added to the start state. Keys u_m_s v_m_s w_m_s p_deg_s q_deg_s r_deg_s phi_deg
  // theta_deg psi_deg x_m y_m z_m, or mode = "longitudinal" | "lateral" (the most unstable Floquet mode of that
  // subsystem) scaled to mode_amplitude (non-dimensional max-norm).
  std::vector<std::pair<std::string, double>> perturbation;  // (state name, SI value)
  std::string mode;
  double mode_amplitude = 1e-3;
};

// [control]: the feedback law (flight/controller.hpp) and the (gain, latency) map (flapstab control-map).
struct ControlSettings {
  std::string type = "none";          // "none" | "pitch" | "state-feedback"
  std::string update = "continuous";  // "continuous" | "wingbeat"
  // [control.pitch]
  std::string actuator = "stroke_plane_deg";
  double pitch_gain = 0, rate_gain_s = 0, pitch_latency_s = 0, rate_latency_s = 0, filter_time_s = 0;
  double limit_deg = 30;
  // [[control.feedback]] and [[control.actuator]] (state-feedback)
  struct Term {
    std::string state, actuator;
    double gain = 0, latency_s = 0, filter_time_s = 0;
  };
  std::vector<Term> feedback;
  std::vector<TrimParameterSpec> actuators;  // name with absolute lower/upper limits
  // [control.map]
  std::string map_gain = "pitch";     // "pitch" | "rate": the gain on the map's first axis
  double map_gain_min = -2, map_gain_max = 2;
  int map_gains = 50;
  double map_latency_max_s = 0;       // 0: three wingbeats
  int map_latencies = 50;
  int map_periodic_gains = 12, map_periodic_latencies = 12;  // the periodic (Floquet) loop's coarser map; 0: none
  int map_check_points = 3;           // simulated points each side of the boundary
  double map_check_wingbeats = 15;
};

// [body_motion]: the body's attitude prescribed as the trimmed attitude turned by periodic 3-2-1 Euler angles, with
// the translation-only model (trim/translation.hpp): position and velocity free, attitude not.
struct BodyMotionSettings {
  bool present = false;
  std::string model = "translation-only";
  AngleSeries roll, pitch, yaw;              // rad, against the wingbeat phase; zero when not given
  std::vector<std::string> trim_parameters;  // the [[trim.parameter]] names its cyclic trim varies
};

struct Case {
  std::string path;          // the case file
  std::string description;
  std::vector<std::string> sources;
  Insect insect;
  Kinematics kinematics;
  FluidProperties fluid;
  AeroSettings aero;
  TrimSettings trim;
  DerivativeSettings derivatives;
  FlightSettings flight;
  ControlSettings control;
  BodyMotionSettings body_motion;
  std::string output_directory = "out";
};

// Names accepted in [[trim.parameter]] name = ...
const std::vector<std::string>& trim_parameter_names();

// Loads and validates a case file. Throws InputError(file, key, problem, expected).
Case load_case(const std::string& path);
// [derivatives.pitch_oscillation] against the rest of the case (load_case calls it; so does a CFD study of a case
// built in code): it needs [aero] model = "cfd", a longitudinal table and no CFD trim. InputError naming the key.
void check_pitch_oscillation(const Case& c);
// The CFD geometry is one rigid body with one or two pairs of wings: InputError naming `path` and `key` (empty: the
// section, "abdomen") for an abdomen. load_case calls it for model = "cfd", flapstab cfd for every case.
void check_cfd_geometry(const Insect& insect, const std::string& path, const std::string& key = "");

}  // namespace flapstab
