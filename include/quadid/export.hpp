// Export of a designed trajectory for an autopilot (issue 14, item 3): the
// whole flight (take-off from the ground, hover to settle, the excitation
// trajectory, hover, landing) as
//   - setpoints (CSV): t, x, y, z, vx, vy, vz, ax, ay, az, yaw, yaw_rate at a
//     chosen rate, SI units and radians, inertial frame z up (docs/conventions.md);
//   - the Crazyflie's piecewise-polynomial trajectory (poly4d: pieces of a
//     duration and 8 coefficients, powers 0..7 of the time since the piece's
//     start, for each of x, y, z, yaw), in Crazyswarm's CSV layout
//     Duration,x^0..x^7,y^0..y^7,z^0..z^7,yaw^0..yaw^7, which crazyflie-lib-python's
//     Uploader (trajectory memory) and Crazyswarm's uploadTrajectory load;
//   - a MAVSDK-Python script that flies the setpoint CSV in PX4 offboard mode
//     (converted to NED on the fly).
// See docs/fly-it.md.
#pragma once

#include "quadid/trajectory.hpp"

#include <nlohmann/json.hpp>

#include <array>
#include <filesystem>
#include <memory>
#include <string>
#include <string_view>
#include <vector>

namespace quadid {

/// The flight around the excitation trajectory.
struct FlightPlanOptions {
  double ground_z = 0.0;        // m, height of the take-off and landing point (z up)
  double climb_speed = 0.3;     // m/s, peak vertical speed of take-off and landing
  double min_climb_time = 2.0;  // s, shortest take-off (and landing)
  double settle = 3.0;          // s, hover at the start point before and after the excitation
  int cycles = 1;               // periods of the excitation trajectory flown
  /// |velocity| and |acceleration| the excitation must have at its start and end
  /// (it must start and end at rest, as designed trajectories do), SI units.
  double rest_tol = 1e-3;
  /// Throws std::invalid_argument naming the option (command-line spelling).
  void validate() const;
};

/// The whole flight as one trajectory (take-off, settle, cycles x excitation,
/// settle, landing): it can be flown by simulate and sampled by the exports.
/// Take-off and landing are the rest-to-rest polynomial z = z_g + d s(u),
/// s(u) = 35u^4 - 84u^5 + 70u^6 - 20u^7 (velocity, acceleration and jerk 0 at
/// both ends, peak speed 35/16 d / T), so the flight is continuous in position,
/// velocity and acceleration everywhere.
class FlightPlan final : public Trajectory {
 public:
  struct Segment {
    std::string name;   // "takeoff", "settle", "excitation", "settle", "landing"
    double t0 = 0.0, t1 = 0.0;  // s, from the start of the flight
    bool polynomial = false;    // exactly a polynomial of degree <= 7 (one poly4d piece)
  };
  /// Throws std::invalid_argument for bad options, when the excitation does not start
  /// and end at rest, or when it starts below the ground.
  FlightPlan(std::shared_ptr<const Trajectory> excitation, const FlightPlanOptions& opt = {});

  FlatOutput eval(double t) const override;
  std::string describe() const override;
  double period() const override { return total_; }  // the whole flight, s
  const std::vector<Segment>& segments() const { return segments_; }
  /// Time of the excitation's t = 0 within the flight, s.
  double excitation_start() const { return segments_[2].t0; }
  const Trajectory& excitation() const { return *exc_; }
  /// Segment i's own formula at tau s after its start (clamped to the segment): at a
  /// boundary, the value from inside segment i (eval() takes the later segment's).
  FlatOutput eval_segment(size_t i, double tau) const;

 private:
  std::shared_ptr<const Trajectory> exc_;
  FlightPlanOptions opt_;
  FlatOutput start_{}, end_{};
  double climb_ = 0.0, total_ = 0.0;
  std::vector<Segment> segments_;
};

/// Fits the flight with degree-7 pieces: each polynomial segment is one piece (exact),
/// the excitation is cut into pieces of at most `piece` seconds, each the Hermite
/// interpolant matching position, velocity, acceleration and jerk at both ends
/// (so the fit is C3 across pieces). Throws std::invalid_argument if piece <= 0.
std::vector<PolyPiece> fit_polynomial(const FlightPlan& plan, double piece = 0.5);

/// Largest |position| and |yaw| error of `fit` against `traj` on a grid of step dt over [0, traj.period()].
struct FitError {
  double position = 0.0;  // m
  double yaw = 0.0;       // rad
  double velocity = 0.0;  // m/s
};
FitError max_fit_error(const Trajectory& traj, const Trajectory& fit, double dt = 1e-3);

/// Bytes of a poly4d upload (the Crazyflie's trajectory memory holds 4096): 132 per piece.
inline constexpr int kPoly4dBytesPerPiece = 132;
inline constexpr int kCrazyflieTrajectoryMemory = 4096;

/// Rows of setpoints_csv: t = 0, 1/rate, ... up to the first sample at or after the plan's end.
long setpoint_count(const FlightPlan& plan, double rate);
/// Setpoints every 1/rate s from 0 to the plan's end (uniform; the last row at or after
/// the end, landed), with
/// leading '#' comment lines (segments, source), then the header
/// t,x,y,z,vx,vy,vz,ax,ay,az,yaw,yaw_rate. Throws std::invalid_argument if rate <= 0.
std::string setpoints_csv(const FlightPlan& plan, double rate, const std::vector<std::string>& comments = {});
/// Crazyswarm's layout: header Duration,x^0,...,yaw^7, one piece per row.
std::string crazyflie_poly_csv(const std::vector<PolyPiece>& pieces);
/// A MAVSDK-Python script flying the setpoint CSV `csv_name` (a path relative to the
/// script's folder, or absolute) in PX4 offboard mode.
std::string mavsdk_script(const std::string& csv_name);

enum class ExportFormat { Setpoints, Crazyflie, Mavsdk };
/// "setpoints" | "crazyflie" | "mavsdk"; throws std::invalid_argument listing them.
ExportFormat parse_export_format(std::string_view name);
/// From the file name: *.py -> mavsdk, *.poly.csv or *.poly -> crazyflie, *.csv -> setpoints;
/// throws std::invalid_argument (naming `option`) for another extension.
ExportFormat export_format_for(const std::filesystem::path& path, std::string_view option);

struct ExportOptions {
  FlightPlanOptions plan{};
  double rate = 50.0;           // Hz, setpoints
  double piece = 0.5;           // s, longest polynomial piece
  std::string format;           // empty: from the file name
  void validate() const;        // throws std::invalid_argument naming the option
};

struct ExportSummary {
  ExportFormat format = ExportFormat::Setpoints;
  std::vector<std::filesystem::path> files;  // written, atomically
  double duration = 0.0;                     // s, whole flight
  std::vector<FlightPlan::Segment> segments;
  long setpoints = 0;                        // rows of the CSV (setpoints, mavsdk)
  int pieces = 0;                            // crazyflie
  FitError fit;                              // crazyflie: the polynomial against the plan
};

/// Writes the export of `traj` to `path` (the MAVSDK script also writes its setpoint
/// CSV beside it, same name with .csv). Nothing is written on an error.
ExportSummary export_flight(const std::shared_ptr<const Trajectory>& traj, const std::filesystem::path& path,
                            const ExportOptions& opt = {}, const std::vector<std::string>& comments = {});
std::string format_export_summary(const ExportSummary& s);
/// {"format", "files", "duration", "segments": [{"name", "t0", "t1"}], "setpoints" | "pieces", "bytes", "fit"}.
nlohmann::ordered_json to_json(const ExportSummary& s);

}  // namespace quadid
