// JSON and text forms of the design module's results. JSON keeps SI units and
// radians; the text tables convert angles to degrees for people.
#include "design_internal.hpp"

#include "quadid/core/json.hpp"
#include "quadid/io.hpp"

#include <fmt/format.h>

namespace quadid {

using json = nlohmann::ordered_json;

namespace {


// Angles are shown in degrees; the unit string says which.
struct Shown {
  double factor;
  std::string unit;
};
Shown shown(const std::string& si_unit) {
  if (si_unit == "rad") return {1.0 / kDeg, "deg"};
  if (si_unit == "rad/s") return {1.0 / kDeg, "deg/s"};
  if (si_unit == "rad/s^2") return {1.0 / kDeg, "deg/s^2"};
  return {1.0, si_unit};
}

std::string pad(const std::string& s, size_t w, bool left) {
  if (s.size() >= w) return s;
  return left ? s + std::string(w - s.size(), ' ') : std::string(w - s.size(), ' ') + s;
}

std::string table(const std::vector<std::string>& head, const std::vector<std::vector<std::string>>& rows) {
  std::vector<size_t> w(head.size());
  for (size_t c = 0; c < head.size(); ++c) {
    w[c] = head[c].size();
    for (const auto& r : rows) w[c] = std::max(w[c], r[c].size());
  }
  std::string out;
  auto line = [&](const std::vector<std::string>& r) {
    for (size_t c = 0; c < r.size(); ++c) out += (c ? "  " : "") + pad(r[c], w[c], c == 0);
    out += '\n';
  };
  line(head);
  for (const auto& r : rows) line(r);
  return out;
}

}  // namespace

json to_json(const Constraints& c) {
  json j = {{"x_max", finite_or_null(c.x_max)},
          {"y_max", finite_or_null(c.y_max)},
          {"z_min", finite_or_null(c.z_min)},
          {"z_max", finite_or_null(c.z_max)},
          {"psi_max", finite_or_null(c.psi_max)},
          {"tilt_max", finite_or_null(c.tilt_max)},
          {"xdot_max", finite_or_null(c.xdot_max)},
          {"ydot_max", finite_or_null(c.ydot_max)},
          {"zdot_max", finite_or_null(c.zdot_max)},
          {"psidot_max", finite_or_null(c.psidot_max)},
          {"zddot_min", finite_or_null(c.zddot_min)},
          {"zddot_max", finite_or_null(c.zddot_max)},
          {"psiddot_max", finite_or_null(c.psiddot_max)},
          {"rate_max", finite_or_null(c.rate_max)},
          {"start", {{"x", c.x0}, {"y", c.y0}, {"z", c.z0}, {"psi", c.psi0}}},
          {"units", "SI: m, m/s, m/s^2, rad, rad/s, rad/s^2; null = unbounded"}};
  if (c.rotor_mixer.rows() > 0) {
    json mixer = json::array();
    for (Eigen::Index i = 0; i < c.rotor_mixer.rows(); ++i)
      mixer.push_back({c.rotor_mixer(i, 0), c.rotor_mixer(i, 1), c.rotor_mixer(i, 2), c.rotor_mixer(i, 3)});
    j["rotors"] = {{"vehicle", c.vehicle_name},
                   {"parameters", to_json(c.vehicle)},
                   {"thrust_low", c.thrust_low},
                   {"thrust_high", c.thrust_high},
                   {"mixer", mixer},
                   {"units", "mixer: rotor thrust / its largest thrust, per N and N m of [Fz tau_phi tau_theta tau_psi]"}};
  }
  return j;
}

Constraints constraints_from_json(const json& j, const std::string& source, Constraints c) {
  if (!j.is_object()) throw InputError(fmt::format("{}: \"constraints\" must be an object", source));
  auto field = [&](const json& obj, const char* key, double& v, const std::string& where) {
    if (!obj.contains(key)) return;
    const json& x = obj[key];
    if (x.is_null()) v = std::string_view(key).ends_with("_min") ? -kInf : kInf;  // null = unbounded
    else if (x.is_number()) v = x.get<double>();
    else throw InputError(fmt::format("{}: {}.{} must be a number or null", source, where, key));
  };
  const std::pair<const char*, double*> fields[] = {
      {"x_max", &c.x_max},       {"y_max", &c.y_max},         {"z_min", &c.z_min},
      {"z_max", &c.z_max},       {"psi_max", &c.psi_max},     {"tilt_max", &c.tilt_max},
      {"xdot_max", &c.xdot_max}, {"ydot_max", &c.ydot_max},   {"zdot_max", &c.zdot_max},
      {"psidot_max", &c.psidot_max}, {"zddot_min", &c.zddot_min}, {"zddot_max", &c.zddot_max},
      {"psiddot_max", &c.psiddot_max}, {"rate_max", &c.rate_max}};
  for (const auto& [k, v] : fields) field(j, k, *v, "constraints");
  if (j.contains("start")) {
    const json& s = j["start"];
    if (!s.is_object()) throw InputError(fmt::format("{}: constraints.start must be an object", source));
    const std::pair<const char*, double*> start[] = {{"x", &c.x0}, {"y", &c.y0}, {"z", &c.z0}, {"psi", &c.psi0}};
    for (const auto& [k, v] : start) field(s, k, *v, "constraints.start");
  }
  if (j.contains("rotors")) {
    const json& r = j["rotors"];
    const std::string where = source + ": constraints.rotors";
    if (!r.is_object() || !r.contains("mixer") || !r["mixer"].is_array() || r["mixer"].empty() ||
        !r.contains("parameters"))
      throw InputError(where + " must be an object with \"mixer\" (rows of 4 numbers) and \"parameters\"");
    const json& mx = r["mixer"];
    c.rotor_mixer.resize(static_cast<Eigen::Index>(mx.size()), 4);
    for (size_t i = 0; i < mx.size(); ++i) {
      if (!mx[i].is_array() || mx[i].size() != 4)
        throw InputError(fmt::format("{}.mixer[{}] must be an array of 4 numbers", where, i));
      for (size_t k = 0; k < 4; ++k) {
        if (!mx[i][k].is_number()) throw InputError(fmt::format("{}.mixer[{}][{}] must be a number", where, i, k));
        c.rotor_mixer(static_cast<Eigen::Index>(i), static_cast<Eigen::Index>(k)) = mx[i][k].get<double>();
      }
    }
    c.vehicle = params_from_json(r["parameters"], where + ".parameters");
    field(r, "thrust_low", c.thrust_low, "constraints.rotors");
    field(r, "thrust_high", c.thrust_high, "constraints.rotors");
    if (r.contains("vehicle") && r["vehicle"].is_string()) c.vehicle_name = r["vehicle"].get<std::string>();
  }
  try {
    c.validate();
  } catch (const std::invalid_argument& e) {
    throw InputError(fmt::format("{}: constraints: {}", source, e.what()));
  }
  return c;
}

json to_json(const CheckReport& r) {
  json cons = json::array();
  for (const auto& c : r.constraints)
    cons.push_back({{"name", c.name}, {"unit", c.unit}, {"kind", c.kind}, {"limit", c.limit},
                    {"worst", c.worst}, {"time", c.time}, {"margin", c.margin}, {"holds", c.holds}});
  json ends = json::array();
  for (const auto& e : r.endpoints)
    ends.push_back({{"axis", e.axis}, {"time", e.time}, {"value", e.value}, {"velocity", e.velocity},
                    {"acceleration", e.acceleration}, {"target", e.target}, {"error", e.error},
                    {"holds", e.holds}});
  const auto& cv = r.criteria;
  return {{"trajectory", r.trajectory},
          {"duration", r.duration},
          {"constraint_dt", r.constraint_dt},
          {"cond_dt", r.cond_dt},
          {"constraints", cons},
          {"endpoints", ends},
          {"cond", finite_or_null(cv.cond)},
          {"criteria",
           {{"cond", finite_or_null(cv.cond)},
            {"cond_scaled", finite_or_null(cv.cond_scaled)},
            {"dopt", finite_or_null(cv.dopt)},
            {"precision", finite_or_null(cv.precision)},
            {"worst_relative_std", finite_or_null(cv.worst_relative_std)},
            {"samples", cv.samples},
            {"eigenvalues", std::vector<double>(cv.eigenvalues.data(), cv.eigenvalues.data() + 7)}}},
          {"constraints_hold", r.constraints_hold},
          {"endpoints_hold", r.endpoints_hold},
          {"all_hold", r.all_hold()}};
}

json to_json(const StartSummary& s) {
  return {{"index", s.index},
          {"criterion", finite_or_null(s.criterion)},
          {"cond", finite_or_null(s.cond)},
          {"feasible", s.feasible},
          {"worst_violation", s.worst_violation},
          {"evaluations", s.evaluations},
          {"rounds", s.rounds},
          {"status", s.status}};
}

json design_to_json(const DesignResult& r, const DesignOptions& opt) {
  json j = to_json(r.trajectory);
  j["criterion"] = {{"name", std::string(criterion_name(opt.criterion))},
                    {"value", finite_or_null(r.check.criteria.value(opt.criterion))}};
  if (opt.criterion != Criterion::Cond) {
    j["criterion"]["reference"] = to_json(opt.reference);
    j["criterion"]["product_floor"] = opt.product_floor;
  }
  j["constraints"] = to_json(opt.limits);
  j["check"] = to_json(r.check);
  j["seed"] = opt.seed;
  j["starts"] = opt.starts;
  json starts = json::array();
  for (const auto& s : r.starts) starts.push_back(to_json(s));
  j["start_results"] = starts;
  j["best_start"] = r.best + 1;  // counted from 1, as the text's "best start 2" (start_results[best_start - 1])
  j["grid"] = {{"grid_dt", opt.grid_dt}, {"check_dt", opt.check_dt}, {"cell_dt", opt.cell_dt}, {"cond_dt", opt.cond_dt}, {"margin", opt.margin}};
  return j;
}

std::string format_check_report(const CheckReport& r) {
  std::string out = fmt::format("trajectory: {}\n", r.trajectory);
  out += fmt::format("limits checked every {:g} ms over 0..{:g} s; cond(W) from {} samples every {:g} ms (eq. 20)\n\n",
                     r.constraint_dt * 1e3, r.duration, r.criteria.samples, r.cond_dt * 1e3);
  std::vector<std::vector<std::string>> rows;
  for (const auto& c : r.constraints) {
    const Shown s = shown(c.unit);
    const std::string name = c.kind == "abs" ? "|" + c.name + "|" : c.name;
    const std::string rel = c.kind == "min" ? ">=" : "<=";
    rows.push_back({fmt::format("{} ({})", name, s.unit), fmt::format("{} {:.4f}", rel, c.limit * s.factor),
                    fmt::format("{:.4f}", c.worst * s.factor), fmt::format("{:.3f}", c.time),
                    fmt::format("{:+.4f}", c.margin * s.factor), c.holds ? "yes" : "NO"});
  }
  out += table({"constraint (unit)", "limit", "worst", "at t (s)", "margin", "holds"}, rows);

  rows.clear();
  for (const auto& e : r.endpoints) {
    const double f = e.axis == "psi" ? 1.0 / kDeg : 1.0;
    rows.push_back({e.time == 0.0 ? "start" : "end", fmt::format("{:.3f}", e.time), e.axis,
                    fmt::format("{:.6f}", e.value * f), fmt::format("{:.6f}", e.target * f),
                    fmt::format("{:+.2e}", e.velocity * f), fmt::format("{:+.2e}", e.acceleration * f),
                    e.holds ? "yes" : "NO"});
  }
  out += "\nstart and end conditions (q = q0, q_dot = 0, q_ddot = 0; psi in deg)\n";
  out += table({"end", "t (s)", "axis", "q (m|deg)", "q0 (m|deg)", "q_dot (m/s|deg/s)", "q_ddot (m/s^2|deg/s^2)", "holds"},
               rows);

  const auto& cv = r.criteria;
  out += fmt::format("\ncond(W)           = {:.4f}   (W: {} x 7, unscaled, 2-norm)\n", cv.cond, 4 * cv.samples);
  out += fmt::format("cond(W S)         = {:.4f}   (parameters scaled by the reference set)\n", cv.cond_scaled);
  out += fmt::format("D-opt criterion   = {:.4f}   (-(1/7) log det(S W^T W S / K))\n", cv.dopt);
  if (std::isfinite(cv.worst_relative_std))
    out += fmt::format("precision         = {:.4g} %  (worst relative std error of LS, rows weighted by their noise, "
                       "white-row approximation; smooth maximum {:.4g} %)\n",
                       100.0 * cv.worst_relative_std, 100.0 * cv.precision);
  out += fmt::format("eig(W^T W)        = [{:.4g}]\n", fmt::join(cv.eigenvalues, ", "));
  out += fmt::format("\nconstraints: {}   start/end: {}\n", r.constraints_hold ? "all hold" : "VIOLATED",
                     r.endpoints_hold ? "hold" : "VIOLATED");
  return out;
}

}  // namespace quadid
