// quadid models: the identified vehicle written for the simulators people use
// (issue 39; docs/models.md). The input is identify's result JSON; the output
// a text in the target's own format: a quadid vehicle file, a MuJoCo MJCF
// model, a RotorPy quad_params dict, a URDF. Each target's frame and sign
// conversions live in one function of src/models/ (a new target: one file there).
#pragma once

#include "quadid/core.hpp"
#include "quadid/model.hpp"
#include "quadid/vehicle.hpp"

#include <nlohmann/json.hpp>

#include <array>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

namespace quadid {

/// What identify's result says of the identified vehicle (docs/file-formats.md,
/// "Identification result"). SI units, body FLU about the centre of mass.
struct IdentifiedModel {
  std::string set;          // the set written: LS, FMLS, PC, FMPC, GD, FMGD
  std::string reason;       // why that set: "the result's recommended set" or "chosen by name"
  std::string vehicle;      // the vehicle's name ("" for a log with its own wrench columns)
  std::string source;       // the result file
  Params params;            // m (kg), I (kg m^2)
  /// 95 % intervals per Theta entry (m Ixx Ixy Ixz Iyy Iyz Izz) when the set has them.
  std::optional<std::array<std::pair<double, double>, 7>> ci95;
  /// The rotor model identify used, with the identified thrust scale folded into
  /// kf and thrust_max (the torques scale with them): absent without a vehicle.
  std::optional<RotorModel> rotors;
  double thrust_scale = 1.0;  // folded in above (1: not estimated)
};

/// Reads a result JSON. `set` empty: the recommended set. Throws InputError
/// naming the file and the field (an unknown set lists those the file holds).
IdentifiedModel identified_model_from_json(const nlohmann::ordered_json& result, const std::string& source,
                                           const std::string& set = "");
/// The same from a file.
IdentifiedModel load_identified_model(const std::string& path, const std::string& set = "");

enum class ModelFormat { kVehicle, kMjcf, kRotorpy, kUrdf, kPx4Sih, kPx4SihQgc, kSdf, kSdfClassic, kArdupilotSitl };
/// "vehicle", "mjcf", "rotorpy", "urdf", "px4-sih" (a `param set` script),
/// "px4-sih-qgc" (a QGroundControl .params file), "sdf" (Gazebo, gz-sim's
/// MulticopterMotorModel), "sdf-classic" (PX4 SITL_gazebo-classic's motor
/// plugin), "ardupilot-sitl" (SITL's frame JSON); throws std::invalid_argument listing them.
ModelFormat parse_model_format(std::string_view name);
std::string to_string(ModelFormat f);
/// The formats' names, in the order above.
std::vector<std::string> model_format_names();

struct ModelOptions {
  /// PX4 SIH only: every mass, inertia, thrust, torque, drag and damping
  /// parameter multiplied by this factor (> 0). Every acceleration stays the
  /// same; a small vehicle's tensor then clears SIH's determinant threshold
  /// (model_warnings names the factor needed). 1: as identified.
  double sih_scale = 1.0;
  /// MJCF only: each motor a first-order filter actuator (MuJoCo dyntype
  /// "filter", its time constant the rotors' time_constant) in place of a
  /// motor that gives the commanded thrust at once.
  bool mjcf_motor_lag = false;
  /// URDF only: "" (plain URDF) or "gym-pybullet-drones" (its <properties>
  /// and the element order its parser reads by position).
  std::string urdf_flavour;
  /// Throws std::invalid_argument naming the field.
  void validate() const;
};

/// The model as the target's text. Values the identification did not give and
/// the vehicle file does not hold are left out (with a comment), never
/// invented; a target that needs one refuses, naming it.
std::string model_text(const IdentifiedModel& m, ModelFormat f, const ModelOptions& opt = {});

/// What the target will do differently from the identified vehicle, beyond
/// what the text's comments say (e.g. SIH's inertia below its determinant
/// threshold): one sentence each, naming the fix. Empty when nothing.
std::vector<std::string> model_warnings(const IdentifiedModel& m, ModelFormat f, const ModelOptions& opt = {});

}  // namespace quadid
