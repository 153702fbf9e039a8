#include "quadid/io.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <array>

namespace quadid {

using json = nlohmann::ordered_json;

json to_json(const Params& P) {
  const Theta th = P.theta();
  json j = json::object();
  for (int i = 0; i < 7; ++i) j[kThetaNames[static_cast<size_t>(i)]] = th(i);
  return j;
}

double json_number(const json& j, const std::string& key, const std::string& where, bool required,
                   double fallback) {
  if (!j.contains(key)) {
    if (required) throw InputError(fmt::format("{}: missing field \"{}\"", where, key));
    return fallback;
  }
  const auto& v = j.at(key);
  if (!v.is_number()) throw InputError(fmt::format("{}: field \"{}\" must be a number", where, key));
  const double x = v.get<double>();
  if (!std::isfinite(x)) throw InputError(fmt::format("{}: field \"{}\" is not finite", where, key));
  return x;
}

Eigen::VectorXd json_number_array(const json& j, const std::string& key, const std::string& where) {
  if (!j.contains(key)) throw InputError(fmt::format("{}: missing field \"{}\"", where, key));
  const auto& a = j.at(key);
  if (!a.is_array()) throw InputError(fmt::format("{}: field \"{}\" must be an array of numbers", where, key));
  Eigen::VectorXd v(static_cast<Eigen::Index>(a.size()));
  for (size_t i = 0; i < a.size(); ++i) {
    if (!a[i].is_number())
      throw InputError(fmt::format("{}: \"{}\"[{}] must be a number", where, key, i));
    v(static_cast<Eigen::Index>(i)) = a[i].get<double>();
  }
  return v;
}

Params params_from_json(const json& j, const std::string& source, bool physical) {
  if (!j.is_object()) throw InputError(fmt::format("{}: parameters must be a JSON object", source));
  Theta th;
  for (int i = 0; i < 7; ++i) {
    const std::string key = kThetaNames[static_cast<size_t>(i)];
    const bool product = key == "Ixy" || key == "Ixz" || key == "Iyz";
    th(i) = json_number(j, key, source, !product);
  }
  Params P = Params::from_theta(th);
  if (!physical) return P;
  try {
    P.validate(source);
  } catch (const std::invalid_argument& e) {
    throw InputError(e.what());
  }
  return P;
}

Params load_params(const std::string& spec) {
  for (const auto& n : Params::preset_names())
    if (spec == n) return Params::preset(spec);
  if (!std::filesystem::exists(spec))
    throw InputError(fmt::format("parameters '{}': neither a preset ({}) nor an existing file", spec,
                                 fmt::join(Params::preset_names(), ", ")));
  const json j = read_json_file(spec);
  if (j.contains("estimates"))
    throw InputError(fmt::format("{}: holds several parameter sets (\"estimates\"); this option takes one set", spec));
  return params_from_json(j, spec);
}

std::vector<NamedParams> load_param_sets(const std::string& spec) {
  for (const auto& n : Params::preset_names())
    if (spec == n) return {{spec, Params::preset(spec)}};
  if (!std::filesystem::exists(spec))
    throw InputError(fmt::format("parameters '{}': neither a preset ({}) nor an existing file", spec,
                                 fmt::join(Params::preset_names(), ", ")));
  const json j = read_json_file(spec);
  std::vector<NamedParams> sets;
  if (j.contains("estimates")) {
    const json& e = j["estimates"];
    if (!e.is_object()) throw InputError(fmt::format("{}: \"estimates\" must be an object", spec));
    auto add = [&](const std::string& key) {
      const std::string where = fmt::format("{}: estimates.{}", spec, key);
      NamedParams s{key, params_from_json(e[key], where, false)};
      if (e[key].contains("extra")) {  // identify --vehicle's real-flight terms
        const json& x = e[key]["extra"];
        if (!x.is_object()) throw InputError(fmt::format("{}.extra: must be an object of term: value", where));
        for (auto it = x.begin(); it != x.end(); ++it) s.terms.emplace_back(it.key(), json_number(x, it.key(), where + ".extra", true));
      }
      sets.push_back(std::move(s));
    };
    // identify's order (its Table 3), then any other set by name.
    static constexpr std::array<const char*, 6> kOrder{"LS", "GD", "FMLS", "FMGD", "PC", "FMPC"};
    for (const char* key : kOrder)
      if (e.contains(key)) add(key);
    for (auto it = e.begin(); it != e.end(); ++it)
      if (std::find(kOrder.begin(), kOrder.end(), it.key()) == kOrder.end()) add(it.key());
    if (sets.empty()) throw InputError(fmt::format("{}: \"estimates\" is empty", spec));
    return sets;
  }
  sets.push_back({std::filesystem::path(spec).stem().string(), params_from_json(j, spec)});
  return sets;
}

std::string param_set_name(const std::string& spec) {
  if (spec == "qball2-nominal") return "nom";
  for (const auto& n : Params::preset_names())
    if (spec == n) return spec;
  return std::filesystem::path(spec).stem().string();
}

}  // namespace quadid
