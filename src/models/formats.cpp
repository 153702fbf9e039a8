// The model formats by name, and the dispatch to each target's writer (include/quadid/models.hpp).
#include "common.hpp"

#include <fmt/ranges.h>

#include <cmath>
#include <stdexcept>

namespace quadid {

std::vector<std::string> model_format_names() { return {"vehicle", "mjcf", "rotorpy", "urdf", "px4-sih", "px4-sih-qgc", "sdf", "sdf-classic", "ardupilot-sitl"}; }

void ModelOptions::validate() const {
  if (!(sih_scale > 0.0) || !std::isfinite(sih_scale))
    throw std::invalid_argument(fmt::format("sih_scale = {}: must be a positive factor", sih_scale));
  if (!urdf_flavour.empty() && urdf_flavour != "gym-pybullet-drones")
    throw std::invalid_argument(fmt::format("urdf_flavour = '{}': expected '' or gym-pybullet-drones", urdf_flavour));
}

ModelFormat parse_model_format(std::string_view name) {
  if (name == "vehicle") return ModelFormat::kVehicle;
  if (name == "mjcf") return ModelFormat::kMjcf;
  if (name == "rotorpy") return ModelFormat::kRotorpy;
  if (name == "urdf") return ModelFormat::kUrdf;
  if (name == "px4-sih") return ModelFormat::kPx4Sih;
  if (name == "px4-sih-qgc") return ModelFormat::kPx4SihQgc;
  if (name == "sdf") return ModelFormat::kSdf;
  if (name == "sdf-classic") return ModelFormat::kSdfClassic;
  if (name == "ardupilot-sitl") return ModelFormat::kArdupilotSitl;
  throw std::invalid_argument(fmt::format("model format '{}': expected one of {}", name, fmt::join(model_format_names(), ", ")));
}

std::string to_string(ModelFormat f) { return model_format_names().at(static_cast<size_t>(f)); }

std::string model_text(const IdentifiedModel& m, ModelFormat f, const ModelOptions& opt) {
  opt.validate();
  switch (f) {
    case ModelFormat::kVehicle: return models_detail::vehicle_toml(m);
    case ModelFormat::kMjcf: return models_detail::mjcf(m, opt.mjcf_motor_lag);
    case ModelFormat::kRotorpy: return models_detail::rotorpy(m);
    case ModelFormat::kUrdf:
      return opt.urdf_flavour.empty() ? models_detail::urdf(m) : models_detail::gym_pybullet_urdf(m);
    case ModelFormat::kPx4Sih: return models_detail::px4_sih(m, opt, false);
    case ModelFormat::kPx4SihQgc: return models_detail::px4_sih(m, opt, true);
    case ModelFormat::kSdf: return models_detail::sdf(m, false);
    case ModelFormat::kSdfClassic: return models_detail::sdf(m, true);
    case ModelFormat::kArdupilotSitl: return models_detail::ardupilot_sitl(m);
  }
  throw std::logic_error("model_text: unknown format");
}

std::vector<std::string> model_warnings(const IdentifiedModel& m, ModelFormat f, const ModelOptions& opt) {
  opt.validate();
  if (f == ModelFormat::kPx4Sih || f == ModelFormat::kPx4SihQgc) return models_detail::px4_sih_warnings(m, opt);
  if (f == ModelFormat::kUrdf && !opt.urdf_flavour.empty()) return models_detail::gym_pybullet_warnings(m);
  return {};
}

}  // namespace quadid
