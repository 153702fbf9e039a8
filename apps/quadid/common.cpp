#include "common.hpp"

#include <fmt/format.h>

#include <filesystem>
#include <stdexcept>

namespace quadid::cli {

CLI::Validator seed_range() {
  return CLI::Validator(
      [](std::string& s) -> std::string {
        const bool digits = !s.empty() && s.size() <= 20 && s.find_first_not_of("0123456789") == std::string::npos;
        if (digits && (s.size() < 20 || s <= "18446744073709551615")) return {};
        return "must be a whole number in [0, 18446744073709551615], got '" + s + "'";
      },
      "SEED", "seed range");
}


void ProcessingArgs::add_to(CLI::App* sub) {
  sub->add_option("--filter", filter, "zero-phase pre-filter: butter (Butterworth IIR) or fir (31-tap Blackman-Harris)")
      ->capture_default_str();
  sub->add_option("--cutoff", cutoff,
                  "pre-filter cutoff, Hz; 4 Hz passes the excitation (<= 0.5 Hz) and removes 30 Hz motion-capture steps")
      ->capture_default_str();
  sub->add_option("--order", order, "Butterworth order (1-8)")->capture_default_str();
  sub->add_option("--taps", taps, "FIR length (odd)")->capture_default_str();
  sub->add_option("--lambda", lambda, "bandwidth of f_D, g_D of the filtered model (eqs. 35-36), rad/s")
      ->capture_default_str();
  sub->add_option("--derivative-filter", derivative_filter,
                  "g_D: consistent ((1-a)/T (z-1)/(z-a), the derivative of f_D's output) or printed (eq. 36)")
      ->capture_default_str();
  sub->add_option("--g", g, "gravity, m/s^2")->capture_default_str();
  sub->add_option("--period-tolerance", period_tolerance, "relative tolerance on a uniform sample period")
      ->capture_default_str();
  sub->add_option("--time-unit", time_unit,
                  "unit of the log's column t: s (the format's), ms, us or ns (e.g. a logger's millisecond stamps)")
      ->capture_default_str();
  sub->add_flag("--keep-edges", keep_edges,
                "use the windows literally, including the filters' settling at the log's two ends (by default the "
                "pre-filter's settling time, 0.57 s for the default filter, is left out at each end)");
  sub->add_flag("--keep-held-samples", keep_held,
                "use the pose (x y z psi) as logged even where it repeats each sample until the next (by default a "
                "held pose, e.g. 30 Hz motion capture in a 500 Hz log, is put back on its sample instants: a hold "
                "delays it by half its period)");
  sub->add_option("--map", map, "column name mapping CANONICAL=NAME, e.g. --map tau_phi=tau_x (repeatable)");
}

ProcessingOptions ProcessingArgs::processing() const {
  ProcessingOptions p;
  auto& lp = p.lowpass;
  if (filter == "butter") lp.kind = signal::LowpassOptions::Kind::Butterworth;
  else if (filter == "fir") lp.kind = signal::LowpassOptions::Kind::FirBlackmanHarris;
  else throw std::invalid_argument(fmt::format("--filter {}: expected butter or fir", filter));
  lp.cutoff_hz = cutoff;
  lp.order = order;
  lp.taps = taps;
  p.g = g;
  p.period_tolerance = period_tolerance;
  p.exclude_edges = !keep_edges;
  p.interpolate_held = !keep_held;
  return p;
}

signal::GdVariant ProcessingArgs::gd_variant() const {
  if (derivative_filter == "consistent") return signal::GdVariant::Consistent;
  if (derivative_filter == "printed") return signal::GdVariant::Printed;
  throw std::invalid_argument(fmt::format("--derivative-filter {}: expected consistent or printed", derivative_filter));
}

CsvReadOptions ProcessingArgs::csv() const {
  CsvReadOptions c;
  c.map = parse_column_map(map);
  c.period_tolerance = period_tolerance;
  c.time_units_per_second = parse_time_unit(time_unit);
  return c;
}

void LimitArgs::add_to(CLI::App* sub) {
  auto& L = limits;
  options_ = {
      sub->add_option("--x-max", L.x_max, "|x| limit, m")->capture_default_str(),
      sub->add_option("--y-max", L.y_max, "|y| limit, m")->capture_default_str(),
      sub->add_option("--z-min", L.z_min, "lower z limit, m")->capture_default_str(),
      sub->add_option("--z-max", L.z_max, "upper z limit, m")->capture_default_str(),
      sub->add_option("--psi-max", psi_max_deg, "|psi| limit, deg")->capture_default_str(),
      sub->add_option("--tilt-max", tilt_max_deg, "|phi|, |theta| limit of eqs. (26)-(27), deg")->capture_default_str(),
      sub->add_option("--xdot-max", L.xdot_max, "|x_dot| limit, m/s")->capture_default_str(),
      sub->add_option("--ydot-max", L.ydot_max, "|y_dot| limit, m/s")->capture_default_str(),
      sub->add_option("--zdot-max", L.zdot_max, "|z_dot| limit, m/s")->capture_default_str(),
      sub->add_option("--psidot-max", psidot_max_deg, "|psi_dot| limit, deg/s")->capture_default_str(),
      sub->add_option("--zddot-min", L.zddot_min, "lower z_ddot limit, m/s^2")->capture_default_str(),
      sub->add_option("--rate-max", rate_max_deg, "|p|, |q| limit (body rates of the reference), deg/s")
          ->capture_default_str(),
      sub->add_option("--z0", L.z0, "start/end height, m")->capture_default_str()};
}

Constraints LimitArgs::over(Constraints c) const {
  const double given[] = {limits.x_max,    limits.y_max,    limits.z_min,    limits.z_max,
                          psi_max_deg * kDeg, tilt_max_deg * kDeg, limits.xdot_max, limits.ydot_max,
                          limits.zdot_max, psidot_max_deg * kDeg, limits.zddot_min, rate_max_deg * kDeg, limits.z0};
  double* const dest[] = {&c.x_max,    &c.y_max,      &c.z_min,   &c.z_max,
                          &c.psi_max,  &c.tilt_max,   &c.xdot_max, &c.ydot_max,
                          &c.zdot_max, &c.psidot_max, &c.zddot_min, &c.rate_max, &c.z0};
  for (size_t i = 0; i < options_.size(); ++i)
    if (options_[i]->count() > 0) *dest[i] = given[i];
  return c;
}

bool LimitArgs::any_given() const {
  for (const auto* o : options_)
    if (o->count() > 0) return true;
  return false;
}

Constraints LimitArgs::constraints() const {
  Constraints c = limits;
  c.psi_max = psi_max_deg * kDeg;
  c.tilt_max = tilt_max_deg * kDeg;
  c.psidot_max = psidot_max_deg * kDeg;
  c.rate_max = rate_max_deg * kDeg;
  return c;
}

}  // namespace quadid::cli
