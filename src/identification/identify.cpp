// The whole identification: process the log, build both regressions, run LS
// and GD on each (four sets), diagnose identifiability, and compute the output
// prediction errors (Tables 5-6).
#include "quadid/identification.hpp"

#include "quadid/identification/extended.hpp"

#include "quadid/core/parallel.hpp"
#include "wrench_offset.hpp"

#include <fmt/format.h>

#include <Eigen/Cholesky>
#include <Eigen/Eigenvalues>
#include <array>
#include <cmath>
#include <exception>
#include <future>
#include <limits>
#include <optional>
#include <numbers>
#include <stdexcept>
#include <string_view>
#include <tuple>

namespace quadid {
namespace {

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();
// Above this share of the roll and pitch rows left unexplained (at the best
// high-pass band) the torques may not belong to the rotations: real
// Crazyflie flights leave 2-6 %, simulated flights in gusts up to 8 %; rotor
// columns rotated by one 46-101 %, an X layout given for a + vehicle 50 %
// when roll and pitch move independently (20 % when they move together: the
// rotor-mapping check, vehicle.hpp, finds those); but 2 % rotor-speed noise
// on a 32 g quad 61 % with a correct model, hence a warning.
constexpr double kMaxUnexplained = 0.3;

// Which samples of the window are recorded in the evolution.
struct Recorder {
  Eigen::Index begin, end, stride;
  bool enabled = true;
  Eigen::Index rows() const { return (end - 1 - begin) / stride + 1 + (((end - 1 - begin) % stride) ? 1 : 0); }
  // Row of sample k, or -1.
  Eigen::Index row(Eigen::Index k) const {
    if (!enabled) return -1;
    const Eigen::Index j = k - begin;
    if (j % stride == 0) return j / stride;
    if (k == end - 1) return rows() - 1;
    return -1;
  }
};

struct alignas(64) RunOutput {  // own cache lines: the two regressions run at once
  LeastSquaresAccumulator acc;
  std::unique_ptr<GradientDescent> gd;
};

// Accumulates LS and runs GD over the regression, recording both in columns
// ls_col.. and gd_col.. of the evolution (and the time in column 0 when asked:
// the two regressions run at once and share the rows).
RunOutput run_regression(const Regression& reg, const Theta& init, const GradientDescentOptions& gdo, const Recorder& rec,
                         Eigen::MatrixXd& evo, Eigen::Index ls_col, Eigen::Index gd_col, bool write_time) {
  RunOutput out;
  out.gd = std::make_unique<GradientDescent>(init, reg.T(), gdo);
  reg.for_each([&](Eigen::Index k, const Regressor4x7& G, const Vec4& Y) {
    out.acc.add(G, Y);
    out.gd->step(G, Y);
    const Eigen::Index r = rec.row(k);
    if (r >= 0) {
      if (write_time) evo(r, 0) = reg.time(k);
      evo.row(r).segment<7>(ls_col) = out.acc.solve_quick().transpose();
      const Theta gd_now = out.gd->diverged() ? Theta::Constant(kNaN) : out.gd->theta();
      evo.row(r).segment<7>(gd_col) = gd_now.transpose();
    }
  });
  return out;
}

// Frequency (Hz) below which the residuals of a regression carry their
// information: the pre-filter's -3 dB point, and for the filtered model also
// f_D's bandwidth lambda / (2 pi). Residuals decorrelate over ~fs / (2 f) samples.
double correlation_length(double fs, double f3db, double lambda, bool filtered) {
  double f = f3db;
  if (filtered) f = std::min(f, lambda / (2.0 * std::numbers::pi));
  return std::max(1.0, fs / (2.0 * f));
}

// With a vehicle file: the share of the roll and pitch rows that the
// real-flight regression leaves unexplained in its best high-pass band. Above
// kMaxUnexplained the rotor model may not be the vehicle's, or the rotor
// speeds are noisy: a warning, not an error (2 % rotor-speed noise on a 32 g
// quad leaves 61 % with estimates within 3 %).
std::optional<std::string> unexplained_warning(const IdentificationResult& res) {
  if (!res.extended || !res.extended->highpass_selection) return std::nullopt;
  double best = std::numeric_limits<double>::infinity();
  for (const auto& c : res.extended->highpass_selection->candidates)
    if (c.se_Ixx > 0.0) best = std::min(best, c.unexplained);  // the bands that were fitted
  if (!(best > kMaxUnexplained) || !std::isfinite(best)) return std::nullopt;
  return fmt::format(
      "model-fit: the rotor model's roll and pitch torques leave {:.0f} % of those rows unexplained in the best "
      "high-pass band (good logs: under 10 %): check that the vehicle file's rotor positions and the order of the "
      "log's rotor columns are the vehicle's (the motor numbering; an X layout given for a + vehicle, or the "
      "reverse, leaves about 50 %); noisy rotor speeds on a light vehicle leave as much with a correct model",
      100.0 * best);
}

// Input-check errors stop the identification, unless ignored: then they are
// warnings, marked so.
void input_check_errors(const std::vector<std::string>& errors, const IdentificationOptions& opt,
                        std::string_view if_right, std::vector<std::string>& warnings) {
  if (errors.empty()) return;
  if (!opt.ignore_input_errors)
    throw InputError(fmt::format("the log fails the input checks: {}; if {}, ignore the checks (--ignore-input-errors)",
                                 fmt::join(errors, "; "), if_right));
  for (const auto& e : errors) warnings.push_back("input check " + e + " (ignored)");
}

// The torques must explain the rotations with positive moments of inertia: a
// principal moment negative beyond its 95 % interval is not a body but a
// torque of the wrong sign (a wrench in the wrong frame, or a rotor model
// that does not match the log: spin directions, motor order). Errors by the
// input checks' rule (docs/input-checks.md, "Model fit").
std::vector<std::string> model_fit_findings(const IdentificationResult& res) {
  std::vector<std::string> out;
  constexpr std::array<std::pair<int, const char*>, 3> kMoments{
      {{1, "tau_phi (roll)"}, {4, "tau_theta (pitch)"}, {6, "tau_psi (yaw)"}}};
  for (const auto& [j, torque] : kMoments) {
    for (const auto& [set, sol] : {std::pair{"LS", &res.ls_standard}, std::pair{"FMLS", &res.ls_filtered}}) {
      const auto& u = sol->uncertainty;
      if (!u.computed || !(u.ci_high(j) < 0.0)) continue;
      const bool yaw = j == 6;
      out.push_back(fmt::format(
          "model-fit: {} {} = {:.4g} kg m^2 is negative (95 % interval [{:.4g}, {:.4g}]): the torque {} has the wrong "
          "sign for the measured rotations ({})",
          set, kThetaNames[static_cast<size_t>(j)], sol->theta(j), u.ci_low(j), u.ci_high(j), torque,
          yaw ? "with a vehicle file: its spin directions are reversed, or the log's rotor columns are not in its "
                "order; with torque columns: tau_psi's sign (body FLU: a z-down FRD log needs tau_theta and tau_psi "
                "negated)"
              : "with a vehicle file: its rotor positions or the order of the log's rotor columns do not match the "
                "vehicle (motor numbering, X vs + layout); with torque columns: their axes and signs (body FLU)"));
      break;  // one finding per moment
    }
  }
  return out;
}

// A pre-filter below the motion removes what the fit needs, and the fit then
// looks like a wrong torque sign or a wrong layout. The root cause is named
// first (issue 37): the share of the body rates' variance (mean removed) that
// the pre-filter keeps, against a Butterworth order 4 at 20 Hz (or 0.4 of the
// sample rate) that keeps all motion a multirotor makes and little noise.
// Below half, the filter is the finding.
std::optional<std::string> prefilter_removes_motion(const FlightLog& log, const ProcessingOptions& po) {
  if (log.rows() < 64 || !log.has("p") || !log.has("q") || !log.has("t")) return std::nullopt;
  const Eigen::VectorXd t = log.column("t");
  const double fs = static_cast<double>(t.size() - 1) / (t(t.size() - 1) - t(0));
  if (!(fs > 0.0) || !std::isfinite(fs)) return std::nullopt;
  signal::LowpassOptions wide;
  wide.cutoff_hz = std::min(20.0, 0.4 * fs);
  if (!(po.lowpass.cutoff_hz < wide.cutoff_hz)) return std::nullopt;
  Eigen::MatrixXd rates(log.rows(), 2);
  rates << log.column("p"), log.column("q");
  rates.rowwise() -= rates.colwise().mean();
  double kept = 0.0;
  try {
    const Eigen::MatrixXd a = signal::zero_phase_lowpass(rates, fs, po.lowpass);
    const Eigen::MatrixXd b = signal::zero_phase_lowpass(rates, fs, wide);
    if (!(b.squaredNorm() > 0.0)) return std::nullopt;
    kept = a.squaredNorm() / b.squaredNorm();
  } catch (const std::exception&) {
    return std::nullopt;  // a filter the log cannot take is reported by the processing
  }
  if (kept >= 0.5) return std::nullopt;
  return fmt::format("the pre-filter ({}) keeps {:.0f} % of the roll and pitch rates' motion (against a "
                     "{:g} Hz filter): it removes the motion the fit needs, and the estimates that follow are the "
                     "filter's, not the vehicle's; raise the cutoff (--cutoff, default 4 Hz)",
                     po.lowpass.name(), 100.0 * kept, wide.cutoff_hz);
}

}  // namespace

void IdentificationOptions::validate() const {
  processing.validate();
  if (wrench_offset && !(std::abs(*wrench_offset) <= kMaxWrenchOffset))
    throw std::invalid_argument(fmt::format("wrench_offset={} s must be within +-{:g} s", *wrench_offset,
                                            kMaxWrenchOffset));
  if (!(window.t0 >= 0.0) || !(window.t1 > window.t0))
    throw std::invalid_argument(fmt::format("--window {}: need 0 <= T0 < T1", window.to_string()));
  if (error_window && (!(error_window->t0 >= 0.0) || !(error_window->t1 > error_window->t0)))
    throw std::invalid_argument(fmt::format("--error-window {}: need 0 <= T0 < T1", error_window->to_string()));
  if (!(lambda > 0.0) || !std::isfinite(lambda))
    throw std::invalid_argument(fmt::format("--lambda = {:g} rad/s must be a finite, positive bandwidth", lambda));
  gd.validate();
  ls.validate();
  terms.validate();
  for (auto [name, f] : {std::pair{"--cutoff-force", force_cutoff_hz}, std::pair{"--cutoff-moment", moment_cutoff_hz}})
    if (f && (!(*f > 0.0) || !std::isfinite(*f)))
      throw std::invalid_argument(fmt::format("{} {}: must be a positive frequency in Hz", name, *f));
  reference.params.validate("reference parameter set '" + reference.name + "'");
  if (gd_initial && !gd_initial->theta().allFinite())
    throw std::invalid_argument("gd_initial: the initial guess is not finite");
  if (!(evolution_interval >= 0.0 && evolution_interval <= kMaxEvolutionInterval))
    throw std::invalid_argument(fmt::format("--evolution-interval = {:g} s must be in [0, {:g}] s (0 = every sample)",
                                            evolution_interval, kMaxEvolutionInterval));
  uncertainty.validate();
  physical.validate();
}

ExtendedOptions extended_options(const IdentificationOptions& opt) {
  ExtendedOptions xo;
  xo.processing = opt.processing;
  xo.force_cutoff_hz = opt.force_cutoff_hz.value_or(opt.processing.lowpass.cutoff_hz);
  xo.moment_cutoff_hz = opt.moment_cutoff_hz.value_or(opt.processing.lowpass.cutoff_hz);
  xo.window = opt.window;
  xo.lambda = opt.lambda;
  xo.gd_variant = opt.gd_variant;
  xo.terms = opt.terms;
  xo.reference = opt.reference.params;
  xo.ls = opt.ls;
  xo.uncertainty = opt.uncertainty;
  xo.auto_cutoffs = opt.auto_cutoffs;
  xo.moment_highpass_hz = opt.moment_highpass_hz;
  return xo;
}

bool IdentificationOptions::extended() const {
  const double c = processing.lowpass.cutoff_hz;
  return terms.any() || auto_cutoffs || force_cutoff_hz.value_or(c) != c || moment_cutoff_hz.value_or(c) != c ||
         moment_highpass_hz != 0.0;

}

std::vector<const SetEstimate*> IdentificationResult::all_sets() const {
  std::vector<const SetEstimate*> v;
  for (const auto& e : estimates) v.push_back(&e);
  for (const auto& e : physical_sets) v.push_back(&e);
  return v;
}

const LeastSquaresSolution* IdentificationResult::least_squares_of(std::string_view set) const {
  if (set == "LS") return &ls_standard;
  if (set == "FMLS") return &ls_filtered;
  return nullptr;
}

const SetEstimate& IdentificationResult::estimate(std::string_view name) const {
  for (const auto* e : all_sets())
    if (e->name == name) return *e;
  throw std::invalid_argument(fmt::format("no estimate named '{}' (LS, GD, FMLS, FMGD, PC, FMPC)", name));
}

namespace {

// One identify() call: its state and its steps, in the order identify() takes
// them (the warnings keep that order).
class IdentifyRun {
 public:
  IdentifyRun(const FlightLog& log, const IdentificationOptions& opt)
      : log_(log),
        opt_(opt),
        two_(detail::use_second_thread(opt.processing.threads)),
        prior_(opt.reference.params.theta()),
        error_window_(opt.error_window.value_or(TimeWindow{})) {}

  IdentificationResult run() {
    start_input_checks();
    try {
      estimate_paper_model();
    } catch (...) {
      estimation_error_ = std::current_exception();
    }
    finish_input_checks();
    if (estimation_error_) std::rethrow_exception(estimation_error_);
    collect_sets();
    if (opt_.extended()) use_real_flight_regression();
    widen_for_model_disagreement();
    check_model_fit();
    const std::vector<std::string> deficient = judge_rank();
    warn_poorly_determined(deficient);
    warn_disagreement();
    warn_unphysical();
    warn_implausible_size();
    prediction_tables();
    // The input checks' warnings first: they name causes in the log, of which
    // the estimates' warnings are often consequences (root cause first).
    res_.warnings.insert(res_.warnings.begin(), input_warnings_.begin(), input_warnings_.end());
    res_.recommended = recommend_set(res_);
    return std::move(res_);
  }

 private:
  // The input checks read the log independently of the estimation: on a
  // thread of their own, from the start, when two threads are allowed (they
  // cost a fifth of the work and would otherwise hold up the processing or the
  // two regressions). A failed check is still reported first, as if the
  // estimation had not started; what it computed meanwhile is dropped.
  void start_input_checks() {
    if (!opt_.input_checks) return;
    auto run_checks = [this] {
      InputCheckOptions ic;
      ic.g = opt_.processing.g;
      ic.reference_mass = opt_.reference.params.m;
      // A log with the vehicle on the ground at an end (airborne_part) is
      // checked in the air: on the ground the thrust sits at idle or 0 and the
      // vertical acceleration has nothing to do with it, which the saturation
      // and z-direction checks would report as faults of the log.
      if (const auto air = airborne_part(log_); air && air->trimmed())
        return check_input(rows_in(log_, air->in_air), ic);
      return check_input(log_, ic);
    };
    if (two_) checks_ = std::async(std::launch::async, run_checks);
    else res_.input_findings = run_checks();
  }

  void finish_input_checks() {
    if (checks_.valid()) res_.input_findings = checks_.get();
    if (!opt_.input_checks) return;
    std::vector<std::string> errors;
    for (const auto& fd : res_.input_findings) {
      if (fd.severity == Severity::Error) errors.push_back(fmt::format("{}: {} ({})", fd.check, fd.saw, fd.action));
      else if (fd.severity == Severity::Warning)
        input_warnings_.push_back(fmt::format("input check {}: {} ({})", fd.check, fd.saw, fd.action));
    }
    input_check_errors(errors, opt_, "the log is right", input_warnings_);
  }

  // Section II-C processing, the standard (eq. 34) and filtered (eqs. 35-39)
  // regressions, and on each LS (eq. 40), GD (eqs. 41-42), the HAC intervals
  // and the physically consistent set.
  void estimate_paper_model() {
    sig_ = process_log(log_, opt_.processing, &res_.processing);
    align_wrench();
    std_reg_.emplace(sig_, RegressionModel::Standard, opt_.window);
    filt_reg_.emplace(sig_, RegressionModel::Filtered, opt_.window, opt_.lambda, opt_.gd_variant);
    res_.window = std_reg_->window();
    res_.window_samples = std_reg_->size();
    res_.reference = opt_.reference;
    res_.options = opt_;
    res_.gd_initial = opt_.gd_initial ? opt_.gd_initial->theta() : prior_;
    start_evolution();
    // The two regressions are independent until the tables: each on its own
    // thread when two are allowed.
    detail::run_both(
        two_, [&] { chain(*std_reg_, s_, res_.ls_standard, pc_std_, 1, 8, false); },
        [&] { chain(*filt_reg_, f_, res_.ls_filtered, pc_filt_, 15, 22, true); });
  }

  // The wrench's lead over the motion (wrench_offset.hpp), measured on the
  // standard regression and read out of the processed wrench.
  void align_wrench() {
    if (opt_.extended()) return;
    WrenchTiming& w = res_.wrench_timing;
    if (opt_.wrench_offset) {
      w.applied = *opt_.wrench_offset;
    } else {
      std::optional<detail::WrenchOffsetEstimate> e;
      try {
        e = detail::estimate_wrench_offset(Regression(sig_, RegressionModel::Standard, opt_.window),
                                           opt_.processing.lowpass.cutoff_hz);
      } catch (const InputError&) {
        return;  // the window's own error follows, from the regressions
      }
      if (!e) return;
      w.estimated = true;
      w.measured = e->offset;
      w.std_error = e->std_error;
      const double lead = std::abs(e->offset);
      if (lead >= 3.0 * e->std_error && lead >= 0.1 * sig_->T && lead <= IdentificationOptions::kMaxWrenchOffset) w.applied = e->offset;
    }
    if (w.applied != 0.0) sig_ = detail::wrench_read_earlier(*sig_, w.applied);
  }

  // Evolution: t, then LS, GD, FMLS, FMGD (7 each).
  void start_evolution() {
    const double T = sig_->T;
    const Eigen::Index stride =
        opt_.evolution_interval <= 0.0 ? 1 : std::max<Eigen::Index>(1, std::llround(opt_.evolution_interval / T));
    rec_ = Recorder{std_reg_->begin(), std_reg_->end(), stride, opt_.record_evolution};
    if (!opt_.record_evolution) return;
    res_.evolution.columns.push_back("t");
    for (const char* set : {"LS", "GD", "FMLS", "FMGD"})
      for (const char* p : kThetaNames) res_.evolution.columns.push_back(fmt::format("{}_{}", set, p));
    res_.evolution.data.setConstant(rec_.rows(), 29, kNaN);
  }

  // One regression: LS and GD, the solve, the HAC intervals, the physically
  // consistent set.
  void chain(const Regression& reg, RunOutput& out, LeastSquaresSolution& sol, PhysicalProjection& pc,
             Eigen::Index ls_col, Eigen::Index gd_col, bool filtered) {
    const double fs = res_.processing.fs, f3 = res_.processing.filter_f3db;
    out = run_regression(reg, res_.gd_initial, opt_.gd, rec_, res_.evolution.data, ls_col, gd_col, !filtered);
    sol = solve_least_squares(out.acc, prior_, opt_.ls, correlation_length(fs, f3, opt_.lambda, filtered));
    // With terms or two cutoffs the real-flight regression gives LS and FMLS,
    // their intervals and consistent sets (use_real_flight_regression); this
    // solution keeps only what the paper's model alone can say (its singular
    // values, near-null directions, GD), so its intervals and projection are
    // not computed.
    if (opt_.extended()) return;
    // Second pass: the influence of each sample on the estimate, for the HAC
    // covariance (docs/uncertainty.md), and, when one window holds the other
    // (by default Tables 5-6 cover the whole log), the tables' sums in the
    // same pass: each sum still sees its own samples in their order.
    InfluenceAccumulator infl(sol);
    infl.reserve(static_cast<long>(reg.size()));
    const Regression err_reg = reg.with_window(error_window_);
    const bool err_outer = err_reg.begin() <= reg.begin() && err_reg.end() >= reg.end();
    const bool reg_outer = reg.begin() <= err_reg.begin() && reg.end() >= err_reg.end();
    if (err_outer || reg_outer) {
      std::vector<NamedParams> sets{{filtered ? "FMLS" : "LS", Params::from_theta(sol.theta)}};
      if (!out.gd->diverged()) sets.push_back({filtered ? "FMGD" : "GD", Params::from_theta(out.gd->theta())});
      PredictionErrorSums errors(sets, opt_.reference);
      (err_outer ? err_reg : reg).for_each([&](Eigen::Index k, const Regressor4x7& G, const Vec4& Y) {
        if (k >= reg.begin() && k < reg.end()) infl.add(G, Y);
        if (k >= err_reg.begin() && k < err_reg.end()) errors.add(G, Y);
      });
      (filtered ? errors_filtered_ : errors_standard_) = errors.table(err_reg);
    } else {
      reg.for_each([&](Eigen::Index, const Regressor4x7& G, const Vec4& Y) { infl.add(G, Y); });
    }
    attach_uncertainty(sol, infl.finish(opt_.uncertainty), prior_, opt_.ls);
    // Kept for the disagreement's noise.
    influences_[filtered ? 1 : 0] = {infl.series(), static_cast<long>(reg.begin())};
    // The physically consistent set: the closest consistent Theta in the LS metric.
    pc = closest_physical(sol, prior_, opt_.physical);
  }

  SetEstimate gd_estimate(const char* name, RegressionModel m, const GradientDescent& gd) {
    SetEstimate e{name, m, false, gd.theta(), !gd.diverged(), "", {}};
    if (gd.diverged()) {
      e.note = fmt::format("{} diverged: {}", name, gd.divergence_reason());
      res_.warnings.push_back(e.note);
    }
    return e;
  }

  // The four sets of the paper and the two physically consistent ones.
  void collect_sets() {
    res_.gd_step_gain_standard = s_.gd->max_step_gain();
    res_.gd_step_gain_filtered = f_.gd->max_step_gain();
    res_.estimates[0] = SetEstimate{"LS", RegressionModel::Standard, true, res_.ls_standard.theta, true, "", {}, {}};
    res_.estimates[1] = gd_estimate("GD", RegressionModel::Standard, *s_.gd);
    res_.estimates[2] = SetEstimate{"FMLS", RegressionModel::Filtered, true, res_.ls_filtered.theta, true, "", {}, {}};
    res_.estimates[3] = gd_estimate("FMGD", RegressionModel::Filtered, *f_.gd);
    for (auto [name, model, pr] : {std::tuple{"PC", RegressionModel::Standard, &pc_std_},
                                    std::tuple{"FMPC", RegressionModel::Filtered, &pc_filt_}}) {
      SetEstimate e{name, model, true, pr->theta, pr->theta.allFinite(), "", {}};
      if (!e.valid) e.note = fmt::format("{}: no consistent set ({})", name, pr->status);
      res_.physical_sets.push_back(e);
      res_.projections.push_back(std::move(*pr));
    }
  }

  // LS and FMLS from the real-flight regression (extended.hpp); the paper's
  // model above still gives GD, FMGD and the identifiability diagnostics.
  void use_real_flight_regression() {
    auto xr = std::make_shared<ExtendedResult>(identify_extended(log_, extended_options(opt_)));
    for (int i : {0, 1}) {
      const ExtendedEstimate& x = xr->estimates[static_cast<size_t>(i)];
      SetEstimate& e = res_.estimates[static_cast<size_t>(2 * i)];
      LeastSquaresSolution& sol = i == 0 ? res_.ls_standard : res_.ls_filtered;
      e.theta = x.theta;
      e.extra = x.extra;
      e.extra_std_error.clear();
      for (const auto& [name, value] : x.extra) {
        (void)value;
        const Eigen::Index j = x.index_of(name);
        if (j >= 0) e.extra_std_error.emplace_back(name, x.std_error(j));
      }
      sol.theta = x.theta;
      sol.condition = x.condition;
      // Intervals of the real-flight regression: its HAC standard errors,
      // Student t quantile, in Theta order.
      sol.uncertainty = rigid_body_estimate(x, opt_.terms.known_mass.has_value());
      sol.std_error = sol.uncertainty.std_error;
      sol.poorly_determined = sol.uncertainty.poorly_determined;
      sol.std_error_method =
          x.jackknife_blocks > 0
              ? fmt::format("real-flight regression: the larger of the HAC (low-frequency periodogram) covariance of "
                            "each sample's influence on the weighted fit and the jackknife over {} time blocks",
                            x.jackknife_blocks)
              : "real-flight regression: HAC (low-frequency periodogram) covariance of each sample's influence on the "
                "weighted fit";
      project_with_terms(x, static_cast<size_t>(i));
    }
    for (const auto& w : xr->warnings) res_.warnings.push_back(w);
    check_known_mass(xr->estimates[0]);
    res_.extended = std::move(xr);
  }

  // A known mass the flight contradicts (issue 37): with the mass given, the
  // regression estimates the thrust scale s (true wrench = s x the logged or
  // modelled one), so the flight itself measures the mass as known_mass / s.
  // A thrust model is rarely more than a factor 2 off; beyond that, and beyond
  // five standard errors of s, the number given is wrong (or the rotor model
  // is), and every inertia would be scaled by the same wrong factor.
  void check_known_mass(const ExtendedEstimate& ls) const {
    if (!opt_.terms.known_mass) return;
    const Eigen::Index j = ls.index_of("thrust_scale");
    if (j < 0) return;
    const double s = ls.value(j), se = ls.std_error(j), m = *opt_.terms.known_mass;
    if (!std::isfinite(s) || !(s > 0.0)) {
      throw std::invalid_argument(fmt::format(
          "--known-mass {:g} kg: the flight's thrust scale came out {:g}, not a positive number: the wrench columns "
          "(Fz, or the rotor model) do not lift the vehicle; leave --known-mass out to see what the flight measures",
          m, s));
    }
    const double measured = m / s;
    if (s >= 0.5 && s <= 2.0) return;
    if (std::isfinite(se) && std::abs(s - 1.0) <= 5.0 * se) return;
    const bool grams = s > 300.0 && s < 3000.0;
    throw std::invalid_argument(fmt::format(
        "--known-mass {:g} kg contradicts the flight: its thrust measures {:.4g} kg (thrust scale {:.4g} +- {:.2g}, "
        "expected near 1).{} Give --known-mass {:.4g} if that is the vehicle's mass, or leave --known-mass out to "
        "estimate it; if {:g} kg is right, the thrust is off by that factor (the vehicle file's kf, or Fz's unit)",
        m, measured, s, se, grams ? " Grams? The mass is in kg." : "", measured, m));
  }

  // The physically consistent set closest to a real-flight estimate, in the
  // metric of its covariance (m held at the known mass when given), with its terms.
  void project_with_terms(const ExtendedEstimate& x, size_t i) {
    TermsProjection tp = closest_physical_with_terms(x, opt_.terms.known_mass, prior_, opt_.physical);
    PhysicalProjection pr = std::move(tp.body);
    SetEstimate& pc = res_.physical_sets[i];
    pc.theta = pr.theta;
    pc.valid = pr.theta.allFinite();
    pc.note = pc.valid ? "" : fmt::format("{}: no consistent set ({})", pc.name, pr.status);
    if (pc.valid) pc.extra = std::move(tp.extra);
    if (pc.valid && !tp.pinned.empty()) {
      pr.changed = true;
      pr.status += fmt::format("; {} held at 0 (sign)", fmt::join(tp.pinned, ", "));
    }
    res_.projections[i] = std::move(pr);
  }

  // The two regressions' disagreement, |LS - FMLS|, beyond what noise
  // explains, in quadrature in both sets' standard errors and intervals
  // (UncertaintyOptions::model_disagreement): processing and model error that
  // the residuals do not show. Noise moves the two sets nearly together but
  // not quite: on a flight with no model error their difference is noise
  // (the QBall's m: |LS - FMLS| ~0.45 of its standard error), which, added,
  // counted the noise twice (m's 95 % intervals covered 100 % of 200 flights).
  // So only the part beyond the difference's own interval is added: t times
  // the HAC standard error of the two influence series' difference.
  void widen_for_model_disagreement() {
    if (!opt_.uncertainty.model_disagreement) return;
    LeastSquaresSolution* sols[2] = {&res_.ls_standard, &res_.ls_filtered};
    if (!sols[0]->uncertainty.computed || !sols[1]->uncertainty.computed) return;
    Theta d = (res_.estimates[0].theta - res_.estimates[2].theta).cwiseAbs();
    const Influences &a = influences_[0], &b = influences_[1];
    if (!opt_.extended() && !a.psi.empty() && !b.psi.empty()) {
      // The difference decorrelates when both series have: the larger of
      // their correlation times (no search of its own).
      const long m = std::max(sols[0]->uncertainty.correlation_time, sols[1]->uncertainty.correlation_time);
      const LongRunCovariance noise = difference_covariance(a.psi, a.begin, b.psi, b.begin, 7, opt_.uncertainty, m);
      for (Eigen::Index j = 0; j < 7; ++j) {
        const double within = noise.quantile * std::sqrt(std::max(0.0, noise.covariance(j, j)));
        if (std::isfinite(within)) d(j) = std::max(0.0, d(j) - within);
      }
    }
    for (LeastSquaresSolution* sol : sols) {
      Estimate& u = sol->uncertainty;
      if (u.size() != 7) continue;
      u.model_disagreement = Eigen::VectorXd::Zero(7);
      for (Eigen::Index j = 0; j < 7; ++j) {
        if (!std::isfinite(d(j)) || !std::isfinite(u.std_error(j))) continue;
        u.model_disagreement(j) = d(j);
        const double mid = 0.5 * (u.ci_low(j) + u.ci_high(j)), half = 0.5 * (u.ci_high(j) - u.ci_low(j));
        const double wider = std::hypot(half, u.quantile * d(j));
        u.ci_low(j) = mid - wider;
        u.ci_high(j) = mid + wider;
        u.std_error(j) = std::hypot(u.std_error(j), d(j));
        if (u.covariance.rows() > j && u.covariance.cols() > j) u.covariance(j, j) += d(j) * d(j);
        sol->std_error(j) = u.std_error(j);
      }
      // The determinedness rule of the estimators, on the wider errors.
      const Theta scale = determinedness_scale(sol->theta);
      const Eigen::VectorXd data = u.data_std_error();  // the rotor coefficients' share is not the data's
      for (int j = 0; j < 7; ++j) {
        const std::string name(kThetaNames[static_cast<size_t>(j)]);
        auto& poor = sol->poorly_determined;
        if (poorly_determined(data(j), scale(j), opt_.ls.poor_fraction) &&
            std::find(poor.begin(), poor.end(), name) == poor.end())
          poor.push_back(name);
      }
      u.poorly_determined = sol->poorly_determined;
    }
  }

  // The torques must fit the rotations: otherwise the error is the log's or
  // the vehicle file's, and the estimates are not a body's.
  void check_model_fit() {
    if (!opt_.input_checks) return;
    const std::vector<std::string> findings = model_fit_findings(res_);
    const auto filter = prefilter_removes_motion(log_, opt_.processing);
    if (!findings.empty() && filter) throw InputError(*filter);  // the root cause first
    // The moment rows may still fit (the rate products are filtered as
    // formed), but the force row's c is formed from filtered signals: the mass
    // is then the filter's (order 8 at 0.3 Hz: +0.67 %, at 11 of its standard errors).
    if (filter) input_warnings_.push_back("input check prefilter: " + *filter);
    input_check_errors(findings, opt_, "the log and the vehicle file are right", input_warnings_);
    if (const auto w = unexplained_warning(res_)) input_warnings_.push_back("input check " + *w);
  }

  // Rank deficiency is an error unless allowed (then a warning); returns the
  // parameters the data do not determine.
  std::vector<std::string> judge_rank() {
    std::vector<std::string> deficient;
    for (const auto* sol : {&res_.ls_standard, &res_.ls_filtered})
      for (const auto& n : sol->unidentifiable)
        if (std::find(deficient.begin(), deficient.end(), n) == deficient.end()) deficient.push_back(n);
    if (deficient.empty()) return deficient;
    const std::string msg = fmt::format(
        "the data do not determine {} (column-scaled condition number: standard {:.3g}, filtered {:.3g}): the "
        "flight does not excite these parameters (hover, or too little rotation)",
        fmt::join(deficient, ", "), res_.ls_standard.condition, res_.ls_filtered.condition);
    if (!opt_.allow_rank_deficient)
      throw InputError(msg + "; fly an exciting trajectory (quadid design), or allow rank-deficient data to keep "
                             "them at the reference values");
    res_.warnings.push_back(msg + fmt::format("; LS keeps them at the reference set '{}' and GD at its initial guess",
                                              opt_.reference.name));
    return deficient;
  }

  // A large standard error against the parameter's scale is a warning.
  void warn_poorly_determined(const std::vector<std::string>& deficient) {
    for (const auto& [name, sol] : {std::pair{"LS", &res_.ls_standard}, std::pair{"FMLS", &res_.ls_filtered}}) {
      std::vector<std::string> detail;
      for (const auto& n : sol->poorly_determined) {
        if (std::find(deficient.begin(), deficient.end(), n) != deficient.end()) continue;
        int j = 0;
        while (kThetaNames[static_cast<size_t>(j)] != n) ++j;
        detail.push_back(fmt::format("{} = {:.4g} +- {:.2g}", n, sol->theta(j), sol->std_error(j)));
      }
      if (detail.empty()) continue;
      res_.warnings.push_back(fmt::format("{}: poorly determined by these data (standard error above {:g}% of the "
                                          "parameter's scale{}): {}",
                                          name, 100.0 * opt_.ls.poor_fraction,
                                          sol->near_null.empty()
                                              ? std::string()
                                              : fmt::format(", or in a near-null direction: {}",
                                                            fmt::join(sol->near_null, ", ")),
                                          fmt::join(detail, ", ")));
    }
  }

  // The two regressions see the same flight through different filters; when
  // they disagree the processing is wrong for these data (e.g. motion-capture
  // steps left in the position, which the standard model differentiates twice).
  // LS and FMLS see the same data through different discretizations (eq. 33
  // against f_D/g_D, eqs. 35-36): they differ where the pre-filter passes a
  // band the two weigh differently. A difference counts when it is over 3 %
  // and beyond both sets' 95 % intervals (inside them it says nothing). The
  // advice is only the one that works: a pre-filter that passes more than a
  // few Hz (motion-capture steps, noise) is what Butterworth 4 Hz removes;
  // with that filter already on, the difference is model error, and no
  // processing option fixes it.
  void warn_disagreement() {
    std::vector<std::string> differ;
    // Noise alone: the std errors without the disagreement itself.
    const auto noise = [](const LeastSquaresSolution& s) {
      return s.uncertainty.computed && s.uncertainty.size() == 7 ? Theta(s.uncertainty.noise_std_error()) : s.std_error;
    };
    const Theta sa = noise(res_.ls_standard), sb = noise(res_.ls_filtered);
    for (int j : {0, 1, 4, 6}) {
      const double a = res_.ls_standard.theta(j), b = res_.ls_filtered.theta(j);
      const double se = std::max(std::isfinite(sa(j)) ? sa(j) : 0.0, std::isfinite(sb(j)) ? sb(j) : 0.0);
      if (std::abs(a - b) > 0.03 * std::max(std::abs(a), std::abs(b)) && std::abs(a - b) > kZ95 * se)
        differ.push_back(fmt::format("{} {:.4g} vs {:.4g}", kThetaNames[static_cast<size_t>(j)], a, b));
    }
    if (differ.empty()) return;
    const signal::LowpassOptions& lp = opt_.processing.lowpass;
    const double cutoff = std::max({lp.cutoff_hz, opt_.force_cutoff_hz.value_or(lp.cutoff_hz),
                                    opt_.moment_cutoff_hz.value_or(lp.cutoff_hz)});
    constexpr double kFewHz = 8.0;
    const bool smooth = lp.kind == signal::LowpassOptions::Kind::Butterworth && cutoff <= kFewHz;
    if (!smooth) {
      res_.warnings.push_back(fmt::format(
          "LS and FMLS disagree by more than 3 % and beyond their intervals ({}): the pre-filter ({}, up to {:g} Hz) "
          "passes motion-capture steps and noise that the two discretizations weigh differently; use the default "
          "Butterworth pre-filter: --filter butter --cutoff 4",
          fmt::join(differ, ", "), lp.name(), cutoff));
      return;
    }
    res_.warnings.push_back(fmt::format(
        "LS and FMLS disagree by more than 3 % and beyond their intervals ({}): with a smooth pre-filter ({}) this "
        "is model error -- motion the rigid-body model does not explain (unmodelled aerodynamics, delays, a flexible "
        "frame), weighed differently by the two discretizations. Neither set confirms the other; take the spread as "
        "a lower bound on the parameters' model error, and compare the sets' prediction errors",
        fmt::join(differ, ", "), lp.name()));
  }

  // A least-squares set inconsistent by many standard errors: the data are
  // not a rigid body's, whatever the set (issue 37). Otherwise positivity
  // only: the triangle inequalities are reported in consistency.<SET>.
  void warn_unphysical() {
    std::vector<std::string> far;
    for (const auto& e : res_.estimates) {
      if (!e.valid || !e.least_squares) continue;
      const double z = rigid_body_contradiction(*res_.least_squares_of(e.name), e.theta);
      if (z <= -kContradicts) far.push_back(fmt::format("{} by {:.0f}", e.name, -z));
    }
    if (!far.empty())
      res_.warnings.push_back(fmt::format(
          "the data contradict a rigid body: {} standard errors outside the physically consistent sets ({}), which "
          "noise does not explain: a unit, axis or frame slip in the log (docs/input-checks.md), model error the "
          "intervals leave out (on a real flight, e.g. the rotor model's yaw torque), or, for a simulated flight, a "
          "plant that is not a physical body (the built-in virtual QBall 2 flies the paper's Table 3 tensor, whose "
          "Izz > Ixx + Iyy). PC and FMPC are then the nearest consistent bodies, not necessarily near the truth",
          fmt::join(far, " and "), check_physical_consistency(res_.estimates[0].theta).why));
    for (const auto& e : res_.estimates) {
      if (!e.valid) continue;
      const PhysicalConsistency c = check_physical_consistency(e.theta);
      if (c.physical || c.why.find("triangle") != std::string::npos) continue;
      res_.warnings.push_back(fmt::format(
          "{}: not a physical body: {}{}", e.name, c.why,
          e.least_squares
              ? fmt::format(" (the closest physical set is {})", e.model == RegressionModel::Standard ? "PC" : "FMPC")
              : std::string()));
    }
  }

  // Units by plausibility (issue 37): a torque column in N mm or N cm scales
  // every moment of inertia by 1000 or 100 and nothing else in the fit shows it
  // (the torque rows fit as well). The mass comes from the force row, so the
  // radius of gyration sqrt(I_max / m) can be held against the size of a
  // multirotor of that mass (typical_multirotor_arm: built-ins at 0.47-0.65 of
  // it; accepted 0.15-3, which leaves a 10x-off torque unit outside).
  void warn_implausible_size() {
    // A thrust or position unit the input checks already named explains a
    // mass that is off; the radius of gyration would only blame the torques.
    for (const auto& f : res_.input_findings)
      if ((f.check == "thrust-units" || f.check == "position-units") && f.severity >= Severity::Warning) return;
    const SetEstimate& e = res_.estimates[0];
    if (!e.valid || !(e.theta(0) > 0.0)) return;
    const Params P = e.params();
    const Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> es(P.I, Eigen::EigenvaluesOnly);
    const double Imax = es.eigenvalues().maxCoeff();
    if (!(Imax > 0.0)) return;
    const double m = P.m, rg = std::sqrt(Imax / m), arm = typical_multirotor_arm(m), ratio = rg / arm;
    constexpr double kLow = 0.15, kHigh = 3.0;
    if (ratio >= kLow && ratio <= kHigh) return;
    const std::string facts = fmt::format(
        "{}: the largest moment of inertia {:.4g} kg m^2 for a mass of {:.4g} kg gives sqrt(I/m) = {:.3g} m, where a "
        "multirotor of that mass has arms of ~{:.2g} m and sqrt(I/m) of ~{:.2g} m",
        e.name, Imax, m, rg, arm, 0.6 * arm);
    if (ratio > kHigh) {
      // The unit whose factor brings sqrt(I/m) closest to the typical 0.6 arm.
      const auto distance = [&](double f) { return std::abs(std::log(ratio / std::sqrt(f) / 0.6)); };
      const char* unit = distance(1000.0) < distance(100.0) ? "N mm (1000x)" : "N cm (100x)";
      res_.warnings.push_back(fmt::format("{}: the torque columns look like {}: convert tau_phi, tau_theta, tau_psi "
                                          "to N m (or the mass is too small: positions in mm make the vertical acceleration, which the mass "
                                          "multiplies, 1000x too large)",
                                          facts, unit));
    } else {
      res_.warnings.push_back(fmt::format("{}: the mass looks too large for the inertia: Fz in mN or the positions "
                                          "in mm (the mass comes from Fz over the vertical acceleration), or the "
                                          "torques in a unit larger than N m; convert to N, m and N m",
                                          facts));
    }
  }

  // The valid sets among estimates a and b, with their real-flight terms
  // (the paper's prediction_error does not read them).
  std::vector<NamedParams> sets_of(int a, int b) const {
    std::vector<NamedParams> v;
    for (int i : {a, b}) {
      const SetEstimate& e = res_.estimates[static_cast<size_t>(i)];
      if (e.valid) v.push_back({e.name, e.params(), e.extra});
    }
    return v;
  }

  // Tables 5-6: each model with its own sets and the reference.
  void prediction_tables() {
    if (errors_standard_ && errors_filtered_) {
      res_.errors_standard = std::move(*errors_standard_);
      res_.errors_filtered = std::move(*errors_filtered_);
      return;
    }
    const std::vector<NamedParams> std_sets = sets_of(0, 1), filt_sets = sets_of(2, 3);
    if (opt_.extended()) {
      ExtendedOptions eo = extended_options(opt_);
      eo.window = error_window_;
      detail::run_both(
          two_,
          [&] {
            res_.errors_standard =
                real_flight_prediction_error(log_, std_sets, opt_.reference, RegressionModel::Standard, eo, true);
          },
          [&] {
            res_.errors_filtered =
                real_flight_prediction_error(log_, filt_sets, opt_.reference, RegressionModel::Filtered, eo, true);
          });
      res_.errors_real_flight = true;
      return;
    }
    detail::run_both(
        two_,
        [&] { res_.errors_standard = prediction_error(std_reg_->with_window(error_window_), std_sets, opt_.reference); },
        [&] {
          res_.errors_filtered = prediction_error(filt_reg_->with_window(error_window_), filt_sets, opt_.reference);
        });
  }

  const FlightLog& log_;
  const IdentificationOptions& opt_;
  const bool two_;
  const Theta prior_;
  // Tables 5-6 over the error window (the regression's by default).
  const TimeWindow error_window_;
  IdentificationResult res_;
  std::vector<std::string> input_warnings_;  // listed after the estimation's own warnings
  std::future<std::vector<InputFinding>> checks_;
  std::shared_ptr<const RegressionSignals> sig_;
  std::optional<Regression> std_reg_, filt_reg_;
  Recorder rec_{0, 1, 1, false};
  RunOutput s_, f_;
  // Each regression's influence series and its first sample (LS, FMLS): the
  // noise in their difference (widen_for_model_disagreement).
  struct Influences {
    std::vector<double> psi;
    long begin = 0;
  };
  std::array<Influences, 2> influences_;
  PhysicalProjection pc_std_, pc_filt_;
  std::exception_ptr estimation_error_;
  std::optional<PredictionErrorTable> errors_standard_, errors_filtered_;  // when computed in the second pass
};

}  // namespace

IdentificationResult identify(const FlightLog& log, const IdentificationOptions& opt) {
  opt.validate();
  return IdentifyRun(log, opt).run();
}

}  // namespace quadid
