// The real-flight regression (include/quadid/extended.hpp): the paper's rows
// with two pre-filter cutoffs (force and moment rows), optional extra terms,
// row weighting, and least squares by streaming QR.
#include "quadid/extended.hpp"

#include "quadid/qr_least_squares.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <numbers>
#include <stdexcept>

namespace quadid {
namespace {

// Columns of the raw signal matrix. "a" signals enter differentiated (eq. 33
// in the standard model, g_D in the filtered one), "b" signals as they are
// (f_D in the filtered model): every column of the regressor is d/dt a + b.
enum : int {
  // a signals
  A_W = 0, A_P, A_Q, A_R, A_OMEGA_R, kNumA,
};
enum : int {
  // b signals (index into the b block)
  B_C = 0, B_PQ, B_PR, B_QR, B_PP, B_QQ, B_RR,  // Phi_b signals (eq. 13)
  B_FZ, B_TX, B_TY, B_TZ,                       // outputs
  B_ONE, B_U, B_V, B_W, B_P, B_Q, B_R, B_QOM, B_POM,
  kNumB,
};

struct Term {
  const char* name;
  // Column of G for this parameter, given d/dt a (da) and b at one sample.
  Vec4 (*column)(const double* da, const double* b);
};

Vec4 v4(double a, double b, double c, double d) { return Vec4(a, b, c, d); }

// Extra columns. Signs follow the rows of the header: terms moved to the
// left-hand side of "= s tau".
const Term kOffsetTerms[] = {
    {"offset_x", [](const double*, const double*) { return v4(0, -1, 0, 0); }},
    {"offset_y", [](const double*, const double*) { return v4(0, 0, -1, 0); }},
    {"offset_z", [](const double*, const double*) { return v4(0, 0, 0, -1); }},
};
// -K (e_z x v_b) = -K (-v, u, 0): moved left, +K_x (-v) ... as K_x * (-v) on row x.
const Term kFlapTerms[] = {
    {"flapping_x", [](const double*, const double* b) { return v4(0, -b[B_V], 0, 0); }},
    {"flapping_y", [](const double*, const double* b) { return v4(0, 0, b[B_U], 0); }},
};
const Term kDampTerms[] = {
    {"damping_x", [](const double*, const double* b) { return v4(0, b[B_P], 0, 0); }},
    {"damping_y", [](const double*, const double* b) { return v4(0, 0, b[B_Q], 0); }},
    {"damping_z", [](const double*, const double* b) { return v4(0, 0, 0, b[B_R]); }},
};
// J_r (Omega_r_dot e_z + w x e_z Omega_r), w x e_z = (q, -p, 0).
const Term kRotorTerms[] = {
    {"rotor_inertia",
     [](const double* da, const double* b) { return v4(0, b[B_QOM], -b[B_POM], da[A_OMEGA_R]); }},
};
const Term kDragTerms[] = {
    {"drag_z", [](const double*, const double* b) { return v4(b[B_W], 0, 0, 0); }},
};

std::vector<Term> active_terms(const ModelTerms& t) {
  std::vector<Term> v;
  auto add = [&](const auto& arr) { v.insert(v.end(), std::begin(arr), std::end(arr)); };
  if (t.torque_offsets) add(kOffsetTerms);
  if (t.flapping) add(kFlapTerms);
  if (t.rate_damping) add(kDampTerms);
  if (t.rotor_inertia) add(kRotorTerms);
  if (t.force_drag) add(kDragTerms);
  return v;
}

// The regressor of one sample: G (4 x P) and Y (4) with G x = Y.
struct Assembler {
  const ModelTerms& terms;
  const std::vector<Term>& extra;
  Eigen::Index P;
  void operator()(const double* da, const double* b, Eigen::Matrix<double, 4, Eigen::Dynamic>& G, Vec4& Y) const {
    Eigen::Matrix<double, 7, 1> bb;
    for (int i = 0; i < 7; ++i) bb(i) = b[i];
    const Regressor4x7 Gamma = assemble_regressor(Vec4(da[A_W], da[A_P], da[A_Q], da[A_R]), bb);
    const Vec4 F(b[B_FZ], b[B_TX], b[B_TY], b[B_TZ]);
    if (terms.known_mass) {
      // m0 Gamma_m + Gamma_I I + E x_e - s F = 0
      G.col(0) = -F;
      G.middleCols<6>(1) = Gamma.rightCols<6>();
      Y = -*terms.known_mass * Gamma.col(0);
    } else {
      G.leftCols<7>() = Gamma;
      Y = F;
    }
    for (size_t j = 0; j < extra.size(); ++j) G.col(7 + static_cast<Eigen::Index>(j)) = extra[j].column(da, b);
  }
};

double rms(const Eigen::Ref<const Eigen::VectorXd>& x) {
  return x.size() ? std::sqrt(x.squaredNorm() / static_cast<double>(x.size())) : 0.0;
}

}  // namespace

ModelTerms ModelTerms::real_flight(bool have_rotor_speeds) {
  ModelTerms t;
  t.torque_offsets = true;
  t.flapping = true;
  t.rotor_inertia = have_rotor_speeds;
  t.weight_rows = true;
  return t;
}

void ModelTerms::validate() const {
  if (known_mass && !(*known_mass > 0.0 && std::isfinite(*known_mass)))
    throw std::invalid_argument(fmt::format("--known-mass {}: must be a positive mass in kg", *known_mass));
}

void ExtendedOptions::validate() const {
  processing.validate();
  terms.validate();
  for (auto [name, f] : {std::pair{"--cutoff-force", force_cutoff_hz}, std::pair{"--cutoff-moment", moment_cutoff_hz}})
    if (!(f > 0.0) || !std::isfinite(f)) throw std::invalid_argument(fmt::format("{} {}: must be a positive frequency in Hz", name, f));
  if (!(lambda > 0.0) || !std::isfinite(lambda))
    throw std::invalid_argument(fmt::format("--lambda {}: must be a positive bandwidth in rad/s", lambda));
  ls.validate();
  reference.validate("reference parameter set");
}

ExtendedResult identify_extended(const FlightLog& log, const ExtendedOptions& opt) {
  opt.validate();
  ExtendedResult res;
  const ModelTerms& terms = opt.terms;

  // Two processings: force row and moment rows, each at its own cutoff.
  ProcessingOptions pf = opt.processing, pm = opt.processing;
  pf.lowpass.cutoff_hz = opt.force_cutoff_hz;
  pm.lowpass.cutoff_hz = opt.moment_cutoff_hz;
  pm.keep_body_velocity = terms.flapping;
  const auto sf = process_log(log, pf, &res.force_processing);
  const auto sm = process_log(log, pm, &res.moment_processing);
  const Eigen::Index n = sf->size();
  const double T = sf->T, fs = 1.0 / T;

  Eigen::VectorXd omega_r = Eigen::VectorXd::Zero(n);
  if (terms.rotor_inertia) {
    if (!log.has(kRotorMomentumColumn))
      throw InputError(fmt::format(
          "the rotor-inertia term needs the rotor speeds (log column '{}', made from the rotor columns by --vehicle); "
          "turn it off with --no-rotor-inertia",
          kRotorMomentumColumn));
    omega_r = signal::zero_phase_lowpass(log.column(kRotorMomentumColumn), fs, pm.lowpass);
  }

  // The raw a and b signals.
  Eigen::MatrixXd a(n, kNumA), b(n, kNumB);
  const auto& XF = sf->x;
  const auto& XM = sm->x;
  a.col(A_W) = XF.col(0);
  a.middleCols<3>(A_P) = XM.middleCols<3>(1);
  a.col(A_OMEGA_R) = omega_r;
  b.col(B_C) = XF.col(4);
  b.middleCols<6>(B_PQ) = XM.middleCols<6>(5);
  b.col(B_FZ) = XF.col(11);
  b.middleCols<3>(B_TX) = XM.middleCols<3>(12);
  b.col(B_ONE).setOnes();
  if (terms.flapping) b.middleCols<2>(B_U) = sm->uv;
  else b.middleCols<2>(B_U).setZero();
  b.col(B_W) = XF.col(0);
  b.middleCols<3>(B_P) = XM.middleCols<3>(1);
  b.col(B_QOM) = XM.col(2).cwiseProduct(omega_r);
  b.col(B_POM) = XM.col(1).cwiseProduct(omega_r);

  const std::vector<Term> extra = active_terms(terms);
  const Eigen::Index P = 7 + static_cast<Eigen::Index>(extra.size());
  std::vector<std::string> names;
  names.emplace_back(terms.known_mass ? "thrust_scale" : "m");
  for (int j = 1; j < 7; ++j) names.emplace_back(kThetaNames[static_cast<size_t>(j)]);
  for (const auto& t : extra) names.emplace_back(t.name);

  Eigen::VectorXd prior = Eigen::VectorXd::Zero(P);
  prior.head<7>() = opt.reference.theta();
  if (terms.known_mass) prior(0) = 1.0;

  const Assembler assemble{terms, extra, P};
  const RegressionModel models[2] = {RegressionModel::Standard, RegressionModel::Filtered};
  for (int mi = 0; mi < 2; ++mi) {
    const RegressionModel model = models[mi];
    // The window: clear of both processings' edges (and f_D's start).
    const Regression rf(sf, model, opt.window, opt.lambda, opt.gd_variant);
    const Regression rm(sm, model, opt.window, opt.lambda, opt.gd_variant);
    const Eigen::Index k0 = std::max(rf.begin(), rm.begin()), k1 = std::min(rf.end(), rm.end());
    if (k1 - k0 < 8)
      throw InputError(fmt::format("window {}: fewer than 8 samples clear of the pre-filters' edges", opt.window.to_string()));
    if (mi == 0) {
      res.window = {static_cast<double>(k0) * T, static_cast<double>(k1 - 1) * T};
      res.window_samples = k1 - k0;
    }
    Eigen::MatrixXd da, bv;
    if (model == RegressionModel::Standard) {
      da = signal::central_difference(a, T);  // eq. (33)
      bv = b;
    } else {
      da = signal::filter_gD(a, opt.lambda, T, opt.gd_variant);  // eq. (36)
      bv = signal::filter_fD(b, opt.lambda, T);                  // eq. (35)
    }
    // Row-major copies so that one sample's signals are contiguous.
    const Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor> DA = da, BV = bv;

    Eigen::Matrix<double, 4, Eigen::Dynamic> G(4, P);
    Vec4 Y;
    // Pass 0 weights: the inverse RMS of each row's output (N, N m), so that
    // the rows count alike whatever the vehicle's size.
    Vec4 w = Vec4::Ones();
    if (terms.weight_rows) {
      for (int r = 0; r < 4; ++r) {
        const double s = rms(bv.col(B_FZ + r).segment(k0, k1 - k0));
        w(r) = s > 0.0 ? 1.0 / s : 1.0;
      }
    }
    QRSolution sol;
    Vec4 res_rms = Vec4::Zero();
    const int passes = terms.weight_rows ? 3 : 1;
    for (int pass = 0; pass < passes; ++pass) {
      StreamingQR qr(P);
      for (Eigen::Index k = k0; k < k1; ++k) {
        assemble(DA.row(k).data(), BV.row(k).data(), G, Y);
        for (int r = 0; r < 4; ++r) qr.add_row(w(r) * G.row(r).transpose(), w(r) * Y(r));
      }
      sol = solve_qr(qr.factor(), qr.rows(), prior, opt.ls.rank_tolerance);
      // Unweighted residual RMS per row, for the next pass's weights and the report.
      Vec4 ss = Vec4::Zero();
      for (Eigen::Index k = k0; k < k1; ++k) {
        assemble(DA.row(k).data(), BV.row(k).data(), G, Y);
        ss += (G * sol.x - Y).cwiseAbs2();
      }
      res_rms = (ss / static_cast<double>(k1 - k0)).cwiseSqrt();
      if (pass + 1 < passes) {
        for (int r = 0; r < 4; ++r) {
          const double floor = 1e-9 * rms(bv.col(B_FZ + r).segment(k0, k1 - k0)) + 1e-300;
          w(r) = 1.0 / std::max(res_rms(r), floor);
        }
      }
    }

    ExtendedEstimate e;
    e.name = mi == 0 ? "LS" : "FMLS";
    e.model = model;
    e.names = names;
    e.value = sol.x;
    // Residuals of filtered data are correlated over ~fs / (2 f) samples: the
    // standard errors grow by the square root of that length (as for the
    // paper's model in identify.cpp).
    const double f3 = std::min(res.force_processing.filter_f3db, res.moment_processing.filter_f3db);
    double f = f3;
    if (model == RegressionModel::Filtered) f = std::min(f, opt.lambda / (2.0 * std::numbers::pi));
    const double corr = std::max(1.0, fs / (2.0 * f));
    e.std_error = (sol.covariance.diagonal() * corr).cwiseSqrt();
    e.theta = sol.x.head<7>();
    if (terms.known_mass) e.theta(0) = *terms.known_mass;
    for (Eigen::Index j = 7; j < P; ++j) e.extra.emplace_back(names[static_cast<size_t>(j)], sol.x(j));
    if (terms.known_mass) e.extra.insert(e.extra.begin(), {"thrust_scale", sol.x(0)});
    e.row_weight = w;
    e.residual_rms = res_rms;
    e.condition = sol.condition;
    for (auto j : sol.unidentifiable) e.unidentifiable.push_back(names[static_cast<size_t>(j)]);
    // Poorly determined: the rigid-body parameters against their scale (the
    // mass, or the mean principal moment), the thrust scale against 1.
    const double iscale = (std::abs(e.theta(1)) + std::abs(e.theta(4)) + std::abs(e.theta(6))) / 3.0;
    for (Eigen::Index j = 0; j < 7; ++j) {
      const double scale = j == 0 ? std::abs(sol.x(0)) : iscale;
      if (!(e.std_error(j) <= opt.ls.poor_fraction * scale)) e.poorly_determined.push_back(names[static_cast<size_t>(j)]);
    }
    res.estimates[static_cast<size_t>(mi)] = std::move(e);
  }
  return res;
}

}  // namespace quadid
