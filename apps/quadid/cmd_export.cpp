// quadid export: a trajectory (designed JSON or built-in) -> the whole flight
// (take-off, settle, excitation, settle, landing) for an autopilot: setpoint
// CSV, Crazyflie piecewise polynomial, or MAVSDK-Python offboard script.
#include "commands.hpp"
#include "options_cli.hpp"
#include "quadid/pipeline.hpp"
#include "quadid/io.hpp"

#include <fmt/format.h>

#include <memory>

namespace quadid::cli {

namespace {

void run(const OptionValues& v) {
  const std::string spec = *v.string("trajectory"), out = *v.string("out");
  std::shared_ptr<const Trajectory> traj = load_trajectory(spec);
  const ExportSummary s = export_flight(traj, out, export_options(v), {fmt::format("quadid export of {}", spec)});
  if (v.flag("json")) fmt::print("{}\n", to_json(s).dump(2));
  else fmt::print("{}", format_export_summary(s));
}

}  // namespace

void register_export(CLI::App& app) {
  auto* sub = app.add_subcommand(
      "export", "a trajectory -> setpoints / Crazyflie polynomial / PX4 MAVSDK script, with take-off and landing");
  sub->footer(
      "Writes the flight: take-off from (x0, y0, --ground-z) to the trajectory's start (a rest-to-rest\n"
      "polynomial, peak speed --climb-speed), hover --settle s, --cycles periods of the trajectory, hover,\n"
      "landing. Formats (from the file name, or --export-format):\n"
      "  .csv       setpoints t,x,y,z,vx,vy,vz,ax,ay,az,yaw,yaw_rate every 1/--export-rate s (SI, z up)\n"
      "  .poly.csv  Crazyflie poly4d pieces (Crazyswarm CSV: Duration,x^0..x^7,y^0..,z^0..,yaw^0..yaw^7)\n"
      "  .py        MAVSDK-Python script flying the setpoints in PX4 offboard mode (+ FILE.csv beside it)\n"
      "Files are written atomically. See docs/fly-it.md.\n\n"
      "Examples:\n"
      "  quadid export table2 -o flight.csv\n"
      "  quadid export traj.json -o flight.poly.csv --piece 0.5");
  auto given = add_table_options(sub, "export");
  sub->callback([given] { run(given->read()); });
}

}  // namespace quadid::cli
