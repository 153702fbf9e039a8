// The one table of every command's options (include/quadid/pipeline/options.hpp).
// Defaults come from the library's option structs where they hold one, so
// that a changed default changes --help, the JSON options and Python alike.
#include "quadid/pipeline/options.hpp"

#include "quadid/control.hpp"
#include "quadid/design.hpp"
#include "quadid/estimation.hpp"
#include "quadid/export.hpp"
#include "quadid/models.hpp"
#include "quadid/identification.hpp"
#include "quadid/logs.hpp"
#include "quadid/montecarlo.hpp"
#include "quadid/online.hpp"
#include "quadid/simulation.hpp"
#include "quadid/vehicle.hpp"

#include <fmt/format.h>
#include <fmt/ranges.h>

#include <algorithm>
#include <cmath>
#include <map>
#include <stdexcept>

namespace quadid {
namespace {

using K = OptionKind;

/// A default number as typed: the shortest text that reads back to the same double.
std::string num(double x) { return std::isinf(x) ? (x > 0 ? "inf" : "-inf") : fmt::format("{}", x); }

/// Builds one OptionDef (chained setters keep the tables readable).
struct B {
  OptionDef d;
  B(std::string name, K kind, std::string help) {
    d.name = std::move(name);
    d.kind = kind;
    d.help = std::move(help);
  }
  B& def(std::string v) { d.default_value = std::move(v); return *this; }
  B& def(double v) { d.default_value = num(v); return *this; }
  B& text(std::string t) { d.default_text = std::move(t); return *this; }
  B& unit(std::string u) { d.unit = std::move(u); return *this; }
  B& choices(std::vector<std::string> c) { d.choices = std::move(c); return *this; }
  B& or_number() { d.number_or_choice = true; return *this; }
  B& at_least(double lo) { d.min = lo; return *this; }
  B& above(double lo) { d.min = lo; d.min_open = true; return *this; }
  B& range(double lo, double hi) { d.min = lo; d.max = hi; return *this; }
  B& range_below(double lo, double hi) { d.min = lo; d.max = hi; d.max_open = true; return *this; }
  B& alias(std::string a) { d.aliases.push_back(std::move(a)); return *this; }
  B& shorthand(std::string s) { d.short_name = std::move(s); return *this; }
  B& positional() { d.positional = true; return *this; }
  B& required() { d.required = true; return *this; }
  B& cli() { d.scope = OptionScope::Cli; return *this; }
  operator OptionDef() const { return d; }  // NOLINT: the tables below convert implicitly
};

using Defs = std::vector<OptionDef>;

Defs operator+(Defs a, const Defs& b) {
  a.insert(a.end(), b.begin(), b.end());
  return a;
}

// --- Groups shared by several commands ---------------------------------------------

B out_file(const std::string& help) { return B("out", K::String, help).shorthand("o").text("none").cli(); }
B json_flag(const std::string& help = "print the result JSON on stdout (nothing else there)") {
  return B("json", K::Flag, help).cli();
}
B quiet_flag(const std::string& help = "nothing on stderr but errors (no progress, notes or warnings)") {
  return B("quiet", K::Flag, help).shorthand("q").cli();
}

Defs processing_group() {
  const ProcessingOptions p;
  return {
      B("filter", K::String, "zero-phase pre-filter: butter (Butterworth IIR) or fir (31-tap Blackman-Harris)")
          .def("butter").choices({"butter", "fir"}),
      B("cutoff", K::Number,
        "pre-filter cutoff; 4 Hz passes the excitation (<= 0.5 Hz) and removes 30 Hz motion-capture steps")
          .def(p.lowpass.cutoff_hz).unit("Hz").above(0),
      B("order", K::Integer, "Butterworth order").def(num(p.lowpass.order)).range(1, 8),
      B("taps", K::Integer, "FIR length (odd)").def(num(p.lowpass.taps)).at_least(1),
      B("lambda", K::Number, "bandwidth of f_D, g_D of the filtered model (eqs. 35-36)")
          .def(IdentificationOptions{}.lambda).unit("rad/s"),
      B("derivative-filter", K::String,
        "g_D: consistent ((1-a)/T (z-1)/(z-a), the derivative of f_D's output) or printed (eq. 36)")
          .def("consistent").choices({"consistent", "printed"}),
      B("products", K::String,
        "the rate products pq pr qr p^2 q^2 r^2 of the moment rows: filtered (the log's rates multiplied, then "
        "pre-filtered like every signal, F[pq]: exact for the filtered rigid body) or paper (products of the "
        "filtered rates, F[p]F[q], section II-C as printed; rotation above the cutoff then biases the inertia)")
          .def("filtered").choices({"filtered", "paper"}),
      B("g", K::Number, "gravity").def(p.g).unit("m/s^2"),
      B("period-tolerance", K::Number, "relative tolerance on a uniform sample period").def(p.period_tolerance),
      B("time-unit", K::String, "unit of the log's column t: s (the format's), ms, us or ns (e.g. a logger's "
                                "millisecond stamps)")
          .def("s").choices({"s", "ms", "us", "ns"}),
      B("keep-edges", K::Flag,
        "use the windows literally, including the filters' settling at the log's two ends (by default the "
        "pre-filter's settling time, 0.57 s for the default filter, is left out at each end)"),
      B("keep-held-samples", K::Flag,
        "use the pose (x y z psi) as logged even where it repeats each sample until the next (by default a held "
        "pose, e.g. 30 Hz motion capture in a 500 Hz log, is put back on its sample instants: a hold delays it by "
        "half its period)"),
      B("gyro-delay", K::Number,
        "the gyro's lag behind the pose and the torques: each p, q, r row is taken as measured this much before "
        "its time stamp (the input check 'timing' measures the lag; docs/input-checks.md)")
          .def(0.0).unit("s").range(-1, 1),
      B("map", K::List, "column name mapping CANONICAL=NAME, e.g. --map tau_phi=tau_x, or CANONICAL=-NAME for the column negated, e.g. --map q=-q (repeatable)").text("none"),
  };
}

Defs limit_group() {
  const Constraints c;
  return {
      B("x-max", K::Number, "|x| limit").def(c.x_max).unit("m"),
      B("y-max", K::Number, "|y| limit").def(c.y_max).unit("m"),
      B("z-min", K::Number, "lower z limit").def(c.z_min).unit("m"),
      B("z-max", K::Number, "upper z limit").def(c.z_max).unit("m"),
      B("psi-max-deg", K::Number, "|psi| limit").def("180").unit("deg").alias("psi-max"),
      B("tilt-max-deg", K::Number, "|phi|, |theta| limit of eqs. (26)-(27)").def("5.73").unit("deg").alias("tilt-max"),
      B("xdot-max", K::Number, "|x_dot| limit").def(c.xdot_max).unit("m/s"),
      B("ydot-max", K::Number, "|y_dot| limit").def(c.ydot_max).unit("m/s"),
      B("zdot-max", K::Number, "|z_dot| limit").def(c.zdot_max).unit("m/s"),
      B("psidot-max-deg", K::Number, "|psi_dot| limit").def("28.65").unit("deg/s").alias("psidot-max"),
      B("zddot-min", K::Number, "lower z_ddot limit").def(c.zddot_min).unit("m/s^2"),
      B("rate-max-deg", K::Number, "|p|, |q| limit (body rates of the reference)")
          .def("inf").unit("deg/s").alias("rate-max"),
      B("z0", K::Number, "start/end height").def(c.z0).unit("m"),
  };
}

/// The predicted precision of design and check-trajectory (PrecisionOptions).
Defs precision_group() {
  return {
      B("vehicle", K::String,
        "vehicle flown: built-in (" + builtin_vehicle_list() +
            ") or vehicle file; its [nominal], rates, [sensors] noise and rotors for the predicted precision, and its "
            "[limits] and per-rotor thrust limits for the trajectory")
          .text("the paper's virtual QBall 2"),
      B("flight-duration", K::Number, "length of the identification flight's log").def(50.0).unit("s").above(0),
      B("window", K::Window, "estimation window T0:T1, s (as identify --window)").def("10:50"),
      B("sigma-position", K::Number, "mocap position noise std").unit("m").text("0.3 mm or the vehicle's").at_least(0),
      B("sigma-yaw", K::Number, "mocap yaw noise std").unit("rad").text("the noise profile's or the vehicle's").at_least(0),
      B("sigma-attitude", K::Number, "IMU roll/pitch noise std").unit("rad").text("the noise profile's or the vehicle's").at_least(0),
      B("sigma-gyro", K::Number, "gyro noise std per sample").unit("rad/s").text("the noise profile's or the vehicle's").at_least(0),
      B("sigma-rotor", K::Number, "with --vehicle: noise std on the logged rotor speeds, rad/s or rpm")
          .text("the vehicle's [sensors] rotor_noise").at_least(0),
      B("closed-loop-flights", K::Integer,
        "simulated flights of the plan measuring the closed-loop term of the precision (0 = leave it out)")
          .def("4").at_least(0),
      B("regression", K::String,
        "regression predicted: auto (real with --vehicle, as identify --vehicle; else paper), paper (the paper's LS "
        "and FMLS, identify --terms paper --cutoffs fixed), or real (rows weighted by their residual RMS, moment rows "
        "pre-filtered at twice the cutoff; the extra terms not modelled)")
          .def("auto").choices({"auto", "paper", "real"}),
      B("no-precision", K::Flag, "do not predict the standard errors"),
  };
}

/// The export for an autopilot (ExportOptions): export and design --export.
Defs export_group() {
  const ExportOptions e;
  return {
      B("export-rate", K::Number, "setpoint rate of the exported CSV").def(e.rate).unit("Hz").cli(),
      B("export-format", K::String, "setpoints | crazyflie | mavsdk")
          .text("from the file name: .csv, .poly.csv, .py").choices({"setpoints", "crazyflie", "mavsdk"}).cli(),
      B("settle", K::Number, "hover before and after the excitation").def(e.plan.settle).unit("s").cli(),
      B("cycles", K::Integer, "periods of the excitation flown").def(num(e.plan.cycles)).cli(),
      B("ground-z", K::Number, "height of the take-off and landing point").def(e.plan.ground_z).unit("m").cli(),
      B("climb-speed", K::Number, "peak vertical speed of take-off and landing").def(e.plan.climb_speed).unit("m/s").cli(),
      B("piece", K::Number, "longest piece of the Crazyflie polynomial").def(e.piece).unit("s").cli(),
  };
}

B reference_option(const std::string& what) {
  return B("reference", K::String,
           what + ": preset qball2-nominal|qball2-virtual or a params JSON")
      .def("qball2-nominal").text("qball2-nominal; with --vehicle its [nominal]").alias("nominal");
}

// --- The commands -------------------------------------------------------------------

// Where the force row's acceleration comes from (identify): issue 38, section 5.
Defs force_row_group() {
  return {
      B("force-from", K::String,
        "the force row's body acceleration: position (the motion differentiated twice, the paper's), "
        "accelerometer (the IMU's specific force az_b: for a log without motion capture or EKF position), "
        "or auto (accelerometer when the log has az_b but no x y z) (docs/identify.md)")
          .def("auto").choices({"auto", "position", "accelerometer"}),
      B("imu-position", K::String,
        "with --force-from accelerometer: the IMU's position from the centre of mass, X,Y,Z in m, body FLU "
        "(its rotation then adds to the specific force, and is taken out)")
          .def("0,0,0").unit("m"),
      B("accel-bias-z", K::String,
        "with --force-from accelerometer: the accelerometer's z bias, m/s^2, subtracted: auto = measured on "
        "the ground before take-off when the log has 0.5 s of it (else 0, and the mass carries it), or a "
        "value")
          .def("auto").choices({"auto"}).or_number().unit("m/s^2").range(-5, 5),
  };
}

Defs identify_options() {
  return Defs{
             B("log", K::String,
               "flight log: CSV (docs/file-formats.md columns: t x y z phi theta psi p q r Fz tau_phi tau_theta "
               "tau_psi), PX4 ULog or Crazyflie uSD file")
                 .positional().required().cli(),
             B("window", K::Window,
               "estimation window T0:T1, seconds from the log's start ('T0:' = to the end). The default keeps to "
               "the air, 1 s clear of take-off and touchdown, and ends before a crash (docs/real-flights.md); the "
               "paper's 10-50 s on a log under 50 s: 10 s to its end (the whole log under 20 s)")
                 .def("10:50")
                 .text("the whole log; 10:50, the paper's, for a log `quadid simulate` wrote of the paper's setup"),
             B("error-window", K::Window, "window of the prediction-error tables")
                 .text("the whole log, as the paper's 0-50 s, or its part in the air"),
             B("sigma", K::Number, "gradient-descent gain of eq. (41), with --gd-gain paper").def(30.0),
             B("gd-gain", K::String,
               "gradient-descent gain: auto (normalized with --vehicle, else paper), paper (--sigma, the paper's "
               "law), or normalized (--gd-rate; the same default for a 30 g and a 2 kg vehicle)")
                 .def("auto").choices({"auto", "paper", "normalized"}),
             B("gd-rate", K::Number,
               "normalized gradient descent: rate of a direction carrying all of its block's excitation")
                 .def(GradientDescentOptions{}.rate).unit("1/s"),
             B("gd-discretization", K::String,
               "exact (exact solution over each sample, always stable) or literal (eq. 42, forward Euler: diverges "
               "at the paper's values, and says so)")
                 .def("exact").choices({"exact", "literal"}),
             B("gd-init", K::String, "GD initial guess: nominal (the --reference set), a preset or a params JSON")
                 .def("nominal"),
             reference_option("reference set of Tables 5-6 (P_imp%) and the value kept for unidentifiable "
                              "parameters"),
             B("vehicle", K::String,
               "vehicle file or built-in (" + builtin_vehicle_list() +
                   "): compute Fz and the torques from the log's rotor columns with its rotor model, take its "
                   "[nominal] as the reference set, and use the real-flight regression (docs/vehicles.md, "
                   "docs/real-flights.md). Without it, a PX4 ULog's CA_ROTOR* parameters give the rotor model "
                   "(docs/import.md)")
                 .text("none: the log's Fz and torque columns"),
             B("known-mass", K::Number,
               "weighed mass: estimate the thrust scale s (true wrench = s x the rotor model's) with the inertia, "
               "instead of the mass (motion alone cannot fix mass, thrust and inertia together)")
                 .unit("kg").text("none: the mass is estimated").above(0),
             B("terms", K::String,
               "regression terms: auto (real with --vehicle, else paper), paper, real (offsets, flapping, "
               "rotor-inertia, weighting), or a comma list of offsets, flapping, damping, rotor-inertia, drag, "
               "wind, weighting (docs/real-flights.md)")
                 .def("auto"),
             B("cutoffs", K::String,
               "pre-filter cutoffs: auto (with --vehicle the moment rows at twice --cutoff, else --cutoff for all "
               "rows), held-out (chosen by prediction error on held-out time blocks), or fixed (--cutoff, "
               "--cutoff-force, --cutoff-moment)")
                 .def("auto").choices({"auto", "held-out", "fixed"}),
             B("cutoff-force", K::Number, "pre-filter cutoff of the force row (positions differentiated twice)")
                 .unit("Hz").text("--cutoff"),
             B("cutoff-moment", K::Number, "pre-filter cutoff of the moment rows (gyro differentiated once)")
                 .unit("Hz").text("--cutoff; with --vehicle twice it"),
             B("wrench-offset", K::String,
               "how far the log's Fz and torques lead the motion, s: auto = measured on the standard regression "
               "and read out when determined (a controller's log holds each command from its time stamp: half a "
               "period); 0 = as logged; or a value in seconds. The paper's model only (docs/identify.md)")
                 .def("auto").choices({"auto"}).or_number().unit("s").range(-0.05, 0.05),
             B("motor-time-constant", K::String,
               "motor time constant, s (first-order lag of the rotor speed behind a command): auto = the rotor "
               "model's, estimated from the flight when the log holds commands and the model gives none (PX4 does "
               "not log it); or a value in seconds (docs/real-flights.md)")
                 .def("auto").choices({"auto"}).or_number().unit("s").range(0, 1),
             B("rotor-inertia", K::String,
               "with the rotor-inertia term: auto (the vehicle file's rotor_inertia when it gives one, else "
               "estimated), estimate, or one rotor's inertia in kg m^2 (docs/real-flights.md)")
                 .def("auto").choices({"auto", "estimate"}).or_number().range_below(0, 1),
             B("moment-highpass", K::String,
               "high-pass of the roll and pitch rows (real-flight regression): auto (with --vehicle the lowest "
               "cutoff, 0-3 Hz, above which Ixx and Iyy stop moving; else off), off, or Hz (docs/real-flights.md)")
                 .def("auto").choices({"auto", "off"}).or_number().unit("Hz").range_below(0, 100),
             B("term-signs", K::String,
               "real-flight terms whose sign physics fixes (damping, drag, rotor inertia, blade flapping: >= 0): "
               "enforce (a set breaking one is not physical, and PC/FMPC hold it at 0) or free (for rotors well "
               "below the centre of mass, where the flapping moment may change sign) (docs/uncertainty.md)")
                 .def("enforce").choices({"enforce", "free"}),
             B("time-offsets", K::String,
               "with a rotor model: estimate (the gyro's and the rotor signals' time offsets against the pose, "
               "estimated and applied) or none (docs/real-flights.md)")
                 .def("estimate").choices({"estimate", "none"}),
             B("jackknife-blocks", K::Integer,
               "with --vehicle: time blocks of the jackknife whose standard error is a floor under the HAC one, so "
               "that model error that changes along the flight widens the intervals (0 = off, else 3-100; "
               "docs/uncertainty.md)")
                 .def(num(UncertaintyOptions{}.jackknife_blocks)),
             B("allow-rank-deficient", K::Flag,
               "warn instead of failing when the data do not determine some parameters (they keep the reference "
               "values)"),
             B("ignore-input-errors", K::Flag,
               "go on when the input checks find an error (angles in degrees, z down, time gaps, rotor columns or "
               "layout not the vehicle file's, a negative moment of inertia; docs/input-checks.md)"),
         } +
         processing_group() +
         Defs{
             B("evolution", K::String,
               "write the estimates over time (Figs. 4-5) as CSV: t then LS_m..LS_Izz, GD_*, FMLS_*, FMGD_*")
                 .text("none").cli(),
             B("evolution-interval", K::Number, "seconds between evolution rows (0 = every sample)")
                 .def(0.01).unit("s"),
             out_file("write the result JSON (estimates.{LS,GD,FMLS,FMGD}, prediction errors)"),
             B("model", K::String,
               "also write the identified vehicle for a simulator, FORMAT:FILE (formats of quadid model: "
               "vehicle, mjcf, rotorpy, urdf; docs/models.md)")
                 .text("none").cli(),
             B("report", K::String,
               "write DIR/report.html: one self-contained page (works offline) with the recommended set, its "
               "intervals and conclusions, measured vs predicted per axis and their spectra (interactive), the "
               "parameter correlations, the log and every warning (docs/report.md)")
                 .text("none").cli(),
             B("verbose", K::Flag,
               "print every set (LS, GD, FMLS, FMGD, PC, FMPC), the wrench and timing, the intervals' method, "
               "physical consistency and Tables 5-6; without it a short summary of the recommended set")
                 .shorthand("v").cli(),
             json_flag(),
             quiet_flag(),
         } +
         force_row_group();
}

}  // namespace

const std::vector<std::string> kFollowUnused = {
    "window", "error-window", "sigma", "gd-gain", "gd-rate", "gd-discretization", "gd-init", "cutoffs",
    "cutoff-force", "moment-highpass", "term-signs", "jackknife-blocks", "evolution-interval", "wrench-offset",
    "allow-rank-deficient", "lambda", "derivative-filter", "taps", "keep-edges", "force-from", "accel-bias-z",
    "imu-position"};

namespace {

// quadid follow: identify's options of the log, the vehicle, the terms and the
// processing (the batch estimators' are accepted and unused), then its own.
Defs follow_options() {
  const OnlineOptions o;
  Defs d;
  for (OptionDef x : identify_options()) {
    if (x.name == "evolution" || x.name == "model" || x.name == "verbose" || x.name == "out" || x.name == "json" ||
        x.name == "report" ||
        x.name == "quiet")
      continue;
    if (std::find(kFollowUnused.begin(), kFollowUnused.end(), x.name) != kFollowUnused.end()) x.hidden = true;
    if (x.name == "log")
      x.help = "flight log as identify reads it (CSV, PX4 ULog, Crazyflie uSD, ArduPilot .bin), or - for flight-log "
               "CSV rows on stdin as they arrive (a live telemetry bridge; header line first)";
    d.push_back(std::move(x));
  }
  return d + Defs{
      B("every", K::Number, "seconds between the estimates printed (and written to --track)").def(1.0).unit("s").above(0).cli(),
      B("track", K::String, "write the tracking estimate every --every seconds as CSV: t, then each parameter and its "
                            "std error").text("none").cli(),
      B("memory", K::Number, "time constant of the tracking estimate's exponential forgetting (0 = forget nothing)")
          .def(o.memory).unit("s").at_least(0),
      B("warmup", K::Number, "no change reported in the first seconds (once the filter settled) and after each change")
          .def(o.warmup).unit("s").at_least(0),
      B("block", K::Number, "length of the change test's blocks (mean residual per row)").def(o.block).unit("s").above(0),
      B("cusum-drift", K::Number, "the change test's drift, in block standard deviations (half the shift it is built for)")
          .def(o.cusum_drift).at_least(0),
      B("cusum-threshold", K::Number, "the change test's threshold (larger: fewer false alarms, later detection)")
          .def(o.cusum_threshold).above(0),
      B("no-changes", K::Flag, "no change detection: one segment, the tracking estimate only follows"),
      B("report", K::String, "write DIR/report.html: the changes, the segments and the tracking estimate over time "
                             "(one self-contained page, docs/report.md)").text("none").cli(),
      out_file("write the result JSON (changes, segments, track)"),
      json_flag(),
      quiet_flag(),
  };
}

Defs simulate_options() {
  const SimulationOptions s;
  const ControllerOptions c;
  return {
      B("trajectory", K::String,
        "reference: a trajectory JSON file (from `quadid design`), table2, circle1, circle2, circle3, or circle "
        "(eq. 44 with --radius/--altitude)")
          .positional().required(),
      B("radius", K::Number, "circle radius (with --trajectory circle)").unit("m").text("0.5"),
      B("altitude", K::Number, "circle altitude rho of eq. (44) (with --trajectory circle)").unit("m").text("1"),
      B("duration", K::Number, "flight length").def(s.duration).unit("s"),
      out_file("flight log CSV to write (atomically)"),
      B("truth", K::String, "also write the true state (CSV, same instants) to this file").text("none").cli(),
      B("ulog", K::String,
        "with --vehicle whose rotors take commands: also write the flight as a PX4 ULog (PX4's topics, frames and "
        "motor order; the commands in actuator_motors, the geometry as CA_ROTOR* parameters)")
          .text("none").cli(),
      B("plant", K::String, "the simulated vehicle: qball2-virtual (Table 3 LS), qball2-nominal or a parameters JSON")
          .def("qball2-virtual").text("qball2-virtual; with --vehicle its [nominal]"),
      B("controller-params", K::String,
        "the controller's model (its mass enters eq. 32): qball2-nominal (m = 1.79 kg), qball2-virtual or a JSON")
          .def("qball2-nominal").text("qball2-nominal; with --vehicle its [nominal]"),
      B("torque-map", K::String,
        "eq. (31) map from Euler-angle PID output to body torque: WT (W(eta)^T, power-consistent) or WinvT "
        "(W(eta)^-T, as printed)")
          .def("WT").choices({"WT", "WinvT"}),
      B("derivative", K::String, "discretization of D(s) = 20 s/(s + 20) at the controller rate")
          .def("tustin").choices({"tustin", "backward-euler"}),
      B("fz-max", K::Number, "thrust saturation (0 <= Fz <= this)").def(c.Fz_max).unit("N"),
      B("tau-max", K::Number, "torque saturation |tau_i|").def(c.tau_max).unit("N m"),
      B("noise", K::String,
        "sensor noise profile: default (motion capture 0.3 mm / 0.1 deg yaw; IMU 0.05 deg roll/pitch, 0.0014 rad/s "
        "gyro) or none")
          .def("default").choices({"default", "none"}),
      B("sigma-position", K::Number, "override: mocap position noise std").unit("m").text("the --noise profile's"),
      B("sigma-yaw", K::Number, "override: mocap yaw noise std").unit("rad").text("the --noise profile's"),
      B("sigma-attitude", K::Number, "override: IMU roll/pitch noise std").unit("rad").text("the --noise profile's"),
      B("sigma-gyro", K::Number, "override: gyro noise std per sample").unit("rad/s").text("the --noise profile's"),
      B("sigma-velocity", K::Number, "override: velocity noise std (--velocity-source truth)")
          .unit("m/s").text("the --noise profile's"),
      B("sigma-yaw-rate", K::Number, "override: yaw-rate noise std (--velocity-source truth)")
          .unit("rad/s").text("the --noise profile's"),
      B("velocity-source", K::String,
        "controller's velocity and yaw rate: mocap-difference (difference of successive 30 Hz samples) or truth "
        "(true value sampled at the mocap rate + noise)")
          .def("mocap-difference").choices({"mocap-difference", "truth"}),
      B("seed", K::Integer, "noise seed; same seed and options -> byte-identical log").def("1").at_least(0),
      B("rate", K::Number,
        "controller (and log) rate; the sensor rates are capped at it and the RK4 step becomes the divisor of its "
        "period nearest 1 ms")
          .unit("Hz").text("500, or the vehicle's"),
      B("dt", K::Number, "plant RK4 step (the controller period must be a whole multiple)")
          .unit("s").text("0.001, or as --rate implies"),
      B("mocap-rate", K::Number, "motion-capture rate for x y z psi (at most --rate)").unit("Hz").text("30"),
      B("imu-rate", K::Number, "IMU rate for phi theta p q r (at most --rate)").unit("Hz").text("500"),
      B("actuator-tau", K::Number, "first-order actuator lag time constant (0 = ideal)").def(s.actuator_tau).unit("s"),
      B("g", K::Number, "gravity (plant and controller)").def(s.g).unit("m/s^2"),
      B("summary-from", K::Number, "start of the window for the RMS tracking errors").def(s.summary_from).unit("s"),
      B("speedup", K::Number,
        "play the trajectory this many times faster (same path; velocities x S, accelerations x S^2; Fourier "
        "trajectories only), e.g. for a small vehicle")
          .def(1.0).above(0),
      B("sigma-rotor", K::Number,
        "with --vehicle: noise std on the logged rotor speeds, rad/s or rpm (overrides [sensors] rotor_noise)")
          .text("the vehicle's [sensors] rotor_noise").at_least(0),
      B("sigma-accel", K::Number,
        "log the accelerometer too: ax_b ay_b az_b (specific force, body FLU, at the centre of mass) with this "
        "noise std (e.g. 0.03), for --force-from accelerometer")
          .unit("m/s^2").text("no accelerometer columns").at_least(0),
      B("vehicle", K::String,
        "fly a vehicle with rotor-level actuation: a vehicle file or built-in (" + builtin_vehicle_list() +
            "); plant and controller model = its [nominal], gains scaled to it (docs/vehicles.md); the log gains "
            "its rotor columns")
          .text("none: the paper's QBall 2 with wrench actuation"),
      B("payload-change", K::List,
        "change the plant's mass mid-flight, unknown to the controller: T:DM (s, kg; 25:0.2 picks up 0.2 kg at "
        "25 s, 25:-0.2 drops it), T:DM:X,Y,Z (the payload's centre of mass from the vehicle's, m, body FLU) or "
        "T:DM:X,Y,Z:IXX,IYY,IZZ (and its own principal moments, kg m^2); the truth gains m Ixx..Izz (repeatable)")
          .text("none"),
      json_flag("print the summary as JSON on stdout (nothing else there)"),
      quiet_flag(),
  };
}

Defs design_options() {
  const DesignOptions o;
  return Defs{
             out_file("write the trajectory JSON here (atomically)"),
             json_flag("print the trajectory JSON on stdout instead of the tables"),
             quiet_flag("no progress on stderr"),
             B("seed", K::Integer, "seed of the random starts (std::mt19937_64)").def(num(static_cast<double>(o.seed))).at_least(0),
             B("starts", K::Integer, "number of random starts").def(num(o.starts)),
             B("threads", K::Integer, "worker threads; 0 = one per core (result does not depend on it)")
                 .def(num(o.threads)).at_least(0),
             B("criterion", K::String,
               "cond | cond-scaled | dopt | precision (the worst relative standard error of LS for the vehicle and "
               "sensors of --vehicle, --sigma-*)")
                 .def("cond").choices({"cond", "cond-scaled", "dopt", "precision"}),
             B("scaling-set", K::String,
               "parameter set scaling cond-scaled and dopt (and flown by precision): preset (qball2-nominal, "
               "qball2-virtual) or params JSON")
                 .def("qball2-nominal")
                 .text("qball2-nominal; with --vehicle its [nominal]; with precision the set flown")
                 .alias("reference"),
             B("harmonics", K::Integer, "number of harmonics N of eq. (18)").def(num(o.harmonics)),
             B("wf-deg", K::Number, "fundamental frequency w_f (36 deg/s = 10 s period)")
                 .def("36").text("36; with --vehicle from its bandwidth").unit("deg/s").alias("wf"),
             B("thrust-margin", K::Number,
               "with --vehicle: fraction of each rotor's largest thrust left to the controller")
                 .text("the vehicle file's limits.thrust_margin, else 0.2"),
             B("thrust-min", K::Number, "with --vehicle: lowest thrust of a rotor, fraction of its largest")
                 .text("limits.thrust_min, else 0.05"),
             B("max-evals", K::Integer, "SLSQP evaluations per round of one start").def(num(o.max_evals)),
             B("check-dt", K::Number, "grid on which the limits are imposed and checked").def(o.check_dt).unit("s"),
             B("cond-dt", K::Number, "sampling period T of W for the reported criteria (eq. 20)").def(o.cond_dt).unit("s"),
         } +
         limit_group() + precision_group() +
         Defs{B("export", K::String,
                "also write the flight for an autopilot (take-off, settle, trajectory, landing): .csv setpoints, "
                ".poly.csv Crazyflie polynomial, .py MAVSDK script (docs/fly-it.md)")
                  .text("none")
                  .cli()} +
         export_group();
}

Defs check_options() {
  const CheckOptions o;
  return Defs{
             B("trajectory", K::String, "trajectory JSON file, or built-in: table2, circle1..3")
                 .positional().required().cli(),
             json_flag("print the report as JSON on stdout (SI units, radians)"),
             B("strict", K::Flag, "exit with status 2 when a limit or start/end condition fails").cli(),
             quiet_flag(),
             B("check-span", K::Number, "seconds checked; 0 = one period").def(o.duration).unit("s").alias("duration"),
             B("check-dt", K::Number, "grid of the limit check").def(o.constraint_dt).unit("s"),
             B("cond-dt", K::Number, "sampling period T of W (eq. 20)").def(o.cond_dt).unit("s"),
             B("endpoint-tol", K::Number, "tolerance of the start/end conditions, SI units").def(o.endpoint_tol),
         } +
         limit_group() + precision_group();
}

Defs validate_options() {
  return Defs{
             B("log", K::String, "flight log: CSV, PX4 ULog or Crazyflie uSD file").positional().required().cli(),
             B("params", K::List,
               "a parameter set to judge (repeatable): params JSON, identify result JSON (its sets LS, GD, FMLS, "
               "FMGD, PC, FMPC), or preset qball2-nominal|qball2-virtual")
                 .required(),
             reference_option("the set improvements are measured against (P_imp%)"),
             B("vehicle", K::String,
               "the wrench from the log's rotor columns by the vehicle's rotor model, as identify --vehicle computes "
               "it (built-in: " + builtin_vehicle_list() +
                   ", or a vehicle file): judge sets identified on one flight by their output prediction error on "
                   "another, each with the real-flight terms and timing identify found for it (not the flight's own "
                   "offsets and wind); no simulation comparison")
                 .text("none: the log's Fz and torque columns"),
             B("trajectory", K::String, "reference to re-fly (table2, circle1..3, or a trajectory JSON)")
                 .text("the one the log records"),
             B("window", K::Window, "window of the simulation comparison, seconds from the log's start").def("10:50"),
             B("error-window", K::Window, "window of the prediction error")
                 .text("the whole log, or its part in the air when the log has the vehicle on the ground at an end"),
             B("no-simulation", K::Flag, "skip the simulation comparison"),
             B("with-noise", K::Flag, "re-fly with the log's sensor noise and seed (default: noise-free)"),
             B("ignore-input-errors", K::Flag,
               "with --vehicle: a rotor-mapping mismatch (the log's rotor columns against the vehicle file's "
               "arrangement, as identify checks it) is a warning instead of an error"),
         } +
         processing_group() +
         Defs{out_file("write the results as JSON"), json_flag("print the results as JSON on stdout (nothing else there)"),
              quiet_flag()};
}

Defs batch_options() {
  // FleetSummaryOptions{} (batch.hpp; the batch module builds on this one)
  Defs own = {
      B("log", K::List, "flight logs (repeatable)").positional().cli().text("none"),
      B("list", K::String, "file with one log path per line ('-' = stdin; '#' comments)").text("none").cli(),
      out_file("write the JSON Lines here (atomically, at the end) instead of stdout"),
      B("threads", K::Integer, "worker threads; 0 = one per core").def("0").at_least(0).cli(),
      quiet_flag("no progress and no comparison of the flights on stderr"),
      B("summary", K::String,
        "write the comparison of the flights here as JSON (atomically): per parameter mean, standard deviation, "
        "standard errors; the flights that depart from the others")
          .text("none")
          .cli(),
      B("report", K::String,
        "write DIR/index.html: the flights compared (the same numbers as --summary), each parameter over the "
        "flights with their intervals, every log with its warnings; and DIR/flights/NNN-NAME.html, each log's own "
        "page as identify --report writes it (self-contained, works offline; docs/report.md)")
          .text("none")
          .cli(),
      B("summary-set", K::String,
        "the set compared across the flights: recommended (each flight's) or LS, GD, FMLS, FMGD, PC, FMPC")
          .def("recommended").cli(),
      B("outlier-level", K::Number,
        "the chance that the comparison flags any flight when all are of one vehicle (a flight is flagged on a "
        "parameter when its leave-one-out t against the others is beyond the critical value)")
          .def(0.01).cli(),
  };
  // identify's options: the same names, defaults and checks (identify_options_from_json reads them).
  for (const OptionDef& d : identify_options())
    if (d.scope == OptionScope::Both) own.push_back(d);
  return own;
}

Defs montecarlo_options() {
  const MonteCarloOptions m;
  return Defs{
             B("runs", K::Integer, "number of flights").def(num(m.runs)),
             B("threads", K::Integer, "worker threads (0 = all cores)").def(num(m.threads)).at_least(0),
             B("seed", K::Integer, "master seed; run i uses splitmix64(seed, i)").def("1").at_least(0),
             B("trajectory", K::String, "table2, circle1..circle3 or a trajectory JSON file").def(m.trajectory),
             B("duration", K::Number, "flight length").def(m.simulation.duration).unit("s"),
             B("noise", K::String, "sensor noise preset").def("default").choices({"default", "none"}),
             B("plant", K::String, "the true vehicle (preset or params JSON)")
                 .def("qball2-virtual").text("qball2-virtual; with --vehicle its [nominal]"),
             reference_option("reference set of identify"),
             B("vehicle", K::String,
               "fly a vehicle with its rotors (built-in: " + builtin_vehicle_list() +
                   ", or a vehicle file): plant, gains and sensors from it, the wrench of each run from its noisy "
                   "rotor columns, gradient descent with the normalized gain (docs/vehicles.md)")
                 .text("none: the paper's QBall 2"),
             B("sigma-rotor", K::Number,
               "with --vehicle: std of the white noise on the logged rotor speeds, rad/s or rpm")
                 .text("the vehicle's [sensors] rotor_noise, else 0")
                 .alias("rotor-noise")
                 .at_least(0),
             B("window", K::Window,
               "estimation window T0:T1 (s); shorter flights than 50 s without it: 10 s to the end (the whole "
               "flight under 20 s)")
                 .def("10:50"),
         } +
         processing_group() +
         Defs{out_file("folder for montecarlo.json, runs.csv, summary.txt, histogram_*.svg, index.html"),
              json_flag(), quiet_flag("no progress on stderr (notes about the flights stay)")};
}

Defs reproduce_options() {
  return {
      B("out", K::String, "output folder (created if needed)").shorthand("o").def("reproduction").cli(),
      B("seed", K::Integer, "seed of the design's random starts and of the sensor noise").def("1").at_least(0).cli(),
      B("trajectory", K::String, "designed (optimize it) or table2 (the paper's coefficients)")
          .def("designed").choices({"designed", "table2"}).cli(),
      B("duration", K::Number,
        "seconds of every flight; windows 10-50 s (identification, Table 4) and 0-50 s (Tables 5-12) shrink in "
        "proportion for shorter flights")
          .def(50.0).unit("s").cli(),
      B("starts", K::Integer, "random starts of the trajectory design").def("8").cli(),
      B("noise", K::String, "sensor noise of the virtual experiments").def("default").choices({"default", "none"}).cli(),
      json_flag("print summary.json on stdout instead of the tables"),
      B("full-logs", K::Flag,
        "also write the circle experiments' and the Table 4 re-flights' logs (flight_circle1..3.csv, "
        "simulation_<set>.csv: ~70 MB more for 50 s flights)")
          .cli(),
      quiet_flag("no progress on stderr"),
  };
}

Defs import_options() {
  const logs::ImportOptions o;
  return {
      B("log", K::String, "PX4 ULog (.ulg), Crazyflie uSD or ArduPilot DataFlash (.bin) log").positional().required().cli(),
      B("out", K::String, "flight log CSV to write").shorthand("o").required().cli(),
      B("rate", K::Number, "grid rate; below 4 x identify's default cutoffs (32 Hz with rotor signals, 16 Hz "
                           "without) it is refused unless --allow-slow-rate")
          .def(o.rate_hz).unit("Hz").cli(),
      B("allow-slow-rate", K::Flag, "accept a --rate below 4 x identify's default cutoffs (then identify the CSV with "
                                    "--cutoff-moment and --cutoff-force at most a quarter of the rate)").cli(),
      B("aa-order", K::Integer, "anti-aliasing Butterworth order").def(num(o.aa_order)).cli(),
      B("aa-fraction", K::Number, "anti-aliasing cutoff as a fraction of --rate").def(o.aa_fraction).cli(),
      B("max-bridge", K::Number, "longest gap bridged by interpolation").def(o.max_bridge_s).unit("s").cli(),
      B("gap-factor", K::Number, "a gap is longer than this x the topic's median period").def(o.gap_factor).cli(),
      B("on-gap", K::String, "a longer gap: longest (keep the longest part) or refuse")
          .def("longest").choices({"longest", "refuse"}).cli(),
      B("position-topic", K::String, "PX4 position topic (NED); ArduPilot: XKF1 (the default), XKF1[CORE] or POS")
          .def(o.position_topic).cli(),
      B("attitude-topic", K::String, "PX4 attitude quaternion topic; ArduPilot: ATT (the default; ANG when it has "
                                     "more records), ANG or XKF1").def(o.attitude_topic).cli(),
      B("rates-topic", K::String, "PX4 body-rate topic (FRD); ArduPilot: IMU (the default) or IMU[INSTANCE]")
          .def(o.rates_topic).cli(),
      B("motors", K::String, "PX4 rotor topic: auto (actuator_motors, else esc_status, else actuator_outputs), a "
                             "topic, or none")
          .def(o.motors_topic).cli(),
      B("pose", K::String, "Crazyflie pose: auto (mocap when logged), mocap or estimate")
          .def(o.crazyflie_pose).choices({"auto", "mocap", "estimate"}).cli(),
      B("allow-truncated", K::Flag, "kept for old scripts: a file cut mid-record (a crash) is always read to its "
                                    "last complete record, with a warning").cli(),
      json_flag("print the import report as JSON on stdout (nothing else there)"),
      quiet_flag(),
  };
}

Defs log_info_options() {
  return {
      B("log", K::String, "PX4 ULog (.ulg), Crazyflie uSD or ArduPilot DataFlash (.bin) log").positional().required().cli(),
      B("verbose", K::Flag, "ULog: also perf_* info messages and the multi-info values").shorthand("v").cli(),
      B("allow-truncated", K::Flag, "ULog: accept a last message cut short (logger stopped by a power loss)").cli(),
      json_flag("print JSON on stdout (nothing else there)"),
      quiet_flag(),
  };
}

Defs export_options() {
  return Defs{
             B("trajectory", K::String, "trajectory JSON file, or built-in: table2").positional().required().cli(),
             B("out", K::String, "file to write (its name chooses the format)").shorthand("o").required().cli(),
             json_flag("print the summary as JSON on stdout (files, segments, pieces, fit)"),
             quiet_flag(),
         } +
         export_group();
}

Defs model_options() {
  return {
      B("result", K::String, "identify's result JSON (quadid identify LOG -o RESULT.json)").positional().required().cli(),
      B("format", K::String, "the simulator's format: " + fmt::format("{}", fmt::join(model_format_names(), " | ")))
          .choices(model_format_names())
          .required()
          .cli(),
      B("out", K::String, "file to write (atomically)").shorthand("o").text("stdout").cli(),
      B("set", K::String, "the parameter set to write (LS, FMLS, PC, FMPC, GD, FMGD)").text("the result's recommended set").cli(),
      B("sih-scale", K::Number,
        "px4-sih: mass, inertia, thrust, torque, drag and damping times this factor (every acceleration unchanged), "
        "for a vehicle too small for SIH's inverse of its inertia")
          .def(1.0)
          .above(0)
          .cli(),
      B("gazebo", K::String, "sdf: gz (gz-sim's MulticopterMotorModel) or classic (PX4 SITL_gazebo-classic's motor plugin)")
          .def("gz")
          .choices({"gz", "classic"})
          .cli(),
      B("flavour", K::String, "urdf: none (plain URDF) or gym-pybullet-drones (its <properties>, its element order)")
          .def("none")
          .choices({"none", "gym-pybullet-drones"})
          .cli(),
      B("mjcf-motor-lag", K::Flag,
        "mjcf: each motor a first-order filter actuator with the rotors' time constant (default: thrust at once)")
          .cli(),
      quiet_flag(),
  };
}

OptionTable make(std::string command, Defs defs) {
  OptionTable t{std::move(command), std::move(defs)};
  // A programming error caught by every test: two options (or aliases) of one name.
  std::map<std::string, int> seen;
  for (const auto& d : t.options) {
    ++seen[d.name];
    for (const auto& a : d.aliases) ++seen[a];
  }
  for (const auto& [n, k] : seen)
    if (k > 1) throw std::logic_error(fmt::format("option table of {}: --{} declared {} times", t.command, n, k));
  return t;
}

}  // namespace

std::string OptionDef::range_text() const {
  const bool lo = min > -std::numeric_limits<double>::infinity(), hi = max < std::numeric_limits<double>::infinity();
  if (lo && hi) return fmt::format("{}{}, {}{}", min_open ? "(" : "[", min, max, max_open ? ")" : "]");
  if (lo) return fmt::format("{} {}", min_open ? ">" : ">=", min);
  if (hi) return fmt::format("{} {}", max_open ? "<" : "<=", max);
  return {};
}

std::string OptionDef::full_help() const {
  std::string h = help;
  if (!unit.empty()) h += fmt::format(" [{}]", unit);
  if (kind == OptionKind::Flag) return h;
  const std::string& d = default_text.empty() ? default_value : default_text;
  if (!d.empty()) h += fmt::format(" (default: {})", d);
  else h += " (default: none)";
  return h;
}

const OptionDef* OptionTable::find(std::string_view name) const {
  const std::string n = normalize_option_key(name);
  for (const auto& d : options)
    if (d.name == n) return &d;
  return alias_of(n);
}

const OptionDef* OptionTable::alias_of(std::string_view name) const {
  const std::string n = normalize_option_key(name);
  for (const auto& d : options)
    for (const auto& a : d.aliases)
      if (a == n) return &d;
  return nullptr;
}

const std::vector<std::string>& option_commands() {
  static const std::vector<std::string> c = {"design",   "check-trajectory", "simulate", "identify",
                                             "validate", "reproduce",        "import",   "log-info",
                                             "batch",    "montecarlo",       "export",   "model",
                                             "follow"};
  return c;
}

const OptionTable& option_table(std::string_view command) {
  static const std::map<std::string, OptionTable, std::less<>> tables = [] {
    std::map<std::string, OptionTable, std::less<>> m;
    m.emplace("identify", make("identify", identify_options()));
    m.emplace("simulate", make("simulate", simulate_options()));
    m.emplace("design", make("design", design_options()));
    m.emplace("check-trajectory", make("check-trajectory", check_options()));
    m.emplace("validate", make("validate", validate_options()));
    m.emplace("batch", make("batch", batch_options()));
    m.emplace("montecarlo", make("montecarlo", montecarlo_options()));
    m.emplace("reproduce", make("reproduce", reproduce_options()));
    m.emplace("import", make("import", import_options()));
    m.emplace("log-info", make("log-info", log_info_options()));
    m.emplace("export", make("export", export_options()));
    m.emplace("model", make("model", model_options()));
    m.emplace("follow", make("follow", follow_options()));
    return m;
  }();
  const auto it = tables.find(command);
  if (it == tables.end()) throw std::invalid_argument(fmt::format("no options table for command '{}'", command));
  return it->second;
}

std::string normalize_option_key(std::string_view key) {
  std::string s(key);
  while (!s.empty() && s.front() == '-') s.erase(s.begin());
  while (!s.empty() && s.back() == '_') s.pop_back();
  std::replace(s.begin(), s.end(), '_', '-');
  return s;
}

std::string deprecation_message(const OptionDef& def, std::string_view old_name) {
  return fmt::format("--{} is now --{}; the old spelling still works", old_name, def.name);
}

}  // namespace quadid
