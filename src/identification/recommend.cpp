// Which set to use (include/quadid/identification.hpp, recommend_set).
#include "quadid/identification.hpp"

#include "quadid/identification/extended.hpp"

#include <fmt/format.h>

#include <cmath>
#include <limits>
#include <string>
#include <string_view>
#include <vector>

namespace quadid {
namespace {

// Root mean square of the standard errors relative to each parameter's scale
// (|m| for m, the mean principal moment for the inertia entries); the mass
// is left out when it was given (its standard error is 0 by construction).
double relative_precision(const LeastSquaresSolution& sol, const Theta& theta, bool mass_known) {
  const Theta se = sol.uncertainty.computed ? Theta(sol.uncertainty.std_error) : sol.std_error;
  const Theta scales = determinedness_scale(theta);
  double ss = 0.0;
  int n = 0;
  for (int j = mass_known ? 1 : 0; j < 7; ++j) {
    const double scale = scales(j);
    if (!(scale > 0.0)) return std::numeric_limits<double>::infinity();
    const double rel = se(j) / scale;
    if (!std::isfinite(rel)) return std::numeric_limits<double>::infinity();
    ss += rel * rel;
    ++n;
  }
  return std::sqrt(ss / n);
}

}  // namespace

double rigid_body_contradiction(const LeastSquaresSolution& sol, const Theta& theta) {
  if (!sol.uncertainty.computed) return std::numeric_limits<double>::quiet_NaN();
  return consistency_margin_sigmas(theta, sol.uncertainty.rigid_body_covariance());
}

std::string interval_source(std::string_view set) {
  if (set == "PC") return "LS";
  if (set == "FMPC") return "FMLS";
  return std::string(set);
}

Recommendation recommend_set(const IdentificationResult& r) {
  const bool mass_known = r.options.terms.known_mass.has_value();
  struct Candidate {
    const SetEstimate* set;
    const LeastSquaresSolution* sol;
    const SetEstimate* physical;
    double precision;
  };
  std::vector<Candidate> c;
  for (int i : {0, 1}) {
    const SetEstimate& e = r.estimates[static_cast<size_t>(2 * i)];
    const LeastSquaresSolution& sol = i == 0 ? r.ls_standard : r.ls_filtered;
    const SetEstimate* pc =
        static_cast<size_t>(i) < r.physical_sets.size() ? &r.physical_sets[static_cast<size_t>(i)] : nullptr;
    if (e.valid && e.theta.allFinite()) c.push_back({&e, &sol, pc, relative_precision(sol, e.theta, mass_known)});
  }
  Recommendation rec;
  if (c.empty()) {
    rec.reason = "no least-squares set could be computed from this log";
    return rec;
  }
  const Candidate* best = &c.front();
  for (const auto& x : c)
    if (x.precision < best->precision) best = &x;
  const Candidate* other = nullptr;
  for (const auto& x : c)
    if (&x != best) other = &x;

  std::string why;
  if (other && std::isfinite(best->precision) && std::isfinite(other->precision)) {
    // Two significant digits, more when two would print the same number ("3 % against 3 %").
    const double a = 100.0 * best->precision, b = 100.0 * other->precision;
    int digits = 2;
    while (digits < 4 && fmt::format("{:.{}g}", a, digits) == fmt::format("{:.{}g}", b, digits)) ++digits;
    why = fmt::format("{} has the smaller standard errors (RMS over the parameters, relative to each one's scale: "
                      "{:.{}g} % against {:.{}g} % for {})",
                      best->set->name, a, digits, b, digits, other->set->name);
  }
  else if (other)
    why = fmt::format("{} is the set whose standard errors are defined", best->set->name);
  else
    why = fmt::format("{} is the only least-squares set", best->set->name);

  const PhysicalConsistency pcheck = check_set_consistency(*best->set, r.options.physical.term_signs);
  rec.set = best->set->name;
  const double z = rigid_body_contradiction(*best->sol, best->set->theta);
  if (!pcheck.physical) {
    if (best->physical && best->physical->valid) {
      rec.set = best->physical->name;
      why += fmt::format("; it is not physically consistent ({}), so its closest consistent set {} is recommended",
                         pcheck.why, best->physical->name);
      // Far outside by its own uncertainty, the projection is the consistent
      // body nearest to data that no body explains, not a correction of noise.
      if (z <= -kContradicts)
        why += fmt::format(". But {} is {:.0f} standard errors outside the consistent sets, which noise does not "
                           "explain: the data contradict a rigid body (see the warning), and {} is the nearest body, "
                           "not necessarily near the truth",
                           best->set->name, -z, best->physical->name);
    } else {
      why += fmt::format("; it is not physically consistent ({}) and no consistent set could be found: treat it with care",
                         pcheck.why);
    }
  } else {
    why += "; it is physically consistent";
  }
  // What the data do not settle, whatever the set.
  if (!best->sol->poorly_determined.empty())
    why += fmt::format(". Poorly determined by this flight: {}", fmt::join(best->sol->poorly_determined, ", "));
  // The two models see the same flight: a disagreement beyond their
  // uncertainty means the processing or the model does not suit the data.
  if (other) {
    std::vector<std::string> differ;
    // Their noise alone: the std errors without the disagreement they hold.
    const Theta sa = best->sol->uncertainty.computed ? Theta(best->sol->uncertainty.noise_std_error()) : best->sol->std_error;
    const Theta sb = other->sol->uncertainty.computed ? Theta(other->sol->uncertainty.noise_std_error()) : other->sol->std_error;
    for (int j : {0, 1, 4, 6}) {
      if (j == 0 && mass_known) continue;
      const double d = std::abs(best->set->theta(j) - other->set->theta(j));
      const double s = std::hypot(sa(j), sb(j));
      if (std::isfinite(s) && d > 3.0 * s && d > 0.01 * std::abs(best->set->theta(j)))
        differ.push_back(std::string(kThetaNames[static_cast<size_t>(j)]));
    }
    if (!differ.empty())
      why += fmt::format(". {} and {} differ by more than three combined standard errors in {}: model error, not "
                         "noise, dominates these parameters",
                         best->set->name, other->set->name, fmt::join(differ, ", "));
  }
  // Model error that no standard error shows (docs/real-flights.md, "When the
  // estimates depend on the band").
  if (r.extended && r.extended->highpass_selection && r.extended->highpass_selection->band_dependent)
    why += ". Ixx and Iyy depend on the band the roll and pitch rows are fitted in (see the warnings): moments no "
           "term models reach those rows, and Ixx and Iyy may be off by more than their intervals";
  rec.reason = why + ".";
  return rec;
}

}  // namespace quadid
