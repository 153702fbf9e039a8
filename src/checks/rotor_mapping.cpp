// Whether a log's rotor columns belong to the vehicle file's rotors as the
// file arranges them: the moment rows of the rigid body (eq. 10's Euler
// equations: six inertias and three constant torques) fitted with the torques
// of the file's arrangement and of every other one (the columns permuted, the
// positions turned by 45 deg). The fit is linear in the allocation, so one QR
// of the rates' regressor serves them all: each arrangement costs a quadratic
// form. Noise in the rotor speeds leaves every arrangement equally
// unexplained, so only a far better fit elsewhere is a finding.
#include "quadid/checks.hpp"
#include "quadid/model/regressor.hpp"
#include "quadid/signal.hpp"

#include <fmt/format.h>

#include <Eigen/QR>

#include <algorithm>
#include <array>
#include <cmath>
#include <numbers>
#include <numeric>
#include <vector>

namespace quadid {

RotorMappingCheck check_rotor_mapping(const FlightLog& log, const RotorModel& rotors, double cutoff_hz) {
  RotorMappingCheck out;
  const int N = rotors.count();
  const Eigen::Index n = log.rows();
  if (N < 3 || N > RotorMappingCheck::kMaxPermutedRotors || n < 3) return out;
  const double T = log_sample_period(log);
  const double fs = 1.0 / T;
  signal::LowpassOptions lp;
  lp.cutoff_hz = std::min(cutoff_hz, 0.2 * fs);
  const auto edge = static_cast<Eigen::Index>(std::ceil(2.0 * fs / lp.cutoff_hz));  // the filter's settling
  const Eigen::Index k0 = edge, k1 = n - edge, m = k1 - k0;
  if (m < 200) return out;

  // Per-rotor thrusts (N) and the body rates, low-passed alike (zero phase).
  const Eigen::MatrixXd w = rotors.speeds(rotor_inputs(log, rotors), T);
  Eigen::MatrixXd cols(n, N + 3);
  cols.leftCols(N) = rotors.thrusts(w);
  cols.col(N) = log.column("p");
  cols.col(N + 1) = log.column("q");
  cols.col(N + 2) = log.column("r");
  const Eigen::MatrixXd f = signal::zero_phase_lowpass(cols, fs, lp);
  const Eigen::MatrixXd wd = signal::central_difference(Eigen::MatrixXd(f.rightCols(3)), T);

  // A (3m x 9): the moment rows of eq. (10) in the six inertias, and a
  // constant torque per row. M (3m x 3N): row r of sample k holds the thrusts
  // in columns r N .. r N + N - 1, so that M vec(B) (B: 3 x N, row-major) is
  // the torques of allocation B.
  Eigen::MatrixXd A = Eigen::MatrixXd::Zero(3 * m, 9), M = Eigen::MatrixXd::Zero(3 * m, 3 * N);
  Eigen::VectorXd mean = Eigen::VectorXd::Zero(N);
  for (Eigen::Index k = k0; k < k1; ++k) {
    const double p = f(k, N), q = f(k, N + 1), r = f(k, N + 2);
    Eigen::Matrix<double, 7, 1> b;
    b << 0.0, p * q, p * r, q * r, p * p, q * q, r * r;
    const Regressor4x7 G = assemble_regressor(Vec4(0.0, wd(k, 0), wd(k, 1), wd(k, 2)), b);
    for (int row = 0; row < 3; ++row) {
      const Eigen::Index i = 3 * (k - k0) + row;
      A.row(i).head<6>() = G.row(row + 1).tail<6>();
      A(i, 6 + row) = 1.0;
      M.row(i).segment(row * N, N) = f.row(k).head(N);
    }
    mean += f.row(k).head(N).transpose();
  }
  mean /= static_cast<double>(m);
  // What the fit leaves: M projected off A's columns (Householder QR, no normal equations).
  const Eigen::HouseholderQR<Eigen::MatrixXd> qr(A);
  Eigen::MatrixXd R = M;
  R.applyOnTheLeft(qr.householderQ().adjoint());
  R.topRows(9).setZero();
  R.applyOnTheLeft(qr.householderQ());
  const Eigen::MatrixXd residual_gram = R.transpose() * R;  // only for quadratic forms
  // The rows' variance about their means: the centred thrusts' Gram, once per row.
  Eigen::MatrixXd Fc(m, N);
  for (Eigen::Index k = k0; k < k1; ++k) Fc.row(k - k0) = f.row(k).head(N) - mean.transpose();
  const Eigen::MatrixXd thrust_gram = Fc.transpose() * Fc;

  const Eigen::Matrix<double, 3, Eigen::Dynamic> B = rotors.allocation().bottomRows(3);
  auto unexplained = [&](const Eigen::Matrix<double, 3, Eigen::Dynamic>& Bh) {
    Eigen::VectorXd v(3 * N);
    double total = 0.0;
    for (int row = 0; row < 3; ++row) {
      v.segment(row * N, N) = Bh.row(row).transpose();
      total += Bh.row(row) * thrust_gram * Bh.row(row).transpose();
    }
    return total > 0.0 ? double(v.transpose() * residual_gram * v) / total : 1.0;
  };
  out.unexplained = unexplained(B);
  out.checked = true;
  // Every other arrangement: the positions turned by 0 or +-45 deg about z (X
  // for +), and log column j driving the file's rotor perm[j]. Some fit
  // equally well (a + layout turned by -45 deg is the X layout with its
  // columns rotated and turned by +45 deg); which of them comes out least by
  // rounding is arbitrary, so the simplest within kTie of the least is named:
  // a turn alone or a reorder alone before both.
  constexpr double kTie = 0.005;  // half a point of the variance: rounding is ~1e-12, real differences are points
  struct Candidate {
    double u;
    int changes;  // 0 the file's own, 1 a turn or a reorder, 2 both
    double deg;
    std::vector<int> perm;
  };
  std::vector<Candidate> all{{out.unexplained, 0, 0.0, {}}};
  constexpr std::array<double, 3> kTurns{0.0, 45.0, -45.0};
  std::vector<int> perm(static_cast<size_t>(N));
  for (const double deg : kTurns) {
    const double a = deg * std::numbers::pi / 180.0;
    Eigen::Matrix<double, 3, Eigen::Dynamic> Bt = B;
    Bt.row(0) = std::cos(a) * B.row(0) - std::sin(a) * B.row(1);  // (tau_phi, tau_theta) turned with the positions
    Bt.row(1) = std::sin(a) * B.row(0) + std::cos(a) * B.row(1);
    std::iota(perm.begin(), perm.end(), 0);
    do {
      const bool reordered = !std::is_sorted(perm.begin(), perm.end());
      if (deg == 0.0 && !reordered) continue;  // the file's own
      Eigen::Matrix<double, 3, Eigen::Dynamic> Bh(3, N);
      for (int j = 0; j < N; ++j) Bh.col(j) = Bt.col(perm[static_cast<size_t>(j)]);
      all.push_back({unexplained(Bh), int(deg != 0.0) + int(reordered), deg, reordered ? perm : std::vector<int>{}});
    } while (std::next_permutation(perm.begin(), perm.end()));
  }
  double least = out.unexplained;
  for (const auto& c : all) least = std::min(least, c.u);
  const Candidate* named = nullptr;
  for (const auto& c : all)
    if (c.u <= least + kTie && (!named || c.changes < named->changes || (c.changes == named->changes && c.u < named->u)))
      named = &c;
  out.best_unexplained = named->u;
  out.best_turn_deg = named->deg;
  if (!named->perm.empty()) {  // rotor perm[j]'s column is column j
    out.best_columns.assign(static_cast<size_t>(N), std::string());
    for (size_t j = 0; j < named->perm.size(); ++j)
      out.best_columns[static_cast<size_t>(named->perm[j])] = rotors.columns[j];
  }
  out.mismatch = out.best_unexplained < RotorMappingCheck::kFactor * out.unexplained &&
                 out.unexplained - out.best_unexplained >= RotorMappingCheck::kMargin;
  return out;
}

std::string RotorMappingCheck::describe() const {
  std::vector<std::string> fix;
  if (!best_columns.empty()) {
    std::vector<std::string> q;
    for (const auto& c : best_columns) q.push_back("\"" + c + "\"");
    fix.push_back(fmt::format("columns = [{}]", fmt::join(q, ", ")));
  }
  if (best_turn_deg != 0.0)
    fix.push_back(fmt::format("the positions turned by {:+g} deg about z (an X layout for a + vehicle, or the reverse)",
                              best_turn_deg));
  return fmt::format("the vehicle file's rotors leave {:.0f} % of the moment rows unexplained, and {} would leave "
                     "{:.1f} %: the log's rotor columns do not drive the rotors the file says (its [rotors] columns "
                     "and positions)",
                     100.0 * unexplained, fmt::join(fix, " and "), 100.0 * best_unexplained);
}

}  // namespace quadid
