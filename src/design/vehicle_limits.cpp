// What a vehicle can fly, for `design --vehicle` (issue 14): its [limits]
// table, the per-rotor thrust limits of its rotor model, and the frequency of
// the excitation's highest harmonic from its closed-loop bandwidth.
#include "quadid/design.hpp"

#include <fmt/format.h>

#include <cmath>
#include <stdexcept>

namespace quadid {

namespace {

// Defaults of the rotor limits: a fifth of every rotor's thrust is left to the
// tracking controller (the reference is planned with the nominal parameters,
// the controller corrects the rest), and no rotor is asked to idle, where its
// response is slow and its thrust model poor.
constexpr double kThrustMargin = 0.2;
constexpr double kThrustMin = 0.05;

}  // namespace

Constraints vehicle_constraints(const Vehicle& v, Constraints c) {
  const VehicleFlightLimits& l = v.limits;
  if (l.tilt_max) c.tilt_max = *l.tilt_max;
  if (l.rate_max) c.rate_max = *l.rate_max;
  if (l.speed_max) c.xdot_max = c.ydot_max = c.zdot_max = *l.speed_max;
  const RotorModel& r = v.rotors;
  if (!(r.max_thrust() > 0.0))
    throw std::invalid_argument(fmt::format("{}: rotors.thrust_max is needed for the per-rotor thrust limits of design "
                                            "--vehicle (the largest thrust of one rotor, N)",
                                            v.source));
  c.rotor_mixer = r.mixer() / r.max_thrust();  // thrust fraction per unit wrench
  c.thrust_high = 1.0 - l.thrust_margin.value_or(kThrustMargin);
  c.thrust_low = l.thrust_min.value_or(kThrustMin);
  c.vehicle = v.nominal;
  c.vehicle_name = v.name;
  if (!(c.thrust_low < c.thrust_high))
    throw std::invalid_argument(fmt::format("{}: limits.thrust_min = {:g} leaves no room below 1 - limits.thrust_margin "
                                            "= {:g}",
                                            v.source, c.thrust_low, c.thrust_high));
  // The start and end hover must itself be within the limits.
  const Eigen::Vector4d hover(v.nominal.m * kDefaultGravity, 0.0, 0.0, 0.0);
  const Eigen::VectorXd f = c.rotor_mixer * hover;
  if (f.minCoeff() < c.thrust_low || f.maxCoeff() > c.thrust_high)
  {
    // One number when every rotor carries the same share (not "0.245 to 0.245").
    const std::string lo = fmt::format("{:.3g}", f.minCoeff()), hi = fmt::format("{:.3g}", f.maxCoeff());
    throw std::invalid_argument(fmt::format(
        "{}: hovering needs {} of the rotors' largest thrust, outside [limits.thrust_min, 1 - "
        "limits.thrust_margin] = [{:g}, {:g}] (check nominal.m and rotors.thrust_max)",
        v.source, lo == hi ? lo : lo + " to " + hi, c.thrust_low, c.thrust_high));
  }
  return c;
}

double vehicle_excitation_frequency(const Vehicle& v) {
  constexpr double kPaperHighest = 5 * 36.0 * kDeg;  // N wf of section III-B: pi rad/s
  const PidGains paper;                              // section III-C, tuned for the QBall 2
  const double m_q = Params::qball2_nominal().m;
  const double w_paper = std::sqrt(paper.Kpp.minCoeff() / m_q);
  const PidGains g = vehicle_gains(v);
  const double w_vehicle = std::sqrt(g.Kpp.minCoeff() / v.nominal.m);
  double w = kPaperHighest * w_vehicle / w_paper;
  if (v.rotors.time_constant > 0.0) w = std::min(w, 0.2 / v.rotors.time_constant);
  return w;
}

}  // namespace quadid
