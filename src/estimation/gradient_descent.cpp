// Gradient descent, eqs. (41)-(42), with a stable discretization (docs/method.md, "Corrections to the printed paper",
// "Estimators").
//
// With Gamma and Upsilon held over one sample, the error e = Gamma Theta - Upsilon
// obeys de/dt = -sigma G e, G = Gamma Gamma^T (4x4), so over a period T
//   Theta(T) = Theta(0) - sigma Gamma^T int_0^T exp(-sigma s G) ds e(0)
//            = Theta(0) - Gamma^T psi(G) e(0),   psi(x) = (1 - exp(-sigma T x)) / x,
// with psi evaluated on the eigenvalues of G (psi(0) = sigma T). Every mode
// decays monotonically, for any sigma T: unconditionally stable, and equal to
// forward Euler to first order in sigma T |G|.
//
// Speed: rows (7)-(10) of the regressor make G block diagonal (the mass row
// shares no column with the torque rows), so the 4x4 eigenproblem splits into a
// scalar and a 3x3 solved in closed form. A general G takes the iterative path.
#include "quadid/estimation.hpp"

#include <fmt/format.h>

#include <Eigen/Eigenvalues>
#include <array>
#include <cmath>
#include <stdexcept>

namespace quadid {
namespace {

// 1/n! for n = 0..26 (no divisions in the per-sample loop).
constexpr std::array<double, 27> make_inv_fact() {
  std::array<double, 27> f{};
  double v = 1.0;
  for (int n = 0; n < 27; ++n) {
    if (n > 0) v /= n;
    f[static_cast<size_t>(n)] = v;
  }
  return f;
}
constexpr std::array<double, 27> kInvFact = make_inv_fact();

// psi(x) = (1 - exp(-h x)) / x, accurate near 0; x < 0 only from rounding.
inline double psi(double x, double h) {
  if (x * h < 1e-12) return h;
  return -std::expm1(-h * x) / x;
}

}  // namespace

void GradientDescentOptions::validate() const {
  if (!(sigma > 0.0) || !std::isfinite(sigma))
    throw std::invalid_argument(fmt::format("--sigma = {:g} (GD gain) must be finite and positive", sigma));
  if (gain == GdGain::Normalized) {
    if (!(rate > 0.0) || !std::isfinite(rate))
      throw std::invalid_argument(fmt::format("--gd-rate {:g}: must be a positive rate in 1/s", rate));
    if (!(normalization_time > 0.0) || !std::isfinite(normalization_time))
      throw std::invalid_argument(
          fmt::format("GradientDescentOptions: normalization_time={:g} must be a positive time in s", normalization_time));
  }
  if (discretization != GdDiscretization::Exact && discretization != GdDiscretization::ForwardEuler)
    throw std::invalid_argument("GradientDescentOptions: unknown discretization");
  if (!(divergence_bound > 0.0) || !std::isfinite(divergence_bound))
    throw std::invalid_argument(fmt::format(
        "GradientDescentOptions: divergence_bound={} must be a positive finite number (kg, kg m^2)", divergence_bound));
}

GradientDescent::GradientDescent(const Theta& initial, double T, const GradientDescentOptions& opt)
    : theta_(initial), opt_(opt) {
  opt.validate();
  if (!(T > 0.0) || !std::isfinite(T))
    throw std::invalid_argument(fmt::format("GradientDescent: sample period T={} must be positive", T));
  if (!initial.allFinite()) throw std::invalid_argument("GradientDescent: the initial guess is not finite");
  sigma_T_ = opt.sigma * T;
  alpha_ = 1.0 - std::exp(-T / opt.normalization_time);
}

void GradientDescent::step(const Regressor4x7& G, const Vec4& Y) {
  if (diverged_) return;
  const Vec4 e = G * theta_ - Y;
  const Eigen::Matrix4d GG = G * G.transpose();
  double h = sigma_T_;  // sigma T of the torque block (and of the whole G when it is not block diagonal)
  double h0 = sigma_T_;  // sigma T of the mass row
  Vec4 pe;  // psi(G) e for Exact, h e for forward Euler
  double lmax = 0.0;
  const bool block = GG.row(0).tail<3>().isZero(0.0);
  if (opt_.gain == GdGain::Normalized) {
    // sigma_b = rate / nu_b, nu_b the running mean of |Gamma_b|^2 (the first
    // sample starts it). A block with no excitation yet takes no step.
    const double f = block ? GG(0, 0) : GG.trace(), t3 = block ? GG.bottomRightCorner<3, 3>().trace() : f;
    nu_force_ = steps_ == 0 ? f : nu_force_ + alpha_ * (f - nu_force_);
    nu_torque_ = steps_ == 0 ? t3 : nu_torque_ + alpha_ * (t3 - nu_torque_);
    const double rT = opt_.rate * sigma_T_ / opt_.sigma;  // rate * T
    h0 = nu_force_ > 0.0 ? rT / nu_force_ : 0.0;
    h = nu_torque_ > 0.0 ? rT / nu_torque_ : 0.0;
    if (!block) h0 = h;
  }
  if (block) {
    const Eigen::Matrix3d G3 = GG.bottomRightCorner<3, 3>();
    const double tr = G3.trace();  // >= lambda_max(G3), as G3 is positive semidefinite
    pe(0) = (opt_.discretization == GdDiscretization::Exact ? psi(GG(0, 0), h0) : h0) * e(0);
    if (opt_.discretization == GdDiscretization::ForwardEuler) {
      pe.tail<3>() = h * e.tail<3>();
      // The stability diagnostic: tr bounds lambda_max; refine only when it could exceed 2.
      double l3 = tr;
      if (h * tr > 2.0) {
        Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> es;
        es.computeDirect(G3, Eigen::EigenvaluesOnly);
        l3 = es.eigenvalues().maxCoeff();
      }
      lmax = std::max(h0 * GG(0, 0), h * l3);
    } else if (h * tr <= 2.0) {
      // Moderate step gain (the usual case for the torque rows): psi(G) e by its
      // Taylor series h sum_k (-h G)^k e / (k+1)!, Horner form, with as many
      // terms as make the first omitted one (h tr)^(K+1) / (K+2)! < 1e-13
      // (at most 21 for h tr = 2); cheaper than the 3x3 eigen-decomposition.
      const double x = h * tr;
      int K = 0;
      for (double xp = x; xp * kInvFact[K + 2] >= 1e-13 && K < 24; xp *= x) ++K;
      const Eigen::Vector3d e3 = e.tail<3>();
      Eigen::Vector3d acc = kInvFact[K + 1] * e3;
      for (int k = K - 1; k >= 0; --k) acc = kInvFact[k + 1] * e3 - h * (G3 * acc);
      pe.tail<3>() = h * acc;
      lmax = std::max(h0 * GG(0, 0), h * tr);
    } else {
      Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> es;
      es.computeDirect(G3);
      const Eigen::Vector3d l = es.eigenvalues();
      lmax = std::max(h0 * GG(0, 0), h * l.maxCoeff());
      const Eigen::Vector3d c = es.eigenvectors().transpose() * e.tail<3>();
      pe.tail<3>() = es.eigenvectors() * Eigen::Vector3d(psi(l(0), h) * c(0), psi(l(1), h) * c(1), psi(l(2), h) * c(2));
    }
  } else {
    const Eigen::SelfAdjointEigenSolver<Eigen::Matrix4d> es(GG);
    const Vec4 l = es.eigenvalues();
    lmax = h * l.maxCoeff();
    if (opt_.discretization == GdDiscretization::Exact) {
      Vec4 c = es.eigenvectors().transpose() * e;
      for (int i = 0; i < 4; ++i) c(i) *= psi(l(i), h);
      pe = es.eigenvectors() * c;
    } else {
      pe = h * e;
    }
  }
  max_gain_ = std::max(max_gain_, lmax);  // sigma T lambda_max
  const Theta next = theta_ - G.transpose() * pe;
  // Divergence: non-finite, or an entry beyond the absolute bound (see the option).
  const bool finite = next.allFinite();
  if (!finite || next.cwiseAbs().maxCoeff() > opt_.divergence_bound) {
    diverged_ = true;
    diverged_at_ = steps_;
    const std::string what =
        finite ? fmt::format("grew beyond {:g} (kg, kg m^2)", opt_.divergence_bound) : std::string("became non-finite");
    if (opt_.discretization == GdDiscretization::ForwardEuler)
      reason_ = fmt::format(
          "the estimate {} after {} samples: sigma T lambda_max(Gamma^T Gamma) reached {:.3g}, above the "
          "forward-Euler stability limit 2",
          what, steps_, max_gain_);
    else
      reason_ = fmt::format("the estimate {} after {} samples (non-finite or huge regression data?)", what, steps_);
    return;
  }
  theta_ = next;
  ++steps_;
}

}  // namespace quadid
