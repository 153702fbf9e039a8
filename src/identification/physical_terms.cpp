// The physically consistent set of the real-flight regression: the rigid body
// (closest_physical) together with the extra terms (docs/uncertainty.md,
// "Physical consistency"). The estimate x and its covariance C describe a
// Gaussian over every parameter; the closest point in the metric C^-1 under
// constraints on the rigid body alone splits into the marginal projection of
// the rigid body and the conditional mean of the terms given it. A term held
// at its bound (0) is one more condition: the rest is then conditioned on it
// first.
#include "quadid/identification/extended.hpp"

#include <fmt/format.h>

#include <Eigen/Cholesky>
#include <algorithm>
#include <array>
#include <cmath>

namespace quadid {
namespace {

using Index = Eigen::Index;
using Indices = std::vector<Index>;

Eigen::MatrixXd block(const Eigen::MatrixXd& C, const Indices& rows, const Indices& cols) {
  Eigen::MatrixXd B(static_cast<Index>(rows.size()), static_cast<Index>(cols.size()));
  for (size_t a = 0; a < rows.size(); ++a)
    for (size_t b = 0; b < cols.size(); ++b) B(static_cast<Index>(a), static_cast<Index>(b)) = C(rows[a], cols[b]);
  return B;
}

Eigen::VectorXd part(const Eigen::VectorXd& v, const Indices& idx) {
  Eigen::VectorXd p(static_cast<Index>(idx.size()));
  for (size_t a = 0; a < idx.size(); ++a) p(static_cast<Index>(a)) = v(idx[a]);
  return p;
}

// A^-1 B for a covariance block A; a tiny ridge (relative to its largest
// variance) keeps a parameter held fixed (zero variance) from making it singular.
Eigen::MatrixXd solve_covariance(Eigen::MatrixXd A, const Eigen::MatrixXd& B) {
  if (A.rows() == 0) return Eigen::MatrixXd::Zero(0, B.cols());
  const double top = A.diagonal().cwiseAbs().maxCoeff();
  A.diagonal().array() += 1e-12 * (top > 0.0 ? top : 1.0);
  return Eigen::LDLT<Eigen::MatrixXd>(A).solve(B);
}

// The rigid body's projection in the metric of its covariance `cov` around
// `mean` (m pinned at the known mass when given): the metric is cov^-1 with a
// relative ridge of 1e-9 of each variance, so a rank-deficient covariance
// (the HAC one on a short flight) still gives a metric.
PhysicalProjection project_body(const Theta& mean, const Mat7& cov, const Theta& std_error, bool known_mass,
                                const Theta& scale, const PhysicalProjectionOptions& opt) {
  const Theta sd = std_error.cwiseMax(1e-12 * mean.cwiseAbs().maxCoeff());
  const Eigen::LDLT<Mat7> ldlt(cov + Mat7(sd.cwiseAbs2().asDiagonal()) * 1e-9);
  Mat7 info = ldlt.solve(Mat7::Identity());
  if (known_mass) {
    // Pin m: a million times the inertia entries' weight in the problem's
    // own scaling (m / |m|, I / mean principal moment). Not more: the
    // projection's ridge is relative to the metric's size, and a larger pin
    // would make that ridge, not the covariance, decide how the inertia moves.
    const double ms = std::abs(mean(0)), sI = (std::abs(mean(1)) + std::abs(mean(4)) + std::abs(mean(6))) / 3.0;
    if (ms > 0.0 && sI > 0.0) info(0, 0) = 1e6 * info.diagonal().tail<6>().maxCoeff() * (sI * sI) / (ms * ms);
  }
  const Eigen::LLT<Mat7> llt(0.5 * (info + info.transpose()));
  const Mat7 F = llt.matrixU();
  return closest_physical(F, mean, scale, opt);
}

}  // namespace

bool term_is_nonnegative(std::string_view name) {
  static constexpr std::array<std::string_view, 7> kNonnegative = {
      "flapping_x", "flapping_y", "damping_x", "damping_y", "damping_z", "rotor_inertia", "drag_z"};
  return std::find(kNonnegative.begin(), kNonnegative.end(), name) != kNonnegative.end();
}

PhysicalConsistency check_term_signs(const std::vector<std::pair<std::string, double>>& extra,
                                     const std::vector<std::pair<std::string, double>>& std_errors) {
  for (const auto& [name, value] : extra) {
    if (!term_is_nonnegative(name)) continue;
    double se = 0.0;
    for (const auto& [n, s] : std_errors)
      if (n == name && std::isfinite(s) && s > 0.0) se = s;
    if (value >= -kZ95 * se) continue;
    const std::string interval =
        se > 0.0 ? fmt::format(" +- {:.2g}: its 95 % interval lies below 0", se) : std::string();
    return {false, fmt::format("{} = {:.4g}{} ({})", name, value, interval,
                                 name.starts_with("flapping")  ? "a flapping moment toward the velocity"
                                 : name == "rotor_inertia"     ? "a negative inertia"
                                                               : "a drag that adds energy")};
  }
  return {true, "the terms' signs hold"};
}

PhysicalConsistency check_set_consistency(const SetEstimate& e, bool term_signs) {
  PhysicalConsistency c = check_physical_consistency(e.theta);
  if (c.physical && term_signs && !e.extra.empty()) {
    const PhysicalConsistency t = check_term_signs(e.extra, e.extra_std_error);
    if (!t.physical) return t;
    c.why += "; " + t.why;
  }
  return c;
}

TermsProjection closest_physical_with_terms(const ExtendedEstimate& x, std::optional<double> known_mass,
                                            const Theta& scale, const PhysicalProjectionOptions& opt) {
  TermsProjection out;
  out.extra = x.extra;
  const Index P = x.value.size();
  if (P < 7 || x.covariance.rows() != P || x.covariance.cols() != P || x.std_error.size() != P ||
      static_cast<Index>(x.names.size()) != P)
    throw std::invalid_argument(fmt::format(
        "closest_physical_with_terms: {} values, {} names, a {}x{} covariance and {} standard errors (expected one "
        "per parameter, at least 7)",
        P, x.names.size(), x.covariance.rows(), x.covariance.cols(), x.std_error.size()));
  // Rigid-body entries of x.value (m only when estimated), and the terms'.
  Indices rigid, terms;
  for (Index j = 0; j < P; ++j) ((j == 0 && known_mass) || j >= 7 ? terms : rigid).push_back(j);
  auto name_of = [&](Index j) { return j == 0 ? std::string("thrust_scale") : x.names[static_cast<size_t>(j)]; };

  Indices all(static_cast<size_t>(P));
  for (Index j = 0; j < P; ++j) all[static_cast<size_t>(j)] = j;
  Indices pinned;  // held at 0
  auto unpinned = [&](const Indices& idx) {
    Indices v;
    for (Index j : idx)
      if (std::find(pinned.begin(), pinned.end(), j) == pinned.end()) v.push_back(j);
    return v;
  };
  for (size_t round = 0; round <= terms.size(); ++round) {
    // The distribution conditional on the pinned terms being 0.
    const Indices free = unpinned(all);
    Eigen::VectorXd mu = x.value;
    Eigen::MatrixXd C = x.covariance;
    if (!pinned.empty()) {
      const Eigen::MatrixXd CfA = block(x.covariance, free, pinned);
      const Eigen::MatrixXd K = solve_covariance(block(x.covariance, pinned, pinned), CfA.transpose()).transpose();
      const Eigen::VectorXd shift = K * (-part(x.value, pinned));
      const Eigen::MatrixXd Cc = block(x.covariance, free, free) - K * CfA.transpose();
      for (size_t a = 0; a < free.size(); ++a) {
        mu(free[a]) += shift(static_cast<Index>(a));
        for (size_t b = 0; b < free.size(); ++b) C(free[a], free[b]) = Cc(static_cast<Index>(a), static_cast<Index>(b));
      }
      for (Index j : pinned) mu(j) = 0.0;
    }
    // The rigid body.
    Theta mean = mu.head<7>();
    Mat7 cov = C.topLeftCorner<7, 7>();
    Theta sd = pinned.empty() ? Theta(x.std_error.head<7>()) : Theta(cov.diagonal().cwiseMax(0.0).cwiseSqrt());
    if (known_mass) {  // m is given: no variance, no correlation
      mean(0) = *known_mass;
      cov.row(0).setZero();
      cov.col(0).setZero();
      sd(0) = 0.0;
    }
    out.body = project_body(mean, cov, sd, known_mass.has_value(), scale, opt);
    if (!out.body.theta.allFinite()) return out;  // no consistent body: x's terms, nothing pinned
    // The free terms given the body: mu_t + C_tr C_rr^-1 (theta_r - mu_r).
    const Indices free_terms = unpinned(terms);
    Eigen::VectorXd d(static_cast<Index>(rigid.size()));
    for (size_t a = 0; a < rigid.size(); ++a) d(static_cast<Index>(a)) = out.body.theta(rigid[a]) - mu(rigid[a]);
    Eigen::VectorXd value = mu;
    if (!free_terms.empty() && !d.isZero(0.0)) {
      const Eigen::VectorXd shift = block(C, free_terms, rigid) * solve_covariance(block(C, rigid, rigid), d);
      for (size_t a = 0; a < free_terms.size(); ++a) value(free_terms[a]) += shift(static_cast<Index>(a));
    }
    Indices broken;
    if (opt.term_signs)
      for (Index j : free_terms)
        if (term_is_nonnegative(name_of(j)) && !(value(j) >= 0.0)) broken.push_back(j);
    if (broken.empty() || round == terms.size()) {
      for (Index j : terms)
        for (auto& [n, v] : out.extra)
          if (n == name_of(j)) v = value(j);
      for (Index j : pinned) out.pinned.push_back(name_of(j));
      return out;
    }
    pinned.insert(pinned.end(), broken.begin(), broken.end());
  }
  return out;  // not reached: the last round returns
}

}  // namespace quadid
