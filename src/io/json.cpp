#include "quadid/io.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <array>

namespace quadid {

using nlohmann::json;

json to_json(const Params& P) {
  const Theta th = P.theta();
  json j = json::object();
  for (int i = 0; i < 7; ++i) j[kThetaNames[static_cast<size_t>(i)]] = th(i);
  return j;
}

namespace {

double number_field(const json& j, const std::string& key, const std::string& where, bool required,
                    double fallback = 0.0) {
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

Eigen::VectorXd number_array(const json& j, const std::string& key, const std::string& where) {
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

}  // namespace

Params params_from_json(const json& j, const std::string& source, bool physical) {
  if (!j.is_object()) throw InputError(fmt::format("{}: parameters must be a JSON object", source));
  Theta th;
  for (int i = 0; i < 7; ++i) {
    const std::string key = kThetaNames[static_cast<size_t>(i)];
    const bool product = key == "Ixy" || key == "Ixz" || key == "Iyz";
    th(i) = number_field(j, key, source, !product);
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

json to_json(const FourierTrajectory& traj) {
  json j;
  j["type"] = "fourier";
  j["wf"] = traj.wf();
  j["harmonics"] = traj.harmonics();
  json axes = json::object();
  for (int i = 0; i < 4; ++i) {
    const auto& ax = traj.axis(i);
    axes[kAxisNames[static_cast<size_t>(i)]] = {
        {"a", std::vector<double>(ax.a.data(), ax.a.data() + ax.a.size())},
        {"b", std::vector<double>(ax.b.data(), ax.b.data() + ax.b.size())},
        {"c", ax.c}};
  }
  j["axes"] = axes;
  return j;
}

FourierTrajectory trajectory_from_json(const json& j, const std::string& source) {
  if (!j.is_object()) throw InputError(fmt::format("{}: a trajectory must be a JSON object", source));
  if (j.contains("type") && j["type"] != "fourier")
    throw InputError(fmt::format("{}: \"type\" is {}, only \"fourier\" is supported", source, j["type"].dump()));
  const double wf = number_field(j, "wf", source, true);
  if (!(wf > 0.0)) throw InputError(fmt::format("{}: \"wf\" = {} rad/s must be positive", source, wf));
  if (!j.contains("axes") || !j["axes"].is_object())
    throw InputError(fmt::format("{}: missing object \"axes\" with x, y, z, psi", source));
  std::array<FourierTrajectory::AxisCoeffs, 4> axes;
  Eigen::Index N = -1;
  for (int i = 0; i < 4; ++i) {
    const std::string name = kAxisNames[static_cast<size_t>(i)];
    const std::string where = fmt::format("{}: axes.{}", source, name);
    if (!j["axes"].contains(name)) throw InputError(fmt::format("{}: missing axis \"{}\" in \"axes\"", source, name));
    const json& ax = j["axes"][name];
    if (!ax.is_object()) throw InputError(fmt::format("{}: must be an object with a, b, c", where));
    auto& out = axes[static_cast<size_t>(i)];
    out.a = number_array(ax, "a", where);
    out.b = number_array(ax, "b", where);
    out.c = number_field(ax, "c", where, true);
    if (out.a.size() != out.b.size())
      throw InputError(fmt::format("{}: \"a\" has {} entries but \"b\" has {}", where, out.a.size(), out.b.size()));
    if (N < 0) N = out.a.size();
    if (out.a.size() != N)
      throw InputError(fmt::format("{}: {} harmonics, but axis x has {}", where, out.a.size(), N));
  }
  if (N < 1) throw InputError(fmt::format("{}: the trajectory needs at least one harmonic", source));
  if (j.contains("harmonics")) {
    const double h = number_field(j, "harmonics", source, true);
    if (h != static_cast<double>(N))
      throw InputError(fmt::format("{}: \"harmonics\" = {} but the coefficient arrays have {} entries", source, h, N));
  }
  try {
    return FourierTrajectory(wf, std::move(axes));
  } catch (const std::invalid_argument& e) {
    throw InputError(fmt::format("{}: {}", source, e.what()));
  }
}

std::unique_ptr<Trajectory> load_trajectory(const std::string& spec) {
  if (auto t = builtin_trajectory(spec)) return t;
  if (!std::filesystem::exists(spec))
    throw InputError(fmt::format("trajectory '{}': neither a built-in ({}) nor an existing file", spec,
                                 fmt::join(builtin_trajectory_names(), ", ")));
  return std::make_unique<FourierTrajectory>(trajectory_from_json(read_json_file(spec), spec));
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
        for (auto it = x.begin(); it != x.end(); ++it) s.terms.emplace_back(it.key(), number_field(x, it.key(), where + ".extra", true));
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

std::optional<Constraints> saved_trajectory_limits(const std::string& spec) {
  const auto names = builtin_trajectory_names();
  if (std::find(names.begin(), names.end(), spec) != names.end() || !std::filesystem::is_regular_file(spec))
    return std::nullopt;
  const nlohmann::json j = read_json_file(spec);
  if (!j.is_object() || !j.contains("constraints")) return std::nullopt;
  return constraints_from_json(j["constraints"], spec);
}

}  // namespace quadid
