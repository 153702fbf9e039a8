// Data processing, paper section II-C: (1) zero-phase low-pass of p, eta,
// omega and F; (2) central differences, eq. (33); (3) v = R(eta)^T p_dot, eq. (3).
//
// Memory: everything is computed inside the 15-column RegressionSignals, with
// one reusable work buffer (signal::ZeroPhaseFilter): for 1.2 million samples
// that is 144 MB + 10 MB beside the log.
#include "quadid/regression.hpp"

#include "body_signals.hpp"

#include "quadid/core/parallel.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <initializer_list>
#include <numbers>
#include <stdexcept>
#include <utility>

namespace quadid {
namespace {

// Frequency where the zero-phase (squared-magnitude) response falls to -3 dB,
// |H|^2 = 1/sqrt(2), by bisection: both filters are monotone in their pass band.
double zero_phase_f3db(const signal::ZeroPhaseFilter& zf, double fs) {
  double lo = 0.0, hi = 0.5 * fs;
  const double target = std::pow(0.5, 0.25);
  for (int i = 0; i < 60; ++i) {
    const double mid = 0.5 * (lo + hi);
    (std::abs(zf.frequency_response(mid, fs)) > target ? lo : hi) = mid;
  }
  return 0.5 * (lo + hi);
}

// How long the filter's impulse response stays above 1% of its peak: the
// time over which an edge of the log (where filtfilt pads) disturbs its output.
double settling_time(const signal::ZeroPhaseFilter& zf, double T) {
  for (Eigen::Index len = 4096;; len *= 4) {  // long enough when the tail is quiet
    const Eigen::VectorXd h = zf.impulse_response(len);
    const double peak = h.cwiseAbs().maxCoeff();
    Eigen::Index last = 0;
    for (Eigen::Index i = 0; i < len; ++i)
      if (std::abs(h(i)) > 0.01 * peak) last = i;
    if (last < len / 2 || len >= (Eigen::Index{1} << 22)) return static_cast<double>(last + 1) * T;
  }
}

}  // namespace

void ProcessingOptions::validate() const {
  if (!(g > 0.0) || !std::isfinite(g))
    throw std::invalid_argument(fmt::format("--g = {:g} m/s^2 must be finite and positive", g));
  if (!(period_tolerance >= 0.0 && period_tolerance < 0.5))
    throw std::invalid_argument(fmt::format("--period-tolerance = {:g} must be in [0, 0.5)", period_tolerance));
  if (threads < 0 || threads > 2)
    throw std::invalid_argument(fmt::format("ProcessingOptions: threads={} must be 0 (automatic), 1 or 2", threads));
  if (!imu_position.allFinite())
    throw std::invalid_argument("--imu-position: the IMU's position from the centre of mass must be 3 finite numbers (m)");
  if (!std::isfinite(accel_bias_z))
    throw std::invalid_argument(fmt::format("--accel-bias-z = {:g} m/s^2 must be finite", accel_bias_z));
  // lowpass is validated against the log's sample rate in process_log.
}

namespace {

using SignalColumns = Eigen::Matrix<double, Eigen::Dynamic, RegressionSignals::kCols>;

// The log's columns of the standard names, in their order; every one must be
// there, but x y z when the force row comes from the accelerometer (-1 then).
std::vector<int> standard_columns(const FlightLog& log, bool need_position) {
  const auto& names = standard_log_columns();  // t x y z phi theta psi p q r Fz tau_phi tau_theta tau_psi
  std::vector<int> col(names.size());
  std::vector<std::string> missing;
  for (size_t i = 0; i < names.size(); ++i)
    if ((col[i] = log.find(names[i])) < 0 && (need_position || i < 1 || i > 3)) missing.push_back(names[i]);
  if (!missing.empty())
    throw InputError(fmt::format("flight log: missing column(s) {} (has: {}){}", fmt::join(missing, ", "),
                                 fmt::join(log.columns, ","),
                                 need_position && log.has("az_b")
                                     ? "; without a position the force row can come from the accelerometer: "
                                       "--force-from accelerometer"
                                     : ""));
  return col;
}

// The filters' period: the mean step over the log, once the samples are
// enough, finite and uniform (check_sample_period).
double checked_period(const FlightLog& log, const std::vector<int>& col, const ProcessingOptions& opt) {
  const auto& names = standard_log_columns();
  const Eigen::Index n = log.rows();
  if (n < 3) throw InputError(fmt::format("flight log: {} sample(s); identification needs a long log", n));
  const auto t = log.data.col(col[0]);
  for (size_t i = 0; i < names.size(); ++i)
    if (col[i] >= 0 && !log.data.col(col[i]).allFinite())
      throw InputError(fmt::format("flight log: column '{}' contains NaN or infinite values", names[i]));
  const signal::SamplePeriodCheck chk = signal::check_sample_period(t, opt.period_tolerance);
  if (!chk.ok()) {
    const Eigen::Index k = chk.bad;
    if (!(chk.step > 0.0))
      throw InputError(fmt::format("flight log: sample {} (t = {}): time does not increase (previous t = {})", k + 1,
                                   t(k), t(k - 1)));
    throw InputError(fmt::format(
        "flight log: sample {} (t = {:.9g}): period {:.6g} s where the log's period is {:.6g} s (its median step): {:+.3g}%, "
        "more than the {:g}% tolerated; the log must be uniformly sampled",
        k + 1, t(k), chk.step, chk.median, 100.0 * (chk.step / chk.median - 1.0), 100.0 * opt.period_tolerance));
  }
  return chk.mean;
}

// The pre-filter (second-order sections or FIR); refused, naming it, when it
// is invalid at this rate or cannot be realised stably, or longer than the log.
signal::ZeroPhaseFilter prefilter(const ProcessingOptions& opt, Eigen::Index n, double T, double fs) {
  signal::ZeroPhaseFilter zf = [&] {
    try {
      return signal::ZeroPhaseFilter(opt.lowpass, fs);
    } catch (const std::invalid_argument& e) {
      throw std::invalid_argument(fmt::format("pre-filter {}", e.what()));
    }
  }();
  const int padlen = zf.padlen();
  if (n <= padlen)
    throw InputError(fmt::format(
        "flight log: {} samples ({:g} s at {:g} Hz) is shorter than the {} pre-filter needs (more than {} samples "
        "of edge padding)",
        n, static_cast<double>(n - 1) * T, fs, opt.lowpass.name(), padlen));
  return zf;
}

// The processing as the report states it: samples, rate, the pre-filter.
void summarize_processing(const signal::ZeroPhaseFilter& zf, const ProcessingOptions& opt, Eigen::Index n, double T,
                          double fs, double settling, ProcessingSummary& summary) {
  summary.filter_settling = settling;
  summary.samples = n;
  summary.T = T;
  summary.fs = fs;
  summary.duration = static_cast<double>(n - 1) * T;
  summary.filter = opt.lowpass.name();
  summary.padlen = zf.padlen();
  summary.filter_f3db = zero_phase_f3db(zf, fs);
}

// The rate products [pq pr qr p^2 q^2 r^2] of Phi_b (eq. 11) formed from the
// log's rates, then pre-filtered like every other signal: F[p q], not
// F[p] F[q]. The rigid body's identity F[tau] = J F[w_dot] + F[w x J w]
// holds for the filtered signals only in this form (F is linear, the
// products are not): rotation above the cutoff (a controller's reaction to
// noisy positions) has products whose slow part F[p] F[q] leaves out, and a
// cutoff near the motion bends F[p] F[q] away from F[p q]. The force row's
// c = p v - q u + g_bz stays formed from filtered signals: its velocity is
// differentiated motion capture, whose noise the controller's rotation
// answers, so the products of their unfiltered parts do not average out
// (the virtual QBall 2's m then came out +0.004 %, six of its standard errors).
// Columns [first, first + 3) of P (sized n x 6 by the caller): the cross
// products (first = 0) or the squares (first = 3), so that the two threads
// of the processing each filter three.
using Products = Eigen::Matrix<double, Eigen::Dynamic, 6>;
void filtered_products(const FlightLog& log, const std::vector<int>& col, signal::ZeroPhaseFilter& f, Products& P,
                       int first) {
  const Eigen::Index n = log.rows();
  const auto p = log.data.col(col[7]), q = log.data.col(col[8]), r = log.data.col(col[9]);
  if (first == 0) {
    P.col(0) = p.cwiseProduct(q);
    P.col(1) = p.cwiseProduct(r);
    P.col(2) = q.cwiseProduct(r);
  } else {
    P.col(3) = p.cwiseAbs2();
    P.col(4) = q.cwiseAbs2();
    P.col(5) = r.cwiseAbs2();
  }
  std::array<double*, 3> cols{};
  for (int j = 0; j < 3; ++j) cols[static_cast<size_t>(j)] = P.col(first + j).data();
  f.apply(cols.data(), 3, n);
}

// Step 1: zero-phase low-pass (as scipy sosfiltfilt: odd padding, steady-state
// starts), and step 2: p_dot by eq. (33) from the filtered position. The
// columns are independent: rates and wrench on one thread, attitude and
// position on the other (each with its own filter work buffer).
// The columns of each half are filtered together (ZeroPhaseFilter's
// several-column apply: the same bits as one at a time, faster).
// Returns the pose columns' held samples (x y z psi phi theta).
std::array<signal::HeldSamples, 6> filter_and_differentiate(const FlightLog& log, const std::vector<int>& col,
                                                            const ProcessingOptions& opt, signal::ZeroPhaseFilter& zf,
                                                            double T, double fs, SignalColumns& X,
                                                            Products* products) {
  const Eigen::Index n = log.rows();
  auto filter_into = [&](signal::ZeroPhaseFilter& f, std::initializer_list<std::pair<int, int>> log_to_x) {
    std::array<double*, 7> cols{};
    int count = 0;
    for (const auto& [log_col, x_col] : log_to_x) {
      if (log_col >= 0) X.col(x_col) = log.data.col(log_col);
      cols[static_cast<size_t>(count++)] = X.col(x_col).data();
    }
    f.apply(cols.data(), count, n);
  };
  auto rates_and_wrench = [&] {  // p q r, Fz tau, and the rate products
    filter_into(zf, {{col[7], 1}, {col[8], 2}, {col[9], 3}, {col[10], 11}, {col[11], 12}, {col[12], 13}, {col[13], 14}});
    if (products) filtered_products(log, col, zf, *products, 0);
  };
  // The pose, put back on its sample instants when held. The yaw is unwrapped
  // first: a wrapped yaw's 2 pi jump, interpolated over a hold, would become
  // a fast turn that the unwrap could no longer see (unwrapping keeps a run of
  // equal values equal).
  std::array<signal::HeldSamples, 6> held{};
  auto pose_into = [&](int log_col, int x_col, size_t i) {
    if (log_col < 0) {  // no position (the force row from the accelerometer): zeros, never used
      X.col(x_col).setZero();
      return;
    }
    X.col(x_col) = log.data.col(log_col);
    if (x_col == 10 && opt.unwrap_yaw) signal::unwrap(X.col(10).data(), n);
    if (opt.interpolate_held) held[i] = signal::interpolate_held_samples(X.col(x_col).data(), n);
  };
  auto attitude_and_position = [&, T](signal::ZeroPhaseFilter& f) {
    pose_into(col[6], 10, 3);  // psi
    for (int i = 0; i < 3; ++i) pose_into(col[1 + static_cast<size_t>(i)], 5 + i, static_cast<size_t>(i));  // x y z
    // Roll and pitch too: from motion capture they are held like the rest of
    // the pose (from an IMU they are not, and stay as logged).
    pose_into(col[4], 8, 4);  // phi
    pose_into(col[5], 9, 5);  // theta
    filter_into(f, {{-1, 8}, {-1, 9}, {-1, 10}, {-1, 5}, {-1, 6}, {-1, 7}});  // phi theta psi x y z
    if (products) filtered_products(log, col, f, *products, 3);
    for (int i = 0; i < 3; ++i) signal::central_difference_inplace(X.col(5 + i).data(), n, T);
  };
  if (detail::use_second_thread(opt.threads)) {
    signal::ZeroPhaseFilter zf2(opt.lowpass, fs);
    detail::run_both(true, rates_and_wrench, [&] { attitude_and_position(zf2); });
  } else {
    rates_and_wrench();
    attitude_and_position(zf);
  }
  return held;
}

// The held pose columns and the slowest of their sensors' rates, for the report.
void summarize_held(const std::array<signal::HeldSamples, 6>& held, Eigen::Index n, double T,
                    ProcessingSummary& summary) {
  static constexpr std::array<const char*, 6> kPose{"x", "y", "z", "psi", "phi", "theta"};
  for (size_t i : {0, 1, 2, 4, 5, 3})  // listed x y z phi theta psi
    if (held[i].held) {
      summary.held_columns.emplace_back(kPose[i]);
      const double rate = static_cast<double>(held[i].samples) / (static_cast<double>(n) * T);
      summary.held_rate_hz = summary.held_rate_hz > 0.0 ? std::min(summary.held_rate_hz, rate) : rate;
    }
}

// Step 3: v = R(eta)^T p_dot (eq. 3), then the Phi_b signals, in place.
void body_signals(const ProcessingOptions& opt, RegressionSignals& out) {
  auto& X = out.x;
  const Eigen::Index n = X.rows();
  const double g = opt.g;
  if (opt.keep_body_velocity) {
    out.uv.resize(n, 2);
    out.world_axes.resize(n, 4);
  }
  for (Eigen::Index k = 0; k < n; ++k) {
    const Vec3 eta(X(k, 8), X(k, 9), X(k, 10));
    const Vec3 pdot(X(k, 5), X(k, 6), X(k, 7));
    const double p = X(k, 1), q = X(k, 2), r = X(k, 3);
    const detail::BodySample s = detail::body_sample(eta, pdot, p, q, g);
    X(k, 0) = s.v(2);
    if (opt.keep_body_velocity) {
      out.uv.row(k) = s.v.head<2>().transpose();
      out.world_axes.row(k) << s.R(0, 0), s.R(1, 0), s.R(0, 1), s.R(1, 1);
    }
    X(k, 4) = s.c;
    X(k, 5) = p * q;
    X(k, 6) = p * r;
    X(k, 7) = q * r;
    X(k, 8) = p * p;
    X(k, 9) = q * q;
    X(k, 10) = r * r;
  }
}

}  // namespace

std::shared_ptr<const RegressionSignals> process_log(const FlightLog& log, const ProcessingOptions& opt,
                                                     ProcessingSummary* summary) {
  opt.validate();
  const bool accel = opt.force_source == ProcessingOptions::ForceSource::kAccelerometer;
  const std::vector<int> col = standard_columns(log, !accel);
  const Eigen::Index n = log.rows();
  const double T = checked_period(log, col, opt);
  const double fs = 1.0 / T;
  signal::ZeroPhaseFilter zf = prefilter(opt, n, T, fs);
  const double settling = settling_time(zf, T);
  if (summary) summarize_processing(zf, opt, n, T, fs, settling, *summary);

  // Everything happens inside the 15 columns of the result (see the header for
  // the final layout); the columns that end up holding products first hold the
  // filtered position (5-7, then p_dot) and attitude (8-10). Row k is read
  // before it is overwritten, so the last loop can work in place.
  auto out = std::make_shared<RegressionSignals>();
  out->t_start = log.data(0, col[0]);
  out->T = T;
  out->edge = opt.exclude_edges ? settling : 0.0;
  out->x.resize(n, RegressionSignals::kCols);
  Products products(opt.filter_products ? n : 0, 6);
  const std::array<signal::HeldSamples, 6> held =
      filter_and_differentiate(log, col, opt, zf, T, fs, out->x, opt.filter_products ? &products : nullptr);
  if (summary) summarize_held(held, n, T, *summary);
  body_signals(opt, *out);
  if (opt.filter_products) out->x.middleCols<6>(5) = products;  // the rate products, pre-filtered as formed
  if (accel) {
    // w_dot + c measured: w = 0 (its derivative adds nothing) and c = the
    // pre-filtered specific force along body z at the centre of mass.
    Eigen::VectorXd az = specific_force_z_at_com(log, opt.imu_position, opt.accel_bias_z);
    double* cols[1] = {az.data()};
    zf.apply(cols, 1, n);
    out->x.col(0).setZero();
    out->x.col(4) = az;
  }
  return out;
}

Eigen::VectorXd specific_force_z_at_com(const FlightLog& log, const Vec3& r, double bias) {
  for (const char* c : {"ax_b", "ay_b", "az_b"})
    if (!log.has(c))
      throw InputError(fmt::format(
          "the force row from the accelerometer (--force-from accelerometer) needs the specific force ax_b ay_b az_b "
          "(m/s^2, body FLU: az_b = +9.81 at rest level); the log has no '{}'",
          c));
  const Eigen::Index n = log.rows();
  Eigen::VectorXd az = log.column("az_b");
  if (r.isZero()) return az.array() - bias;
  const Eigen::VectorXd t = log.column("t");
  const double T = (t(n - 1) - t(0)) / static_cast<double>(n - 1);
  Eigen::VectorXd pd = log.column("p"), qd = log.column("q");
  signal::central_difference_inplace(pd.data(), n, T);  // eq. (33)
  signal::central_difference_inplace(qd.data(), n, T);
  const Eigen::VectorXd p = log.column("p"), q = log.column("q"), w = log.column("r");
  for (Eigen::Index k = 0; k < n; ++k) {
    const Vec3 om(p(k), q(k), w(k)), om_dot(pd(k), qd(k), 0.0);  // r_dot does not reach the z component
    const double tangential = om_dot.cross(r)(2);
    const double centripetal = om.cross(om.cross(r))(2);
    az(k) -= tangential + centripetal + bias;
  }
  return az;
}

TermProcessing process_with_terms(const FlightLog& log, const ProcessingOptions& force, const ProcessingOptions& moment,
                                  const ModelTerms& terms) {
  ProcessingOptions pm = moment;
  pm.keep_body_velocity = terms.flapping || terms.wind;
  TermProcessing tp;
  const auto sf = process_log(log, force, &tp.force);
  const bool one = pm.lowpass.cutoff_hz == force.lowpass.cutoff_hz && !pm.keep_body_velocity;
  const auto sm = one ? sf : process_log(log, pm, &tp.moment);
  if (one) tp.moment = tp.force;
  const Eigen::Index n = sf->size();
  Eigen::VectorXd omega_r = Eigen::VectorXd::Zero(n);
  if (terms.rotor_inertia) {
    if (!log.has(kRotorMomentumColumn))
      throw InputError(fmt::format(
          "the rotor-inertia term needs the rotor speeds (log column '{}', made from the rotor columns by --vehicle); "
          "leave rotor-inertia out of --terms (e.g. --terms offsets,flapping), or give --vehicle",
          kRotorMomentumColumn));
    omega_r = signal::zero_phase_lowpass(log.column(kRotorMomentumColumn), 1.0 / sf->T, pm.lowpass);
  }
  // The force row (w, c, Fz) from the force processing, the moment rows from
  // the moment processing; the edges are the wider of the two.
  auto out = std::make_shared<RegressionSignals>();
  out->t_start = sf->t_start;
  out->T = sf->T;
  out->edge = std::max(sf->edge, sm->edge);
  out->x = sm->x;
  for (int c : kForceRowSignals) out->x.col(c) = sf->x.col(c);
  if (!terms.any()) {  // the paper's rows at two cutoffs: no term signals
    tp.signals = std::move(out);
    return tp;
  }
  auto& Z = out->terms;
  Z.resize(n, kTermSignals);
  Z.col(kTsOmegaR) = omega_r;
  if (pm.keep_body_velocity) {
    Z.middleCols<2>(kTsU) = sm->uv;
    Z.middleCols<4>(kTsRxx) = sm->world_axes;
  } else {
    Z.middleCols<2>(kTsU).setZero();
    Z.middleCols<4>(kTsRxx).setZero();
  }
  Z.col(kTsW) = sf->x.col(0);
  Z.middleCols<3>(kTsP) = sm->x.middleCols<3>(1);
  Z.col(kTsQOmega) = sm->x.col(2).cwiseProduct(omega_r);
  Z.col(kTsPOmega) = sm->x.col(1).cwiseProduct(omega_r);
  tp.signals = std::move(out);
  return tp;
}

}  // namespace quadid
