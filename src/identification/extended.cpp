// The real-flight regression (include/quadid/identification/extended.hpp): the paper's rows
// with two pre-filter cutoffs (force and moment rows), optional extra terms,
// row weighting, and least squares by streaming QR.
#include "quadid/identification/extended.hpp"

#include "quadid/estimation/qr_least_squares.hpp"
#include "quadid/estimation/row_least_squares.hpp"
#include "quadid/identification/timing.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <numbers>
#include <optional>
#include <random>
#include <stdexcept>

namespace quadid {
namespace {

double rms(const Eigen::Ref<const Eigen::VectorXd>& x) {
  return x.size() ? std::sqrt(x.squaredNorm() / static_cast<double>(x.size())) : 0.0;
}

}  // namespace

void ExtendedOptions::validate() const {
  processing.validate();
  terms.validate();
  for (auto [name, f] : {std::pair{"--cutoff-force", force_cutoff_hz}, std::pair{"--cutoff-moment", moment_cutoff_hz}})
    if (!(f > 0.0) || !std::isfinite(f)) throw std::invalid_argument(fmt::format("{} {}: must be a positive frequency in Hz", name, f));
  if (!(lambda > 0.0) || !std::isfinite(lambda))
    throw std::invalid_argument(fmt::format("--lambda {}: must be a positive bandwidth in rad/s", lambda));
  ls.validate();
  reference.validate("reference parameter set");
  if (!(cv_segment > 0.0) || !std::isfinite(cv_segment))
    throw std::invalid_argument(fmt::format("--cv-segment {}: must be a positive duration in s", cv_segment));
  if (cv_blocks < 2 || cv_blocks > 100)
    throw std::invalid_argument(fmt::format("--cv-blocks {}: must be in 2..100", cv_blocks));
  if (moment_highpass_hz && !(*moment_highpass_hz >= 0.0 && *moment_highpass_hz < 0.5 * moment_cutoff_hz))
    throw std::invalid_argument(fmt::format(
        "--moment-highpass {}: must be off (0) or a frequency in Hz below half the moment rows' cutoff ({:g} Hz)",
        *moment_highpass_hz, moment_cutoff_hz));
  if (highpass_order < 1 || highpass_order > 8)
    throw std::invalid_argument(fmt::format("highpass_order {}: must be in 1..8", highpass_order));
}

namespace {


// The signals of one processing at two cutoffs (force row at one, moment
// rows at the other) with the terms' signals (process_with_terms).
struct RawSignals {
  std::shared_ptr<const RegressionSignals> sig;
  ProcessingSummary pf, pm;
  double T = 0.0;
  double f_moment = 0.0;  // Hz, the moment rows' low-pass cutoff
};

RawSignals raw_signals(const FlightLog& log, const ExtendedOptions& opt, double f_force, double f_moment) {
  ProcessingOptions pf = opt.processing, pm = opt.processing;
  pf.lowpass.cutoff_hz = f_force;
  pm.lowpass.cutoff_hz = f_moment;
  TermProcessing tp = process_with_terms(log, pf, pm, opt.terms);
  RawSignals r;
  r.T = tp.signals->T;
  r.f_moment = f_moment;
  r.sig = std::move(tp.signals);
  r.pf = std::move(tp.force);
  r.pm = std::move(tp.moment);
  return r;
}

// The unknowns of a regression with the given terms: their columns, names,
// the prior (the reference set, zero for the terms) and a known J_r, in the
// regression's units (divided by the thrust scale when the mass is known):
// its column moves to the right-hand side.
struct Unknowns {
  std::vector<RegressionTerm> extra;
  Eigen::Index P = 0;
  std::vector<std::string> names;
  Eigen::VectorXd prior;
  double known_jr = 0.0;
  explicit Unknowns(const ExtendedOptions& opt, bool highpass = false) : extra(regression_terms(opt.terms, highpass)) {
    P = 7 + static_cast<Eigen::Index>(extra.size());
    names.emplace_back(opt.terms.known_mass ? "thrust_scale" : "m");  // thrust_scale: after the rescaling
    for (int j = 1; j < 7; ++j) names.emplace_back(kThetaNames[static_cast<size_t>(j)]);
    for (const auto& t : extra) names.emplace_back(t.name);
    prior = Eigen::VectorXd::Zero(P);
    prior.head<7>() = opt.reference.theta();
    known_jr = opt.terms.rotor_inertia ? opt.terms.known_rotor_inertia.value_or(0.0) : 0.0;
  }
};

Regression regression(const RawSignals& r, RegressionModel model, const ExtendedOptions& opt,
                      std::vector<RegressionTerm> terms = {}) {
  return Regression(r.sig, model, opt.window, opt.lambda, opt.gd_variant, std::move(terms));
}

// The window's sample range clear of both processings' edges (and f_D's start).
std::pair<Eigen::Index, Eigen::Index> window_range(const RawSignals& r, RegressionModel model, const ExtendedOptions& opt) {
  const Regression reg = regression(r, model, opt);
  return {reg.begin(), reg.end()};
}

RegressionRows build_rows(const RawSignals& raw, RegressionModel model, const ExtendedOptions& opt, const Unknowns& u) {
  RegressionRows c;
  c.P = u.P;
  const Eigen::Index n = raw.sig->size();
  c.M.resize(n, 4 * c.stride());
  const bool jr = u.known_jr != 0.0;
  regression(raw, model, opt, u.extra).for_each_row(0, n, [&](Eigen::Index k, const TermRow& row) {
    double* m = c.M.row(k).data();
    for (int r = 0; r < 4; ++r, m += c.stride()) {
      for (Eigen::Index j = 0; j < c.P; ++j) m[j] = row.G(r, j);
      m[c.P] = row.Y(r);
      m[c.P + 1] = jr ? row.J(r) : 0.0;
    }
  });
  return c;
}

// High-passes the roll and pitch rows (every column and the output) at f_hz:
// x - the zero-phase Butterworth low-pass of x, whose squared magnitude is
// exactly the zero-phase Butterworth high-pass's (1 - 1/(1 + (f/fc)^2N)).
void highpass_rows(RegressionRows& c, double f_hz, double fs_hz, int order) {
  const Eigen::Index n = c.M.rows(), w = 2 * c.stride();
  Eigen::MatrixXd cols = c.M.middleCols(c.stride(), w);  // rows 1 and 2, column-major copy
  Eigen::MatrixXd low = cols;
  signal::ZeroPhaseFilter lp(signal::butter_sos(order, f_hz, fs_hz));
  std::vector<double*> ptr(static_cast<size_t>(w));
  for (Eigen::Index j = 0; j < w; ++j) ptr[static_cast<size_t>(j)] = low.col(j).data();
  lp.apply(ptr.data(), static_cast<int>(w), n);
  c.M.middleCols(c.stride(), w) = cols - low;
}

// The weighted fit of the rows (row_least_squares.hpp) with this regression's options.
WeightedFit fit(const RegressionRows& c, Eigen::Index k0, Eigen::Index k1, double known_jr, const Eigen::VectorXd& prior,
                const ExtendedOptions& opt) {
  return fit_weighted(c, k0, k1, known_jr, prior, opt.terms.weight_rows, opt.ls.rank_tolerance);
}

// Per time block: the QR factor of the weighted rows of `rows`, integrated
// over consecutive segments of `seg` samples: each row of the regression
// averaged over a segment, d/dt a by its end points and b by the trapezoid
// rule (every column is linear in d/dt a and b, so the average is exact). The
// rates and velocities then enter undifferentiated: their noise does not
// become noise in the regressor, which would make held-out scores favour
// parameters shrunk toward zero.
std::vector<StreamingQR::Factor> block_factors_integral(const RawSignals& r, Eigen::Index k0, Eigen::Index k1,
                                                        int blocks, Eigen::Index seg, const Unknowns& u,
                                                        const Vec4& w, unsigned rows) {
  std::vector<StreamingQR::Factor> out;
  const auto& X = r.sig->x;
  const auto& Z = r.sig->terms;
  TermRow row(u.P);
  Eigen::Matrix<double, 1, RegressionSignals::kCols> xavg;
  Eigen::Matrix<double, 1, Eigen::Dynamic> tavg(Z.cols()), td(Z.cols());
  for (int j = 0; j < blocks; ++j) {
    const Eigen::Index b0 = k0 + (k1 - k0) * j / blocks, b1 = k0 + (k1 - k0) * (j + 1) / blocks;
    StreamingQR qr(u.P);
    for (Eigen::Index s = b0; s + seg < b1; s += seg) {
      const Eigen::Index e = s + seg;
      const double len = static_cast<double>(seg) * r.T;
      xavg = (X.middleRows(s, seg + 1).colwise().sum() - 0.5 * (X.row(s) + X.row(e))) * (r.T / len);
      const bool terms = Z.cols() > 0;  // the paper's rows at two cutoffs have no term signals
      if (terms) {
        tavg = (Z.middleRows(s, seg + 1).colwise().sum() - 0.5 * (Z.row(s) + Z.row(e))) * (r.T / len);
        td = (Z.row(e) - Z.row(s)) / len;
      }
      const Vec4 da = (X.row(e).head<4>() - X.row(s).head<4>()).transpose() / len;
      assemble_term_row(u.extra, da, xavg.segment<7>(4).transpose(), xavg.tail<4>().transpose(),
                        terms ? td.data() : nullptr, terms ? tavg.data() : nullptr, row);
      for (int q = 0; q < 4; ++q)
        if (rows & (1u << q)) qr.add_row(w(q) * row.G.row(q).transpose(), w(q) * row.Y(q));
    }
    out.push_back(qr.factor());
  }
  return out;
}


}  // namespace

std::vector<double> candidate_cutoffs(double fs) {
  std::vector<double> c;
  for (double f : {1.0, 1.5, 2.0, 3.0, 4.0, 6.0, 8.0, 10.0, 12.0, 15.0, 20.0, 25.0, 30.0})
    if (f < 0.2 * fs) c.push_back(f);
  return c;
}

namespace {

// Samples left out at each end of the window after the roll and pitch rows'
// high-pass at f_hz (its zero-phase response has settled to ~1 % by then).
Eigen::Index highpass_edge(double f_hz, double T) { return f_hz > 0.0 ? std::llround(0.5 / f_hz / T) : 0; }

// Candidates of the roll and pitch rows' high-pass, Hz: off, then up to
// 3 Hz, below 40 % of the moment rows' low-pass cutoff (the band between
// them must keep the excitation the fit needs).
std::vector<double> highpass_candidates(double moment_cutoff_hz) {
  std::vector<double> c{0.0};
  for (double f : {0.5, 1.0, 1.5, 2.0, 3.0})
    if (f <= 0.4 * moment_cutoff_hz) c.push_back(f);
  return c;
}

// The roll and pitch rows' high-pass, chosen on the standard model: for each
// candidate, LS and the jackknife standard errors of Ixx and Iyy; the
// reference is the highest candidate that determines every parameter; the
// choice is the lowest candidate whose Ixx and Iyy lie within two of the
// reference's standard errors of the reference's. Where low-frequency model
// error (aerodynamic moments of translational flight, which the inertial
// torque, ~ frequency^2, outgrows) moves the estimates, the choice leaves
// those frequencies out; where it does not, it keeps every frequency.
// The white-noise standard deviation of a gyro column: its part above a
// quarter of the sample rate, where a smooth flight has no motion, holds half
// of a white noise's power (the zero-phase Butterworth's |H|^2 is symmetric
// about its cutoff on the way to Nyquist). Vibration counts as noise: it
// overstates the noise inside the moment rows' band, which errs on the side
// of fewer high-pass candidates.
double white_noise_sd(const Eigen::VectorXd& x, double fs) {
  Eigen::VectorXd low = x;
  signal::ZeroPhaseFilter lp(signal::butter_sos(4, 0.25 * fs, fs));
  lp.apply(low.data(), low.size());
  return std::sqrt(2.0 * (x - low).squaredNorm() / static_cast<double>(x.size()));
}

// The variance that a unit white noise on p has in the roll row's p_dot
// column at high-pass f_hz: the same chain (the moment rows' low-pass, the
// central difference, the high-pass) on a fixed pseudo-random sequence.
double noise_gain(const ExtendedOptions& opt, double f_moment, double f_hz, double T, Eigen::Index n,
                  Eigen::Index k0, Eigen::Index k1) {
  std::mt19937_64 rng(1);
  std::normal_distribution<double> N(0.0, 1.0);
  Eigen::VectorXd x(n);
  for (auto& v : x) v = N(rng);
  signal::LowpassOptions lo = opt.processing.lowpass;
  lo.cutoff_hz = f_moment;
  x = signal::zero_phase_lowpass(Eigen::MatrixXd(x), 1.0 / T, lo).col(0);
  Eigen::VectorXd d = signal::central_difference(Eigen::MatrixXd(x), T).col(0);
  if (f_hz > 0.0) {
    Eigen::VectorXd low = d;
    signal::ZeroPhaseFilter hp(signal::butter_sos(opt.highpass_order, f_hz, 1.0 / T));
    hp.apply(low.data(), low.size());
    d -= low;
  }
  return d.segment(k0, k1 - k0).squaredNorm() / static_cast<double>(k1 - k0);
}

HighpassSelection choose_highpass(const RawSignals& raw, const Eigen::Vector3d& gyro_sd, const ExtendedOptions& opt) {
  HighpassSelection sel;
  const auto [k0, k1] = window_range(raw, RegressionModel::Standard, opt);
  const int K = opt.uncertainty.jackknife_blocks > 0 ? opt.uncertainty.jackknife_blocks : 8;
  const double fs = 1.0 / raw.T;
  const double sd_p = gyro_sd(0), sd_q = gyro_sd(1);
  sel.gyro_noise = std::max(sd_p, sd_q);
  for (double f : highpass_candidates(raw.f_moment)) {
    HighpassCandidate hc;
    hc.hz = f;
    const Unknowns u(opt, f > 0.0);
    RegressionRows c = build_rows(raw, RegressionModel::Standard, opt, u);
    if (f > 0.0) highpass_rows(c, f, fs, opt.highpass_order);
    const Eigen::Index e = highpass_edge(f, raw.T), b0 = k0 + e, b1 = k1 - e;
    if (b1 - b0 >= 32 * K) {
      const WeightedFit ft = fit(c, b0, b1, u.known_jr, u.prior, opt);
      const auto loo =
          leave_one_block_out(block_factors(c, b0, b1, K, u.known_jr, ft.w, 0xFu), b0, b1, u.prior, opt.ls.rank_tolerance);
      // In the known mass's units when it is given (the s = 1 fit's m' = m / s).
      const double sc = opt.terms.known_mass && ft.sol.x(0) > 0.0 ? *opt.terms.known_mass / ft.sol.x(0) : 1.0;
      const Eigen::VectorXd se = jackknife_covariance(loo).diagonal().cwiseSqrt();
      hc.Ixx = sc * ft.sol.x(1);
      hc.Iyy = sc * ft.sol.x(4);
      hc.se_Ixx = sc * se(1);
      hc.se_Iyy = sc * se(4);
      // Power of the p_dot and q_dot columns (roll row's Ixx, pitch row's Iyy) in the band.
      double pp = 0.0, qq = 0.0;
      for (Eigen::Index k = b0; k < b1; ++k) {
        pp += c.M(k, 1 * c.stride() + 1) * c.M(k, 1 * c.stride() + 1);
        qq += c.M(k, 2 * c.stride() + 4) * c.M(k, 2 * c.stride() + 4);
      }
      // Against the outputs' variance about their means: without the
      // high-pass the constant offsets explain the mean, which says nothing
      // about the inertia.
      const double nb = static_cast<double>(b1 - b0);
      const auto var = [&](Eigen::Index col) {
        const auto y = c.M.col(col).segment(b0, b1 - b0);
        return (y.array() - y.mean()).square().sum();
      };
      const double y1 = var(1 * c.stride() + c.P), y2 = var(2 * c.stride() + c.P);
      hc.unexplained = 0.5 * (ft.res_rms(1) * ft.res_rms(1) * nb / std::max(y1, 1e-300) +
                              ft.res_rms(2) * ft.res_rms(2) * nb / std::max(y2, 1e-300));
      const double g = noise_gain(opt, raw.f_moment, f, raw.T, c.M.rows(), b0, b1) * static_cast<double>(b1 - b0);
      hc.noise_share = std::max(sd_p * sd_p * g / std::max(pp, 1e-300), sd_q * sd_q * g / std::max(qq, 1e-300));
      hc.usable = ft.sol.unidentifiable.empty() && ft.sol.x.allFinite() && se.allFinite() && ft.sol.x(0) > 0.0 &&
                  hc.noise_share <= HighpassSelection::max_noise_share;
    }
    sel.candidates.push_back(hc);
  }
  // The reference: the usable band where the rigid-body rows explain the
  // roll and pitch torques best (the least unexplained variance). Below the
  // aerodynamic moments of translational flight that is a high band; with
  // broadband disturbances (gusts) and slow excitation it is a low one.
  const HighpassCandidate* ref = nullptr;
  for (const auto& c : sel.candidates)
    if (c.usable && (!ref || c.unexplained < ref->unexplained)) ref = &c;
  if (!ref) {
    sel.reason = "no candidate determines every parameter with little enough gyro noise in its band: off";
    return sel;
  }
  for (const auto& c : sel.candidates) {
    if (!c.usable) continue;
    if (std::abs(c.Ixx - ref->Ixx) <= 2.0 * ref->se_Ixx && std::abs(c.Iyy - ref->Iyy) <= 2.0 * ref->se_Iyy) {
      sel.hz = c.hz;
      sel.reason =
          c.hz == 0.0
              ? fmt::format("the rows fit best at {:g} Hz ({:.2g} % unexplained), and without a high-pass Ixx and Iyy "
                            "lie within two standard errors of those there: off",
                            ref->hz, 100.0 * ref->unexplained)
              : fmt::format("the rows fit best at {:g} Hz ({:.2g} % unexplained); {:g} Hz is the lowest cutoff whose "
                            "Ixx and Iyy lie within two standard errors of those there: below it they move with the "
                            "cutoff (low-frequency model error)",
                            ref->hz, 100.0 * ref->unexplained, c.hz);
      break;
    }
  }
  // Band dependence: with nothing unmodelled in the rows every usable band
  // estimates the same Ixx and Iyy, within their standard errors.
  const HighpassCandidate* used = nullptr;
  double se_xx = 0.0, se_yy = 0.0;
  bool first = true;
  for (const auto& c : sel.candidates) {
    if (!c.usable) continue;
    if (c.hz == sel.hz) used = &c;
    sel.Ixx_min = first ? c.Ixx : std::min(sel.Ixx_min, c.Ixx);
    sel.Ixx_max = first ? c.Ixx : std::max(sel.Ixx_max, c.Ixx);
    sel.Iyy_min = first ? c.Iyy : std::min(sel.Iyy_min, c.Iyy);
    sel.Iyy_max = first ? c.Iyy : std::max(sel.Iyy_max, c.Iyy);
    se_xx = std::max(se_xx, c.se_Ixx);
    se_yy = std::max(se_yy, c.se_Iyy);
    first = false;
  }
  if (used) {
    const auto spread = [](double lo, double hi, double se, double value) {
      return hi - lo > HighpassSelection::band_spread_se * se &&
             hi - lo > HighpassSelection::band_spread_fraction * std::abs(value);
    };
    sel.band_dependent = spread(sel.Ixx_min, sel.Ixx_max, se_xx, used->Ixx) ||
                         spread(sel.Iyy_min, sel.Iyy_max, se_yy, used->Iyy);
  }
  return sel;
}

// A gyro noise share above this is worth a warning (the bias it predicts is
// beyond what 1 % intervals of a good flight would hold).
constexpr double kNoiseBiasWarning = 0.02;
// The principal moments in Theta (Ixx, Iyy, Izz), each with the row and the
// gyro column its rate derivative comes from: roll p, pitch q, yaw r.
constexpr std::array<int, 3> kMoments{1, 4, 6};

// ExtendedResult::gyro_noise_share: each gyro column's white noise carried
// through the rows' chain (noise_gain), against the power of the column that
// Ixx, Iyy and Izz multiply in their own rows over [k0, k1).
Eigen::Vector3d gyro_noise_share(const RawSignals& raw, const RegressionRows& rows, double hp, const Eigen::Vector3d& gyro_sd,
                                 Eigen::Index k0, Eigen::Index k1, const ExtendedOptions& opt) {
  const Eigen::Index n = rows.M.rows();
  const double g_hp = noise_gain(opt, raw.f_moment, hp, raw.T, n, k0, k1);
  const double g_0 = hp > 0.0 ? noise_gain(opt, raw.f_moment, 0.0, raw.T, n, k0, k1) : g_hp;
  Eigen::Vector3d share;
  for (Eigen::Index i = 0; i < 3; ++i) {
    const Eigen::Index c = (i + 1) * rows.stride() + kMoments[static_cast<size_t>(i)];  // row i + 1, the moment's column
    const double gain = i < 2 ? g_hp : g_0;  // the yaw row has no high-pass
    const double power = rows.M.col(c).segment(k0, k1 - k0).squaredNorm() / static_cast<double>(k1 - k0);
    share(i) = power > 0.0 ? gyro_sd(i) * gyro_sd(i) * gain / power : 0.0;
  }
  return share;
}

// The warning of a band-dependent selection (HighpassSelection::band_dependent).
std::string band_dependence_warning(const HighpassSelection& sel) {
  double lo_hz = -1.0, hi_hz = 0.0;
  for (const auto& c : sel.candidates)
    if (c.usable) {
      if (lo_hz < 0.0) lo_hz = c.hz;
      hi_hz = c.hz;
    }
  const auto span = [](double lo, double hi) {
    return fmt::format("{:.4g} to {:.4g} kg m^2 ({:.0f} %)", lo, hi, 100.0 * (hi - lo) / std::max(std::abs(lo), std::abs(hi)));
  };
  return fmt::format(
      "Ixx and Iyy depend on the band the roll and pitch rows are fitted in: over the usable high-pass cutoffs "
      "{:g}-{:g} Hz, Ixx runs {} and Iyy {}, beyond their standard errors. Moments no term models reach these rows "
      "(wind and gusts, aerodynamic moments of translational flight, the controller reacting to them). The cutoff "
      "used ({:g} Hz) leaves out the band where they move the estimates most; where they also reach its band (wind, "
      "gusts), Ixx and Iyy can be off by as much as this spread, or more, and their intervals do not include it: "
      "compare flights, fly in still air with faster roll and pitch manoeuvres (docs/real-flights.md)",
      lo_hz, hi_hz, span(sel.Ixx_min, sel.Ixx_max), span(sel.Iyy_min, sel.Iyy_max), sel.hz);
}

}  // namespace

namespace {

// The processing's cutoffs, given or chosen from the data (select_cutoffs), and
// the raw signals at them.
RawSignals signals_at_cutoffs(const FlightLog& log, const ExtendedOptions& opt, ExtendedResult& res) {
  double f_force = opt.force_cutoff_hz, f_moment = opt.moment_cutoff_hz;
  if (opt.auto_cutoffs) {
    res.cutoff_selection = select_cutoffs(log, opt);
    f_force = res.cutoff_selection->force_cutoff_hz;
    f_moment = res.cutoff_selection->moment_cutoff_hz;
  }
  RawSignals raw = raw_signals(log, opt, f_force, f_moment);
  res.force_processing = raw.pf;
  res.moment_processing = raw.pm;
  return raw;
}

// The gyro's white noise (p, q, r), rad/s: for the high-pass candidates and the noise shares.
Eigen::Vector3d gyro_white_noise(const FlightLog& log, const RawSignals& raw) {
  Eigen::Vector3d gyro_sd;
  for (Eigen::Index i = 0; i < 3; ++i)
    gyro_sd(i) = white_noise_sd(log.column(std::array{"p", "q", "r"}[static_cast<size_t>(i)]), 1.0 / raw.T);
  return gyro_sd;
}

// The roll and pitch rows' high-pass, Hz: given, or chosen from the data.
double moment_highpass(const RawSignals& raw, const Eigen::Vector3d& gyro_sd, const ExtendedOptions& opt,
                       ExtendedResult& res) {
  double hp = opt.moment_highpass_hz.value_or(0.0);
  if (!opt.moment_highpass_hz) {
    res.highpass_selection = choose_highpass(raw, gyro_sd, opt);
    hp = res.highpass_selection->hz;
    if (res.highpass_selection->band_dependent) res.warnings.push_back(band_dependence_warning(*res.highpass_selection));
  }
  res.moment_highpass_hz = hp;
  return hp;
}

// One estimate (LS or FMLS) of the real-flight regression, step by step: the
// rows, the fit, the HAC covariance, the known mass's map, the block jackknife,
// the gyro noise's widening, the reported covariance, then the terms and what
// is poorly determined.
class ExtendedEstimator {
 public:
  ExtendedEstimator(const RawSignals& raw, const ExtendedOptions& opt, double hp, const Eigen::Vector3d& gyro_sd)
      : raw_(raw),
        opt_(opt),
        terms_(opt.terms),
        hp_(hp),
        gyro_sd_(gyro_sd),
        u_(opt, hp > 0.0),
        edge_(highpass_edge(hp, raw.T)) {}

  ExtendedEstimate estimate(int mi, ExtendedResult& res) const {
    const RegressionModel model = mi == 0 ? RegressionModel::Standard : RegressionModel::Filtered;
    const auto [k0, k1] = samples(model);
    if (mi == 0) {
      res.window = {static_cast<double>(k0) * raw_.T, static_cast<double>(k1 - 1) * raw_.T};
      res.window_samples = k1 - k0;
    }
    RegressionRows rows = build_rows(raw_, model, opt_, u_);
    if (hp_ > 0.0) highpass_rows(rows, hp_, 1.0 / raw_.T, opt_.highpass_order);
    if (mi == 0) gyro_noise(rows, k0, k1, res);
    double jr = u_.known_jr;
    const WeightedFit f = fit_with_rotor_inertia(rows, k0, k1, jr);
    ExtendedEstimate e;
    e.computed = true;
    e.samples = k1 - k0;
    e.name = mi == 0 ? "LS" : "FMLS";
    e.model = model;
    e.names = u_.names;
    Eigen::MatrixXd white;  // lag-0 sandwich: its correlations shape the reported covariance
    hac_covariance(rows, k0, k1, jr, f, e, white);
    Eigen::VectorXd x = f.sol.x;
    if (terms_.known_mass) x = known_mass_map(f, e, white);
    e.hac_std_error = e.covariance.diagonal().cwiseSqrt();
    e.std_error = e.hac_std_error;
    e.ci_low = x - e.quantile * e.hac_std_error;
    e.ci_high = x + e.quantile * e.hac_std_error;
    e.jackknife_std_error = Eigen::VectorXd::Constant(u_.P, std::numeric_limits<double>::quiet_NaN());
    jackknife(rows, k0, k1, jr, f, x, e, res);
    coefficient_uncertainty(rows, k0, k1, f, x, e);
    if (mi == 0) advise_weighing(x, e, res);
    widen_for_gyro_noise(x, res.gyro_noise_share, e);
    reported_covariance(white, e);
    describe(x, f, e);
    return e;
  }

  // The standard model's fit alone: its residual RMS per row (standard_residual_rms).
  Vec4 standard_residual_rms() const {
    const auto [k0, k1] = samples(RegressionModel::Standard);
    RegressionRows rows = build_rows(raw_, RegressionModel::Standard, opt_, u_);
    if (hp_ > 0.0) highpass_rows(rows, hp_, 1.0 / raw_.T, opt_.highpass_order);
    double jr = u_.known_jr;
    return fit_with_rotor_inertia(rows, k0, k1, jr).res_rms;
  }

 private:
  // The window's samples clear of the filters' edges and of the high-pass's.
  std::pair<Eigen::Index, Eigen::Index> samples(RegressionModel model) const {
    auto [k0, k1] = window_range(raw_, model, opt_);
    k0 += edge_;
    k1 -= edge_;
    if (k1 - k0 < 8)
      throw InputError(fmt::format("window {}: fewer than 8 samples clear of the filters' edges (high-pass {:g} Hz)",
                                   opt_.window.to_string(), hp_));
    return {k0, k1};
  }

  // The gyro noise's share of each moment column's power, and a warning where it biases the estimate.
  void gyro_noise(const RegressionRows& rows, Eigen::Index k0, Eigen::Index k1, ExtendedResult& res) const {
    res.gyro_noise_share = gyro_noise_share(raw_, rows, hp_, gyro_sd_, k0, k1, opt_);
    std::vector<std::string> biased;
    for (size_t i = 0; i < kMoments.size(); ++i)
      if (res.gyro_noise_share(static_cast<Eigen::Index>(i)) > kNoiseBiasWarning)
        biased.push_back(fmt::format("{} by about {:.2g} %", kThetaNames[static_cast<size_t>(kMoments[i])],
                                     100.0 * res.gyro_noise_share(static_cast<Eigen::Index>(i))));
    if (!biased.empty())
      res.warnings.push_back(fmt::format(
          "the gyro's noise biases estimates toward zero: {} (errors in variables: the noise in the rate "
          "derivative each one multiplies is that share of its power, above {:.2g} %); their 95 % intervals reach "
          "that far above the estimates. Faster rotation about those axes, or a lower moment-row cutoff "
          "(--cutoff-moment), makes the share smaller (docs/uncertainty.md)",
          fmt::join(biased, ", "), 100.0 * kNoiseBiasWarning));
  }

  // The streamed weighted fit; with a known mass and a known J_r, the s = 1
  // regression holds J_r as J_r / s, s = m / m' (known_mass_map): a fixed point
  // in s. J_r's share of the yaw torque is small, so a few rounds settle it.
  WeightedFit fit_with_rotor_inertia(const RegressionRows& rows, Eigen::Index k0, Eigen::Index k1, double& jr) const {
    WeightedFit f = fit(rows, k0, k1, jr, u_.prior, opt_);
    if (terms_.known_mass && jr != 0.0) {
      for (int round = 0; round < 8 && f.sol.x(0) > 0.0; ++round) {
        const double next = *terms_.known_rotor_inertia * f.sol.x(0) / *terms_.known_mass;
        if (std::abs(next - jr) <= 1e-12 * std::abs(next)) break;
        jr = next;
        f = fit(rows, k0, k1, jr, u_.prior, opt_);
      }
    }
    return f;
  }

  // Covariance: each sample's influence on the weighted fit,
  // psi_k = (A^T W^2 A)^-1 sum_r w_r^2 G_r^T e_r, and their long-run
  // (HAC) covariance: filtered residuals are coloured, and on real flights
  // model error colours them far beyond the filters' own correlation length.
  void hac_covariance(const RegressionRows& rows, Eigen::Index k0, Eigen::Index k1, double jr, const WeightedFit& f,
                      ExtendedEstimate& e, Eigen::MatrixXd& white) const {
    const LongRunCovariance lr = weighted_long_run_covariance(rows, k0, k1, jr, f, opt_.uncertainty);
    e.set_long_run(lr);
    white = lr.white_covariance;
  }

  // "Weigh it, fly it": the regression found m' = m / s and every other
  // parameter divided by s; with m known, s = m / m' and the others are
  // multiplied by s.
  std::optional<Eigen::VectorXd> weigh_it(const Eigen::VectorXd& xr) const {
    if (!terms_.known_mass) return xr;
    if (!(xr(0) > 0.0)) return std::nullopt;
    Eigen::VectorXd out = xr * (*terms_.known_mass / xr(0));
    out(0) = *terms_.known_mass / xr(0);
    return out;
  }

  // The known mass's map applied to the fit, its covariances carried by the
  // Jacobian of that map (exact: it is linear in x given x0, and x0's own
  // variance enters through J.col(0)).
  Eigen::VectorXd known_mass_map(const WeightedFit& f, ExtendedEstimate& e, Eigen::MatrixXd& white) const {
    const double m0 = *terms_.known_mass, x0 = f.sol.x(0);
    if (!(x0 > 0.0))
      throw InputError(fmt::format("the flight gives a mass {:.4g} kg from the rotor model's thrust, not a positive "
                                   "one: the thrust scale cannot be found (check the rotor model and the log's units)",
                                   x0));
    const Eigen::VectorXd x = *weigh_it(f.sol.x);
    const Eigen::MatrixXd J = known_mass_jacobian(f);
    e.covariance = J * e.covariance * J.transpose();
    white = J * white * J.transpose();
    e.white_std_error *= m0 / x0;  // the leading term of the same map
    return x;
  }

  // d(weigh_it(x)) / dx at the fit (x0 > 0).
  Eigen::MatrixXd known_mass_jacobian(const WeightedFit& f) const {
    const Eigen::Index P = u_.P;
    const double m0 = *terms_.known_mass, x0 = f.sol.x(0);
    Eigen::MatrixXd J = Eigen::MatrixXd::Zero(P, P);
    J(0, 0) = -m0 / (x0 * x0);
    for (Eigen::Index j = 1; j < P; ++j) {
      J(j, j) = m0 / x0;
      J(j, 0) = -m0 * f.sol.x(j) / (x0 * x0);
    }
    return J;
  }

  // The rotor model's coefficients (UncertaintyOptions::thrust_coefficient,
  // torque_ratio, positions). The fit is linear in the output, so a relative
  // error eps in a coefficient that scales one part of the output (the whole
  // wrench; the yaw torque; the roll and pitch torques) moves it by eps times
  // the fit of that part alone: the same rows and weights, the known J_r's
  // torque left out (it is the rotors' inertia, not the rotor model's).
  // Through the known mass's map a thrust-coefficient error moves only the
  // thrust scale: weighing the vehicle removes it from the inertia.
  void coefficient_uncertainty(const RegressionRows& rows, Eigen::Index k0, Eigen::Index k1, const WeightedFit& f,
                               const Eigen::VectorXd& x, ExtendedEstimate& e) const {
    const UncertaintyOptions& u = opt_.uncertainty;
    const std::array<std::pair<double, Vec4>, 3> parts{{{u.thrust_coefficient, Vec4(1.0, 1.0, 1.0, 1.0)},
                                                        {u.torque_ratio, Vec4(0.0, 0.0, 0.0, 1.0)},
                                                        {u.positions, Vec4(0.0, 1.0, 1.0, 0.0)}}};
    const Eigen::Index P = u_.P;
    Eigen::VectorXd var = Eigen::VectorXd::Zero(P);
    bool any = false;
    Eigen::Matrix<double, 4, Eigen::Dynamic> G(4, P);
    Vec4 Y;
    for (const auto& [sigma, mask] : parts) {
      if (!(sigma > 0.0)) continue;
      any = true;
      StreamingQR qr(P, 4 * P);
      if (f.known_jr == 0.0) {
        // The fit's own row factors hold these outputs (Q_r^T Y_r): 4 P rows, no pass over the samples.
        for (size_t r = 0; r < 4; ++r) {
          const double w = f.w(static_cast<Eigen::Index>(r)), m = mask(static_cast<Eigen::Index>(r));
          for (Eigen::Index i = 0; i < P; ++i)
            qr.add_row(w * f.row_factors[r].R.row(i).transpose(), w * m * f.row_factors[r].qty(i));
        }
      } else {
        for (Eigen::Index k = k0; k < k1; ++k) {  // the factors hold Y - J_r J, not the rotor model's Y
          rows.get(k, 0.0, G, Y);
          for (int r = 0; r < 4; ++r) qr.add_row(f.w(r) * G.row(r).transpose(), f.w(r) * mask(r) * Y(r));
        }
      }
      Eigen::VectorXd d = solve_qr(qr.factor(), qr.rows(), Eigen::VectorXd::Zero(P), opt_.ls.rank_tolerance).x;
      if (terms_.known_mass) d = known_mass_jacobian(f) * d;
      var += (sigma * d).cwiseAbs2();
    }
    if (!any) return;
    e.coefficient_std_error = var.cwiseSqrt();
    const double z = student_t_quantile(0.5 + 0.5 * u.confidence, std::numeric_limits<double>::infinity());
    for (Eigen::Index j = 0; j < P; ++j) {
      const double c = e.coefficient_std_error(j);
      const double half = std::hypot(0.5 * (e.ci_high(j) - e.ci_low(j)), z * c);
      e.std_error(j) = std::hypot(e.std_error(j), c);
      e.ci_low(j) = x(j) - half;
      e.ci_high(j) = x(j) + half;
    }
  }

  // Without a weighed mass the thrust coefficient's uncertainty is the
  // mass's, and every moment's: when it makes most of the mass's interval,
  // weighing the vehicle is the way to a better one (its error then goes
  // to the thrust scale).
  void advise_weighing(const Eigen::VectorXd& x, const ExtendedEstimate& e, ExtendedResult& res) const {
    const double sigma = opt_.uncertainty.thrust_coefficient;
    if (terms_.known_mass || !(sigma > 0.0) || e.coefficient_std_error.size() == 0) return;
    const double c = e.coefficient_std_error(0), all = e.std_error(0);
    if (!(c * c > 0.5 * all * all)) return;
    res.warnings.push_back(fmt::format(
        "m = {:.4g} kg: the rotor model's thrust coefficient, known to {:g} % (rotors.thrust_coefficient_uncertainty), "
        "makes most of its uncertainty ({:.3g} of {:.3g} kg, 1 sigma), and the inertia carries the same {:g} %: "
        "weigh the vehicle and give --known-mass KG; the thrust scale then takes the coefficient's error, and the "
        "inertia's intervals lose it",
        x(0), 100.0 * sigma, c, all, 100.0 * sigma));
  }

  // Delete-a-block jackknife: the fit without each of K contiguous time
  // blocks (the final row weights kept). Model error that differs along
  // the flight (an excitation that grows, a battery that sags, an effect no
  // term models) moves these fits more than the noise does; the HAC
  // sandwich, which sees only the residuals' size and correlation, does not.
  void jackknife(const RegressionRows& rows, Eigen::Index k0, Eigen::Index k1, double jr, const WeightedFit& f,
                 const Eigen::VectorXd& x, ExtendedEstimate& e, ExtendedResult& res) const {
    const int K = opt_.uncertainty.jackknife_blocks;
    if (!(K > 0 && k1 - k0 >= 8 * static_cast<Eigen::Index>(K))) return;
    std::vector<Eigen::VectorXd> loo;
    for (const auto& xb : leave_one_block_out(block_factors(rows, k0, k1, K, jr, f.w, 0xFu), k0, k1, u_.prior,
                                              opt_.ls.rank_tolerance)) {
      const auto w = weigh_it(xb);
      if (!w || !w->allFinite()) break;
      loo.push_back(*w);
    }
    if (static_cast<int>(loo.size()) != K) {
      res.warnings.push_back(fmt::format(
          "{}: the block jackknife was not computed (a fit without one time block gave a non-positive mass or a "
          "non-finite value); the intervals are the HAC ones only",
          e.name));
      return;
    }
    e.jackknife_blocks = K;
    e.jackknife_std_error = jackknife_covariance(loo).diagonal().cwiseSqrt();
    e.jackknife_quantile = student_t_quantile(0.5 + 0.5 * opt_.uncertainty.confidence, K - 1.0);
    for (Eigen::Index j = 0; j < u_.P; ++j) {
      const double jk = e.jackknife_std_error(j);
      const double half = std::max(e.quantile * e.hac_std_error(j), e.jackknife_quantile * jk);
      e.std_error(j) = std::max(e.hac_std_error(j), jk);
      e.ci_low(j) = x(j) - half;
      e.ci_high(j) = x(j) + half;
    }
  }

  // Errors in variables: gyro noise in the column a moment multiplies biases
  // it toward zero by about its share of that column's power (clean
  // simulated flights: predicted 0.3-0.6 %, Izz found 0.2-0.9 % low), the
  // same in every time block, so neither standard error holds it. The
  // interval reaches up to the estimate the share predicts, x / (1 - s)
  // (the share of the standard model's columns: the filtered model's f_D
  // passes less noise, so for FMLS it is an upper bound).
  static void widen_for_gyro_noise(const Eigen::VectorXd& x, const Eigen::Vector3d& share, ExtendedEstimate& e) {
    for (size_t i = 0; i < kMoments.size(); ++i) {
      const Eigen::Index j = kMoments[i];
      const double sh = std::min(share(static_cast<Eigen::Index>(i)), 0.5);
      // Up to x / (1 - s) + the half-width (max: never below it by rounding when s is tiny).
      if (x(j) > 0.0 && sh > 0.0) e.ci_high(j) = std::max(e.ci_high(j), x(j) / (1.0 - sh) + (e.ci_high(j) - x(j)));
    }
  }

  // The reported covariance: the standard errors above, with the
  // correlations of the lag-0 sandwich. The HAC matrix itself has rank 2 K
  // at most, below the number of parameters when the correlation time is
  // a good part of the window (real flights: K = 1 or 2), and the physically consistent set, which
  // is the closest one in this metric, would then move along whatever
  // direction it happens to leave cheap.
  void reported_covariance(const Eigen::MatrixXd& white, ExtendedEstimate& e) const {
    const Eigen::Index P = u_.P;
    const Eigen::VectorXd wsd = white.diagonal().cwiseSqrt();
    Eigen::MatrixXd corr = Eigen::MatrixXd::Identity(P, P);
    for (Eigen::Index a = 0; a < P; ++a)
      for (Eigen::Index b = 0; b < P; ++b)
        if (a != b && wsd(a) > 0.0 && wsd(b) > 0.0) corr(a, b) = white(a, b) / (wsd(a) * wsd(b));
    e.covariance = e.std_error.asDiagonal() * corr * e.std_error.asDiagonal();
  }

  // The estimate's values, its terms and given values, the fit's figures, and
  // which parameters are poorly determined.
  void describe(const Eigen::VectorXd& x, const WeightedFit& f, ExtendedEstimate& e) const {
    const std::vector<std::string>& names = u_.names;
    e.value = x;
    e.theta = x.head<7>();
    if (terms_.known_mass) e.theta(0) = *terms_.known_mass;
    for (Eigen::Index j = 7; j < u_.P; ++j) e.extra.emplace_back(names[static_cast<size_t>(j)], x(j));
    if (terms_.known_mass) e.extra.insert(e.extra.begin(), {"thrust_scale", x(0)});
    if (terms_.rotor_inertia && terms_.known_rotor_inertia) {
      e.extra.emplace_back("rotor_inertia", *terms_.known_rotor_inertia);
      e.given.emplace_back("rotor_inertia", *terms_.known_rotor_inertia);
    }
    e.row_weight = f.w;
    e.residual_rms = f.res_rms;
    e.condition = f.sol.condition;
    for (auto j : f.sol.unidentifiable) e.unidentifiable.push_back(names[static_cast<size_t>(j)]);
    // Poorly determined: the rigid-body parameters against their scale (the
    // mass, or the mean principal moment), the thrust scale against 1.
    Theta scale = determinedness_scale(e.theta);
    scale(0) = std::abs(e.value(0));
    const Eigen::VectorXd data = e.data_std_error();  // the rotor coefficients' share is not the data's
    for (Eigen::Index j = 0; j < 7; ++j) {
      if (poorly_determined(data(j), scale(j), opt_.ls.poor_fraction)) e.poorly_determined.push_back(names[static_cast<size_t>(j)]);
    }
  }

  const RawSignals& raw_;
  const ExtendedOptions& opt_;
  const ModelTerms& terms_;
  const double hp_;  // Hz, the roll and pitch rows' high-pass (0: none)
  const Eigen::Vector3d gyro_sd_;
  const Unknowns u_;
  const Eigen::Index edge_;  // samples the high-pass leaves out at each end
};

}  // namespace

ExtendedResult identify_extended(const FlightLog& log, const ExtendedOptions& opt) {
  opt.validate();
  ExtendedResult res;
  const RawSignals raw = signals_at_cutoffs(log, opt, res);
  const Eigen::Vector3d gyro_sd = gyro_white_noise(log, raw);
  const double hp = moment_highpass(raw, gyro_sd, opt, res);
  const ExtendedEstimator estimator(raw, opt, hp, gyro_sd);
  for (int mi = 0; mi < 2; ++mi) res.estimates[static_cast<size_t>(mi)] = estimator.estimate(mi, res);
  return res;
}

struct WrenchResidual::Impl {
  ExtendedOptions opt;
  RawSignals raw;
  bool reuse = false;  // the wrench comes back bit for bit: refilter it alone

  // The raw signals of `log`, its wrench refiltered into a copy of the first log's.
  RawSignals rewrenched(const FlightLog& log) const {
    if (log.rows() != raw.sig->x.rows())
      throw std::invalid_argument(fmt::format("WrenchResidual: a log of {} rows, expected {}", log.rows(),
                                              raw.sig->x.rows()));
    auto sig = std::make_shared<RegressionSignals>(*raw.sig);
    const double fs = 1.0 / sig->T;
    signal::LowpassOptions lf = opt.processing.lowpass, lm = opt.processing.lowpass;
    lf.cutoff_hz = opt.force_cutoff_hz;
    lm.cutoff_hz = opt.moment_cutoff_hz;
    // As process_with_terms: Fz from the force processing, the torques and
    // Omega_r from the moment processing.
    sig->x.col(11) = signal::zero_phase_lowpass(log.column("Fz"), fs, lf);
    Eigen::MatrixXd tau(log.rows(), 3);
    tau << log.column("tau_phi"), log.column("tau_theta"), log.column("tau_psi");
    sig->x.middleCols<3>(12) = signal::zero_phase_lowpass(tau, fs, lm);
    if (opt.terms.rotor_inertia) {
      const Eigen::VectorXd w = signal::zero_phase_lowpass(log.column(kRotorMomentumColumn), fs, lm);
      auto& Z = sig->terms;
      Z.col(kTsOmegaR) = w;
      Z.col(kTsQOmega) = sig->x.col(2).cwiseProduct(w);
      Z.col(kTsPOmega) = sig->x.col(1).cwiseProduct(w);
    }
    RawSignals r = raw;
    r.sig = std::move(sig);
    return r;
  }

  Vec4 fit(const RawSignals& r) const {
    return ExtendedEstimator(r, opt, 0.0, Eigen::Vector3d::Zero()).standard_residual_rms();
  }
};

WrenchResidual::WrenchResidual(const FlightLog& log, const ExtendedOptions& opt) : impl_(std::make_unique<Impl>()) {
  opt.validate();
  if (opt.auto_cutoffs || !opt.moment_highpass_hz || *opt.moment_highpass_hz != 0.0)
    throw std::invalid_argument("WrenchResidual: needs fixed cutoffs (auto_cutoffs = false) and no moment high-pass "
                                "(moment_highpass_hz = 0)");
  impl_->opt = opt;
  ExtendedResult res;
  impl_->raw = signals_at_cutoffs(log, opt, res);
  try {
    const RawSignals again = impl_->rewrenched(log);
    impl_->reuse = again.sig->x == impl_->raw.sig->x && again.sig->terms == impl_->raw.sig->terms;
  } catch (const std::exception&) {
    impl_->reuse = false;  // a column it needs is not there: process in full
  }
}

WrenchResidual::~WrenchResidual() = default;

Vec4 WrenchResidual::operator()(const FlightLog& log) const {
  if (impl_->reuse) return impl_->fit(impl_->rewrenched(log));
  ExtendedResult res;
  return impl_->fit(signals_at_cutoffs(log, impl_->opt, res));
}

Estimate rigid_body_estimate(const ExtendedEstimate& x, bool known_mass) {
  Estimate u = x.head(7);
  u.computed = true;
  u.names.assign(kThetaNames.begin(), kThetaNames.end());
  u.value = x.theta;
  u.near_null.clear();
  u.poorly_determined.clear();
  for (const auto& n : x.poorly_determined)
    if (n != "thrust_scale") u.poorly_determined.push_back(n);
  if (known_mass) {  // m is given: no variance, no correlation, its interval the point
    u.std_error(0) = u.white_std_error(0) = 0.0;
    u.covariance.row(0).setZero();
    u.covariance.col(0).setZero();
    u.ci_low(0) = u.ci_high(0) = x.theta(0);
    u.jackknife_std_error(0) = u.hac_std_error(0) = 0.0;
  }
  return u;
}

CutoffSelection select_cutoffs(const FlightLog& log, const ExtendedOptions& opt) {
  opt.validate();
  CutoffSelection sel;
  const Unknowns u(opt);
  const Eigen::VectorXd& prior = u.prior;
  const int K = opt.cv_blocks;

  // The sample rate, from a first processing at the given cutoffs.
  const RawSignals first = raw_signals(log, opt, opt.force_cutoff_hz, opt.moment_cutoff_hz);
  const double fs = 1.0 / first.T;
  std::vector<double> cand = candidate_cutoffs(fs);
  if (cand.empty()) throw InputError(fmt::format("a log sampled at {:g} Hz is too slow to choose pre-filter cutoffs", fs));
  // Held-out data are judged at the widest candidate cutoff: the parameters
  // that best predict the wrench over the data's full band win, whatever
  // cutoff produced them. The window is the one clear of the narrowest
  // filter's edges, so that every candidate sees the same samples.
  const double f_eval = cand.back();
  const RawSignals narrow = raw_signals(log, opt, cand.front(), cand.front());
  const auto [k0, k1] = window_range(narrow, RegressionModel::Standard, opt);
  if (k1 - k0 < 8 * K) throw InputError("the log is too short to choose the pre-filter cutoffs on held-out data");
  const RawSignals eval_raw = raw_signals(log, opt, f_eval, f_eval);
  const Eigen::Index seg = std::max<Eigen::Index>(
      4, std::min<Eigen::Index>(std::llround(opt.cv_segment / first.T), (k1 - k0) / (4 * K)));
  // Weights: the final weights of a fit at the given cutoffs, so that every
  // candidate is scored on the same footing.
  Vec4 w = fit(build_rows(first, RegressionModel::Standard, opt, u), k0, k1, u.known_jr, prior, opt).w;
  if (!opt.terms.weight_rows) {
    for (int r = 0; r < 4; ++r) {
      // The standard model's outputs are the processed wrench itself.
      const double s = rms(eval_raw.sig->x.col(11 + r).segment(k0, k1 - k0));
      w(r) = s > 0.0 ? 1.0 / s : 1.0;
    }
  }
  const auto eval_force = block_factors_integral(eval_raw, k0, k1, K, seg, u, w, 0x1u);
  const auto eval_moment = block_factors_integral(eval_raw, k0, k1, K, seg, u, w, 0xEu);

  // Held-out scores of one candidate pair, per block: fit on K-1 blocks, the
  // held-out block's weighted SSE of the force row and of the moment rows.
  using Scores = std::pair<Eigen::VectorXd, Eigen::VectorXd>;
  auto score = [&](double ff, double fm) {
    const RawSignals r = raw_signals(log, opt, ff, fm);
    const auto train = block_factors(build_rows(r, RegressionModel::Standard, opt, u), k0, k1, K, u.known_jr, w, 0xFu);
    Scores s{Eigen::VectorXd(K), Eigen::VectorXd(K)};
    const auto loo = leave_one_block_out(train, k0, k1, prior, opt.ls.rank_tolerance);
    for (int j = 0; j < K; ++j) {
      s.first(j) = factor_sse(eval_force[static_cast<size_t>(j)], loo[static_cast<size_t>(j)]);
      s.second(j) = factor_sse(eval_moment[static_cast<size_t>(j)], loo[static_cast<size_t>(j)]);
    }
    return s;
  };
  // The choice among candidates: the lowest cutoff (the most noise removed)
  // whose held-out score is not worse than the best one's by more than one
  // standard error of the paired per-block differences (the "one standard
  // error" rule of cross-validation): where the scores are flat the data
  // cannot tell the candidates apart, and the narrower filter is the safer one.
  auto choose = [&](const std::vector<Eigen::VectorXd>& per_block, std::vector<std::pair<double, double>>& table) {
    size_t best = 0;
    for (size_t i = 0; i < per_block.size(); ++i) {
      table.push_back({cand[i], per_block[i].sum()});
      if (per_block[i].sum() < per_block[best].sum()) best = i;
    }
    for (size_t i = 0; i < per_block.size(); ++i) {
      const Eigen::VectorXd d = per_block[i] - per_block[best];
      const double mean = d.mean();
      const double se = std::sqrt((d.array() - mean).square().sum() / (K - 1) / K);
      if (mean <= se) return cand[i];
    }
    return cand[best];
  };
  // Moment rows first (the force row's cutoff barely changes them), then the force row.
  std::vector<Eigen::VectorXd> mom, force;
  for (double fm : cand) mom.push_back(score(opt.force_cutoff_hz, fm).second);
  sel.moment_cutoff_hz = choose(mom, sel.moment_scores);
  for (double ff : cand) force.push_back(score(ff, sel.moment_cutoff_hz).first);
  sel.force_cutoff_hz = choose(force, sel.force_scores);
  return sel;
}

PredictionErrorTable real_flight_prediction_error(const FlightLog& log, const std::vector<NamedParams>& sets,
                                                  const NamedParams& reference, RegressionModel model,
                                                  const ExtendedOptions& opt, bool centre_torques) {
  std::vector<const NamedParams*> all{&reference};  // the reference first, as in PredictionErrorTable
  for (const auto& s : sets) all.push_back(&s);
  // The columns: every term that some set carries to this flight.
  ModelTerms terms;
  for (const auto* s : all)
    for (const auto& [name, v] : s->terms) {
      if (is_timing_extra(name)) continue;  // applied to the log (apply_timing), not a column
      if (!is_term_name(name))
        throw InputError(fmt::format("set {}: '{}' is not a real-flight term (thrust_scale, offset_x|y|z, "
                                     "flapping_x|y, damping_x|y|z, rotor_inertia, drag_z, wind_*)",
                                     s->name, name));
      if (!std::isfinite(v)) throw InputError(fmt::format("set {}: its term {} is not a finite number", s->name, name));
      if (!term_carries_to_other_flights(name)) continue;
      turn_on_carried_term(terms, name);
      if (name == rotor_inertia_term().name && !log.has(kRotorMomentumColumn))
        throw InputError(fmt::format("set {} has a rotor inertia, whose term needs the rotor speeds (log column '{}', "
                                     "made from the rotor columns by --vehicle)",
                                     s->name, kRotorMomentumColumn));
    }
  ExtendedOptions eo = opt;
  eo.terms = terms;
  eo.moment_highpass_hz = 0.0;
  const double f = opt.processing.lowpass.cutoff_hz;
  const RawSignals raw = raw_signals(log, eo, f, f);
  const std::vector<RegressionTerm> extra = regression_terms(terms);
  const Regression reg = regression(raw, model, eo, extra);
  const Eigen::Index k0 = reg.begin(), k1 = reg.end();
  const Eigen::Index P = reg.parameters();
  // Each set's x (rigid body, then its terms in the columns' order) and s.
  std::vector<Eigen::VectorXd> x(all.size(), Eigen::VectorXd::Zero(P));
  std::vector<double> s(all.size(), 1.0);
  for (size_t i = 0; i < all.size(); ++i) {
    x[i].head<7>() = all[i]->params.theta();
    for (const auto& [name, v] : all[i]->terms) {
      if (name == "thrust_scale") s[i] = v;
      for (size_t j = 0; j < extra.size(); ++j)
        if (name == extra[j].name) x[i](7 + static_cast<Eigen::Index>(j)) = v;
    }
  }
  // e = G x - s F (the rows with s F on the right); centred: two passes, the
  // means, then the squares about them (no cancellation).
  const double n = static_cast<double>(k1 - k0);
  std::vector<Vec4> mean(all.size(), Vec4::Zero()), ss(all.size(), Vec4::Zero());
  if (centre_torques) {
    reg.for_each_row(k0, k1, [&](Eigen::Index, const TermRow& row) {
      for (size_t i = 0; i < all.size(); ++i) mean[i] += row.G * x[i] - s[i] * row.Y;
    });
    for (auto& m : mean) {
      m /= n;
      m(0) = 0.0;  // the force row keeps its constant: a wrong mass or thrust scale shows there
    }
  }
  reg.for_each_row(k0, k1, [&](Eigen::Index, const TermRow& row) {
    for (size_t i = 0; i < all.size(); ++i) ss[i] += (row.G * x[i] - s[i] * row.Y - mean[i]).cwiseAbs2();
  });
  std::vector<std::string> names;
  for (const auto* p : all) names.push_back(p->name);
  return prediction_error_table(names, ss, model, {static_cast<double>(k0) * raw.T, static_cast<double>(k1 - 1) * raw.T},
                                k1 - k0);
}

}  // namespace quadid
