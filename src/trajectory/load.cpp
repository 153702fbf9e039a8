// Trajectories as text: the trajectory JSON of docs/file-formats.md, the
// one-line specs simulated logs record, and the one loader every command uses
// (include/quadid/trajectory.hpp).
#include "quadid/trajectory.hpp"

#include "quadid/io.hpp"

#include <fmt/format.h>
#include <fmt/ranges.h>

#include <charconv>
#include <cmath>
#include <filesystem>

namespace quadid {

using json = nlohmann::ordered_json;

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
  const double wf = json_number(j, "wf", source, true);
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
    out.a = json_number_array(ax, "a", where);
    out.b = json_number_array(ax, "b", where);
    out.c = json_number(ax, "c", where, true);
    if (out.a.size() != out.b.size())
      throw InputError(fmt::format("{}: \"a\" has {} entries but \"b\" has {}", where, out.a.size(), out.b.size()));
    if (N < 0) N = out.a.size();
    if (out.a.size() != N)
      throw InputError(fmt::format("{}: {} harmonics, but axis x has {}", where, out.a.size(), N));
  }
  if (N < 1) throw InputError(fmt::format("{}: the trajectory needs at least one harmonic", source));
  if (j.contains("harmonics")) {
    const double h = json_number(j, "harmonics", source, true);
    if (h != static_cast<double>(N))
      throw InputError(fmt::format("{}: \"harmonics\" = {} but the coefficient arrays have {} entries", source, h, N));
  }
  try {
    return FourierTrajectory(wf, std::move(axes));
  } catch (const std::invalid_argument& e) {
    throw InputError(fmt::format("{}: {}", source, e.what()));
  }
}

namespace {

constexpr double kDefaultCirclePeriod = 5.0;
constexpr double kDefaultPsiAmplitude = 15.0 * M_PI / 180.0;

bool same_trajectory(const FourierTrajectory& a, const FourierTrajectory& b) {
  return a.wf() == b.wf() && a.harmonics() == b.harmonics() && a.coefficients() == b.coefficients();
}

// psi_d = A sin(2 pi t / P) (eq. 44), so A is psi_d at a quarter period.
double circle_psi_amplitude(const CircleTrajectory& c) { return c.eval(c.period() / 4.0)(kPsi, 0); }

}  // namespace

std::string trajectory_spec(const Trajectory& traj) {
  if (const auto* f = dynamic_cast<const FourierTrajectory*>(&traj)) {
    if (same_trajectory(*f, FourierTrajectory::table2())) return "table2";
    return to_json(*f).dump();
  }
  if (const auto* c = dynamic_cast<const CircleTrajectory*>(&traj)) {
    const double amp = circle_psi_amplitude(*c);
    const bool default_shape = c->period() == kDefaultCirclePeriod && std::abs(amp - kDefaultPsiAmplitude) < 1e-15;
    for (int k = 1; k <= 3; ++k) {
      const auto e = CircleTrajectory::experiment(k);
      if (default_shape && c->radius() == e.radius() && c->rho() == e.rho()) return fmt::format("circle{}", k);
    }
    std::string s = fmt::format("circle radius={} altitude={}", c->radius(), c->rho());
    if (!default_shape) s += fmt::format(" period={} psi_amplitude={}", c->period(), amp);
    return s;
  }
  if (const auto* p = dynamic_cast<const PolynomialTrajectory*>(&traj)) return to_json(*p).dump();
  throw std::invalid_argument(fmt::format("trajectory '{}' has no spec (only Fourier and circle trajectories do)",
                                          traj.describe()));
}

namespace {

std::unique_ptr<Trajectory> circle_from_spec(std::string_view spec) {
  // "circle radius=R altitude=A [period=P] [psi_amplitude=RAD]"
  double radius = NAN, altitude = NAN, period = kDefaultCirclePeriod, amp = kDefaultPsiAmplitude;
  std::string_view rest = spec.substr(6);
  while (!rest.empty()) {
    const size_t b = rest.find_first_not_of(' ');
    if (b == std::string_view::npos) break;
    rest.remove_prefix(b);
    const size_t e = std::min(rest.find(' '), rest.size());
    const std::string_view item = rest.substr(0, e);
    rest.remove_prefix(e);
    const size_t eq = item.find('=');
    double val = 0.0;
    const char* vb = item.data() + (eq == std::string_view::npos ? item.size() : eq + 1);
    const char* ve = item.data() + item.size();
    const auto [ptr, ec] = std::from_chars(vb, ve, val);
    if (eq == std::string_view::npos || ec != std::errc() || ptr != ve || !std::isfinite(val))
      throw InputError(fmt::format("trajectory spec '{}': '{}' is not KEY=NUMBER", spec, item));
    const std::string_view key = item.substr(0, eq);
    if (key == "radius") radius = val;
    else if (key == "altitude") altitude = val;
    else if (key == "period") period = val;
    else if (key == "psi_amplitude") amp = val;
    else
      throw InputError(fmt::format("trajectory spec '{}': unknown key '{}' (radius, altitude, period, psi_amplitude)",
                                   spec, key));
  }
  if (std::isnan(radius) || std::isnan(altitude))
    throw InputError(fmt::format("trajectory spec '{}': needs radius=R and altitude=A (metres)", spec));
  try {
    return std::make_unique<CircleTrajectory>(radius, altitude, period, amp);
  } catch (const std::invalid_argument& e) {
    throw InputError(fmt::format("trajectory spec '{}': {}", spec, e.what()));
  }
}

}  // namespace

std::unique_ptr<Trajectory> load_trajectory(std::string_view spec) {
  if (auto t = builtin_trajectory(spec)) return t;
  if (spec.rfind("circle ", 0) == 0) return circle_from_spec(spec);
  if (!spec.empty() && spec.front() == '{') {
    json j;
    try {
      j = json::parse(spec);
    } catch (const json::parse_error& e) {
      throw InputError(fmt::format("trajectory spec: invalid JSON ({})", e.what()));
    }
    if (j.is_object() && j.value("type", "") == "poly4d")  // an exported Crazyflie polynomial
      return std::make_unique<PolynomialTrajectory>(polynomial_from_json(j, "trajectory spec"));
    return std::make_unique<FourierTrajectory>(trajectory_from_json(j, "trajectory spec"));
  }
  if (spec.size() > 9 && spec.substr(spec.size() - 9) == ".poly.csv")
    return std::make_unique<PolynomialTrajectory>(read_crazyflie_poly_csv(std::filesystem::path(spec)));
  const std::string path(spec);
  if (!std::filesystem::exists(path))
    throw InputError(fmt::format("trajectory '{}': neither a built-in ({}) nor an existing file", spec,
                                 fmt::join(builtin_trajectory_names(), ", ")));
  return std::make_unique<FourierTrajectory>(trajectory_from_json(read_json_file(path), path));
}

}  // namespace quadid
