// The real-flight regression's terms: the options, the columns each adds to
// Gamma, and one sample's row with them (include/quadid/regression.hpp).
#include "quadid/regression.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <iterator>
#include <stdexcept>

namespace quadid {
namespace {

Vec4 v4(double a, double b, double c, double d) { return Vec4(a, b, c, d); }

// The columns (d: the term signals' derivatives, s: their values). Signs
// follow the rows of eq. (10): each term moved to the left-hand side of "= tau".
const RegressionTerm kOffsetTerms[] = {
    {"offset_x", [](const double*, const double*) { return v4(0, -1, 0, 0); }},
    {"offset_y", [](const double*, const double*) { return v4(0, 0, -1, 0); }},
    {"offset_z", [](const double*, const double*) { return v4(0, 0, 0, -1); }},
};
// Blade flapping -K (e_z x v_b) = -K (-v, u, 0), moved left: K_x (-v) on the roll row, K_y u on the pitch row.
const RegressionTerm kFlapTerms[] = {
    {"flapping_x", [](const double*, const double* s) { return v4(0, -s[kTsV], 0, 0); }},
    {"flapping_y", [](const double*, const double* s) { return v4(0, 0, s[kTsU], 0); }},
};
const RegressionTerm kDampTerms[] = {
    {"damping_x", [](const double*, const double* s) { return v4(0, s[kTsP], 0, 0); }},
    {"damping_y", [](const double*, const double* s) { return v4(0, 0, s[kTsQ], 0); }},
    {"damping_z", [](const double*, const double* s) { return v4(0, 0, 0, s[kTsR]); }},
};
// J_r (Omega_r_dot e_z + w x e_z Omega_r), w x e_z = (q, -p, 0).
const RegressionTerm kRotorTerms[] = {
    {"rotor_inertia",
     [](const double* d, const double* s) { return v4(0, s[kTsQOmega], -s[kTsPOmega], d[kTsOmegaR]); }},
};
// A steady horizontal wind w (world) on flapping blades: -K (e_z x R^T w), whose
// body x part is K_x (R^T w)_y = K_x (R01 w_X + R11 w_Y) and y part
// -K_y (R00 w_X + R10 w_Y). Each product K_i w_J is one parameter: the moment
// about body axis i per unit of the world axis J seen along the other body axis.
const RegressionTerm kWindTerms[] = {
    {"wind_x_X", [](const double*, const double* s) { return v4(0, -s[kTsRxy], 0, 0); }},
    {"wind_x_Y", [](const double*, const double* s) { return v4(0, -s[kTsRyy], 0, 0); }},
    {"wind_y_X", [](const double*, const double* s) { return v4(0, 0, s[kTsRxx], 0); }},
    {"wind_y_Y", [](const double*, const double* s) { return v4(0, 0, s[kTsRyx], 0); }},
};
const RegressionTerm kDragTerms[] = {
    {"drag_z", [](const double*, const double* s) { return v4(s[kTsW], 0, 0, 0); }},
};

template <size_t N>
bool names_a_term(const RegressionTerm (&terms)[N], std::string_view name) {
  return std::any_of(std::begin(terms), std::end(terms), [&](const RegressionTerm& t) { return name == t.name; });
}

}  // namespace

std::vector<RegressionTerm> regression_terms(const ModelTerms& t, bool highpass) {
  std::vector<RegressionTerm> v;
  auto add = [&](const auto& arr) {
    for (const RegressionTerm& term : arr) v.push_back(term);
  };
  if (t.torque_offsets && highpass) v.push_back(kOffsetTerms[2]);
  else if (t.torque_offsets) add(kOffsetTerms);
  if (t.flapping) add(kFlapTerms);
  if (t.rate_damping) add(kDampTerms);
  if (t.rotor_inertia && !t.known_rotor_inertia) add(kRotorTerms);
  if (t.force_drag) add(kDragTerms);
  if (t.wind) add(kWindTerms);
  return v;
}

const RegressionTerm& rotor_inertia_term() { return kRotorTerms[0]; }

bool is_term_name(std::string_view name) {
  return name == "thrust_scale" || names_a_term(kOffsetTerms, name) || names_a_term(kFlapTerms, name) ||
         names_a_term(kDampTerms, name) || names_a_term(kRotorTerms, name) || names_a_term(kWindTerms, name) ||
         names_a_term(kDragTerms, name);
}

bool term_carries_to_other_flights(std::string_view name) {
  return name == "thrust_scale" || names_a_term(kFlapTerms, name) || names_a_term(kDampTerms, name) ||
         names_a_term(kRotorTerms, name) || names_a_term(kDragTerms, name);
}

void turn_on_carried_term(ModelTerms& t, std::string_view name) {
  t.flapping |= names_a_term(kFlapTerms, name);
  t.rate_damping |= names_a_term(kDampTerms, name);
  t.rotor_inertia |= names_a_term(kRotorTerms, name);
  t.force_drag |= names_a_term(kDragTerms, name);
}

void assemble_term_row(const std::vector<RegressionTerm>& terms, const Vec4& da, const Eigen::Matrix<double, 7, 1>& b,
                       const Vec4& y, const double* td, const double* ts, TermRow& row) {
  // Always the thrust model's scale (s = 1): with a known mass the estimates
  // are rescaled afterwards (identify_extended). Estimating s inside the
  // regression would make the moment rows homogeneous in (I, s, terms), and
  // on real data their model error would pull all of them toward zero.
  row.G.leftCols<7>() = assemble_regressor(da, b);
  row.Y = y;
  row.J = td ? rotor_inertia_term().column(td, ts) : Vec4::Zero();
  for (size_t j = 0; j < terms.size(); ++j) row.G.col(7 + static_cast<Eigen::Index>(j)) = terms[j].column(td, ts);
}

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
