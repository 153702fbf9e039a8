// Plausibility checks of a flight log before any estimate (docs/input-checks.md):
// angle/rate units, z direction, thrust units, aliasing, saturation, time gaps.
#include "quadid/checks.hpp"
#include "quadid/signal/median_step.hpp"

#include <fmt/format.h>

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
}

std::vector<InputFinding> check_input(const FlightLog& log, const InputCheckOptions& opt) {
  opt.validate();
  std::vector<InputFinding> out;
  auto add = [&](const char* check, Severity s, std::string saw, std::string action) {
    out.push_back({check, s, std::move(saw), std::move(action)});
  };
  for (const auto& c : standard_log_columns())
    if (!log.has(c)) {
      add("columns", Severity::Info, fmt::format("no column '{}': checks skipped", c),
          "provide the standard columns (DESIGN.md)");
      return out;
    }
  const Eigen::Index n = log.rows();
  if (n < 64) {
    add("length", Severity::Info, fmt::format("{} samples: too few for the input checks", n), "none");
    return out;
  }
  const Eigen::VectorXd t = log.column("t");

  // --- Time gaps --------------------------------------------------------------
  Eigen::VectorXd dt = t.tail(n - 1) - t.head(n - 1);
  const double T = signal::median_step(std::span<const double>(t.data(), static_cast<std::size_t>(t.size())));
  if (!(T > 0.0)) {
    add("time-gaps", Severity::Error, "the median time step is not positive (time does not increase)",
        "sort the log by time and remove repeated samples");
    return out;
  }
  {
    long gaps = 0, backwards = 0;
    double largest = 0.0, at = 0.0;
    for (Eigen::Index k = 0; k < dt.size(); ++k) {
      if (!(dt(k) > 0.0)) ++backwards;
      else if (dt(k) > opt.gap_factor * T) {
        ++gaps;
        if (dt(k) > largest) largest = dt(k), at = t(k) - t(0);
      }
    }
    if (backwards)
      add("time-gaps", Severity::Error, fmt::format("time does not increase at {} sample(s)", backwards),
          "sort the log by time and remove repeated samples");
    if (gaps)
      add("time-gaps", Severity::Error,
          fmt::format("{} gap(s) in time: the largest is {:.4g} s ({:.1f} sample periods of {:.4g} s) at {:.4g} s from "
                      "the start",
                      gaps, largest, largest / T, T, at),
          "identify on a window without gaps (--window), or resample the log onto a uniform time base with an "
          "anti-aliasing filter");
  }
  const double fs = 1.0 / T;

  // Filtered signals for the differentiating checks (zero phase, as identify).
  signal::LowpassOptions lp = opt.lowpass;
  lp.cutoff_hz = std::min(lp.cutoff_hz, 0.2 * fs);
  Eigen::MatrixXd raw(n, 9);
  const char* names[9] = {"z", "phi", "theta", "psi", "p", "q", "r", "Fz", "tau_phi"};
  for (int c = 0; c < 9; ++c) raw.col(c) = log.column(names[c]);
  signal::unwrap(raw.col(3).data(), n);
  Eigen::MatrixXd f;
  try {
    f = signal::zero_phase_lowpass(raw, fs, lp);
  } catch (const std::exception& e) {
    add("length", Severity::Info, fmt::format("the checks' low-pass does not apply ({})", e.what()), "none");
    return out;
  }
  // Interior: clear of the filter's edge transients (5 % of the log at each end).
  const Eigen::Index e0 = n / 20, e1 = n - n / 20, m = e1 - e0;

  // --- Angle and rate units: gyro vs W(eta)^-1 eta_dot (eq. 4) ----------------
  {
    const Eigen::MatrixXd etad = signal::central_difference(Eigen::MatrixXd(f.middleCols(1, 3)), T);
    Eigen::MatrixXd we(m, 3), gy(m, 3);
    for (Eigen::Index k = e0; k < e1; ++k) {
      const Vec3 eta = f.row(k).segment<3>(1).transpose();
      we.row(k - e0) = (euler_rate_matrix_inverse(eta) * etad.row(k).transpose()).transpose();
      gy.row(k - e0) = f.row(k).segment<3>(4);
    }
    const double r_e = std::sqrt(we.squaredNorm() / double(m)), r_g = std::sqrt(gy.squaredNorm() / double(m));
    const double max_tilt = std::max(raw.col(1).cwiseAbs().maxCoeff(), raw.col(2).cwiseAbs().maxCoeff());
    if (max_tilt > 0.5 * std::numbers::pi)
      add("angle-units", Severity::Error,
          fmt::format("roll or pitch reaches {:.4g}, beyond 90 deg if in radians", max_tilt),
          "the Euler angles are probably in degrees: convert phi, theta, psi to radians");
    else if (std::max(r_e, r_g) < opt.min_rate_rms)
      add("angle-units", Severity::Info,
          fmt::format("too little rotation to compare the gyro with the Euler angles (RMS {:.3g} rad/s)", std::max(r_e, r_g)),
          "none");
    else {
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
      if (near_factor(ratio, 1.0 / kRad2Deg, opt.ratio_tolerance))
        add("angle-units", Severity::Error, saw,
            "the Euler angles are probably in degrees (factor 57.3): convert phi, theta, psi to radians");
      else if (near_factor(ratio, kRad2Deg, opt.ratio_tolerance))
        add("angle-units", Severity::Error, saw, "the body rates are probably in deg/s (factor 57.3): convert p, q, r to rad/s");
      else if (!near_factor(ratio, 1.0, opt.ratio_tolerance))
        add("angle-units", Severity::Warning, saw,
            "the gyro and the Euler angles disagree in scale: check the units of both and the rate column mapping");
      else if (worst_corr < 0.5)
        add("angle-units", Severity::Warning, saw,
            "the gyro and the Euler angles disagree in shape: check the axis order and signs of p, q, r (body FLU) "
            "and that the angles are ZYX Euler angles in radians");
    }
  }

  // --- z direction and thrust units: z'' against Fz cos(phi) cos(theta) ---------
  double zsign = 1.0;
  {
    const Eigen::VectorXd zdd = signal::central_difference(signal::central_difference(Eigen::VectorXd(f.col(0)), T), T);
    Eigen::VectorXd a(m), u(m);
    for (Eigen::Index k = e0; k < e1; ++k) {
      a(k - e0) = zdd(k);
      u(k - e0) = f(k, 7) * std::cos(f(k, 1)) * std::cos(f(k, 2));  // eq. (1), vertical: m z'' = Fz c(phi) c(theta) - m g
    }
    const double mean_fz = raw.col(7).mean();
    // No thrust at all: a log from the ground (motors stopped or disarmed), where
    // every other finding would only be a consequence.
    const bool no_thrust = raw.col(7).cwiseAbs().maxCoeff() == 0.0;
    if (no_thrust)
      add("thrust-units", Severity::Error, "the thrust Fz is 0 N throughout the log",
          "the vehicle did not fly (motors stopped or disarmed, e.g. PWM at its disarmed value below the vehicle's "
          "command_range): identify the log of a flight");
    if (mean_fz < 0.0)
      add("z-down", Severity::Error, fmt::format("the mean thrust Fz is {:.4g} N, negative", mean_fz),
          "Fz must be the thrust along +z body (up): a z-down (NED/FRD) log needs its frames converted (z -> -z, "
          "Fz -> -Fz, tau_theta and tau_psi -> minus themselves)");
    const Eigen::VectorXd ac = a.array() - a.mean(), uc = u.array() - u.mean();
    if (rms(ac) < opt.min_accel_rms || uc.norm() == 0.0) {
      add("z-down", Severity::Info,
          fmt::format("too little vertical acceleration to check the direction of z (RMS {:.3g} m/s^2)", rms(ac)),
          "none");
    } else {
      const double corr = ac.dot(uc) / (ac.norm() * uc.norm());
      if (corr < -0.3) {
        zsign = -1.0;
        add("z-down", Severity::Error,
            fmt::format("the vertical acceleration z'' falls when the thrust's vertical part Fz cos(phi) cos(theta) "
                        "rises (correlation {:.2f}; z mean {:.3g} m)",
                        corr, raw.col(0).mean()),
            "z appears to point down (NED): convert positions to z up (x, -y, -z for NED -> FLU-aligned ENU-like "
            "frames, DESIGN.md)");
      } else if (corr < 0.3) {
        add("z-down", Severity::Warning,
            fmt::format("the vertical acceleration z'' and the thrust's vertical part hardly correlate ({:.2f})", corr),
            "check that z is the altitude in m (z up) and Fz the total thrust in N");
      }
    }
    if (opt.reference_mass && !no_thrust) {
      // u = m (z'' + g) in the least-squares sense (with z'' as logged, times the sign found above).
      const Eigen::VectorXd acc = (zsign * a).array() + opt.g;
      const double m_est = u.dot(acc) / acc.squaredNorm();
      const double ratio = m_est / *opt.reference_mass;
      const std::string saw = fmt::format(
          "the thrust gives a mass of {:.4g} kg (Fz cos(phi) cos(theta) / (z'' + g)), {:.3g} times the reference "
          "{:.4g} kg",
          m_est, ratio, *opt.reference_mass);
      if (!(ratio > 0.0))
        add("thrust-units", Severity::Error, saw, "Fz must be the total thrust in N along +z body");
      else if (near_factor(ratio, 1.0 / opt.g, opt.ratio_tolerance))
        add("thrust-units", Severity::Warning, saw,
            fmt::format("Fz is probably in kgf (factor {:g}): multiply it by g (or the reference mass is in the wrong unit)", opt.g));
      else if (near_factor(ratio, opt.g, opt.ratio_tolerance))
        add("thrust-units", Severity::Warning, saw,
            "Fz is g times too large for the reference mass: the reference mass may be a weight in N, or Fz scaled");
      else if (near_factor(ratio, kRadPerSPerRpm * kRadPerSPerRpm, opt.ratio_tolerance) ||
               near_factor(ratio, 1.0 / (kRadPerSPerRpm * kRadPerSPerRpm), opt.ratio_tolerance))
        add("thrust-units", Severity::Warning, saw,
            fmt::format("a factor (60 / 2 pi)^2 = {:.1f}: rotor speeds in rad/s where the vehicle file says rpm, or "
                        "the reverse (its [rotors] input)",
                        1.0 / (kRadPerSPerRpm * kRadPerSPerRpm)));
      else if (near_factor(ratio, 1e-3, opt.ratio_tolerance) || near_factor(ratio, 1e3, opt.ratio_tolerance))
        add("thrust-units", Severity::Warning, saw, "a factor 1000: grams vs kilograms (mass) or mN vs N (thrust)");
      else if (!near_factor(ratio, 1.0, opt.ratio_tolerance))
        add("thrust-units", Severity::Warning, saw,
            "the thrust and the reference mass disagree: check the thrust model (kf, thrust scale) and the reference "
            "set (--nominal)");
    }
  }

  // --- Aliasing: power near Nyquist against the identification band ------------
  {
    const double fN = 0.5 * fs;
    Eigen::Index nseg = 16;
    while (double(nseg) < 4.0 * fs / opt.band_hz && nseg < n) nseg *= 2;
    if (nseg > n) nseg /= 2;
    const char* sigs[4] = {"Fz", "tau_phi", "tau_theta", "tau_psi"};
    if (fs / double(nseg) > opt.band_hz || opt.band_hz > 0.5 * fN) {
      add("aliasing", Severity::Info,
          fmt::format("log too short or too slow ({:g} Hz) to compare the spectrum near Nyquist with the band below "
                      "{:g} Hz",
                      fs, opt.band_hz),
          "none");
    } else {
      std::vector<std::string> bad;
      for (const char* s : sigs) {
        const std::vector<double> psd = signal::welch_psd(log.column(s), fs, nseg);
        // Top fifth below Nyquist against the median density between the band
        // and there (the noise floor): a flat (white) spectrum gives ~1 whether
        // or not it was aliased; folded vibration or noise that rises towards
        // Nyquist gives more.
        // It must also matter against the band itself (a noise-free log has a
        // floor near rounding, so any ripple stands above it).
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
        if (nt == 0 || nb == 0 || mid.size() < 4) continue;
        if (!((top / nt) > opt.aliasing_band_ratio * (band / nb))) continue;
        std::nth_element(mid.begin(), mid.begin() + static_cast<long>(mid.size() / 2), mid.end());
        const double floor = mid[mid.size() / 2];
        if (!(floor > 0.0)) continue;
        const double ratio = (top / nt) / floor;
        if (ratio > opt.aliasing_ratio)
          bad.push_back(fmt::format("{} +{:.1f} dB", s, 10.0 * std::log10(ratio)));
      }
      if (!bad.empty())
        add("aliasing", Severity::Warning,
            fmt::format("the power spectral density near Nyquist ({:.3g}-{:.3g} Hz) stands above the median density "
                        "between {:g} Hz and there: {} (threshold +{:.0f} dB)",
                        0.75 * fN, 0.95 * fN, opt.band_hz, fmt::join(bad, ", "), 10.0 * std::log10(opt.aliasing_ratio)),
            "the signals were not band-limited when sampled: a log decimated without an anti-aliasing filter folds "
            "vibration and noise into the band; log at the full rate or low-pass before decimating");
    }
  }

  // --- Actuator saturation: flat tops at the log's extremes ------------------------
  {
    const char* sigs[4] = {"Fz", "tau_phi", "tau_theta", "tau_psi"};
    const char* units[4] = {"N", "N m", "N m", "N m"};
    for (int s = 0; s < 4; ++s) {
      const Eigen::VectorXd x = log.column(sigs[s]);
      const double hi = x.maxCoeff(), lo = x.minCoeff();
      const double tol = 1e-9 * std::max(hi - lo, std::abs(hi));
      for (int side = 0; side < 2; ++side) {
        const double ext = side ? lo : hi;
        long count = 0, run = 0, longest = 0;
        for (Eigen::Index k = 0; k < n; ++k) {
          if (std::abs(x(k) - ext) <= tol) {
            ++count;
            longest = std::max(longest, ++run);
          } else {
            run = 0;
          }
        }
        if (hi > lo && longest >= opt.saturation_run && double(count) >= opt.saturation_fraction * double(n))
          add("saturation", Severity::Warning,
              fmt::format("{} sits at its {} {:.4g} {} for {} samples ({:.3g} s, longest run {})", sigs[s],
                          side ? "minimum" : "maximum", ext, units[s], count, double(count) * T, longest),
              "the actuators saturate: the logged command may not be what the rotors delivered; identify on a window "
              "without saturation (--window) or fly a gentler trajectory");
      }
    }
  }
  return out;
}

nlohmann::json to_json(const InputFinding& f) {
  return {{"check", f.check}, {"severity", to_string(f.severity)}, {"saw", f.saw}, {"action", f.action}};
}

nlohmann::json to_json(const std::vector<InputFinding>& fs) {
  nlohmann::json a = nlohmann::json::array();
  for (const auto& f : fs) a.push_back(to_json(f));
  return a;
}

std::string format_findings(const std::vector<InputFinding>& fs) {
  std::string s;
  for (const auto& f : fs) s += fmt::format("{}: {}: {} -> {}\n", to_string(f.severity), f.check, f.saw, f.action);
  return s;
}

}  // namespace quadid
