// Plausibility checks of a flight log before any estimate (docs/input-checks.md):
// angle/rate units, z direction, thrust units, aliasing, saturation, time gaps.
#include "quadid/checks.hpp"
#include "axes.hpp"
#include "quadid/model.hpp"
#include "quadid/signal/median_step.hpp"

#include <fmt/format.h>

#include <Eigen/QR>

#include <algorithm>
#include <cmath>
#include <complex>
#include <numbers>
#include <stdexcept>
#include <unsupported/Eigen/FFT>

namespace quadid {
namespace {

constexpr double kRad2Deg = 180.0 / std::numbers::pi;
constexpr double kRadPerSPerRpm = 2.0 * std::numbers::pi / 60.0;  // rad/s per rpm: thrust goes as its square

double rms(const Eigen::VectorXd& v) { return v.size() ? std::sqrt(v.squaredNorm() / double(v.size())) : 0.0; }

// r within a factor tol of target (both positive).
bool near_factor(double r, double target, double tol) { return r > target / tol && r < target * tol; }

}  // namespace

const char* to_string(Severity s) {
  switch (s) {
    case Severity::Info: return "info";
    case Severity::Warning: return "warning";
    case Severity::Error: return "error";
  }
  return "?";
}

void InputCheckOptions::validate() const {
  if (!(g > 0.0)) throw std::invalid_argument(fmt::format("InputCheckOptions: g={} must be positive", g));
  if (reference_mass && !(*reference_mass > 0.0))
    throw std::invalid_argument(fmt::format("InputCheckOptions: reference_mass={} must be positive", *reference_mass));
  if (!(ratio_tolerance > 1.0 && ratio_tolerance < 5.0))
    throw std::invalid_argument(fmt::format("InputCheckOptions: ratio_tolerance={} must be in (1, 5)", ratio_tolerance));
  if (!(min_rate_rms > 0.0) || !(min_accel_rms > 0.0))
    throw std::invalid_argument("InputCheckOptions: min_rate_rms and min_accel_rms must be positive");
  if (!(aliasing_ratio > 0.0) || !(band_hz > 0.0))
    throw std::invalid_argument("InputCheckOptions: aliasing_ratio and band_hz must be positive");
  if (saturation_run < 2 || !(saturation_fraction >= 0.0 && saturation_fraction < 1.0))
    throw std::invalid_argument("InputCheckOptions: saturation_run must be >= 2, saturation_fraction in [0, 1)");
  if (!(gap_factor > 1.0)) throw std::invalid_argument(fmt::format("InputCheckOptions: gap_factor={} must be > 1", gap_factor));
  if (!(sampling_min_r2 >= 0.0 && sampling_min_r2 < 1.0) || !(sampling_band_hz > 0.0) || !(sampling_gain_ratio > 1.0))
    throw std::invalid_argument(fmt::format(
        "InputCheckOptions: sampling_min_r2={} must be in [0, 1), sampling_band_hz={} positive and "
        "sampling_gain_ratio={} above 1",
        sampling_min_r2, sampling_band_hz, sampling_gain_ratio));
}

namespace {

// Top fifth below Nyquist against the median density between the band
// and there (the noise floor): a flat (white) spectrum gives ~1 whether
// or not it was aliased; folded vibration or noise that rises towards
// Nyquist gives more.
// It must also matter against the band itself (a noise-free log has a
// floor near rounding, so any ripple stands above it). 0 when not measurable.
double near_nyquist_ratio(const std::vector<double>& psd, double fs, Eigen::Index nseg, const InputCheckOptions& opt) {
  const double fN = 0.5 * fs;
  double top = 0.0, band = 0.0;
  int nt = 0, nb = 0;
  std::vector<double> mid;
  for (size_t k = 1; k < psd.size(); ++k) {
    const double fk = double(k) * fs / double(nseg);
    // The last 5 % below Nyquist are left out: a discrete controller's
    // own period-2 ringing sits there, native, not aliased.
    if (fk >= 0.95 * fN) continue;
    if (fk >= 0.75 * fN) top += psd[k], ++nt;
    else if (fk > opt.band_hz) mid.push_back(psd[k]);
    else band += psd[k], ++nb;
  }
  if (nt == 0 || nb == 0 || mid.size() < 4) return 0.0;
  if (!((top / nt) > opt.aliasing_band_ratio * (band / nb))) return 0.0;
  std::nth_element(mid.begin(), mid.begin() + static_cast<long>(mid.size() / 2), mid.end());
  const double floor = mid[mid.size() / 2];
  if (!(floor > 0.0)) return 0.0;
  return (top / nt) / floor;
}

// One run of check_input: each check a step, in the order of the findings.
// The steps that return false end the checks (what follows would not apply).
class InputChecks {
 public:
  InputChecks(const FlightLog& log, const InputCheckOptions& opt) : log_(log), opt_(opt) {}

  std::vector<InputFinding> run() {
    if (!has_columns() || !long_enough() || !time_gaps() || !filtered()) return std::move(out_);
    const size_t before = out_.size();
    angle_units();
    const auto no_error = [&] {
      return std::none_of(out_.begin() + static_cast<std::ptrdiff_t>(before), out_.end(),
                          [](const InputFinding& f) { return f.severity == Severity::Error; });
    };
    if (no_error()) axes();
    if (no_error()) torque_sampling();
    vertical_signals();
    const bool no_thrust = thrust_present();
    const double zsign = z_direction();
    const bool positions_ok = no_thrust || zsign < 0.0 || position_units();
    if (opt_.reference_mass && !no_thrust && positions_ok) thrust_units(zsign);
    aliasing();
    saturation();
    return std::move(out_);
  }

 private:
  void add(const char* check, Severity s, std::string saw, std::string action) {
    out_.push_back({check, s, std::move(saw), std::move(action)});
  }

  // The checks need every standard column.
  bool has_columns() {
    for (const auto& c : standard_log_columns())
      if (!log_.has(c)) {
        add("columns", Severity::Info, fmt::format("no column '{}': checks skipped", c),
            "provide the standard columns (docs/file-formats.md)");
        return false;
      }
    return true;
  }

  // Too short a log says nothing the checks could trust.
  bool long_enough() {
    n_ = log_.rows();
    if (n_ < 64) {
      add("length", Severity::Info, fmt::format("{} samples: too few for the input checks", n_), "none");
      return false;
    }
    t_ = log_.column("t");
    return true;
  }

  // Time gaps: the median step is the log's period; steps far beyond it are gaps.
  bool time_gaps() {
    Eigen::VectorXd dt = t_.tail(n_ - 1) - t_.head(n_ - 1);
    T_ = signal::median_step(std::span<const double>(t_.data(), static_cast<std::size_t>(t_.size())));
    if (!(T_ > 0.0)) {
      add("time-gaps", Severity::Error, "the median time step is not positive (time does not increase)",
          "sort the log by time and remove repeated samples");
      return false;
    }
    long gaps = 0, backwards = 0;
    double largest = 0.0, at = 0.0;
    for (Eigen::Index k = 0; k < dt.size(); ++k) {
      if (!(dt(k) > 0.0)) ++backwards;
      else if (dt(k) > opt_.gap_factor * T_) {
        ++gaps;
        if (dt(k) > largest) largest = dt(k), at = t_(k) - t_(0);
      }
    }
    if (backwards)
      add("time-gaps", Severity::Error, fmt::format("time does not increase at {} sample(s)", backwards),
          "sort the log by time and remove repeated samples");
    if (gaps)
      add("time-gaps", Severity::Error,
          fmt::format("{} gap(s) in time: the largest is {:.4g} s ({:.1f} sample periods of {:.4g} s) at {:.4g} s from "
                      "the start",
                      gaps, largest, largest / T_, T_, at),
          "identify on a window without gaps (--window), or resample the log onto a uniform time base with an "
          "anti-aliasing filter");
    fs_ = 1.0 / T_;
    return true;
  }

  // Filtered signals for the differentiating checks (zero phase, as identify).
  bool filtered() {
    signal::LowpassOptions lp = opt_.lowpass;
    lp.cutoff_hz = std::min(lp.cutoff_hz, 0.2 * fs_);
    const char* names[13] = {"z", "phi", "theta", "psi", "p", "q", "r", "Fz", "tau_phi", "tau_theta", "tau_psi", "x", "y"};
    raw_.resize(n_, 13);
    for (int c = 0; c < 13; ++c) raw_.col(c) = log_.column(names[c]);
    signal::unwrap(raw_.col(3).data(), n_);
    try {
      f_ = signal::zero_phase_lowpass(raw_, fs_, lp);
    } catch (const std::exception& e) {
      add("length", Severity::Info, fmt::format("the checks' low-pass does not apply ({})", e.what()), "none");
      return false;
    }
    // Interior: clear of the filter's edge transients (5 % of the log at each end).
    e0_ = n_ / 20;
    e1_ = n_ - n_ / 20;
    m_ = e1_ - e0_;
    return true;
  }

  // Angle and rate units: gyro vs W(eta)^-1 eta_dot (eq. 4).
  void angle_units() {
    const Eigen::MatrixXd etad = signal::central_difference(Eigen::MatrixXd(f_.middleCols(1, 3)), T_);
    Eigen::MatrixXd we(m_, 3), gy(m_, 3);
    for (Eigen::Index k = e0_; k < e1_; ++k) {
      const Vec3 eta = f_.row(k).segment<3>(1).transpose();
      we.row(k - e0_) = (euler_rate_matrix_inverse(eta) * etad.row(k).transpose()).transpose();
      gy.row(k - e0_) = f_.row(k).segment<3>(4);
    }
    const double r_e = std::sqrt(we.squaredNorm() / double(m_)), r_g = std::sqrt(gy.squaredNorm() / double(m_));
    const double max_tilt = std::max(raw_.col(1).cwiseAbs().maxCoeff(), raw_.col(2).cwiseAbs().maxCoeff());
    if (max_tilt > 0.5 * std::numbers::pi)
      add("angle-units", Severity::Error,
          fmt::format("roll or pitch reaches {:.4g}, beyond 90 deg if in radians", max_tilt),
          "the Euler angles are probably in degrees: convert phi, theta, psi to radians");
    else if (std::max(r_e, r_g) < opt_.min_rate_rms)
      add("angle-units", Severity::Info,
          fmt::format("too little rotation to compare the gyro with the Euler angles (RMS {:.3g} rad/s)", std::max(r_e, r_g)),
          "none");
    else
      rate_ratio(we, gy, r_e, r_g);
  }

  // The gyro against W^-1 eta_dot once both rotate enough: a factor 57.3 is degrees.
  void rate_ratio(const Eigen::MatrixXd& we, const Eigen::MatrixXd& gy, double r_e, double r_g) {
    const double ratio = r_g / r_e;
    // Per-axis agreement once scaled: correlation of the gyro with W^-1 eta_dot.
    double worst_corr = 1.0;
    for (int i = 0; i < 3; ++i) {
      const double a = we.col(i).norm(), b = gy.col(i).norm();
      if (a > 0.0 && b > 0.0 && rms(gy.col(i)) > 0.2 * r_g) worst_corr = std::min(worst_corr, we.col(i).dot(gy.col(i)) / (a * b));
    }
    const std::string saw = fmt::format(
        "the body rates (p, q, r) are {:.3g} times W(eta)^-1 d(eta)/dt (RMS {:.3g} vs {:.3g}; worst per-axis "
        "correlation {:.2f})",
        ratio, r_g, r_e, worst_corr);
    if (near_factor(ratio, 1.0 / kRad2Deg, opt_.ratio_tolerance))
      add("angle-units", Severity::Error, saw,
          "the Euler angles are probably in degrees (factor 57.3): convert phi, theta, psi to radians");
    else if (near_factor(ratio, kRad2Deg, opt_.ratio_tolerance))
      add("angle-units", Severity::Error, saw, "the body rates are probably in deg/s (factor 57.3): convert p, q, r to rad/s");
    else if (!near_factor(ratio, 1.0, opt_.ratio_tolerance))
      add("angle-units", Severity::Warning, saw,
          "the gyro and the Euler angles disagree in scale: check the units of both and the rate column mapping");
    else if (worst_corr < 0.5)
      add("angle-units", Severity::Warning, saw,
          "the gyro and the Euler angles disagree in shape: check the axis order and signs of p, q, r (body FLU) "
          "and that the angles are ZYX Euler angles in radians");
  }

  // Gyro, torques and horizontal acceleration against the attitude (axes.hpp):
  // an Error with the --map that makes them agree replaces the shape warning.
  // The low-passed signals of the interior rows and their kinematics (the
  // axes, timing and position-units checks share them; computed once).
  const detail::AxisSignals& axis_signals() {
    if (axis_.fz.size() == m_ && m_ > 0) return axis_;
    detail::AxisSignals& s = axis_;
    const Eigen::MatrixXd d = signal::central_difference(Eigen::MatrixXd(f_.middleCols(1, 6)), T_);
    const Eigen::MatrixXd& dd = horizontal_acceleration();
    s.eta = f_.block(e0_, 1, m_, 3);
    s.eta_dot = d.block(e0_, 0, m_, 3);
    s.gyro = f_.block(e0_, 4, m_, 3);
    s.alpha = d.block(e0_, 3, m_, 3);
    s.tau = f_.block(e0_, 8, m_, 3);
    s.acc = dd.block(e0_, 0, m_, 2);
    s.fz = f_.block(e0_, 7, m_, 1);
    detail::add_kinematics(s);
    return axis_;
  }

  void axes() {
    const detail::AxisSignals& s = axis_signals();
    if (auto f = detail::check_axes(s, opt_)) {
      std::erase_if(out_, [](const InputFinding& x) {
        return x.check == "angle-units" && x.severity == Severity::Warning;
      });
      out_.push_back(std::move(*f));
    } else if (auto d = detail::check_gyro_delay(s, T_, opt_)) {
      out_.push_back(std::move(*d));
    }
  }

  // Torque sampling: a rigid body's angular velocity changes over one period
  // by the torque it felt over that period (eq. 2), so a logged torque that
  // is the one applied (held over the period) is followed by the gyro's
  // forward difference also at the fast end of the band. A command point-
  // sampled from a faster controller (a log decimated without an anti-
  // aliasing filter) carries content folded from above the rate that the
  // gyro never saw: in the band, correlated with the motion, it biases Ixx
  // and Iyy (every 10th row of a 500 Hz simulated flight: Ixx +102 %, R^2
  // 0.45; as logged: 0.97).
  void torque_sampling() {
    const double lo = std::min(opt_.sampling_band_hz, 0.1 * fs_), hi = std::min(30.0, 0.45 * fs_);
    if (!(hi > 1.5 * lo) || n_ < 64) return;
    const Eigen::Index n = n_ - 1;
    Eigen::MatrixXd x(n, 4);  // tau_phi, tau_theta, dp/dt, dq/dt
    x.leftCols(2) = raw_.block(0, 8, n, 2);
    x.rightCols(2) = (raw_.block(1, 4, n, 2) - raw_.block(0, 4, n, 2)) / T_;
    // The band lo-hi as the difference of two zero-phase low-passes.
    const auto lowpassed = [&](Eigen::MatrixXd v, double f) {
      signal::ZeroPhaseFilter lp(signal::butter_sos(4, f, fs_));
      std::array<double*, 4> cols{};
      for (int c = 0; c < 4; ++c) cols[static_cast<size_t>(c)] = v.col(c).data();
      lp.apply(cols.data(), 4, v.rows());
      return v;
    };
    Eigen::MatrixXd h, l;
    try {
      const Eigen::Index rows = std::min(m_, n - e0_);
      const Eigen::MatrixXd slow = lowpassed(x, lo);
      h = ((hi < 0.45 * fs_ - 1e-9 ? lowpassed(x, hi) : x) - slow).middleRows(e0_, rows);
      l = slow.middleRows(e0_, rows);
      l = l.rowwise() - l.colwise().mean();
    } catch (const std::exception&) {
      return;  // too short for the filters
    }
    // Per axis: R^2 of the torque on the rate change in the fast band, and
    // the gain there against the gain in the band below (about the moment of
    // inertia in both when the torque is the one felt). Noise on the torques
    // (noisy rotor speeds) lowers R^2 but leaves the gain; folded content
    // lowers both R^2 and the fast band's gain (every 10th row: 0.59 of the
    // slow band's).
    std::array<double, 2> r2{}, gain_ratio{};
    for (int i = 0; i < 2; ++i) {
      const auto t = h.col(i), a = h.col(2 + i);
      const double tt = t.squaredNorm(), aa = a.squaredNorm(), ta = t.dot(a);
      const double la = l.col(2 + i).squaredNorm(), lt = l.col(i).dot(l.col(2 + i));
      // Too little fast torque to judge (a perfect-tracking log): nothing to say.
      if (!(tt > 0.0 && aa > 0.0 && la > 0.0) ||
          std::sqrt(tt / double(h.rows())) < 1e-3 * raw_.col(8 + i).cwiseAbs().maxCoeff())
        return;
      r2[static_cast<size_t>(i)] = ta * ta / (tt * aa);
      gain_ratio[static_cast<size_t>(i)] = (ta / aa) / (lt / la);
    }
    const auto gain_off = [&](double g) { return !(std::abs(std::log(g)) <= std::log(opt_.sampling_gain_ratio)); };
    if (std::max(r2[0], r2[1]) >= opt_.sampling_min_r2 || !gain_off(gain_ratio[0]) || !gain_off(gain_ratio[1])) return;
    add("torque-sampling", Severity::Warning,
        fmt::format("the torques' fast content ({:.3g}-{:.3g} Hz) is not what turned the vehicle: tau_phi against "
                    "the gyro's change over each period dp/dt R^2 = {:.2f}, tau_theta against dq/dt {:.2f} (right "
                    "logs: 0.58-0.88 on four real Crazyflie flights, above 0.96 simulated), with gains {:.2f} and "
                    "{:.2f} times those below {:.3g} Hz (noise on the torques leaves them near 1)",
                    lo, hi, r2[0], r2[1], gain_ratio[0], gain_ratio[1], lo),
        "the torque columns look like point samples of a command that changes faster than the log's rate (a log "
        "decimated without an anti-aliasing filter, or a controller's output logged at a lower rate): what folds "
        "into the band biases Ixx and Iyy beyond their intervals (every 10th row of a 500 Hz simulated flight: Ixx "
        "+102 %); log the torques at the controller's rate, or as their means over each log period");
  }

  // x'' and y'' of the low-passed positions, every row (the axes and the
  // position-units checks both need them; computed once).
  const Eigen::MatrixXd& horizontal_acceleration() {
    if (xy_acc_.rows() == 0)
      xy_acc_ = signal::central_difference(signal::central_difference(Eigen::MatrixXd(f_.middleCols(11, 2)), T_), T_);
    return xy_acc_;
  }

  // z'' and Fz cos(phi) cos(theta) over the interior, for the z and thrust checks.
  void vertical_signals() {
    const Eigen::VectorXd zdd = signal::central_difference(signal::central_difference(Eigen::VectorXd(f_.col(0)), T_), T_);
    a_.resize(m_);
    u_.resize(m_);
    for (Eigen::Index k = e0_; k < e1_; ++k) {
      a_(k - e0_) = zdd(k);
      u_(k - e0_) = f_(k, 7) * std::cos(f_(k, 1)) * std::cos(f_(k, 2));  // eq. (1), vertical: m z'' = Fz c(phi) c(theta) - m g
    }
  }

  // No thrust at all: a log from the ground (motors stopped or disarmed), where
  // every other finding would only be a consequence; a negative mean is z down.
  bool thrust_present() {
    const double mean_fz = raw_.col(7).mean();
    const auto none = no_thrust_finding(raw_.col(7));
    const bool no_thrust = none.has_value();
    if (none) out_.push_back(*none);
    if (mean_fz < 0.0)
      add("z-down", Severity::Error, fmt::format("the mean thrust Fz is {:.4g} N, negative", mean_fz),
          "Fz must be the thrust along +z body (up): a z-down (NED/FRD) log needs its frames converted (z -> -z, "
          "Fz -> -Fz, tau_theta and tau_psi -> minus themselves)");
    return no_thrust;
  }

  // z direction: z'' must rise with the thrust's vertical part. Returns the sign of z found.
  double z_direction() {
    const Eigen::VectorXd ac = a_.array() - a_.mean(), uc = u_.array() - u_.mean();
    if (rms(ac) < opt_.min_accel_rms || uc.norm() == 0.0) {
      add("z-down", Severity::Info,
          fmt::format("too little vertical acceleration to check the direction of z (RMS {:.3g} m/s^2)", rms(ac)),
          "none");
      return 1.0;
    }
    const double corr = ac.dot(uc) / (ac.norm() * uc.norm());
    if (corr < -0.3) {
      add("z-down", Severity::Error,
          fmt::format("the vertical acceleration z'' falls when the thrust's vertical part Fz cos(phi) cos(theta) "
                      "rises (correlation {:.2f}; z mean {:.3g} m)",
                      corr, raw_.col(0).mean()),
          "z appears to point down (NED): read it with --map z=-z (a whole NED log also needs its y, and the "
          "attitude's theta and psi, negated, which the axes check names; docs/file-formats.md)");
      return -1.0;
    }
    if (corr < 0.3)
      add("z-down", Severity::Warning,
          fmt::format("the vertical acceleration z'' and the thrust's vertical part hardly correlate ({:.2f})", corr),
          "check that z is the altitude in m (z up) and Fz the total thrust in N");
    return 1.0;
  }

  // Thrust units: u = m (z'' + g) in the least-squares sense (with z'' as logged,
  // times the sign found), against the reference mass; known factors named.
  void thrust_units(double zsign) {
    const Eigen::VectorXd acc = (zsign * a_).array() + opt_.g;
    const double m_est = u_.dot(acc) / acc.squaredNorm();
    const double ratio = m_est / *opt_.reference_mass;
    const std::string saw = fmt::format(
        "the thrust gives a mass of {:.4g} kg (Fz cos(phi) cos(theta) / (z'' + g)), {:.3g} times the reference "
        "{:.4g} kg",
        m_est, ratio, *opt_.reference_mass);
    const double tol = opt_.ratio_tolerance;
    if (!(ratio > 0.0))
      add("thrust-units", Severity::Error, saw, "Fz must be the total thrust in N along +z body");
    else if (near_factor(ratio, 1.0 / opt_.g, tol))
      add("thrust-units", Severity::Warning, saw,
          fmt::format("Fz is probably in kgf (factor {:g}): multiply it by g (or the reference mass is in the wrong unit)", opt_.g));
    else if (near_factor(ratio, opt_.g, tol))
      add("thrust-units", Severity::Warning, saw,
          "Fz is g times too large for the reference mass: the reference mass may be a weight in N, or Fz scaled");
    else if (near_factor(ratio, kRadPerSPerRpm * kRadPerSPerRpm, tol) ||
             near_factor(ratio, 1.0 / (kRadPerSPerRpm * kRadPerSPerRpm), tol))
      add("thrust-units", Severity::Warning, saw,
          fmt::format("a factor (60 / 2 pi)^2 = {:.1f}: rotor speeds in rad/s where the vehicle file says rpm, or "
                      "the reverse (its [rotors] input)",
                      1.0 / (kRadPerSPerRpm * kRadPerSPerRpm)));
    else if (near_factor(ratio, 1e-3, tol) || near_factor(ratio, 1e3, tol))
      add("thrust-units", Severity::Warning, saw, "a factor 1000: grams vs kilograms (mass) or mN vs N (thrust)");
    else if (!near_factor(ratio, 1.0, tol))
      add("thrust-units", Severity::Warning, saw,
          "the thrust and the reference mass disagree: check the thrust model (kf, thrust scale) and the reference "
          "set (--nominal)");
  }

  // The positions' unit, mass-free (issue 37): eq. (1) divided by m reads
  // p'' = (Fz/m) R(eta) e3 - g e3. Positions logged in a unit u metres give
  // p''/u, so p'' = b Fz R e3 - c g e3 with b = 1/(m u), c = 1/u: two unknowns
  // that the horizontal rows (b alone) and the vertical row (b and c) fix.
  // c is 1 for metres, 1000 for millimetres; gravity is the yardstick. A
  // wrong c scales the mass (the force row) and nothing else shows it.
  // Returns false when the positions are not in metres.
  bool position_units() {
    const Eigen::MatrixXd& dd = horizontal_acceleration();
    const Eigen::MatrixXd& thrust = axis_signals().thrust;  // Fz R(eta) e3 of rows e0..e1
    Eigen::MatrixXd A = Eigen::MatrixXd::Zero(3 * m_, 2);
    Eigen::VectorXd y(3 * m_);
    for (Eigen::Index k = e0_; k < e1_; ++k) {
      const Eigen::Index i = k - e0_;
      A.block(3 * i, 0, 3, 1) = thrust.row(i).transpose();
      A(3 * i + 2, 1) = -opt_.g;
      y.segment(3 * i, 3) << dd(k, 0), dd(k, 1), a_(i);
    }
    const Eigen::ColPivHouseholderQR<Eigen::MatrixXd> qr(A);
    if (qr.rank() < 2) return true;
    const Eigen::Vector2d x = qr.solve(y);
    const Eigen::VectorXd e = y - A * x;
    // Standard error of c from the residual, inflated for the residuals'
    // correlation over the pre-filter's memory; the unit is judged only when
    // the flight pins it to 10 %.
    const Eigen::Matrix2d cov = (A.transpose() * A).inverse() * (e.squaredNorm() / double(A.rows() - 2)) *
                                std::max(1.0, fs_ / opt_.lowpass.cutoff_hz);
    const double c = x(1), se = std::sqrt(std::max(0.0, cov(1, 1)));
    if (!std::isfinite(c) || !(c > 0.0) || !(se < 0.1 * c)) return true;
    const double tol = opt_.ratio_tolerance;
    const std::string saw = fmt::format(
        "the positions' second derivative against gravity and the thrust's direction (p'' = b Fz R(eta) e3 - c g e3, "
        "least squares) gives c = {:.4g} +- {:.2g}, where positions in metres give 1",
        c, se);
    const auto unit = [&](const char* name, double per_m) {
      add("position-units", Severity::Error, saw,
          fmt::format("x, y, z look like they are in {}: divide them by {:g} (positions in metres; the mass, which "
                      "divides by the vertical acceleration, would be {:g} times off)",
                      name, per_m, per_m));
      return false;
    };
    if (near_factor(c, 1000.0, tol)) return unit("millimetres", 1000.0);
    if (near_factor(c, 100.0, tol)) return unit("centimetres", 100.0);
    if (near_factor(c, 1.0 / 0.3048, 1.2)) return unit("feet", 1.0 / 0.3048);
    if (near_factor(c, 1.0, tol)) return true;
    add("position-units", Severity::Warning, saw,
        fmt::format("the positions are not in metres, or the thrust's direction (the attitude) is off: positions "
                    "times {:.3g} would be metres",
                    1.0 / c));
    return false;
  }

  // Aliasing: power near Nyquist against the identification band.
  void aliasing() {
    const double fN = 0.5 * fs_;
    Eigen::Index nseg = 16;
    while (double(nseg) < 4.0 * fs_ / opt_.band_hz && nseg < n_) nseg *= 2;
    if (nseg > n_) nseg /= 2;
    const char* sigs[4] = {"Fz", "tau_phi", "tau_theta", "tau_psi"};
    if (fs_ / double(nseg) > opt_.band_hz || opt_.band_hz > 0.5 * fN) {
      add("aliasing", Severity::Info,
          fmt::format("log too short or too slow ({:g} Hz) to compare the spectrum near Nyquist with the band below "
                      "{:g} Hz",
                      fs_, opt_.band_hz),
          "none");
      return;
    }
    std::vector<std::string> bad;
    for (const char* s : sigs) {
      const double ratio = near_nyquist_ratio(signal::welch_psd(log_.column(s), fs_, nseg), fs_, nseg, opt_);
      if (ratio > opt_.aliasing_ratio) bad.push_back(fmt::format("{} +{:.1f} dB", s, 10.0 * std::log10(ratio)));
    }
    if (!bad.empty())
      add("aliasing", Severity::Warning,
          fmt::format("the power spectral density near Nyquist ({:.3g}-{:.3g} Hz) stands above the median density "
                      "between {:g} Hz and there: {} (threshold +{:.0f} dB)",
                      0.75 * fN, 0.95 * fN, opt_.band_hz, fmt::join(bad, ", "), 10.0 * std::log10(opt_.aliasing_ratio)),
          "the signals were not band-limited when sampled: a log decimated without an anti-aliasing filter folds "
          "vibration and noise into the band; log at the full rate or low-pass before decimating");
  }

  // Actuator saturation: flat tops at the log's extremes.
  void saturation() {
    const char* sigs[4] = {"Fz", "tau_phi", "tau_theta", "tau_psi"};
    const char* units[4] = {"N", "N m", "N m", "N m"};
    for (int s = 0; s < 4; ++s) {
      const Eigen::VectorXd x = log_.column(sigs[s]);
      const double hi = x.maxCoeff(), lo = x.minCoeff();
      const double tol = 1e-9 * std::max(hi - lo, std::abs(hi));
      for (int side = 0; side < 2; ++side) {
        const double ext = side ? lo : hi;
        long count = 0, run = 0, longest = 0;
        for (Eigen::Index k = 0; k < n_; ++k) {
          if (std::abs(x(k) - ext) <= tol) {
            ++count;
            longest = std::max(longest, ++run);
          } else {
            run = 0;
          }
        }
        if (hi > lo && longest >= opt_.saturation_run && double(count) >= opt_.saturation_fraction * double(n_))
          add("saturation", Severity::Warning,
              fmt::format("{} sits at its {} {:.4g} {} for {} samples ({:.3g} s, longest run {})", sigs[s],
                          side ? "minimum" : "maximum", ext, units[s], count, double(count) * T_, longest),
              "the actuators saturate: the logged command may not be what the rotors delivered; identify on a window "
              "without saturation (--window) or fly a gentler trajectory");
      }
    }
  }

  const FlightLog& log_;
  const InputCheckOptions& opt_;
  std::vector<InputFinding> out_;
  Eigen::Index n_ = 0;
  Eigen::VectorXd t_;
  double T_ = 0.0, fs_ = 0.0;  // s, the median time step; Hz, its rate
  Eigen::MatrixXd raw_, f_;    // z phi theta psi p q r Fz tau_phi tau_theta tau_psi x y, as logged (psi unwrapped) and low-passed
  Eigen::Index e0_ = 0, e1_ = 0, m_ = 0;  // the interior rows [e0, e1), m of them
  detail::AxisSignals axis_;              // by axis_signals()
  Eigen::VectorXd a_, u_;      // z'' and Fz cos(phi) cos(theta) over the interior
  Eigen::MatrixXd xy_acc_;     // x'' y'' (horizontal_acceleration), empty until asked
};

}  // namespace

std::optional<InputFinding> no_thrust_finding(const Eigen::VectorXd& fz) {
  if (fz.size() == 0 || fz.cwiseAbs().maxCoeff() != 0.0) return std::nullopt;
  return InputFinding{"thrust-units", Severity::Error, "the thrust Fz is 0 N throughout the log",
                      "the vehicle did not fly (motors stopped or disarmed, e.g. PWM at its disarmed value below the "
                      "vehicle's command_range): identify the log of a flight"};
}

std::vector<InputFinding> check_input(const FlightLog& log, const InputCheckOptions& opt) {
  opt.validate();
  return InputChecks(log, opt).run();
}

nlohmann::ordered_json to_json(const InputFinding& f) {
  return {{"check", f.check}, {"severity", to_string(f.severity)}, {"saw", f.saw}, {"action", f.action}};
}

nlohmann::ordered_json to_json(const std::vector<InputFinding>& fs) {
  nlohmann::ordered_json a = nlohmann::ordered_json::array();
  for (const auto& f : fs) a.push_back(to_json(f));
  return a;
}

std::string format_findings(const std::vector<InputFinding>& fs) {
  std::string s;
  for (const auto& f : fs) s += fmt::format("{}: {}: {} -> {}\n", to_string(f.severity), f.check, f.saw, f.action);
  return s;
}

}  // namespace quadid
