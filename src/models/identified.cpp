// Reading identify's result JSON into an IdentifiedModel (include/quadid/models.hpp).
#include "quadid/estimation.hpp"
#include "quadid/io.hpp"
#include "quadid/models.hpp"

#include <fmt/format.h>
#include <fmt/ranges.h>

#include <fstream>
#include <sstream>

namespace quadid {
namespace {

using json = nlohmann::ordered_json;

// The real-flight regression a set comes from: LS and PC from the standard
// model's, FMLS and FMPC from the filtered one's; GD and FMGD from none.
std::string regression_of(const std::string& set) {
  if (set == "LS" || set == "PC") return "LS";
  if (set == "FMLS" || set == "FMPC") return "FMLS";
  return "";
}

// The identified thrust scale (true thrust / modelled) of a set, 1 when the
// regression did not estimate one (mass estimated, or no rotor model).
double thrust_scale_of(const json& result, const std::string& set, const std::string& source) {
  const std::string reg = regression_of(set);
  if (reg.empty() || !result.contains("real_flight")) return 1.0;
  const json* p = &result.at("real_flight");
  for (const char* key : {"sets", reg.c_str(), "parameters"}) {
    if (!p->contains(key)) return 1.0;
    p = &p->at(key);
  }
  if (!p->contains("thrust_scale")) return 1.0;
  const double s = json_number(p->at("thrust_scale"), "value", source + ": real_flight.sets." + reg + ".parameters.thrust_scale", true);
  if (!(s > 0.0)) throw InputError(fmt::format("{}: real_flight.sets.{}.parameters.thrust_scale = {} must be positive", source, reg, s));
  return s;
}

std::optional<std::array<std::pair<double, double>, 7>> intervals_of(const json& result, const std::string& set) {
  if (!result.contains("uncertainty") || !result.at("uncertainty").contains(set)) return std::nullopt;
  const json& u = result.at("uncertainty").at(set);
  std::array<std::pair<double, double>, 7> ci{};
  for (size_t i = 0; i < 7; ++i) {
    const char* name = kThetaNames[i];
    if (!u.contains(name) || !u.at(name).contains("ci95")) return std::nullopt;
    const json& c = u.at(name).at("ci95");
    if (!c.is_array() || c.size() != 2 || !c[0].is_number() || !c[1].is_number()) return std::nullopt;
    ci[i] = {c[0].get<double>(), c[1].get<double>()};
  }
  return ci;
}

}  // namespace

IdentifiedModel identified_model_from_json(const json& result, const std::string& source, const std::string& set) {
  if (!result.is_object() || !result.contains("estimates") || !result.at("estimates").is_object())
    throw InputError(fmt::format("{}: not an identification result (no \"estimates\": write one with quadid identify LOG -o "
                                 "RESULT.json)",
                                 source));
  const json& est = result.at("estimates");
  IdentifiedModel m;
  m.source = source;
  if (set.empty()) {
    if (!result.contains("recommended") || !result.at("recommended").contains("set"))
      throw InputError(fmt::format("{}: no \"recommended\".\"set\"; name one with --set", source));
    m.set = result.at("recommended").at("set").get<std::string>();
    m.reason = "the result's recommended set";
  } else {
    m.set = set;
    m.reason = "chosen by name";
  }
  if (!est.contains(m.set)) {
    std::vector<std::string> have;
    for (const auto& [k, v] : est.items()) have.push_back(k);
    throw InputError(fmt::format("{}: no estimate named {} (the file holds {})", source, m.set, fmt::join(have, ", ")));
  }
  m.params = params_from_json(est.at(m.set), fmt::format("{}: estimates.{}", source, m.set), false);
  if (const auto c = check_physical_consistency(m.params.theta()); !c.physical) {
    std::vector<std::string> ok;
    for (const auto& [k, v] : est.items())
      if (check_physical_consistency(params_from_json(v, source, false).theta()).physical) ok.push_back(k);
    throw InputError(fmt::format(
        "{}: the {} set is not a rigid body ({}), which a simulator cannot integrate (or integrates wrongly); {}",
        source, m.set, c.why,
        ok.empty() ? std::string("no set in this file is; see the result's warnings")
                   : fmt::format("give --set {} (physically consistent)", ok.front())));
  }
  m.ci95 = intervals_of(result, m.set);
  if (result.contains("vehicle") && result.at("vehicle").contains("name"))
    m.vehicle = result.at("vehicle").at("name").get<std::string>();
  if (result.contains("rotors")) {
    RotorModel r = rotor_model_from_json(result.at("rotors"), source);
    m.thrust_scale = thrust_scale_of(result, m.set, source);
    r.kf *= m.thrust_scale;
    r.thrust_max *= m.thrust_scale;
    m.rotors = std::move(r);
  }
  return m;
}

IdentifiedModel load_identified_model(const std::string& path, const std::string& set) {
  std::ifstream in(path);
  if (!in) throw InputError(fmt::format("{}: cannot open the result file", path));
  std::stringstream ss;
  ss << in.rdbuf();
  json j;
  try {
    j = json::parse(ss.str());
  } catch (const json::parse_error& e) {
    throw InputError(fmt::format("{}: not JSON ({})", path, e.what()));
  }
  return identified_model_from_json(j, path, set);
}

}  // namespace quadid
