// The real-flight regression's terms as options (include/quadid/regression.hpp).
#include "quadid/regression.hpp"

#include <fmt/format.h>

#include <cmath>
#include <stdexcept>

namespace quadid {

ModelTerms ModelTerms::real_flight(bool have_rotor_speeds) {
  ModelTerms t;
  t.torque_offsets = true;
  t.flapping = true;
  t.rotor_inertia = have_rotor_speeds;
  t.weight_rows = true;
  return t;
}

ModelTerms parse_model_terms(std::string_view spec, bool have_rotor_speeds) {
  if (spec == "paper") return ModelTerms{};
  if (spec == "real") return ModelTerms::real_flight(have_rotor_speeds);
  ModelTerms t;
  std::string_view rest = spec;
  while (!rest.empty()) {
    const size_t comma = rest.find(',');
    const std::string_view item = rest.substr(0, comma);
    rest = comma == std::string_view::npos ? std::string_view{} : rest.substr(comma + 1);
    if (item == "offsets") t.torque_offsets = true;
    else if (item == "flapping") t.flapping = true;
    else if (item == "damping") t.rate_damping = true;
    else if (item == "rotor-inertia") t.rotor_inertia = true;
    else if (item == "drag") t.force_drag = true;
    else if (item == "wind") t.wind = true;
    else if (item == "weighting") t.weight_rows = true;
    else
      throw std::invalid_argument(fmt::format(
          "--terms {}: '{}' is not a term; expected paper, real, or a comma list of offsets, flapping, damping, "
          "rotor-inertia, drag, wind, weighting",
          spec, item));
  }
  return t;
}

void ModelTerms::validate() const {
  if (known_mass && !(*known_mass > 0.0 && std::isfinite(*known_mass)))
    throw std::invalid_argument(fmt::format("--known-mass {}: must be a positive mass in kg", *known_mass));
  if (known_rotor_inertia && !(*known_rotor_inertia >= 0.0 && std::isfinite(*known_rotor_inertia)))
    throw std::invalid_argument(
        fmt::format("--rotor-inertia {}: must be a rotor's inertia in kg m^2, >= 0", *known_rotor_inertia));
}

}  // namespace quadid
