// Tests of quadid::signal against SciPy golden data (tests/data/signal, made by
// gen_signal_golden.py) and against closed-form properties.
//
// Tolerances. Golden comparisons use 1e-9: relative for coefficients, absolute
// for the O(1) filtered signals. Both sides compute in IEEE double (unit roundoff
// 1.1e-16) with the same algorithms, but in different operation orders (LAPACK
// solve vs a recurrence for lfilter_zi, DF2T vs convolution for FIR). A recursive
// filter of order 4-8 with poles at |z| ~ 0.95-0.99 remembers ~100 samples and
// its companion-form state amplifies rounding by up to ~1e4 over the ~2000 steps
// of a forward-backward pass, so differences up to ~1e-10 are expected (scipy's
// own filtfilt of the 4 Hz case is 1.2e-10 from an exact-arithmetic result);
// 1e-9 keeps a margin and is still far below any algorithmic mistake (a
// different padding or initial state changes edge samples by 1e-3 or more).
#include "quadid/signal.hpp"

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include <cmath>
#include <fstream>
#include <functional>
#include <map>
#include <random>
#include <numbers>
#include <sstream>
#include <string>

namespace sig = quadid::signal;
using Eigen::MatrixXd;
using Eigen::VectorXd;

namespace {

const std::string kDir = std::string(QUADID_TEST_DATA) + "/signal/";
constexpr double kGoldenTol = 1e-9;
constexpr double kPi = std::numbers::pi;

const nlohmann::json& coeffs() {
  static const nlohmann::json j = [] {
    std::ifstream f(kDir + "signal_coeffs.json");
    if (!f) throw std::runtime_error("cannot open " + kDir + "signal_coeffs.json");
    return nlohmann::json::parse(f);
  }();
  return j;
}

const std::map<std::string, VectorXd>& golden() {
  static const std::map<std::string, VectorXd> cols = [] {
    std::ifstream f(kDir + "signal_golden.csv");
    if (!f) throw std::runtime_error("cannot open " + kDir + "signal_golden.csv");
    std::string line, cell;
    std::getline(f, line);
    std::vector<std::string> names;
    for (std::stringstream ss(line); std::getline(ss, cell, ',');) names.push_back(cell);
    std::vector<std::vector<double>> data(names.size());
    while (std::getline(f, line)) {
      std::size_t i = 0;
      for (std::stringstream ss(line); std::getline(ss, cell, ','); ++i) data.at(i).push_back(std::stod(cell));
    }
    std::map<std::string, VectorXd> out;
    for (std::size_t i = 0; i < names.size(); ++i)
      out[names[i]] = Eigen::Map<VectorXd>(data[i].data(), static_cast<Eigen::Index>(data[i].size()));
    return out;
  }();
  return cols;
}

const VectorXd& col(const std::string& name) {
  const auto it = golden().find(name);
  if (it == golden().end()) throw std::runtime_error("golden column missing: " + name);
  return it->second;
}

sig::TransferFunction tf_of(const nlohmann::json& f) {
  return {f.at("b").get<std::vector<double>>(), f.at("a").get<std::vector<double>>()};
}

double max_rel_diff(const std::vector<double>& got, const std::vector<double>& want) {
  EXPECT_EQ(got.size(), want.size());
  double m = 0.0;
  for (std::size_t i = 0; i < std::min(got.size(), want.size()); ++i)
    m = std::max(m, std::abs(got[i] - want[i]) / std::abs(want[i]));
  return m;
}

// Expects `fn` to throw std::invalid_argument whose message contains every `parts`.
void expect_invalid(const std::function<void()>& fn, std::initializer_list<std::string> parts) {
  try {
    fn();
    ADD_FAILURE() << "no exception thrown";
  } catch (const std::invalid_argument& e) {
    const std::string msg = e.what();
    for (const auto& p : parts) EXPECT_NE(msg.find(p), std::string::npos) << "'" << p << "' not in: " << msg;
  }
}

VectorXd sampled(int n, double fs, const std::function<double(double)>& f) {
  VectorXd x(n);
  for (int i = 0; i < n; ++i) x(i) = f(i / fs);
  return x;
}

}  // namespace

// ---------------------------------------------------------------- SciPy golden

TEST(SignalGolden, ButterCoefficientsMatchScipy) {
  int n = 0;
  for (const auto& [name, f] : coeffs().at("filters").items()) {
    if (f.at("kind") != "butter") continue;
    const auto tf = sig::butter_lowpass(f.at("order"), f.at("cutoff_hz"), f.at("fs_hz"));
    EXPECT_LT(max_rel_diff(tf.b, f.at("b")), kGoldenTol) << name;
    EXPECT_LT(max_rel_diff(tf.a, f.at("a")), kGoldenTol) << name;
    ++n;
  }
  EXPECT_EQ(n, 6);
}

TEST(SignalGolden, FirBlackmanHarrisTapsMatchScipyFirwin) {
  int n = 0;
  for (const auto& [name, f] : coeffs().at("filters").items()) {
    if (f.at("kind") != "fir") continue;
    const auto h = sig::fir_lowpass_blackmanharris(f.at("taps"), f.at("cutoff_hz"), f.at("fs_hz"));
    EXPECT_LT(max_rel_diff(h, f.at("b")), kGoldenTol) << name;
    ++n;
  }
  EXPECT_EQ(n, 6);
}

TEST(SignalGolden, LfilterZiMatchesScipyAndExactRational) {
  int n = 0;
  for (const auto& [name, f] : coeffs().at("filters").items()) {
    if (!f.contains("zi")) continue;
    const VectorXd zi = sig::lfilter_zi(tf_of(f));
    const auto want = f.at("zi").get<std::vector<double>>();
    const auto exact = f.at("zi_exact").get<std::vector<double>>();
    ASSERT_EQ(zi.size(), static_cast<Eigen::Index>(want.size())) << name;
    for (Eigen::Index i = 0; i < zi.size(); ++i) {
      // O(1) entries. scipy solves (I - A) zi = B by LAPACK, which for the 4 Hz
      // filter (sum(a) = 6e-6) is itself off by 1.9e-10; hence 1e-9 against scipy.
      EXPECT_NEAR(zi(i), want[i], kGoldenTol) << name << " " << i;
      // Against the exact rational solution for the same doubles, our recurrence
      // with compensated sums is good to a few ulps.
      EXPECT_NEAR(zi(i), exact[i], 1e-14) << name << " " << i;
    }
    ++n;
  }
  EXPECT_EQ(n, 9);
}

TEST(SignalGolden, LfilterFromRestMatchesScipy) {
  const VectorXd y = sig::lfilter(tf_of(coeffs().at("filters").at("butter_o4_fc4_fs500")), col("x"));
  EXPECT_LT((y - col("lfilter_butter_o4_fc4_fs500")).cwiseAbs().maxCoeff(), kGoldenTol);
}

TEST(SignalGolden, FiltfiltMatchesScipyWithMatlabPadding) {
  const VectorXd& x = col("x");
  for (const auto& name : coeffs().at("filtfilt_cases")) {
    const auto& f = coeffs().at("filters").at(name.get<std::string>());
    const VectorXd& want = col("filtfilt_" + name.get<std::string>());
    // (1) scipy's own coefficients: checks filtfilt alone.
    const VectorXd y1 = sig::filtfilt(tf_of(f), x);
    EXPECT_LT((y1 - want).cwiseAbs().maxCoeff(), kGoldenTol) << name;
    // (2) our designed coefficients: design + filtfilt end to end. Our
    // coefficients differ from scipy's in the last bit (tan, exp and complex
    // products rounded differently, <= 6e-16 relative), and a narrow low-pass
    // amplifies that by the condition number of its DC gain, kappa =
    // sum|a| / |sum a| (2.7e6 for 4 Hz at 500 Hz; measured 5.8e-10 here). So the
    // tolerance is 1e-9 or 4 eps kappa max|x|, whichever is larger.
    const auto a = f.at("a").get<std::vector<double>>();
    double sa = 0.0, sabs = 0.0;
    for (double v : a) sa += v, sabs += std::abs(v);
    const double tol2 = std::max(kGoldenTol, 4 * 2.22e-16 * (sabs / std::abs(sa)) * x.cwiseAbs().maxCoeff());
    const VectorXd y2 = f.at("kind") == "butter"
        ? sig::filtfilt(sig::butter_lowpass(f.at("order"), f.at("cutoff_hz"), f.at("fs_hz")), x)
        : sig::filtfilt(sig::fir_lowpass_blackmanharris(f.at("taps"), f.at("cutoff_hz"), f.at("fs_hz")), x);
    EXPECT_LT((y2 - want).cwiseAbs().maxCoeff(), tol2) << name;
  }
}

TEST(SignalGolden, FirstOrderFiltersMatchScipyLfilter) {
  const auto& F = coeffs().at("filters");
  const double lam = F.at("fD").at("lambda"), T = F.at("fD").at("T");
  const std::vector<std::pair<std::string, sig::TransferFunction>> tfs = {
      {"fD", sig::fD_tf(lam, T)},
      {"gD_printed", sig::gD_tf(lam, T, sig::GdVariant::Printed)},
      {"gD_consistent", sig::gD_tf(lam, T, sig::GdVariant::Consistent)}};
  for (const auto& [name, tf] : tfs) {
    const auto b = F.at(name).at("b").get<std::vector<double>>();
    const auto a = F.at(name).at("a").get<std::vector<double>>();
    ASSERT_EQ(tf.b.size(), 2u);
    ASSERT_EQ(tf.a.size(), 2u);
    EXPECT_NEAR(tf.b[0], b[0], kGoldenTol * std::abs(b[1])) << name;  // fD's b0 is 0
    EXPECT_LT(std::abs(tf.b[1] - b[1]), kGoldenTol * std::abs(b[1])) << name;
    EXPECT_EQ(tf.a[0], 1.0);
    EXPECT_LT(std::abs(tf.a[1] - a[1]), kGoldenTol * std::abs(a[1])) << name;
  }
  const MatrixXd X = col("x");
  EXPECT_LT((sig::filter_fD(X, lam, T).col(0) - col("lfilter_fD")).cwiseAbs().maxCoeff(), kGoldenTol);
  // g_D outputs are derivatives, O(100) for this noisy x: 1e-9 relative to that scale.
  const double gs = col("lfilter_gD_printed").cwiseAbs().maxCoeff();
  EXPECT_LT((sig::filter_gD(X, lam, T, sig::GdVariant::Printed).col(0) - col("lfilter_gD_printed"))
                .cwiseAbs().maxCoeff(), kGoldenTol * gs);
  EXPECT_LT((sig::filter_gD(X, lam, T).col(0) - col("lfilter_gD_consistent")).cwiseAbs().maxCoeff(),
            kGoldenTol * gs);
}

// ----------------------------------------------------------- closed-form checks

TEST(SignalButter, MinusThreeDbAtCutoffUnityDcZeroAtNyquistMonotone) {
  struct Case { int order; double fc, fs; };
  for (const Case c : {Case{1, 10, 500}, Case{2, 5, 500}, Case{4, 4, 500}, Case{4, 100, 500},
                       Case{6, 20, 500}, Case{8, 30, 500}, Case{3, 10, 100}, Case{5, 240, 500}}) {
    const auto tf = sig::butter_lowpass(c.order, c.fc, c.fs);
    ASSERT_EQ(tf.b.size(), static_cast<std::size_t>(c.order + 1));
    ASSERT_EQ(tf.a.size(), static_cast<std::size_t>(c.order + 1));
    EXPECT_EQ(tf.a[0], 1.0);
    // Prewarping makes |H| = 1/sqrt(2) exactly at the cutoff (-3.0103 dB).
    EXPECT_NEAR(std::abs(sig::frequency_response(tf, c.fc, c.fs)), 1.0 / std::sqrt(2.0), 1e-9)
        << c.order << " " << c.fc;
    EXPECT_NEAR(std::abs(sig::frequency_response(tf, 0.0, c.fs)), 1.0, 1e-9);
    EXPECT_NEAR(std::abs(sig::frequency_response(tf, c.fs / 2, c.fs)), 0.0, 1e-9);
    // Maximally flat: no ripple. Slack 1e-9: evaluating H near z = 1 divides by
    // sum(a) ~ 1e-6..1e-2, which costs up to ~1e-10 of the 1e-16 rounding.
    double prev = 2.0;
    for (int i = 0; i <= 200; ++i) {
      const double m = std::abs(sig::frequency_response(tf, i * (c.fs / 2) / 200.0, c.fs));
      EXPECT_LE(m, prev + 1e-9) << c.order << " " << c.fc << " " << i;
      prev = m;
    }
  }
}

TEST(SignalFir, BlackmanHarrisSymmetricUnityDcAndWindowShape) {
  const auto h = sig::fir_lowpass_blackmanharris(31, 11.0, 500.0);
  ASSERT_EQ(h.size(), 31u);
  double s = 0.0;
  for (std::size_t i = 0; i < h.size(); ++i) {
    // Symmetric up to rounding: like firwin, the window argument comes from
    // linspace(-pi, pi), which is not bit-symmetric.
    EXPECT_NEAR(h[i], h[h.size() - 1 - i], 1e-16) << i;
    s += h[i];
  }
  EXPECT_NEAR(s, 1.0, 1e-14);
  // With a vanishing cutoff the sinc is flat, so the taps are the 4-term
  // Blackman-Harris window itself, normalized: w[n] = a0 - a1 cos(2 pi n/(M-1))
  // + a2 cos(4 pi n/(M-1)) - a3 cos(6 pi n/(M-1)) (Harris 1978).
  const auto w = sig::fir_lowpass_blackmanharris(31, 1e-9, 500.0);
  std::vector<double> ref(31);
  double rs = 0.0;
  for (int n = 0; n < 31; ++n) {
    const double t = 2 * kPi * n / 30.0;
    ref[n] = 0.35875 - 0.48829 * std::cos(t) + 0.14128 * std::cos(2 * t) - 0.01168 * std::cos(3 * t);
    rs += ref[n];
  }
  for (int n = 0; n < 31; ++n) EXPECT_NEAR(w[n], ref[n] / rs, 1e-12) << n;
}

TEST(SignalFiltfilt, ZeroLagOnSinusoidBelowCutoff) {
  const double fs = 500.0, f0 = 1.0;
  const VectorXd x = sampled(5000, fs, [&](double t) { return std::sin(2 * kPi * f0 * t + 0.3); });
  const auto check = [&](const sig::TransferFunction& tf, const VectorXd& y, const char* what) {
    // Zero phase: y = |H(f0)|^2 x exactly in the interior (edge transients decay
    // as exp(-9.6 t) for the slowest 4 Hz Butterworth mode: < 1e-8 after 2 s).
    const double g2 = std::norm(sig::frequency_response(tf, f0, fs));
    EXPECT_LT((y.segment(1000, 3000) - g2 * x.segment(1000, 3000)).cwiseAbs().maxCoeff(), 1e-7) << what;
  };
  const auto bw = sig::butter_lowpass(4, 4.0, fs);
  check(bw, sig::filtfilt(bw, x), "butter");
  const auto fir = sig::fir_lowpass_blackmanharris(31, 4.0, fs);
  check({fir, {1.0}}, sig::filtfilt(fir, x), "fir");
  // The check can see a lag: a single forward pass of the Butterworth is late
  // by ~0.09 s at 1 Hz, which fails it by a wide margin.
  const VectorXd once = sig::lfilter(bw, x);
  const double g1 = std::abs(sig::frequency_response(bw, f0, fs));
  EXPECT_GT((once.segment(1000, 3000) - g1 * x.segment(1000, 3000)).cwiseAbs().maxCoeff(), 0.3);
}

TEST(SignalFiltfilt, ConstantPassesUnchangedAndMatrixIsColumnwise) {
  const auto tf = sig::butter_lowpass(4, 4.0, 500.0);
  const VectorXd c = VectorXd::Constant(100, -2.5);
  EXPECT_LT((sig::filtfilt(tf, c).array() + 2.5).abs().maxCoeff(), 1e-9);  // no edge transient
  const auto fir = sig::fir_lowpass_blackmanharris(31, 20.0, 500.0);
  EXPECT_LT((sig::filtfilt(fir, c).array() + 2.5).abs().maxCoeff(), 1e-12);

  MatrixXd X(700, 3);
  X.col(0) = col("x").head(700);
  X.col(1) = col("x").segment(900, 700);
  X.col(2) = VectorXd::LinSpaced(700, -1.0, 3.0);
  const MatrixXd Y = sig::filtfilt(tf, X);
  const MatrixXd Yf = sig::filtfilt(fir, X);
  for (int j = 0; j < 3; ++j) {
    EXPECT_EQ(Y.col(j), sig::filtfilt(tf, VectorXd(X.col(j)))) << j;
    EXPECT_EQ(Yf.col(j), sig::filtfilt(fir, X.col(j))) << j;  // expression overload
  }
}

TEST(SignalLowpass, FrontEndIsFiltfiltOfTheChosenDesign) {
  const MatrixXd X = col("x");
  const sig::LowpassOptions def;
  EXPECT_EQ(def.kind, sig::LowpassOptions::Kind::Butterworth);
  EXPECT_EQ(def.order, 4);
  EXPECT_EQ(def.cutoff_hz, 4.0);
  EXPECT_EQ(sig::zero_phase_lowpass(X, 500.0, def), sig::filtfilt(sig::butter_lowpass(4, 4.0, 500.0), X));
  // Own 4 Hz design vs scipy's: see FiltfiltMatchesScipyWithMatlabPadding for
  // why this one needs 4 eps kappa max|x| = 5e-9 rather than 1e-9.
  EXPECT_LT((sig::zero_phase_lowpass(X, 500.0).col(0) - col("filtfilt_butter_o4_fc4_fs500")).cwiseAbs().maxCoeff(),
            5e-9);
  sig::LowpassOptions fir;
  fir.kind = sig::LowpassOptions::Kind::FirBlackmanHarris;
  fir.cutoff_hz = 11.0;
  EXPECT_LT((sig::zero_phase_lowpass(X, 500.0, fir).col(0) - col("filtfilt_fir_n31_fc11_fs500")).cwiseAbs().maxCoeff(),
            kGoldenTol);
}

TEST(SignalLowpass, DefaultRemovesThirtyHzZeroOrderHoldBeforeDoubleDifferentiation) {
  // Position sampled and held at 30 Hz inside a 500 Hz log (section III-D), as
  // the mass row needs its second derivative. Truth: x = A sin(w t) delayed by
  // the hold's mean lag of half a hold period.
  const double fs = 500.0, T = 1 / fs, A = 0.5, w = 2 * kPi * 0.2, lag = 0.5 / 30.0;
  const VectorXd x = sampled(10000, fs, [&](double t) {
    const double th = std::floor(t * 30.0 + 1e-9) / 30.0;
    return A * std::sin(w * th);
  });
  const auto accel_error = [&](const MatrixXd& xf) {
    const VectorXd acc = sig::central_difference(sig::central_difference(xf.col(0), T), T);
    double e2 = 0.0;
    int n = 0;
    for (int i = 1000; i < 9000; ++i, ++n) {
      const double truth = -A * w * w * std::sin(w * (i * T - lag));
      e2 += (acc(i) - truth) * (acc(i) - truth);
    }
    return std::sqrt(e2 / n) / (A * w * w);  // RMS error relative to the true amplitude
  };
  const double e_default = accel_error(sig::zero_phase_lowpass(x, fs));
  sig::LowpassOptions fir;
  fir.kind = sig::LowpassOptions::Kind::FirBlackmanHarris;
  fir.cutoff_hz = 11.0;
  const double e_fir = accel_error(sig::zero_phase_lowpass(x, fs, fir));
  // Measured: 0.09 % for the 4 Hz Butterworth, 1450 % for the 31-tap FIR. The
  // hold steps land every 16 or 17 samples (500/30 = 50/3), so their energy sits
  // at 10, 20 and 30 Hz, where the zero-phase 31-tap FIR, even at the paper's
  // 0.001 Hz, passes 76 %, 33 % and 7.5 % of the amplitude, and the 4 Hz
  // Butterworth -64, -112 and -141 dB.
  EXPECT_LT(e_default, 0.005);  // < 0.5 % of the 0.79 m/s^2 amplitude
  EXPECT_GT(e_fir, 1.0);        // ripple larger than the signal itself
}

TEST(SignalDifference, ExactOnQuadraticIncludingEndsAndSecondOrderOnCubic) {
  const double T = 0.002;
  const VectorXd x = sampled(50, 500.0, [](double t) { return 3.0 + 2.0 * t - 5.0 * t * t; });
  const VectorXd d = sig::central_difference(x, T);
  for (int i = 0; i < 50; ++i) EXPECT_NEAR(d(i), 2.0 - 10.0 * i * T, 1e-10) << i;  // rounding of x/T
  // Cubic t^3: the central difference has error exactly T^2 (x'''/6) = T^2 in the
  // interior, which a one-sided or mis-scaled formula would not reproduce.
  const VectorXd c = sampled(50, 500.0, [](double t) { return t * t * t; });
  const VectorXd dc = sig::central_difference(c, T);
  for (int i = 1; i < 49; ++i) EXPECT_NEAR(dc(i), 3.0 * (i * T) * (i * T) + T * T, 1e-12) << i;
  MatrixXd X(50, 2);
  X << x, c;
  const MatrixXd D = sig::central_difference(X, T);
  EXPECT_EQ(D.col(0), d);
  EXPECT_EQ(D.col(1), dc);
}

TEST(SignalFirstOrder, CoefficientsAreEquations35And36) {
  const double lam = 30.0, T = 0.002, a = std::exp(-lam * T);
  const auto f = sig::fD_tf(lam, T);
  EXPECT_EQ(f.b, (std::vector<double>{0.0, -std::expm1(-lam * T)}));
  EXPECT_NEAR(f.b[1], 1 - a, 1e-15);
  EXPECT_EQ(f.a, (std::vector<double>{1.0, -a}));
  const auto gp = sig::gD_tf(lam, T, sig::GdVariant::Printed);
  EXPECT_EQ(gp.b, (std::vector<double>{lam, -lam}));
  EXPECT_EQ(gp.a, f.a);
  const auto gc = sig::gD_tf(lam, T);  // default: consistent
  EXPECT_NEAR(gc.b[0], (1 - a) / T, 1e-12);
  EXPECT_EQ(gc.b[1], -gc.b[0]);
  EXPECT_EQ(gc.a, f.a);
}

TEST(SignalFirstOrder, SteadyStateInitialization) {
  const MatrixXd X = MatrixXd::Constant(20, 2, 1.7);
  const MatrixXd F = sig::filter_fD(X, 30.0, 0.002);
  const MatrixXd Gc = sig::filter_gD(X, 30.0, 0.002);
  const MatrixXd Gp = sig::filter_gD(X, 30.0, 0.002, sig::GdVariant::Printed);
  EXPECT_LT((F.array() - 1.7).abs().maxCoeff(), 1e-14);  // from the first sample on
  EXPECT_LT(Gc.cwiseAbs().maxCoeff(), 1e-12);
  EXPECT_LT(Gp.cwiseAbs().maxCoeff(), 1e-12);
}

TEST(SignalFirstOrder, RampSlopeConsistentIsExactPrintedIs1030Percent) {
  const double lam = 30.0, T = 0.002, c = 0.8, a = std::exp(-lam * T);
  const MatrixXd x = sampled(2000, 1 / T, [&](double t) { return 1.0 + c * t; });
  const MatrixXd F = sig::filter_fD(x, lam, T);
  const MatrixXd Gc = sig::filter_gD(x, lam, T);
  const MatrixXd Gp = sig::filter_gD(x, lam, T, sig::GdVariant::Printed);
  // Consistent g_D is the forward difference quotient of f_D's output, at every sample.
  for (int k = 0; k + 1 < 2000; ++k) EXPECT_NEAR(Gc(k, 0), (F(k + 1, 0) - F(k, 0)) / T, 1e-9) << k;
  // Printed g_D = lambda (1 - f_D).
  for (int k = 0; k < 2000; ++k) EXPECT_NEAR(Gp(k, 0), lam * (x(k, 0) - F(k, 0)), 1e-9) << k;
  // Steady state on the ramp (transient exp(-30 t) < 1e-20 after 1.5 s).
  const double factor = lam * T / (1 - a);
  EXPECT_NEAR(factor, 1.0303, 1e-4);
  EXPECT_NEAR(Gc(1999, 0), c, 1e-9);
  EXPECT_NEAR(Gp(1999, 0), c * factor, 1e-9);
}

// ------------------------------------------------------------------ error cases

TEST(SignalErrors, InvalidArgumentsNameTheField) {
  const auto tf = sig::butter_lowpass(4, 4.0, 500.0);  // padlen 12
  expect_invalid([&] { sig::filtfilt(tf, VectorXd::Ones(12)); }, {"length 12", "padding length 12"});
  EXPECT_NO_THROW(sig::filtfilt(tf, VectorXd::Ones(13)));
  const auto fir = sig::fir_lowpass_blackmanharris(31, 4.0, 500.0);  // padlen 90
  expect_invalid([&] { sig::filtfilt(fir, MatrixXd::Ones(50, 2)); }, {"length 50", "padding length 90"});

  expect_invalid([] { sig::butter_lowpass(0, 4.0, 500.0); }, {"order=0"});
  expect_invalid([] { sig::butter_lowpass(4, 0.0, 500.0); }, {"cutoff_hz=0"});
  expect_invalid([] { sig::butter_lowpass(4, 250.0, 500.0); }, {"cutoff_hz=250", "Nyquist 250"});
  expect_invalid([] { sig::butter_lowpass(4, 4.0, -1.0); }, {"fs_hz=-1"});
  expect_invalid([] { sig::fir_lowpass_blackmanharris(2, 4.0, 500.0); }, {"taps=2"});

  sig::LowpassOptions o;
  o.cutoff_hz = 300.0;
  expect_invalid([&] { o.validate(500.0); }, {"cutoff_hz=300 must be below Nyquist 250 Hz"});
  expect_invalid([&] { sig::zero_phase_lowpass(MatrixXd::Ones(100, 1), 500.0, o); }, {"cutoff_hz=300"});
  o = {};
  o.taps = 30;
  expect_invalid([&] { o.validate(500.0); }, {"taps=30", "odd"});
  o = {};
  o.order = 0;
  expect_invalid([&] { o.validate(500.0); }, {"order=0"});
  EXPECT_NO_THROW(sig::LowpassOptions{}.validate(500.0));

  expect_invalid([] { sig::central_difference(VectorXd::Ones(2), 0.002); }, {"length 2"});
  expect_invalid([] { sig::central_difference(VectorXd::Ones(5), 0.0); }, {"T=0"});
  const VectorXd bad_zi = VectorXd::Zero(2);
  expect_invalid([&] { sig::lfilter(tf, VectorXd::Ones(5), &bad_zi); }, {"zi", "size 2"});
  expect_invalid([] { sig::lfilter({{1.0}, {0.0}}, VectorXd::Ones(5)); }, {"a[0]"});
  expect_invalid([] { sig::fD_tf(-1.0, 0.002); }, {"lambda=-1"});
  expect_invalid([] { sig::gD_tf(30.0, 0.0); }, {"T=0"});
}

// The in-place filter of long logs runs the same code as filtfilt and
// central_difference, so the results are equal bit for bit.
TEST(SignalInPlace, ZeroPhaseFilterAndDifferenceEqualTheCopyingVersions) {
  std::mt19937 rng(12);
  std::normal_distribution<double> N(0.0, 1.0);
  Eigen::VectorXd x(3001);
  for (Eigen::Index k = 0; k < x.size(); ++k) x(k) = std::sin(0.01 * static_cast<double>(k)) + 0.1 * N(rng);
  const sig::TransferFunction butter = sig::butter_lowpass(4, 4.0, 500.0);
  const sig::TransferFunction fir{sig::fir_lowpass_blackmanharris(31, 4.0, 500.0), {1.0}};
  for (const auto& tf : {butter, fir}) {
    sig::ZeroPhaseFilter zf(tf);
    for (int call = 0; call < 2; ++call) {  // the reused work space must not leak into the next call
      Eigen::VectorXd y = x;
      zf.apply(y.data(), y.size());
      EXPECT_EQ(y, sig::filtfilt(tf, x));
    }
    Eigen::VectorXd short_x = x.head(zf.padlen());
    EXPECT_THROW(zf.apply(short_x.data(), short_x.size()), std::invalid_argument);
  }
  Eigen::VectorXd d = x;
  sig::central_difference_inplace(d.data(), d.size(), 0.002);
  EXPECT_EQ(d, sig::central_difference(x, 0.002));
}
