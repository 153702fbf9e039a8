// Predicted standard errors of LS and FMLS along a planned flight (see
// include/quadid/precision.hpp for the model).
//
// The nominal signals come from the library's own pipeline run on a noise-free
// log of the reference: reference_at (eqs. 26-27 and the kinematics below
// eq. 20) for the states, the regressor of eq. (11) times the true Theta for
// the wrench, process_log (section II-C) and Regression (eqs. 34, 38) for
// Gamma_k; with simulated flights, Gamma_k and P are each flight's (its true
// states through process_log and Regression) and the Jacobians J_k stay the
// reference's. The noise is then propagated to first order:
//   x_k (the 15 processed signals of RegressionSignals) = x_k^0 + J_k z_k,
//   z = the pre-filtered noise of [p_dot(3) eta(3) omega(3) F(4)],
//   e_k = M_a a_k + M_b b_k - y_k (Gamma theta is linear in the signals a, b),
//   delta_theta = sum_k P Gamma_k^T delta_e_k.
// Each linear operator (pre-filter H, central difference D of eq. 33, f_D and
// g_D of eqs. 35-36) is applied in its adjoint form to the weight series
// P Gamma_k^T, which gives delta_theta = sum_j g_j n_j over the raw noise
// samples n_j, hence Cov = sum sigma^2 sum_blocks (sum_{j in block} g_j)(...)^T
// with a block per held sensor sample.
#include "quadid/precision.hpp"

#include "quadid/identification/extended.hpp"
#include "quadid/model/regressor.hpp"
#include "quadid/signal.hpp"
#include "quadid/core/json.hpp"
#include "quadid/core/parallel.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <memory>
#include <utility>
#include <stdexcept>

namespace quadid {
namespace {

using Mat7 = Eigen::Matrix<double, 7, 7>;
// Inputs of the Jacobian J_k: [p_dot(3) eta(3) omega(3) F(4)].
constexpr int kIn = 13;
enum : int { kPdot = 0, kEta = 3, kOmega = 6, kF = 9 };

// The sensor sample that log sample k holds: the first tick at or after each
// sensor instant, as the simulator samples (simulation/sensors.cpp).
long long held_index(Eigen::Index k, double sensor_rate, double log_rate) {
  return static_cast<long long>(std::floor(static_cast<double>(k) * sensor_rate / log_rate + 1e-9));
}

// Adjoint of f_D as Regression::for_each applies it (s_k = alpha s_{k-1} + (1 - alpha) x_{k-1}):
// (f_D^T u)_j = (1 - alpha) sum_{k > j} alpha^(k-1-j) u_k, by a backward recursion.
void fD_adjoint(double* u, Eigen::Index n, double alpha, double one_minus) {
  double t = 0.0;  // sum_{k > j} alpha^(k-1-j) u_k
  for (Eigen::Index j = n - 1; j >= 0; --j) {
    const double uj = u[j];
    u[j] = one_minus * t;
    t = uj + alpha * t;
  }
}

// Adjoint of the central difference of eq. (33) in the interior: D^T = -D.
void difference_adjoint(double* u, Eigen::Index n, double T) {
  signal::central_difference_inplace(u, n, T);
  for (Eigen::Index j = 0; j < n; ++j) u[j] = -u[j];
}

// Row blocks of the adjoint's n x (7 x signals) weight matrices: computed row
// by row in a small row-major buffer, moved to and from the column-major
// matrices (whose columns the recursions and filters run along) column by column.
constexpr Eigen::Index kBlock = 64;
using RowBlock = Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor>;
void store_rows(const RowBlock& buf, Eigen::Index rows, Eigen::MatrixXd& M, Eigen::Index first) {
  for (Eigen::Index c = 0; c < M.cols(); ++c) {
    double* dst = M.col(c).data() + first;
    for (Eigen::Index r = 0; r < rows; ++r) dst[r] = buf(r, c);
  }
}
void load_rows(const Eigen::MatrixXd& M, Eigen::Index first, Eigen::Index rows, RowBlock& buf) {
  for (Eigen::Index c = 0; c < M.cols(); ++c) {
    const double* src = M.col(c).data() + first;
    for (Eigen::Index r = 0; r < rows; ++r) buf(r, c) = src[r];
  }
}

// The regressor series Gamma_k of one regression (0 outside its window), its row
// weights W, its information matrix sum Gamma_k^T W^2 Gamma_k, and the residual
// Gamma_k theta - y_k.
struct RegressorSeries {
  std::vector<Regressor4x7> G;
  Vec4 w2 = Vec4::Ones();  // squared row weights (weighted least squares: sum_r w_r^2 e_r^2)
  Mat7 A = Mat7::Zero();   // sum Gamma_k^T W^2 Gamma_k
  Eigen::MatrixXd e;  // n x 4
  Eigen::Index begin = 0, end = 0;
};

RegressorSeries regressor_series(const Regression& reg, Eigen::Index n, const Theta& theta, const Vec4& w2) {
  RegressorSeries s;
  s.w2 = w2;
  s.G.assign(static_cast<size_t>(n), Regressor4x7::Zero());
  s.e = Eigen::MatrixXd::Zero(n, 4);
  s.begin = reg.begin();
  s.end = reg.end();
  reg.for_each([&](Eigen::Index k, const Regressor4x7& Gk, const Vec4& y) {
    s.G[static_cast<size_t>(k)] = Gk;
    s.A.noalias() += Gk.transpose() * w2.asDiagonal() * Gk;
    s.e.row(k) = (Gk * theta - y).transpose();
  });
  return s;
}

// The signals of section II-C as the real-flight regression takes them
// (process_with_terms): the force row's (kForceRowSignals) pre-filtered at the
// force cutoff, the others at the moment cutoff; the edges left out are the wider filter's.
bool is_force_signal(int s) {
  return std::find(kForceRowSignals.begin(), kForceRowSignals.end(), s) != kForceRowSignals.end();
}

std::shared_ptr<const RegressionSignals> row_signals(const FlightLog& log, const ProcessingOptions& proc,
                                                     double f_force, double f_moment) {
  ProcessingOptions pf = proc, pm = proc;
  pf.lowpass.cutoff_hz = f_force;
  pm.lowpass.cutoff_hz = f_moment;
  return process_with_terms(log, pf, pm, ModelTerms{}).signals;
}

// The simulation of the planned flight: PrecisionOptions::simulation, or one built from its fields.
SimulationOptions flight_options(const PrecisionOptions& opt) {
  SimulationOptions so = opt.simulation.value_or(SimulationOptions{});
  if (!opt.simulation) {
    so.plant = opt.params;
    so.set_rate(opt.rate);
    so.sensors = opt.sensors;
    so.g = opt.g;
    so.controller.g = opt.g;
  }
  so.duration = opt.duration;
  return so;
}

// P = A^-1 computed with the columns scaled to unit norm (the parameters differ
// by ~100x); `condition` = cond of the scaled stack. Throws InputError when singular.
Mat7 information_inverse(const Mat7& A, double* condition, const std::string& what) {
  const Theta d = A.diagonal().cwiseSqrt().cwiseInverse();
  const Mat7 As = d.asDiagonal() * A * d.asDiagonal();
  Eigen::SelfAdjointEigenSolver<Mat7> es(As);
  const auto ev = es.eigenvalues();
  if (!(ev(0) > 1e-12 * ev(6)) || !d.allFinite())
    throw InputError(fmt::format("predicted precision: the {} does not determine every parameter (information "
                                 "matrix singular)", what));
  if (condition) *condition = std::sqrt(ev(6) / ev(0));
  return d.asDiagonal() * es.eigenvectors() * ev.cwiseInverse().asDiagonal() * es.eigenvectors().transpose() *
         d.asDiagonal();
}

// The pre-filter cutoffs of the force row and of the moment rows, Hz.
std::pair<double, double> cutoffs(const PrecisionOptions& opt) {
  const double f = opt.processing.lowpass.cutoff_hz;
  return {opt.force_cutoff_hz.value_or(f), opt.moment_cutoff_hz.value_or(f)};
}

}  // namespace

PrecisionOptions PrecisionOptions::from(const SimulationOptions& sim, const IdentificationOptions& id) {
  PrecisionOptions o;
  o.params = sim.plant;
  o.rate = sim.controller.rate;
  o.duration = sim.duration;
  o.window = id.window;
  o.sensors = sim.sensors;
  o.rotors = sim.rotors;
  o.rotor_noise = sim.rotor_noise;
  o.processing = id.processing;
  o.lambda = id.lambda;
  o.gd_variant = id.gd_variant;
  o.force_cutoff_hz = id.force_cutoff_hz;
  o.moment_cutoff_hz = id.moment_cutoff_hz;
  o.weight_rows = id.terms.weight_rows;
  o.g = sim.g;
  o.simulation = sim;
  return o;
}

void PrecisionOptions::validate() const {
  if (!(rate > 0.0) || !std::isfinite(rate)) throw std::invalid_argument(fmt::format("--rate = {} must be > 0 Hz", rate));
  if (!(duration > 0.0) || !std::isfinite(duration) || duration * rate > SimulationOptions::kMaxSamples)
    throw std::invalid_argument(
        fmt::format("--duration = {} s must be > 0 and hold at most {:g} samples at {} Hz", duration,
                    SimulationOptions::kMaxSamples, rate));
  if (!(params.m > 0.0)) throw std::invalid_argument("precision: the vehicle's mass must be > 0");
  sensors.validate(rate);
  if (!std::isfinite(rotor_noise) || rotor_noise < 0.0)
    throw std::invalid_argument(fmt::format("--sigma-rotor = {} must be finite and >= 0", rotor_noise));
  if (rotor_noise > 0.0 && (!rotors || rotors->input_leads_rotor()))
    throw std::invalid_argument("--sigma-rotor applies to logged rotor speeds (a vehicle with rotors.input = speed or rpm)");
  if (rotors) rotors->validate();
  for (int i = 0; i < 4; ++i)
    if (!std::isfinite(wrench_noise(i)) || wrench_noise(i) < 0.0)
      throw std::invalid_argument(fmt::format("--sigma-wrench = {} must be finite and >= 0", wrench_noise(i)));
  processing.validate();
  if (!(lambda > 0.0) || !std::isfinite(lambda)) throw std::invalid_argument(fmt::format("--lambda = {} must be > 0", lambda));
  if (!(g > 0.0) || !std::isfinite(g)) throw std::invalid_argument(fmt::format("--g = {} must be > 0", g));
  if (closed_loop_flights == 1 || closed_loop_flights < 0 || closed_loop_flights > 100)
    throw std::invalid_argument(fmt::format(
        "--closed-loop-flights = {} must be 0 (left out) or 2..100 (their spread is measured)", closed_loop_flights));
  for (auto [name, f] : {std::pair{"--cutoff-force", force_cutoff_hz}, std::pair{"--cutoff-moment", moment_cutoff_hz}})
    if (f && !(*f > 0.0 && *f < 0.5 * rate))
      throw std::invalid_argument(
          fmt::format("{} = {} Hz must be > 0 and below half the log rate ({} Hz)", name, *f, rate));
  if (weight_rows && closed_loop_flights == 0)
    throw std::invalid_argument(
        "the row weights of the real-flight regression (weighting) are measured on simulated flights: "
        "--closed-loop-flights must be 2..100, not 0 (or predict the paper's unweighted regression: "
        "--regression paper)");
  if (simulation) simulation->validate();
}

Vec4 regression_row_noise(const PrecisionOptions& opt, double hover_z) {
  opt.validate();
  if (!std::isfinite(hover_z) || hover_z <= 0.0)
    throw std::invalid_argument(fmt::format("hover height {:g} m must be positive", hover_z));
  std::array<FourierTrajectory::AxisCoeffs, 4> axes;
  for (auto& a : axes) a = {Eigen::VectorXd::Zero(1), Eigen::VectorXd::Zero(1), 0.0};
  axes[kZ].c = hover_z;
  const FourierTrajectory hover(1.0, std::move(axes));
  SimulationOptions so = flight_options(opt);
  so.duration = kRowNoiseSeconds;
  so.record_truth = false;
  if (opt.rotors) so.rotor_noise = opt.rotor_noise;
  so.sensors.seed = 1;
  FlightLog log = simulate(hover, so).log;
  if (opt.rotors) log = with_rotor_wrench(log, *opt.rotors);  // as identify --vehicle: the wrench of the noisy columns
  const std::pair<double, double> fc = cutoffs(opt);
  const double f_force = fc.first, f_moment = fc.second;
  const Regression reg(row_signals(log, opt.processing, f_force, f_moment), RegressionModel::Standard,
                       TimeWindow{0.0, kRowNoiseSeconds});
  const Theta theta = opt.params.theta();
  Vec4 ss = Vec4::Zero();
  reg.for_each([&](Eigen::Index, const Regressor4x7& G, const Vec4& Y) { ss += (G * theta - Y).cwiseAbs2(); });
  return (ss / static_cast<double>(reg.size())).cwiseSqrt();
}

namespace {

using StateJacobian = Eigen::Matrix<double, 15, kIn>;

// J_k: d x_k (15 processed signals) / d [p_dot eta omega F] at one nominal state.
StateJacobian state_jacobian(const Reference& r, double g) {
  const Mat3 Rt = rotation<double>(r.eta).transpose();
  Mat3 dv_deta;  // d (R^T p_dot) / d eta, central differences (error ~1e-10 relative)
  for (int i = 0; i < 3; ++i) {
    constexpr double h = 1e-6;
    Vec3 ep = r.eta, em = r.eta;
    ep(i) += h;
    em(i) -= h;
    dv_deta.col(i) = (rotation<double>(ep).transpose() - rotation<double>(em).transpose()) * r.p_dot / (2.0 * h);
  }
  const Vec3 v = Rt * r.p_dot;
  const double p = r.omega(0), q = r.omega(1), rr = r.omega(2);
  const double phi = r.eta(0), th = r.eta(1);
  StateJacobian Jk;
  Jk.setZero();
  Jk.block<1, 3>(0, kPdot) = Rt.row(2);     // w = (R^T p_dot)_z, eq. (3)
  Jk.block<1, 3>(0, kEta) = dv_deta.row(2);
  Jk.block<3, 3>(1, kOmega).setIdentity();  // p q r
  // c = p v - q u + g cos(theta) cos(phi), eq. (7)
  Jk.block<1, 3>(4, kPdot) = p * Rt.row(1) - q * Rt.row(0);
  Jk.block<1, 3>(4, kEta) = p * dv_deta.row(1) - q * dv_deta.row(0);
  Jk(4, kEta + 0) += -g * std::sin(phi) * std::cos(th);
  Jk(4, kEta + 1) += -g * std::cos(phi) * std::sin(th);
  Jk(4, kOmega + 0) = v(1);
  Jk(4, kOmega + 1) = -v(0);
  // pq pr qr p^2 q^2 r^2
  Jk(5, kOmega + 0) = q;  Jk(5, kOmega + 1) = p;
  Jk(6, kOmega + 0) = rr; Jk(6, kOmega + 2) = p;
  Jk(7, kOmega + 1) = rr; Jk(7, kOmega + 2) = q;
  Jk(8, kOmega + 0) = 2.0 * p;
  Jk(9, kOmega + 1) = 2.0 * q;
  Jk(10, kOmega + 2) = 2.0 * rr;
  Jk.block<4, 4>(11, kF).setIdentity();     // Fz tau
  return Jk;
}

// One call of predict_precision in the steps of this file's header comment. The
// members are what the steps share; once run() has built them they are only read,
// as linear_part runs on several threads.
class PrecisionRun {
 public:
  PrecisionRun(const Trajectory& traj, const PrecisionOptions& opt)
      : traj_(traj),
        opt_(opt),
        T_(1.0 / opt.rate),
        n_(static_cast<Eigen::Index>(std::floor(opt.duration * opt.rate + 1e-9)) + 1),
        theta_(opt.params.theta()),
        alpha_(std::exp(-opt.lambda * T_)),
        one_minus_(-std::expm1(-opt.lambda * T_)),
        c_((opt.gd_variant == signal::GdVariant::Printed) ? opt.lambda : one_minus_ / T_) {}

  PrecisionResult run() {
    nominal_log();
    const std::pair<double, double> fc = cutoffs(opt_);
    f_force_ = fc.first;
    f_moment_ = fc.second;
    signals_ = row_signals(log_, opt_.processing, f_force_, f_moment_);
    linear_signal_maps();
    jacobians();
    rotor_speed_jacobian();
    fly_plan();
    prefilters();
    PrecisionResult res = described();
    for (int m = 0; m < 2; ++m) predict_set(m, res);
    return res;
  }

 private:
  // Noise-free log of the reference, and the nominal states for the Jacobians.
  void nominal_log() {
    log_.columns = standard_log_columns();
    log_.data.resize(n_, static_cast<Eigen::Index>(log_.columns.size()));
    ref_.resize(static_cast<size_t>(n_));
    wrench_.resize(n_, 4);
    for (Eigen::Index k = 0; k < n_; ++k) {
      const double t = static_cast<double>(k) * T_;
      const Reference& r = ref_[static_cast<size_t>(k)] = reference_at(traj_, t, opt_.g);
      const Eigen::Vector4d F = regressor<double>(r.v, r.omega, r.eta, r.v_dot, r.omega_dot, opt_.g) * theta_;  // eq. (11)
      wrench_.row(k) = F.transpose();
      log_.data.row(k) << t, r.p(0), r.p(1), r.p(2), r.eta(0), r.eta(1), r.eta(2), r.omega(0), r.omega(1), r.omega(2),
          F(0), F(1), F(2), F(3);
    }
  }

  // Gamma theta = M_a a + M_b b: the regressor is linear in its 4 + 7 signals.
  void linear_signal_maps() {
    for (int i = 0; i < 4; ++i)
      Ma_.col(i) = assemble_regressor(Vec4::Unit(i), Eigen::Matrix<double, 7, 1>::Zero()) * theta_;
    for (int j = 0; j < 7; ++j)
      Mb_.col(j) = assemble_regressor(Vec4::Zero(), Eigen::Matrix<double, 7, 1>::Unit(j)) * theta_;
  }

  // J_k at every sample, and the entries of J any sample makes non-zero.
  void jacobians() {
    J_.resize(static_cast<size_t>(n_));
    for (Eigen::Index k = 0; k < n_; ++k) J_[static_cast<size_t>(k)] = state_jacobian(ref_[static_cast<size_t>(k)], opt_.g);
    // J's structure: ~30 of its 195 entries are ever non-zero (sparse_product).
    for (int i = 0; i < kIn; ++i)
      for (int s = 0; s < 15; ++s)
        if (std::any_of(J_.begin(), J_.end(), [&](const auto& Jk) { return Jk(s, i) != 0.0; }))
          j_nonzero_.emplace_back(s, i);
  }

  // V J_k over J's non-zero entries alone, in the order of a dense product's sum
  // (skipped terms are exact zeros): 6x less work than the dense product, the same bits.
  Eigen::Matrix<double, 7, kIn> sparse_product(const Eigen::Matrix<double, 7, 15>& V, const StateJacobian& Jk) const {
    Eigen::Matrix<double, 7, kIn> W = Eigen::Matrix<double, 7, kIn>::Zero();
    for (const auto& [s, i] : j_nonzero_) W.col(i) += V.col(s) * Jk(s, i);
    return W;
  }

  // Rotor-speed noise -> wrench: dF/dw_i = B_i 2 k w_i at the nominal rotor speeds
  // (columns 4 i .. 4 i + 3 of row k: rotor i's column of dF/dw at sample k).
  void rotor_speed_jacobian() {
    rotor_mode_ = opt_.rotors && opt_.rotor_noise > 0.0;
    if (!rotor_mode_) return;
    const RotorModel& rm = *opt_.rotors;
    const Eigen::Matrix<double, 4, Eigen::Dynamic> B = rm.allocation();
    const Eigen::Matrix<double, Eigen::Dynamic, 4> mixer = rm.mixer();
    dF_dw_.resize(n_, 4 * rm.count());
    for (Eigen::Index k = 0; k < n_; ++k) {
      const Eigen::VectorXd thrusts = mixer * wrench_.row(k).transpose();
      for (int i = 0; i < rm.count(); ++i) {
        const double w = rm.speed_for_thrust(thrusts(i));
        dF_dw_.block<1, 4>(k, 4 * i) = (B.col(i) * (2.0 * rm.thrust_coefficient() * w)).transpose();  // T = k w^2
      }
    }
  }

  // Simulated flights of the plan (closed_loop_flights > 0): the regressor series of
  // each (its true states processed as a log), and its residual for the closed-loop term.
  void fly_plan() {
    if (opt_.closed_loop_flights <= 0) return;
    SimulationOptions so = flight_options(opt_);
    so.record_truth = true;
    // The rotor noise only reaches the log (the flight is the same): it is there for the row weights.
    so.rotor_noise = opt_.weight_rows ? opt_.rotor_noise : 0.0;
    // The flights are independent (each its own seed): on every core.
    flown_.resize(static_cast<size_t>(opt_.closed_loop_flights));
    flown_w2_.resize(static_cast<size_t>(opt_.closed_loop_flights));
    detail::parallel_for(opt_.closed_loop_flights, 0, [&](int f) {
      SimulationOptions sf = so;
      sf.sensors.seed = static_cast<std::uint64_t>(f + 1);
      const SimulationResult flight = fly(sf);
      if (flight.truth.rows() != n_) throw std::logic_error("precision: a simulated flight of another length");
      flown_[static_cast<size_t>(f)] = row_signals(flight.truth, opt_.processing, f_force_, f_moment_);
      std::array<Vec4, 2> w2{Vec4::Ones(), Vec4::Ones()};
      if (opt_.weight_rows) w2 = flown_row_weights(flight, sf);
      flown_w2_[static_cast<size_t>(f)] = w2;
    });
  }

  // One simulated flight; a divergence is the plan's fault, said as such.
  SimulationResult fly(const SimulationOptions& sf) const {
    try {
      return simulate(traj_, sf);
    } catch (const SimulationDiverged& e) {
      throw InputError(fmt::format(
          "predicted precision: the simulated flight of {} diverged at t = {:.3f} s ({}): the vehicle cannot fly "
          "this plan with its controller; --closed-loop-flights 0 leaves the closed-loop term out",
          traj_.describe(), e.time(), e.reason()));
    }
  }

  // The weights identify gives this flight's log: the real-flight regression with
  // its row weighting alone (extended.cpp: three passes, 1 / residual RMS per row).
  std::array<Vec4, 2> flown_row_weights(const SimulationResult& flight, const SimulationOptions& sf) const {
    ExtendedOptions xo;
    xo.processing = opt_.processing;
    xo.force_cutoff_hz = f_force_;
    xo.moment_cutoff_hz = f_moment_;
    xo.window = opt_.window;
    xo.lambda = opt_.lambda;
    xo.gd_variant = opt_.gd_variant;
    xo.terms.weight_rows = true;
    xo.reference = opt_.params;
    const ExtendedResult x = identify_extended(sf.rotors ? with_rotor_wrench(flight.log, *sf.rotors) : flight.log, xo);
    std::array<Vec4, 2> w2;
    for (int m = 0; m < 2; ++m)
      w2[static_cast<size_t>(m)] = x.estimates[static_cast<size_t>(m)].row_weight.cwiseAbs2();
    return w2;
  }

  // The pre-filters of the force row and of the moment rows.
  void prefilters() {
    lp_force_ = opt_.processing.lowpass;
    lp_moment_ = opt_.processing.lowpass;
    lp_force_.cutoff_hz = f_force_;
    lp_moment_.cutoff_hz = f_moment_;
    two_cutoffs_ = f_force_ != f_moment_;
  }

  // The result's description: the plan, the regression, the truth and the noise sources.
  PrecisionResult described() const {
    PrecisionResult res;
    res.trajectory = traj_.describe();
    res.regression = opt_.weight_rows ? "real-flight, rows weighted by 1/residual RMS" : "paper";
    res.regression += two_cutoffs_
                          ? fmt::format(" (force row pre-filtered at {:g} Hz, moment rows at {:g} Hz)", f_force_, f_moment_)
                          : fmt::format(" (pre-filter {:g} Hz)", f_force_);
    res.truth = theta_;
    // A wrench made from rotor speeds: the rotor model given, or the simulated vehicle's.
    if (opt_.rotors || (opt_.simulation && opt_.simulation->rotors)) {
      res.model_error = Eigen::Map<const Theta>(kRotorWrenchModelError.data());
      res.model_error_class = "rotor-speed wrench";
    }
    res.sources = {"position", "yaw", "attitude", "gyro", rotor_mode_ ? "rotor" : "wrench", "closed loop"};
    return res;
  }

  // The linear part for one regressor series S with P = (sum S.G^T W^2 S.G)^-1 (the
  // weights P Gamma_k^T W^2): the covariance of each noise source 0..4.
  std::array<Mat7, 5> linear_part(RegressionModel model, const RegressorSeries& S, const Mat7& P) const {
    Eigen::MatrixXd U = signal_weights(S, P);
    regression_adjoint(model, U);
    const Eigen::MatrixXd Z = input_weights(U);
    return by_source(Z);
  }

  // Weight series on the processed signals: columns [a(4) b(7) y(4)] x 7 parameters.
  // Every row in the window is written below; only those outside need zeros.
  // Rows are computed kBlock at a time into a row-major buffer, then stored
  // column by column: row k of a column-major n x 105 matrix spans 105 pages,
  // and writing it sample by sample cost 5x the arithmetic.
  Eigen::MatrixXd signal_weights(const RegressorSeries& S, const Mat7& P) const {
    Eigen::MatrixXd U(n_, 15 * 7);
    U.topRows(S.begin).setZero();
    U.bottomRows(n_ - S.end).setZero();
    RowBlock buf(kBlock, 15 * 7);
    for (Eigen::Index b0 = S.begin; b0 < S.end; b0 += kBlock) {
      const Eigen::Index nb = std::min<Eigen::Index>(kBlock, S.end - b0);
      for (Eigen::Index r = 0; r < nb; ++r) {
        const auto k = static_cast<size_t>(b0 + r);
        const Eigen::Matrix<double, 7, 4> Q = P * S.G[k].transpose() * S.w2.asDiagonal();
        Eigen::Matrix<double, 7, 15> V;
        V << Q * Ma_, Q * Mb_, -Q;
        for (int s = 0; s < 15; ++s) buf.block<1, 7>(r, 7 * s) = V.col(s).transpose();
      }
      store_rows(buf, nb, U, b0);
    }
    return U;
  }

  // Adjoint of the regression's operators on a, b and y.
  void regression_adjoint(RegressionModel model, Eigen::MatrixXd& U) const {
    for (int col = 0; col < 15 * 7; ++col) {
      double* u = U.col(col).data();
      const bool is_a = col < 4 * 7;
      if (model == RegressionModel::Standard) {
        if (is_a) difference_adjoint(u, n_, T_);  // a = D [w p q r], eq. (33)
      } else if (is_a) {                         // a = g_D x = c (x - f_D x), eq. (36)
        Eigen::VectorXd f = U.col(col);
        fD_adjoint(f.data(), n_, alpha_, one_minus_);
        U.col(col) = c_ * (U.col(col) - f);
      } else {                                   // b = f_D x, y = f_D F, eq. (35)
        fD_adjoint(u, n_, alpha_, one_minus_);
      }
    }
  }

  // Through J_k onto the 13 pre-filtered inputs, then the pre-filter's adjoint
  // (filtfilt is symmetric: H^T = H away from the edges, which the window leaves out).
  // With two cutoffs the force row's signals and the others come from inputs filtered
  // by each filter: Z = H_F^T (V_F J)^T + H_M^T (V_M J)^T.
  Eigen::MatrixXd input_weights(const Eigen::MatrixXd& U) const {
    Eigen::MatrixXd Z(n_, kIn * 7), Zm;  // every row written below, kBlock at a time as U
    if (two_cutoffs_) Zm.resize(n_, kIn * 7);
    jacobian_adjoint(U, Z, Zm);
    // Filters of this call's own (their work space is per object: linear_part runs on
    // several threads), each applied to all its columns at once (same bits as one by one).
    signal::ZeroPhaseFilter zf_force(lp_force_, opt_.rate);
    filter_adjoint(Z, zf_force);
    if (two_cutoffs_) {
      signal::ZeroPhaseFilter zf_moment(lp_moment_, opt_.rate);
      filter_adjoint(Zm, zf_moment);
      Z += Zm;
    }
    return Z;
  }

  // Z = (V J)^T row by row (Zm: the moment filter's part, with two cutoffs).
  void jacobian_adjoint(const Eigen::MatrixXd& U, Eigen::MatrixXd& Z, Eigen::MatrixXd& Zm) const {
    RowBlock buf(kBlock, 15 * 7);
    RowBlock zbuf(kBlock, kIn * 7), zmbuf(two_cutoffs_ ? kBlock : 0, kIn * 7);
    for (Eigen::Index b0 = 0; b0 < n_; b0 += kBlock) {
      const Eigen::Index nb = std::min<Eigen::Index>(kBlock, n_ - b0);
      load_rows(U, b0, nb, buf);
      for (Eigen::Index r = 0; r < nb; ++r) {
        const auto k = static_cast<size_t>(b0 + r);
        Eigen::Matrix<double, 7, 15> V, Vm;  // Vm: the moment filter's part, with two cutoffs
        for (int s = 0; s < 15; ++s) V.col(s) = buf.block<1, 7>(r, 7 * s).transpose();
        if (V.isZero(0.0)) {
          zbuf.row(r).setZero();
          if (two_cutoffs_) zmbuf.row(r).setZero();
          continue;
        }
        if (two_cutoffs_) {
          Vm.setZero();
          for (int s = 0; s < 15; ++s)
            if (!is_force_signal(s)) {
              Vm.col(s) = V.col(s);
              V.col(s).setZero();
            }
        }
        const Eigen::Matrix<double, 7, kIn> W = sparse_product(V, J_[k]);
        for (int i = 0; i < kIn; ++i) zbuf.block<1, 7>(r, 7 * i) = W.col(i).transpose();
        if (two_cutoffs_) {
          const Eigen::Matrix<double, 7, kIn> Wm = sparse_product(Vm, J_[k]);
          for (int i = 0; i < kIn; ++i) zmbuf.block<1, 7>(r, 7 * i) = Wm.col(i).transpose();
        }
      }
      store_rows(zbuf, nb, Z, b0);
      if (two_cutoffs_) store_rows(zmbuf, nb, Zm, b0);
    }
  }

  // The pre-filter's adjoint on every column of M, after the difference's on p_dot's.
  void filter_adjoint(Eigen::MatrixXd& M, signal::ZeroPhaseFilter& zf) const {
    std::vector<double*> cols(static_cast<size_t>(kIn * 7));
    for (int col = 0; col < kIn * 7; ++col) {
      cols[static_cast<size_t>(col)] = M.col(col).data();
      if (col < 3 * 7) difference_adjoint(M.col(col).data(), n_, T_);  // p_dot = D H x, eq. (33)
    }
    zf.apply(cols.data(), kIn * 7, n_);
  }

  // The covariance of each noise source from the weights Z on the raw inputs.
  std::array<Mat7, 5> by_source(const Eigen::MatrixXd& Z) const {
    std::array<Mat7, 5> by{};
    for (auto& m : by) m.setZero();
    auto add = [&](int src, const Eigen::Ref<const Eigen::MatrixXd>& g, double sigma, double rate) {
      if (sigma > 0.0) by[static_cast<size_t>(src)] += sigma * sigma * held_sum(g, rate);
    };
    auto input = [&](int i) { return Z.middleCols(7 * i, 7); };
    const NoiseSigmas& ns = opt_.sensors.noise;
    for (int i = 0; i < 3; ++i) add(0, input(kPdot + i), ns.position, opt_.sensors.mocap_rate);
    add(1, input(kEta + 2), ns.yaw, opt_.sensors.mocap_rate);
    for (int i = 0; i < 2; ++i) add(2, input(kEta + i), ns.attitude, opt_.sensors.imu_rate);
    for (int i = 0; i < 3; ++i) add(3, input(kOmega + i), ns.gyro, opt_.sensors.imu_rate);
    if (rotor_mode_) {
      for (Eigen::Index i = 0; i < dF_dw_.cols() / 4; ++i) {
        Eigen::MatrixXd g = Eigen::MatrixXd::Zero(n_, 7);
        for (Eigen::Index k = 0; k < n_; ++k)
          for (int j = 0; j < 4; ++j) g.row(k) += dF_dw_(k, 4 * i + j) * Z.block<1, 7>(k, 7 * (kF + j));
        add(4, g, opt_.rotor_noise, opt_.rate);  // white on each logged sample (simulation/simulate.cpp)
      }
    } else {
      for (int j = 0; j < 4; ++j) add(4, input(kF + j), opt_.wrench_noise(j), opt_.rate);
    }
    return by;
  }

  // sum_blocks (sum_{k in block} g_k)(...)^T for one input held at `rate` (times
  // sigma^2 it is that input's covariance).
  Mat7 held_sum(const Eigen::Ref<const Eigen::MatrixXd>& g, double rate) const {
    Mat7 C = Mat7::Zero();
    Theta s = Theta::Zero();
    long long blk = held_index(0, rate, opt_.rate);
    for (Eigen::Index k = 0; k < n_; ++k) {
      const long long b = held_index(k, rate, opt_.rate);
      if (b != blk) {
        C.noalias() += s * s.transpose();
        s.setZero();
        blk = b;
      }
      s += g.row(k).transpose();
    }
    C.noalias() += s * s.transpose();
    return C;
  }

  // The predicted covariance of set m (0: LS, 1: FMLS), by source and in all.
  void predict_set(int m, PrecisionResult& res) const {
    const RegressionModel model = m == 0 ? RegressionModel::Standard : RegressionModel::Filtered;
    const Regression reg(signals_, model, opt_.window, opt_.lambda, opt_.gd_variant);
    const std::string what = fmt::format("{} regression along {}", to_string(model), res.trajectory);
    PredictedSet& out = res.sets[static_cast<size_t>(m)];
    out.name = m == 0 ? "LS" : "FMLS";
    out.variance_by_source = Eigen::Matrix<double, 7, Eigen::Dynamic>::Zero(7, 6);
    Mat7 cov = Mat7::Zero();
    if (flown_.empty()) {
      reference_covariance(model, reg, what, out, cov);
      out.linear_std_error = cov.diagonal().cwiseSqrt();
    } else {
      flown_covariance(model, m, what, out, cov);
    }
    out.covariance = cov;
    out.std_error = cov.diagonal().cwiseSqrt();
    out.relative = out.std_error.cwiseQuotient(determinedness_scale(theta_));
    if (res.model_error)
      out.realistic_std_error = (out.std_error.cwiseAbs2() +
                                 res.model_error->cwiseProduct(determinedness_scale(theta_)).cwiseAbs2())
                                    .cwiseSqrt();
    if (m == 0) {
      res.samples = reg.size();
      res.window = reg.window();
    }
  }

  // The information along the reference itself.
  void reference_covariance(RegressionModel model, const Regression& reg, const std::string& what, PredictedSet& out,
                            Mat7& cov) const {
    const RegressorSeries S = regressor_series(reg, n_, theta_, Vec4::Ones());
    const Mat7 P = information_inverse(S.A, &out.condition, what);
    const auto by = linear_part(model, S, P);
    for (int src = 0; src < 5; ++src) {
      cov += by[static_cast<size_t>(src)];
      out.variance_by_source.col(src) = by[static_cast<size_t>(src)].diagonal();
    }
  }

  // Each flight's own regressor series: the vehicle flies the plan plus the jitter
  // its sensors' noise drives through the controller, and that jitter excites the
  // regression too (for a small vehicle, or an axis the plan barely moves, it adds
  // much of the information). The estimate of a flight uses that flight's
  // information, so the covariances are averaged over the flights.
  // Per flight on every core; the sums below run in flight order, so the result is
  // the same bits whatever the thread count.
  void flown_covariance(RegressionModel model, int m, const std::string& what, PredictedSet& out, Mat7& cov) const {
    const int nf = static_cast<int>(flown_.size());
    std::vector<RegressorSeries> S(flown_.size());
    detail::parallel_for(nf, 0, [&](int f) {
      const auto fs = static_cast<size_t>(f);
      S[fs] = regressor_series(Regression(flown_[fs], model, opt_.window, opt_.lambda, opt_.gd_variant), n_, theta_,
                               flown_w2_[fs][static_cast<size_t>(m)]);
    });
    Mat7 A_mean = Mat7::Zero();
    for (size_t f = 0; f < S.size(); ++f) A_mean += S[f].A / static_cast<double>(flown_.size());
    information_inverse(A_mean, &out.condition, what + " (as flown)");
    std::vector<Mat7> P(S.size());
    std::vector<Eigen::MatrixXd> psi(S.size());
    Eigen::MatrixXd psi_mean;
    residual_influence(S, what, P, psi, psi_mean);
    std::vector<std::array<Mat7, 5>> by_flight(S.size());
    std::vector<Mat7> cl_flight(S.size());
    detail::parallel_for(nf, 0, [&](int fi) {
      const auto f = static_cast<size_t>(fi);
      by_flight[f] = linear_part(model, S[f], P[f]);
      std::vector<double> d;
      d.reserve(static_cast<size_t>(7 * (S[f].end - S[f].begin)));
      for (Eigen::Index k = S[f].begin; k < S[f].end; ++k)
        for (int j = 0; j < 7; ++j) d.push_back(psi[f](k, j) - psi_mean(k, j));
      cl_flight[f] = long_run_covariance(d, 7, UncertaintyOptions{}).covariance;
    });
    Mat7 C_cl = Mat7::Zero();
    for (size_t f = 0; f < S.size(); ++f) {
      for (int src = 0; src < 5; ++src) {
        const Mat7 C = by_flight[f][static_cast<size_t>(src)] / static_cast<double>(S.size());
        cov += C;
        out.variance_by_source.col(src) += C.diagonal();
      }
      C_cl += cl_flight[f];
    }
    // sum_f (d_f d_f^T) / (F - 1) estimates one flight's covariance (d_f = e_f - mean).
    C_cl /= static_cast<double>(std::max<size_t>(1, S.size() - 1));
    out.variance_by_source.col(5) = C_cl.diagonal();
    out.closed_loop_std_error = C_cl.diagonal().cwiseSqrt();
    out.linear_std_error = cov.diagonal().cwiseSqrt();
    cov += C_cl;
  }

  // Closed loop: the influence P_f Gamma_f,k^T e_f,k of each flight's residual on its
  // true states, less its mean over the flights at the same sample (which removes
  // what every flight shares: the processing's deterministic error and the mean of
  // the second-order terms, a bias); its HAC covariance (the uncertainty code's
  // estimator, docs/uncertainty.md) is the second-order spread of the jitter.
  void residual_influence(const std::vector<RegressorSeries>& S, const std::string& what, std::vector<Mat7>& P,
                          std::vector<Eigen::MatrixXd>& psi, Eigen::MatrixXd& psi_mean) const {
    psi_mean = Eigen::MatrixXd::Zero(n_, 7);
    for (size_t f = 0; f < S.size(); ++f) {
      P[f] = information_inverse(S[f].A, nullptr, what + " (as flown)");
      psi[f] = Eigen::MatrixXd::Zero(n_, 7);
      for (Eigen::Index k = S[f].begin; k < S[f].end; ++k)
        psi[f].row(k) = (P[f] * S[f].G[static_cast<size_t>(k)].transpose() * S[f].w2.asDiagonal() *
                         S[f].e.row(k).transpose()).transpose();
      psi_mean += psi[f] / static_cast<double>(S.size());
    }
  }

  const Trajectory& traj_;
  const PrecisionOptions& opt_;
  const double T_;        // s, the log's sample period
  const Eigen::Index n_;  // samples of the planned flight
  const Theta theta_;     // the true parameters
  // f_D's recursion s_k = alpha s_{k-1} + (1 - alpha) x_{k-1} and g_D's factor c (eqs. 35-36).
  const double alpha_, one_minus_, c_;
  FlightLog log_;                // noise-free log of the reference
  std::vector<Reference> ref_;   // its nominal states
  Eigen::Matrix<double, Eigen::Dynamic, 4> wrench_;
  double f_force_ = 0.0, f_moment_ = 0.0;  // Hz, the pre-filter cutoffs of the force and moment rows
  signal::LowpassOptions lp_force_, lp_moment_;
  bool two_cutoffs_ = false;
  std::shared_ptr<const RegressionSignals> signals_;  // the reference's processed signals
  Eigen::Matrix4d Ma_;
  Eigen::Matrix<double, 4, 7> Mb_;
  std::vector<StateJacobian> J_;
  std::vector<std::pair<int, int>> j_nonzero_;  // (s, i), by i then s
  bool rotor_mode_ = false;
  Eigen::MatrixXd dF_dw_;
  std::vector<std::shared_ptr<const RegressionSignals>> flown_;
  std::vector<std::array<Vec4, 2>> flown_w2_;  // squared row weights of LS and FMLS on each flight's log
};

}  // namespace

PrecisionResult predict_precision(const Trajectory& traj, const PrecisionOptions& opt) {
  opt.validate();
  return PrecisionRun(traj, opt).run();
}

std::string format_precision(const PrecisionResult& r) {
  const bool real = r.model_error.has_value();
  std::string s = fmt::format("predicted precision ({} regression rows, window {}; regression {}):\n", r.samples,
                              r.window.to_string(), r.regression);
  s += "  noise only: the sensors' noise carried through the regression; the model's own error is not in these\n";
  s += fmt::format("  {:<5} {:>12} {:>13} {:>8} {:>13} {:>8}{}  {}\n", "param", "value", "LS std err", "LS %",
                   "FMLS std err", "FMLS %", real ? fmt::format(" {:>11}", "realistic %") : "", "main noise source (LS)");
  const Theta scale = determinedness_scale(r.truth);
  for (int j = 0; j < 7; ++j) {
    Eigen::Index src = 0;
    r.sets[0].variance_by_source.row(j).maxCoeff(&src);
    const double total = r.sets[0].variance_by_source.row(j).sum();
    const double share = total > 0.0 ? r.sets[0].variance_by_source(j, src) / total : 0.0;
    s += fmt::format("  {:<5} {:>12.5g} {:>13.3e} {:>8.3f} {:>13.3e} {:>8.3f}{}  {} ({:.0f}% of the variance)\n",
                     kThetaNames[static_cast<size_t>(j)], r.truth(j), r.sets[0].std_error(j),
                     100.0 * r.sets[0].relative(j), r.sets[1].std_error(j), 100.0 * r.sets[1].relative(j),
                     real ? fmt::format(" {:>11.2f}", 100.0 * r.sets[0].realistic_std_error(j) / scale(j)) : "",
                     r.sources[static_cast<size_t>(src)], 100.0 * share);
  }
  s += fmt::format("  units: kg for m, kg m^2 for the inertia; % of |m| for m and of the mean principal moment "
                   "({:.4g} kg m^2) for every inertia entry, as identify's rel %\n",
                   scale(1));
  if (real)
    s += fmt::format("  realistic %: with the model error of a {} (m {:g} %, Ixx and Iyy {:g} %, Izz {:g} %, "
                     "products {:g} %; docs/design.md, \"Realistic precision\"): the scatter to expect over real flights\n",
                     r.model_error_class, 100.0 * (*r.model_error)(0), 100.0 * (*r.model_error)(1),
                     100.0 * (*r.model_error)(6), 100.0 * (*r.model_error)(2));
  else
    s += "  realistic %: none for a logged wrench (its model error depends on how it was measured or simulated)\n";
  const double worst = std::max(r.sets[0].relative.maxCoeff(), 0.0);
  Eigen::Index jw = 0;
  r.sets[0].relative.maxCoeff(&jw);
  s += fmt::format("  worst relative std error (LS, noise only): {} at {:.3f}%\n", kThetaNames[static_cast<size_t>(jw)],
                   100.0 * worst);
  return s;
}

nlohmann::ordered_json to_json(const PrecisionResult& r) {
  nlohmann::ordered_json j;
  j["trajectory"] = r.trajectory;
  j["regression"] = r.regression;
  j["samples"] = r.samples;
  j["window"] = {r.window.t0, r.window.t1};
  j["sources"] = r.sources;
  j["noise_only"] = "std_error and relative: the sensors' noise alone; realistic_std_error adds model_error";
  if (r.model_error) {
    j["model_error"]["class"] = r.model_error_class;
    for (int p = 0; p < 7; ++p) j["model_error"]["relative"][kThetaNames[static_cast<size_t>(p)]] = (*r.model_error)(p);
  } else {
    j["model_error"] = nullptr;
  }
  for (const auto& set : r.sets) {
    nlohmann::ordered_json s;
    for (int p = 0; p < 7; ++p) {
      nlohmann::ordered_json e;
      e["std_error"] = set.std_error(p);
      e["relative"] = set.relative(p);
      e["realistic_std_error"] = finite_or_null(set.realistic_std_error(p));
      nlohmann::ordered_json by;
      for (size_t k = 0; k < r.sources.size(); ++k)
        by[r.sources[k]] = std::sqrt(std::max(0.0, set.variance_by_source(p, static_cast<Eigen::Index>(k))));
      e["std_error_by_source"] = by;
      s[kThetaNames[static_cast<size_t>(p)]] = e;
    }
    s["condition"] = set.condition;
    j["sets"][set.name] = s;
  }
  return j;
}

}  // namespace quadid
