// quadid model: an identification result -> the identified vehicle in a
// simulator's format (vehicle file, MuJoCo MJCF, RotorPy, URDF).
#include "commands.hpp"
#include "options_cli.hpp"
#include "quadid/io.hpp"
#include "quadid/models.hpp"

#include <fmt/format.h>

namespace quadid::cli {

namespace {

void run(const OptionValues& v) {
  const std::string result = *v.string("result");
  const IdentifiedModel m = load_identified_model(result, v.string("set").value_or(""));
  ModelFormat f = parse_model_format(*v.string("format"));
  if (f == ModelFormat::kSdf && *v.string("gazebo") == "classic") f = ModelFormat::kSdfClassic;  // --gazebo classic
  ModelOptions opt;
  opt.sih_scale = *v.number("sih-scale");
  opt.mjcf_motor_lag = v.flag("mjcf-motor-lag");
  if (const std::string fl = *v.string("flavour"); fl != "none") opt.urdf_flavour = fl;
  const std::string text = model_text(m, f, opt);
  if (!v.flag("quiet"))
    for (const auto& w : model_warnings(m, f, opt)) fmt::print(stderr, "quadid model: warning: {}\n", w);
  const auto out = v.string("out");
  if (!out) {
    fmt::print("{}", text);
    return;
  }
  write_file_atomic(*out, text);
  if (!v.flag("quiet"))
    fmt::print(stderr, "quadid model: wrote {} ({}, set {}{})\n", *out, to_string(f), m.set,
               m.thrust_scale != 1.0 ? fmt::format(", thrust scale {:.5g} folded into kf", m.thrust_scale) : "");
}

}  // namespace

void register_model(CLI::App& app) {
  auto* sub = app.add_subcommand("model", "an identification result -> the identified vehicle for a simulator");
  sub->footer(
      "Writes the recommended set (or --set) of RESULT.json, with the vehicle's rotor model when identify used one\n"
      "(positions, spins, kf with the identified thrust scale folded in, torque ratio, time constant):\n"
      "  vehicle   a quadid vehicle file: quadid simulate --vehicle FILE flies the identified vehicle\n"
      "  mjcf      MuJoCo: a free body with <inertial fullinertia>, a site and a thrust <motor> per rotor\n"
      "  rotorpy   a RotorPy quad_params dict (Python), for rotorpy.vehicles.multirotor.Multirotor\n"
      "  urdf      ROS: base_link <inertial> and a fixed link per rotor\n"
      "  px4-sih   PX4 SIH: SIH_* parameters (FRD) as a param set script; px4-sih-qgc: a QGroundControl .params file\n"
      "  sdf       Gazebo (gz-sim): links, revolute rotor joints, MulticopterMotorModel plugins; with --gazebo classic\n"
      "            (or --format sdf-classic) PX4 SITL_gazebo-classic's libgazebo_motor_model.so\n"
      "  ardupilot-sitl  ArduPilot SITL's frame JSON (diagonal inertia, FRD motor positions, yaw factors, hoverThrOut)\n"
      "Body FLU, SI units; each target's conventions in docs/models.md. Numbers round-trip.\n\n"
      "Examples:\n"
      "  quadid identify flight.ulg --vehicle x500 -o result.json\n"
      "  quadid model result.json --format mjcf -o x500.xml\n"
      "  quadid model result.json --format vehicle --set FMLS -o identified.toml");
  auto given = add_table_options(sub, "model");
  sub->callback([given] { run(given->read()); });
}

}  // namespace quadid::cli
