// The wrench's lead over the motion, measured and undone (wrench_offset.hpp).
#include "wrench_offset.hpp"

#include "quadid/signal.hpp"

#include <Eigen/Dense>

#include <cmath>
#include <optional>

namespace quadid::detail {

std::optional<WrenchOffsetEstimate> estimate_wrench_offset(const Regression& reg, double cutoff_hz) {
  const RegressionSignals& sig = reg.signals();
  const Eigen::Index n = sig.size();
  const double T = sig.T;
  if (n < 3 || !(T > 0.0)) return std::nullopt;
  // The 8 columns [Gamma, dUpsilon/dt], each moment row one equation;
  // the sums of products scaled to unit diagonal before the solve (a nuisance
  // of one parameter: its conditioning is that of the regression's).
  Eigen::Matrix<double, 8, 8> M = Eigen::Matrix<double, 8, 8>::Zero();
  Eigen::Matrix<double, 8, 1> b = Eigen::Matrix<double, 8, 1>::Zero();
  double yy = 0.0;
  Eigen::Index rows = 0;
  Eigen::Matrix<double, 4, 8> A;
  reg.for_each([&](Eigen::Index k, const Regressor4x7& G, const Vec4& Y) {
    const auto wrench = [&sig](Eigen::Index i) -> Vec4 { return sig.x.row(i).tail<4>().transpose(); };
    const Vec4 dY = signal::central_difference_at(wrench, k, n, T);  // eq. (33), as the regressor's derivatives
    // The moment rows only: the torques against the gyro's derivative pin the
    // lead far better than the thrust against the positions' second
    // derivative (motion capture's noise, differentiated twice); the lead
    // found is then the whole wrench's (one controller logs both).
    A.leftCols<7>() = G;
    A.col(7) = dY;
    const auto Am = A.bottomRows<3>();
    M.noalias() += Am.transpose() * Am;
    b.noalias() += Am.transpose() * Y.tail<3>();
    yy += Y.tail<3>().squaredNorm();
    rows += 3;
  });
  if (rows <= 16) return std::nullopt;
  const Eigen::Matrix<double, 8, 1> d = M.diagonal().cwiseMax(1e-300).cwiseSqrt().cwiseInverse();
  const Eigen::Matrix<double, 8, 8> Ms = d.asDiagonal() * M * d.asDiagonal();
  const Eigen::LDLT<Eigen::Matrix<double, 8, 8>> ldlt(Ms);
  if (ldlt.info() != Eigen::Success || !(ldlt.rcond() > 1e-12)) return std::nullopt;
  const Eigen::Matrix<double, 8, 1> x = d.asDiagonal() * ldlt.solve(d.asDiagonal() * b);
  const double sse = std::max(0.0, yy - x.dot(b));
  // Residuals are correlated over the pre-filter's memory: fs / cutoff
  // samples carry about one independent one (as the position-units check).
  const double inflation = std::max(1.0, 1.0 / (T * cutoff_hz));
  const Eigen::Matrix<double, 8, 1> e7 = Eigen::Matrix<double, 8, 1>::Unit(7);
  const double m77 = d(7) * d(7) * ldlt.solve(e7)(7);
  const double se = std::sqrt(std::max(0.0, sse / double(rows - 8) * m77 * inflation));
  if (!std::isfinite(x(7)) || !std::isfinite(se)) return std::nullopt;
  return WrenchOffsetEstimate{x(7), se};
}

std::shared_ptr<const RegressionSignals> wrench_read_earlier(const RegressionSignals& sig, double offset) {
  auto out = std::make_shared<RegressionSignals>(sig);
  const Eigen::Index n = sig.size();
  const double s = offset / sig.T;  // samples
  for (Eigen::Index k = 0; k < n; ++k) {
    const double at = std::clamp(double(k) - s, 0.0, double(n - 1));
    const auto i = static_cast<Eigen::Index>(std::floor(at));
    const Eigen::Index j = std::min(i + 1, n - 1);
    const double w = at - double(i);
    out->x.row(k).tail<4>() = (1.0 - w) * sig.x.row(i).tail<4>() + w * sig.x.row(j).tail<4>();
  }
  return out;
}

}  // namespace quadid::detail
