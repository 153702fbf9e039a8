// The "axes" input check (axes.hpp): three kinematic identities a right log
// satisfies whatever the vehicle, each tested by correlation per axis (the
// unknown mass and inertia only scale them):
//   gyro        p q r     ~ W(eta)^-1 d(eta)/dt                     eq. (4)
//   torques     tau_i     ~ d(omega_i)/dt (diagonal-dominant inertia) eq. (2)
//   horizontal  x'', y''  ~ Fz (R(eta) e3)_x, Fz (R(eta) e3)_y      eq. (1)
// A log that fails one is tried with each known convention slip (and pairs
// of them); the first, simplest one under which all three hold is named
// with the --map that applies it, so the advice works when followed.
#include "axes.hpp"

#include "quadid/model.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <string>
#include <vector>

namespace quadid::detail {
namespace {

// The checked columns; a mapping takes canonical k from column src[k], times sgn[k].
enum Col { kPhi, kTheta, kPsi, kP, kQ, kR, kTauPhi, kTauTheta, kTauPsi, kX, kY, kCols };
constexpr std::array<const char*, kCols> kNames = {"phi", "theta", "psi", "p", "q", "r",
                                                   "tau_phi", "tau_theta", "tau_psi", "x", "y"};

struct Mapping {
  std::array<int, kCols> src{};
  std::array<double, kCols> sgn{};
  Mapping() {
    for (int k = 0; k < kCols; ++k) src[k] = k, sgn[k] = 1.0;
  }
};

// A convention slip and the --map items that undo it (canonical=source).
struct Slip {
  const char* what;
  std::vector<std::pair<Col, Col>> swaps;  // applied as both directions
  std::vector<Col> negated;
};

// In the order preferred when several explain the log (whole conventions first).
const std::vector<Slip>& slips() {
  static const std::vector<Slip> k = {
      {"body rates and torques in FRD (q, r, tau_theta, tau_psi of the opposite sign to body FLU's)", {},
       {kQ, kR, kTauTheta, kTauPsi}},
      {"body rates in FRD (q and r of the opposite sign to body FLU's) while the torques are FLU", {}, {kQ, kR}},
      {"Euler angles of a z-down (NED/FRD) attitude (theta and psi of the opposite sign to z-up FLU's)", {},
       {kTheta, kPsi}},
      {"p and q swapped", {{kP, kQ}}, {}},
      {"tau_phi and tau_theta swapped", {{kTauPhi, kTauTheta}}, {}},
      {"phi and theta swapped", {{kPhi, kTheta}}, {}},
      {"x and y swapped (an ENU/NED slip)", {{kX, kY}}, {}},
      {"y of the opposite sign (positions in a left-handed or NED-like frame)", {}, {kY}},
      {"x of the opposite sign", {}, {kX}},
      {"p of the opposite sign", {}, {kP}},
      {"q of the opposite sign", {}, {kQ}},
      {"r of the opposite sign", {}, {kR}},
      {"phi of the opposite sign", {}, {kPhi}},
      {"theta of the opposite sign", {}, {kTheta}},
      {"psi of the opposite sign", {}, {kPsi}},
      {"tau_phi of the opposite sign", {}, {kTauPhi}},
      {"tau_theta of the opposite sign", {}, {kTauTheta}},
      {"tau_psi of the opposite sign (a z-down log converted without its torques)", {}, {kTauPsi}},
      {"p and r swapped", {{kP, kR}}, {}},
      {"q and r swapped", {{kQ, kR}}, {}},
  };
  return k;
}

void apply(const Slip& s, Mapping& m) {
  for (const auto& [a, b] : s.swaps) std::swap(m.src[a], m.src[b]), std::swap(m.sgn[a], m.sgn[b]);
  for (Col c : s.negated) m.sgn[c] = -m.sgn[c];
}

// Columns minus their means, with their norms: every correlation of a score
// is then one dot product (a score takes 22 of them).
struct Centered {
  Eigen::RowVectorXd mean;
  Eigen::MatrixXd c;
  Eigen::RowVectorXd norm;
  explicit Centered(const Eigen::MatrixXd& a)
      : mean(a.colwise().mean()), c(a.rowwise() - mean), norm(c.colwise().norm()) {}
  Eigen::Index rows() const { return c.rows(); }
};

double corr(const Centered& a, Eigen::Index i, const Centered& b, Eigen::Index j) {
  const double d = a.norm(i) * b.norm(j);
  return d > 0.0 ? a.c.col(i).dot(b.c.col(j)) / d : std::numeric_limits<double>::quiet_NaN();
}

// W(eta)^-1 d(eta)/dt (eq. 4) and the thrust Fz R(eta) e3 (eq. 1), per row,
// from one sine and cosine of each angle (the formulas of
// euler_rate_matrix_inverse() and rotation()'s third column).
void kinematics(const Eigen::MatrixXd& eta, const Eigen::MatrixXd& etad, const Eigen::VectorXd& fz,
                Eigen::MatrixXd& kin, Eigen::MatrixXd& thrust) {
  const Eigen::Index n = eta.rows();
  kin.resize(n, 3), thrust.resize(n, 3);
  for (Eigen::Index k = 0; k < n; ++k) {
    const double cf = std::cos(eta(k, 0)), sf = std::sin(eta(k, 0));
    const double ct = std::cos(eta(k, 1)), st = std::sin(eta(k, 1));
    const double cp = std::cos(eta(k, 2)), sp = std::sin(eta(k, 2));
    const double e0 = etad(k, 0), e1 = etad(k, 1), e2 = etad(k, 2);
    kin(k, 0) = e0 - st * e2;
    kin(k, 1) = cf * e1 + ct * sf * e2;
    kin(k, 2) = -sf * e1 + ct * cf * e2;
    thrust(k, 0) = fz(k) * (st * cp * cf + sp * sf);
    thrust(k, 1) = fz(k) * (st * sp * cf - cp * sf);
    thrust(k, 2) = fz(k) * (ct * cf);
  }
}

// Per identity, the correlation of each excited axis (NaN: too still to judge).
struct Score {
  std::array<double, 3> gyro{}, torque{};
  std::array<double, 2> horizontal{};
  double worst() const {
    double w = 1.0;
    for (double c : gyro) w = std::isnan(c) ? w : std::min(w, c);
    for (double c : torque) w = std::isnan(c) ? w : std::min(w, c);
    for (double c : horizontal) w = std::isnan(c) ? w : std::min(w, c);
    return w;
  }
};

class AxisCheck {
 public:
  AxisCheck(const AxisSignals& s, const InputCheckOptions& o) : s_(s), o_(o) {}

  Score score(const Mapping& m) const {
    const Eigen::Index n = s_.gyro.rows();
    Eigen::MatrixXd eta(n, 3), etad(n, 3), w(n, 3), wd(n, 3), tau(n, 3), acc(n, 2);
    for (int i = 0; i < 3; ++i) {
      eta.col(i) = m.sgn[kPhi + i] * s_.eta.col(m.src[kPhi + i] - kPhi);
      etad.col(i) = m.sgn[kPhi + i] * s_.eta_dot.col(m.src[kPhi + i] - kPhi);
      w.col(i) = m.sgn[kP + i] * s_.gyro.col(m.src[kP + i] - kP);
      wd.col(i) = m.sgn[kP + i] * s_.alpha.col(m.src[kP + i] - kP);
      tau.col(i) = m.sgn[kTauPhi + i] * s_.tau.col(m.src[kTauPhi + i] - kTauPhi);
    }
    for (int i = 0; i < 2; ++i) acc.col(i) = m.sgn[kX + i] * s_.acc.col(m.src[kX + i] - kX);
    bool eta_as_logged = true;
    for (int i = kPhi; i <= kPsi; ++i) eta_as_logged = eta_as_logged && m.src[i] == i && m.sgn[i] > 0.0;
    Eigen::MatrixXd kin, thrust;
    if (eta_as_logged) {
      kin = s_.kin, thrust = s_.thrust;
    } else {
      kinematics(eta, etad, s_.fz, kin, thrust);
    }
    const Centered cw(w), ckin(kin), ctau(tau), cwd(wd), cacc(acc), cu(thrust.leftCols(2));
    Score sc;
    per_axis<3>(cw, ckin, o_.min_rate_rms, sc.gyro);
    per_axis<3>(ctau, cwd, o_.min_rate_rms, sc.torque);
    per_axis<2>(cacc, cu, o_.min_accel_rms, sc.horizontal);
    // An axis that no column follows says nothing about the order (a light
    // vehicle's rotor-model torques against its noisy angular acceleration):
    // it is left out. Signed permutations keep the largest |correlation|, so
    // every mapping leaves out the same axes.
    informative<3>(ctau, cwd, sc.torque);
    informative<2>(cacc, cu, sc.horizontal);
    informative<3>(cw, ckin, sc.gyro);
    return sc;
  }

  // The simplest slip (one, else two) under which every identity holds. A
  // slip of the torques is named only where they were measured (a rotor
  // model's torques follow the file's rotors, not a --map).
  std::optional<std::pair<std::vector<Slip>, Score>> explain(const Score& now) const {
    std::vector<Slip> k;
    const bool torques = std::any_of(now.torque.begin(), now.torque.end(), [](double c) { return !std::isnan(c); });
    for (const Slip& sl : slips()) {
      const auto is_torque = [](Col c) { return c == kTauPhi || c == kTauTheta || c == kTauPsi; };
      const bool touches = std::any_of(sl.negated.begin(), sl.negated.end(), is_torque) ||
                           std::any_of(sl.swaps.begin(), sl.swaps.end(),
                                       [&](const auto& ab) { return is_torque(ab.first) || is_torque(ab.second); });
      if (torques || !touches) k.push_back(sl);
    }
    for (const Slip& a : k) {
      Mapping m;
      apply(a, m);
      if (const Score s = score(m); s.worst() >= kGood) return std::pair{std::vector<Slip>{a}, s};
    }
    for (size_t i = 0; i < k.size(); ++i)
      for (size_t j = i + 1; j < k.size(); ++j) {
        Mapping m;
        apply(k[i], m);
        apply(k[j], m);
        if (const Score s = score(m); s.worst() >= kGood) return std::pair{std::vector<Slip>{k[i], k[j]}, s};
      }
    return std::nullopt;
  }

  static constexpr double kBad = 0.5;   // a right log's axes correlate above 0.9; below this one is wrong
  static constexpr double kGood = 0.8;  // what a convention must reach on every axis to be named

 private:
  // Correlation of a's and b's columns i where b's (the kinematic side) moves
  // enough: above the floor and above a fifth of the RMS of all its axes.
  template <int N>
  static void per_axis(const Centered& a, const Centered& b, double floor, std::array<double, N>& out) {
    // b's RMS about zero over all axes (b itself, not centred), as a fifth of which an axis must move.
    const double n = double(std::max<Eigen::Index>(b.rows(), 1));
    const double all = std::sqrt((b.norm.squaredNorm() + n * b.mean.squaredNorm()) / n / N);
    for (int i = 0; i < N; ++i) {
      const double r = b.norm(i) / std::sqrt(n);  // RMS of the centred axis
      out[static_cast<size_t>(i)] =
          r > floor && r > 0.2 * all ? corr(a, i, b, i) : std::numeric_limits<double>::quiet_NaN();
    }
  }

  // Leaves out (NaN) each axis i of b that no column of a follows.
  template <int N>
  static void informative(const Centered& a, const Centered& b, std::array<double, N>& out) {
    for (int i = 0; i < N; ++i) {
      double best = 0.0;
      for (int j = 0; j < N; ++j)
        if (const double c = std::abs(corr(a, j, b, i)); !std::isnan(c)) best = std::max(best, c);
      if (best < kGood) out[static_cast<size_t>(i)] = std::numeric_limits<double>::quiet_NaN();
    }
  }

  const AxisSignals& s_;
  const InputCheckOptions& o_;
};

std::string describe(const Score& s) {
  std::vector<std::string> parts;
  const auto add = [&](const char* a, const char* b, double c) {
    if (!std::isnan(c) && c < AxisCheck::kBad) parts.push_back(fmt::format("{} against {} {:.2f}", a, b, c));
  };
  const char* gyro[3] = {"p", "q", "r"};
  const char* kin[3] = {"the roll rate from the attitude", "the pitch rate from the attitude",
                        "the yaw rate from the attitude"};
  const char* tau[3] = {"tau_phi", "tau_theta", "tau_psi"};
  const char* acc[3] = {"dp/dt", "dq/dt", "dr/dt"};
  for (int i = 0; i < 3; ++i) add(gyro[i], kin[i], s.gyro[static_cast<size_t>(i)]);
  for (int i = 0; i < 3; ++i) add(tau[i], acc[i], s.torque[static_cast<size_t>(i)]);
  const char* h[2] = {"x''", "y''"};
  const char* u[2] = {"the thrust's x component Fz (R e3)_x", "the thrust's y component Fz (R e3)_y"};
  for (int i = 0; i < 2; ++i) add(h[i], u[i], s.horizontal[static_cast<size_t>(i)]);
  return fmt::format("{}", fmt::join(parts, ", "));
}

std::string maps_of(const std::vector<Slip>& slips) {
  Mapping m;
  for (const Slip& s : slips) apply(s, m);
  std::vector<std::string> items;
  for (int k = 0; k < kCols; ++k)
    if (m.src[k] != k || m.sgn[k] < 0.0)
      items.push_back(fmt::format("--map {}={}{}", kNames[k], m.sgn[k] < 0.0 ? "-" : "", kNames[m.src[k]]));
  return fmt::format("{}", fmt::join(items, " "));
}

}  // namespace

void add_kinematics(AxisSignals& s) { kinematics(s.eta, s.eta_dot, s.fz, s.kin, s.thrust); }

std::optional<InputFinding> check_axes(const AxisSignals& s, const InputCheckOptions& opt) {
  // A thrust of the wrong sign flips every horizontal identity at once; the
  // z-down check names it (negative mean thrust), not a slip of x and y.
  if (!(s.fz.mean() > 0.0)) return std::nullopt;
  const AxisCheck check(s, opt);
  const Score now = check.score(Mapping{});
  if (!(now.worst() < AxisCheck::kBad)) return std::nullopt;
  const auto fix = check.explain(now);
  if (!fix) return std::nullopt;
  std::vector<std::string> what;
  for (const Slip& sl : fix->first) what.push_back(sl.what);
  return InputFinding{
      "axes", Severity::Error,
      fmt::format("the columns disagree with the kinematics of a rigid body (correlations: {}; a right log's are "
                  "near 1)",
                  describe(now)),
      fmt::format("the log looks like it has {}: read it with {} (then every axis agrees, worst correlation {:.2f}); "
                  "the flight-log format is SI, body FLU, z up (docs/file-formats.md)",
                  fmt::join(what, " and "), maps_of(fix->first), fix->second.worst())};
}

namespace {

// The lag L (samples, sub-sample by a parabola through the peak) maximising
// the summed correlation of late(k + L) with early(k) over the columns whose
// peak correlation reaches 0.8; nullopt when none does or the peak is at the
// search's edge. A coarse grid (about 50 lags, on every step-th sample: the
// signals are low-passed far below the sample rate) and then every lag around
// its best, on every sample, keep it a small part of the checks on long, fast logs.
std::optional<double> lag_of(const Eigen::MatrixXd& late, const Eigen::MatrixXd& early, Eigen::Index max_lag) {
  const Eigen::Index n = late.rows(), len = n - 2 * max_lag, cols = late.cols();
  if (n < 8 * max_lag) return std::nullopt;
  const Eigen::MatrixXd a = late.rowwise() - late.colwise().mean(), b = early.rowwise() - early.colwise().mean();
  const Eigen::Index step = std::max<Eigen::Index>(1, max_lag / 25);
  const Eigen::Index coarse = 2 * max_lag / step + 1, m = (len + step - 1) / step;
  // corr(x, y) of x = v.segment(s, len) and the fixed y, given y's norm and
  // running sums sq of v's squares (the x norm at every lag in O(1)).
  const auto corr = [](const auto& x, const auto& y, double xx, double yy) {
    const double d = std::sqrt(std::max(0.0, xx)) * yy;
    return d > 0.0 ? x.dot(y) / d : 0.0;
  };
  const auto running_squares = [](const Eigen::VectorXd& v) {
    Eigen::VectorXd sq(v.size() + 1);
    sq(0) = 0.0;
    for (Eigen::Index k = 0; k < v.size(); ++k) sq(k + 1) = sq(k) + v(k) * v(k);
    return sq;
  };
  // Coarse: lag -max_lag + i step on every step-th sample; late's samples
  // i step, (i + 1) step, ... are a_dec(i), a_dec(i + 1), ...
  Eigen::MatrixXd grid(coarse, cols);
  std::vector<Eigen::Index> used;
  for (Eigen::Index j = 0; j < cols; ++j) {
    Eigen::VectorXd a_dec((n + step - 1) / step), b_dec(m);
    for (Eigen::Index k = 0; k < a_dec.size(); ++k) a_dec(k) = a(k * step, j);
    for (Eigen::Index k = 0; k < m; ++k) b_dec(k) = b(max_lag + k * step, j);
    const Eigen::VectorXd sq = running_squares(a_dec);
    const double yy = b_dec.norm();
    for (Eigen::Index i = 0; i < coarse; ++i) grid(i, j) = corr(a_dec.segment(i, m), b_dec, sq(i + m) - sq(i), yy);
    if (grid.col(j).maxCoeff() >= 0.8) used.push_back(j);
  }
  if (used.empty()) return std::nullopt;
  Eigen::Index best = 0;
  double best_c = -1e300;
  for (Eigen::Index i = 0; i < coarse; ++i) {
    double c = 0.0;
    for (Eigen::Index j : used) c += grid(i, j);
    if (c > best_c) best_c = c, best = -max_lag + i * step;
  }
  // Fine: every lag within a step of the coarse best, every sample.
  std::vector<Eigen::VectorXd> sq;
  std::vector<double> yy;
  for (Eigen::Index j : used) sq.push_back(running_squares(a.col(j))), yy.push_back(b.col(j).segment(max_lag, len).norm());
  const auto summed = [&](Eigen::Index L) {
    double c = 0.0;
    const Eigen::Index s0 = max_lag + L;
    for (std::size_t u = 0; u < used.size(); ++u) {
      const Eigen::Index j = used[u];
      c += corr(a.col(j).segment(s0, len), b.col(j).segment(max_lag, len), sq[u](s0 + len) - sq[u](s0), yy[u]);
    }
    return c;
  };
  const Eigen::Index lo = std::max(-max_lag, best - step - 1), hi = std::min(max_lag, best + step + 1);
  std::vector<double> fine(static_cast<std::size_t>(hi - lo + 1));
  for (Eigen::Index L = lo; L <= hi; ++L) fine[static_cast<std::size_t>(L - lo)] = summed(L);
  // The best lag within a step of the coarse one; its neighbours are in `fine`.
  const auto at = [&](Eigen::Index L) { return fine[static_cast<std::size_t>(L - lo)]; };
  const Eigen::Index from = std::max(-max_lag, best - step), to = std::min(max_lag, best + step);
  best = from;
  for (Eigen::Index L = from; L <= to; ++L)
    if (at(L) > at(best)) best = L;
  if (best <= -max_lag || best >= max_lag) return std::nullopt;
  const double ym = at(best - 1), y0 = at(best), yp = at(best + 1);
  const double den = ym - 2.0 * y0 + yp;
  return double(best) + (den < 0.0 ? 0.5 * (ym - yp) / den : 0.0);
}

}  // namespace

std::optional<InputFinding> check_gyro_delay(const AxisSignals& s, double T, const InputCheckOptions& opt) {
  (void)opt;
  const auto max_lag = static_cast<Eigen::Index>(std::ceil(0.25 / T));
  const auto att = lag_of(s.gyro, s.kin, max_lag);  // eq. (4)
  const auto tau = lag_of(s.alpha, s.tau, max_lag);  // eq. (2)
  if (!att || !tau) return std::nullopt;
  const double da = *att * T, dt = *tau * T;
  const double floor = std::max(3.0 * T, 0.005);
  if (!(da >= floor && dt >= floor) || std::abs(da - dt) > 0.25 * std::max(da, dt) + 2.0 * T) return std::nullopt;
  const double d = 0.5 * (da + dt);
  return InputFinding{
      "timing", Severity::Error,
      fmt::format("the gyro (p, q, r) lags the attitude by {:.1f} ms and the torques by {:.1f} ms (cross-correlation "
                  "of p, q, r with W(eta)^-1 d(eta)/dt, and of their derivatives with tau_phi, tau_theta, tau_psi)",
                  1e3 * da, 1e3 * dt),
      fmt::format("a late gyro stream biases the moments of inertia (50 ms: Iyy -8 % on a simulated flight): read "
                  "the gyro that much earlier with --gyro-delay {:.4g}, or align the streams' time stamps when "
                  "logging",
                  d)};
}

}  // namespace quadid::detail
