// The model formats by name, and the dispatch to each target's writer (include/quadid/models.hpp).
#include "common.hpp"

#include <fmt/ranges.h>

#include <stdexcept>

namespace quadid {

std::vector<std::string> model_format_names() { return {"vehicle", "mjcf", "rotorpy", "urdf"}; }

ModelFormat parse_model_format(std::string_view name) {
  if (name == "vehicle") return ModelFormat::kVehicle;
  if (name == "mjcf") return ModelFormat::kMjcf;
  if (name == "rotorpy") return ModelFormat::kRotorpy;
  if (name == "urdf") return ModelFormat::kUrdf;
  throw std::invalid_argument(fmt::format("model format '{}': expected one of {}", name, fmt::join(model_format_names(), ", ")));
}

std::string to_string(ModelFormat f) { return model_format_names().at(static_cast<size_t>(f)); }

std::string model_text(const IdentifiedModel& m, ModelFormat f) {
  switch (f) {
    case ModelFormat::kVehicle: return models_detail::vehicle_toml(m);
    case ModelFormat::kMjcf: return models_detail::mjcf(m);
    case ModelFormat::kRotorpy: return models_detail::rotorpy(m);
    case ModelFormat::kUrdf: return models_detail::urdf(m);
  }
  throw std::logic_error("model_text: unknown format");
}

}  // namespace quadid
