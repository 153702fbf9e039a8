// Tests of quadid::signal against SciPy golden data (tests/data/signal, made by
// gen_signal_golden.py) and against closed-form properties.
//
// Tolerances. Golden comparisons of FIR and first-order filters use 1e-9:
// relative for coefficients, absolute for the O(1) filtered signals. Both sides
// compute in IEEE double (unit roundoff 1.1e-16) with the same algorithms, but
// in different operation orders (LAPACK solve vs a recurrence for lfilter_zi,
// DF2T vs convolution for FIR); 1e-9 is still far below any algorithmic mistake
// (a different padding or initial state changes edge samples by 1e-3 or more).
// The Butterworth cases (second-order sections) have their own, tighter,
// tolerances, derived where they are used.
#include "quadid/signal.hpp"

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include <algorithm>
#include <cmath>
#include <fmt/format.h>
#include <iostream>
#include <limits>
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
constexpr double kEps = std::numeric_limits<double>::epsilon();

const nlohmann::ordered_json& coeffs() {
  static const nlohmann::ordered_json j = [] {
    std::ifstream f(kDir + "signal_coeffs.json");
    if (!f) throw std::runtime_error("cannot open " + kDir + "signal_coeffs.json");
    return nlohmann::ordered_json::parse(f);
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

sig::TransferFunction tf_of(const nlohmann::ordered_json& f) {
  return {f.at("b").get<std::vector<double>>(), f.at("a").get<std::vector<double>>()};
}

MatrixXd matrix_of(const nlohmann::ordered_json& j) {
  const auto rows = j.get<std::vector<std::vector<double>>>();
  MatrixXd m(static_cast<Eigen::Index>(rows.size()), rows.empty() ? 0 : static_cast<Eigen::Index>(rows[0].size()));
  for (std::size_t i = 0; i < rows.size(); ++i)
    for (std::size_t k = 0; k < rows[i].size(); ++k) m(static_cast<Eigen::Index>(i), static_cast<Eigen::Index>(k)) = rows[i][k];
  return m;
}

sig::Sos sos_of(const nlohmann::ordered_json& j) { return matrix_of(j); }

// Sum over sections of the condition number of the DC gain, (1 + |a1| + |a2|) / |1 + a1 + a2|.
double dc_condition(const sig::Sos& sos) {
  double kappa = 0.0;
  for (Eigen::Index i = 0; i < sos.rows(); ++i)
    kappa += sos.row(i).tail<3>().cwiseAbs().sum() / std::abs(sos.row(i).tail<3>().sum());
  return kappa;
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

TEST(SignalGolden, ButterSosMatchesScipyForEveryAllowedOrderAndCutoff) {
  // Every order LowpassOptions allows (1-8) and cutoffs from 10 mHz to 249.99 Hz
  // at 500 Hz. Sections: each row compared relative to its largest entry. Both
  // sides compute the same poles by tan, exp and complex division in double,
  // rounded differently in the last bit (measured <= 3e-16); 1e-14 keeps a margin
  // and is far below a wrong pairing or ordering (differences of O(1)).
  // Initial states: the DC gain sum(b)/sum(a) of a section with poles at distance
  // d from z = 1 has condition number kappa ~ 4/d^2, so both sides' rounding is
  // amplified by up to eps kappa: tolerance 1e-12 + 8 eps kappa.
  int n = 0;
  for (const auto& d : coeffs().at("butter_sweep")) {
    const std::string what = fmt::format("order {} cutoff {} Hz", d.at("order").get<int>(), d.at("cutoff_hz").get<double>());
    const sig::Sos want = sos_of(d.at("sos"));
    const sig::Sos got = sig::butter_sos(d.at("order"), d.at("cutoff_hz"), d.at("fs_hz"));
    ASSERT_EQ(got.rows(), want.rows()) << what;
    for (Eigen::Index i = 0; i < got.rows(); ++i) {
      const double scale = want.row(i).cwiseAbs().maxCoeff();
      EXPECT_LT((got.row(i) - want.row(i)).cwiseAbs().maxCoeff(), 1e-14 * scale) << what << " section " << i;
    }
    const MatrixXd zi = sig::sosfilt_zi(got);
    const MatrixXd zi_want = matrix_of(d.at("zi"));
    double kappa = 0.0;
    for (Eigen::Index i = 0; i < got.rows(); ++i)
      kappa += got.row(i).tail<3>().cwiseAbs().sum() / std::abs(got.row(i).tail<3>().sum());
    EXPECT_LT((zi - zi_want).cwiseAbs().maxCoeff(), 1e-12 + 8 * kEps * kappa) << what;
    ++n;
  }
  EXPECT_EQ(n, 8 * 14);
}

TEST(SignalGolden, Zpk2SosPairsAndOrdersAsScipy) {
  int n = 0;
  for (const auto& c : coeffs().at("zpk2sos")) {
    sig::Zpk zpk;
    for (const auto& v : c.at("z")) zpk.z.emplace_back(v[0].get<double>(), v[1].get<double>());
    for (const auto& v : c.at("p")) zpk.p.emplace_back(v[0].get<double>(), v[1].get<double>());
    zpk.k = c.at("k");
    const sig::Sos got = sig::zpk2sos(zpk), want = sos_of(c.at("sos"));
    ASSERT_EQ(got.rows(), want.rows()) << c.at("name");
    // Same operations on the same doubles, up to summation order: 1e-14 of the row.
    for (Eigen::Index i = 0; i < got.rows(); ++i)
      EXPECT_LT((got.row(i) - want.row(i)).cwiseAbs().maxCoeff(), 1e-14 * want.row(i).cwiseAbs().maxCoeff())
          << c.at("name") << " section " << i;
    ++n;
  }
  EXPECT_EQ(n, 3);
}

TEST(SignalGolden, LfilterZiOfFirstOrderFiltersMatchesScipyAndExactRational) {
  int n = 0;
  for (const auto& [name, f] : coeffs().at("filters").items()) {
    if (f.at("kind") != "first_order") continue;
    const VectorXd zi = sig::lfilter_zi(tf_of(f));
    const auto want = f.at("zi").get<std::vector<double>>();
    const auto exact = f.at("zi_exact").get<std::vector<double>>();
    ASSERT_EQ(zi.size(), static_cast<Eigen::Index>(want.size())) << name;
    for (Eigen::Index i = 0; i < zi.size(); ++i) {
      EXPECT_NEAR(zi(i), want[i], kGoldenTol * std::max(1.0, std::abs(want[i]))) << name << " " << i;
      // Against the exact rational solution for the same doubles: a few ulps.
      EXPECT_NEAR(zi(i), exact[i], 4 * kEps * std::max(1.0, std::abs(exact[i]))) << name << " " << i;
    }
    ++n;
  }
  EXPECT_EQ(n, 3);
}

TEST(SignalGolden, SosfiltFromRestMatchesScipy) {
  const sig::Sos sos = sos_of(coeffs().at("filters").at("butter_o4_fc4_fs500").at("sos"));
  // Same recursion, same operation order: rounding differences only (measured ~1e-16).
  EXPECT_LT((sig::sosfilt(sos, col("x")) - col("sosfilt_butter_o4_fc4_fs500")).cwiseAbs().maxCoeff(), 1e-13);
}

TEST(SignalGolden, ZeroPhaseFiltersMatchScipySosfiltfiltAndMatlabFiltfilt) {
  const VectorXd& x = col("x");
  double worst_own = 0.0, worst_scipy = 0.0;
  for (const auto& name_j : coeffs().at("zero_phase_cases")) {
    const std::string name = name_j.get<std::string>();
    const auto& f = coeffs().at("filters").at(name);
    if (f.at("kind") == "fir") {
      const VectorXd& want = col("filtfilt_" + name);
      EXPECT_LT((sig::filtfilt(f.at("b").get<std::vector<double>>(), x) - want).cwiseAbs().maxCoeff(), kGoldenTol)
          << name;
      const auto h = sig::fir_lowpass_blackmanharris(f.at("taps"), f.at("cutoff_hz"), f.at("fs_hz"));
      EXPECT_LT((sig::filtfilt(h, x) - want).cwiseAbs().maxCoeff(), kGoldenTol) << name;
      continue;
    }
    const VectorXd& want = col("sosfiltfilt_" + name);
    // (1) scipy's own sections: checks the zero-phase filter alone (padding,
    // initial states, recursion).
    // (2) our design end to end. Our sections differ from scipy's in the last
    // bit (<= 3e-16 relative), and scipy's sosfilt_zi (a LAPACK solve) and our
    // back-substitution round differently; either moves the output by up to
    // eps times the DC gain's condition number kappa (2.5e6 per section for
    // 0.1 Hz at 500 Hz; measured 9e-11 there, <= 3e-12 for cutoffs >= 0.5 Hz).
    // Tolerance: 1e-12 or 8 eps kappa max|x|, whichever is larger.
    const sig::Sos theirs = sos_of(f.at("sos"));
    const double tol = std::max(1e-12, 8 * kEps * dc_condition(theirs) * x.cwiseAbs().maxCoeff());
    const double d1 = (sig::sosfiltfilt(theirs, x) - want).cwiseAbs().maxCoeff();
    EXPECT_LT(d1, tol) << name;
    const sig::Sos ours = sig::butter_sos(f.at("order"), f.at("cutoff_hz"), f.at("fs_hz"));
    const double d2 = (sig::sosfiltfilt(ours, x) - want).cwiseAbs().maxCoeff();
    EXPECT_LT(d2, tol) << name;
    std::cout << fmt::format("{}: max |diff| to scipy sosfiltfilt {:.2g} (scipy's sections), {:.2g} (ours)\n", name,
                             d1, d2);
    worst_scipy = std::max(worst_scipy, d1);
    worst_own = std::max(worst_own, d2);
  }
  std::cout << "max |sosfiltfilt - scipy| over the Butterworth cases: scipy's sections " << worst_scipy
            << ", our design " << worst_own << "\n";
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
    const sig::Sos tf = sig::butter_sos(c.order, c.fc, c.fs);
    ASSERT_EQ(tf.rows(), (c.order + 1) / 2);
    EXPECT_TRUE((tf.col(3).array() == 1.0).all());
    // Prewarping makes |H| = 1/sqrt(2) exactly at the cutoff (-3.0103 dB).
    EXPECT_NEAR(std::abs(sig::frequency_response(tf, c.fc, c.fs)), 1.0 / std::sqrt(2.0), 1e-9)
        << c.order << " " << c.fc;
    EXPECT_NEAR(std::abs(sig::frequency_response(tf, 0.0, c.fs)), 1.0, 1e-9);
    EXPECT_NEAR(std::abs(sig::frequency_response(tf, c.fs / 2, c.fs)), 0.0, 1e-9);
    // Maximally flat: no ripple. Slack 1e-9: evaluating H near z = 1 divides by
    // each section's 1 + a1 + a2 ~ 1e-4..1, which costs up to ~1e-12 of the 1e-16 rounding.
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
  const auto check = [&](std::complex<double> H, const VectorXd& y, const char* what) {
    // Zero phase: y = |H(f0)|^2 x exactly in the interior (edge transients decay
    // as exp(-9.6 t) for the slowest 4 Hz Butterworth mode: < 1e-8 after 2 s).
    const double g2 = std::norm(H);
    EXPECT_LT((y.segment(1000, 3000) - g2 * x.segment(1000, 3000)).cwiseAbs().maxCoeff(), 1e-7) << what;
  };
  const sig::Sos bw = sig::butter_sos(4, 4.0, fs);
  check(sig::frequency_response(bw, f0, fs), sig::sosfiltfilt(bw, x), "butter");
  const auto fir = sig::fir_lowpass_blackmanharris(31, 4.0, fs);
  check(sig::frequency_response(sig::TransferFunction{fir, {1.0}}, f0, fs), sig::filtfilt(fir, x), "fir");
  // The check can see a lag: a single forward pass of the Butterworth is late
  // by ~0.09 s at 1 Hz, which fails it by a wide margin.
  const VectorXd once = sig::sosfilt(bw, x);
  const double g1 = std::abs(sig::frequency_response(bw, f0, fs));
  EXPECT_GT((once.segment(1000, 3000) - g1 * x.segment(1000, 3000)).cwiseAbs().maxCoeff(), 0.3);
}

TEST(SignalFiltfilt, ConstantPassesUnchangedAndMatrixIsColumnwise) {
  const sig::Sos tf = sig::butter_sos(4, 4.0, 500.0);
  const VectorXd c = VectorXd::Constant(100, -2.5);
  EXPECT_LT((sig::sosfiltfilt(tf, c).array() + 2.5).abs().maxCoeff(), 1e-12);  // no edge transient
  const auto fir = sig::fir_lowpass_blackmanharris(31, 20.0, 500.0);
  EXPECT_LT((sig::filtfilt(fir, c).array() + 2.5).abs().maxCoeff(), 1e-12);

  MatrixXd X(700, 3);
  X.col(0) = col("x").head(700);
  X.col(1) = col("x").segment(900, 700);
  X.col(2) = VectorXd::LinSpaced(700, -1.0, 3.0);
  const MatrixXd Y = sig::sosfiltfilt(tf, X);
  const MatrixXd Yf = sig::filtfilt(fir, X);
  for (int j = 0; j < 3; ++j) {
    EXPECT_EQ(Y.col(j), sig::sosfiltfilt(tf, VectorXd(X.col(j)))) << j;
    EXPECT_EQ(Yf.col(j), sig::filtfilt(fir, X.col(j))) << j;  // expression overload
  }
}

TEST(SignalLowpass, FrontEndIsFiltfiltOfTheChosenDesign) {
  const MatrixXd X = col("x");
  const sig::LowpassOptions def;
  EXPECT_EQ(def.kind, sig::LowpassOptions::Kind::Butterworth);
  EXPECT_EQ(def.order, 4);
  EXPECT_EQ(def.cutoff_hz, 4.0);
  EXPECT_EQ(sig::zero_phase_lowpass(X, 500.0, def), sig::sosfiltfilt(sig::butter_sos(4, 4.0, 500.0), X));
  // Own 4 Hz design vs scipy's sosfiltfilt: see ZeroPhaseFiltersMatchScipy... for the 1e-12.
  EXPECT_LT((sig::zero_phase_lowpass(X, 500.0).col(0) - col("sosfiltfilt_butter_o4_fc4_fs500")).cwiseAbs().maxCoeff(),
            1e-12);
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
  const sig::Sos sos = sig::butter_sos(4, 4.0, 500.0);  // padlen 3 (2 sections + 1) = 15, as scipy
  EXPECT_EQ(sig::ZeroPhaseFilter(sos).padlen(), 15);
  EXPECT_EQ(sig::ZeroPhaseFilter(sig::butter_sos(5, 4.0, 500.0)).padlen(), 18);  // one first-order section
  expect_invalid([&] { sig::sosfiltfilt(sos, VectorXd::Ones(15)); }, {"length 15", "padding length 15"});
  EXPECT_NO_THROW(sig::sosfiltfilt(sos, VectorXd::Ones(16)));
  const auto fir = sig::fir_lowpass_blackmanharris(31, 4.0, 500.0);  // padlen 90
  expect_invalid([&] { sig::filtfilt(fir, MatrixXd::Ones(50, 2)); }, {"length 50", "padding length 90"});

  expect_invalid([] { sig::butter_sos(0, 4.0, 500.0); }, {"order=0"});
  expect_invalid([] { sig::butter_sos(4, 0.0, 500.0); }, {"cutoff_hz=0"});
  expect_invalid([] { sig::butter_sos(4, 250.0, 500.0); }, {"cutoff_hz=250", "Nyquist 250"});
  expect_invalid([] { sig::butter_sos(4, 4.0, -1.0); }, {"fs_hz=-1"});
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
  expect_invalid([&] { sig::lfilter(sig::fD_tf(30.0, 0.002), VectorXd::Ones(5), &bad_zi); }, {"zi", "size 2"});
  const MatrixXd bad_sos_zi = MatrixXd::Zero(3, 2);
  expect_invalid([&] { sig::sosfilt(sos, VectorXd::Ones(5), &bad_sos_zi); }, {"zi", "3x2", "2x2"});
  expect_invalid([] { sig::lfilter({{1.0}, {0.0}}, VectorXd::Ones(5)); }, {"a[0]"});
  expect_invalid([] { sig::fD_tf(-1.0, 0.002); }, {"lambda=-1"});
  expect_invalid([] { sig::gD_tf(30.0, 0.0); }, {"T=0"});
}

TEST(SignalErrors, UnrealisableButterworthIsRefusedNamingTheFilter) {
  // Too close to Nyquist: scipy's own design of order 8 at 249.999999 Hz rounds
  // to a pole at |z| = 1.0000000026 (measured in numpy); ours is refused too.
  // At 249.999 Hz the poles are inside but 1.3e-5 from z = -1, where they
  // nearly cancel the zeros: refused as well.
  expect_invalid([] { sig::butter_sos(8, 249.999999, 500.0); },
                 {"Butterworth order 8, 249.999999 Hz at 500 Hz cannot be realised"});
  expect_invalid([] { sig::butter_sos(4, 249.999, 500.0); }, {"order 4, 249.999 Hz", "too close to Nyquist"});
  // Too close to 0 Hz: order 2 at 1 mHz has its pole pair 1.3e-5 from z = 1;
  // rounding can move the gain at 0 Hz by 5.6e-6 > 1e-6.
  expect_invalid([] { sig::butter_sos(2, 0.001, 500.0); }, {"order 2, 0.001 Hz at 500 Hz", "gain at 0 Hz"});
  // Far below any useful cutoff the poles round to z = 1 itself.
  expect_invalid([] { sig::butter_sos(4, 1e-300, 500.0); }, {"unit circle"});
  // The limits are the documented ones: 10 mHz (order 8) and 249.99 Hz are fine.
  EXPECT_NO_THROW(sig::butter_sos(8, 0.01, 500.0));
  EXPECT_NO_THROW(sig::butter_sos(8, 249.99, 500.0));
  // Through the pre-filter options, the message names the filter as the user set it.
  sig::LowpassOptions o;
  o.order = 8;
  o.cutoff_hz = 0.001;
  expect_invalid([&] { sig::ZeroPhaseFilter(o, 500.0); }, {"Butterworth order 8, 0.001 Hz at 500 Hz"});
  expect_invalid([&] { sig::zero_phase_lowpass(MatrixXd::Ones(100, 1), 500.0, o); }, {"order 8, 0.001 Hz"});
  // Hand-made sections: an unstable one is refused by check_realizable.
  sig::Sos bad(1, 6);
  bad << 1, 0, 0, 1, -2.0, 1.0;  // double pole at z = 1
  expect_invalid([&] { sig::check_realizable(bad); }, {"section 1", "|z| = 1"});
}

// Every order and cutoff the options allow either gives a stable filter whose
// zero-phase response is |H|^2 (unity at DC, 1/2 at the cutoff) or is refused.
TEST(SignalButter, EveryAllowedOrderIsStableAndZeroPhaseGainIsRightOrRefused) {
  const double fs = 500.0;
  int accepted = 0, refused = 0;
  for (int order = 1; order <= 8; ++order)
    for (double fc : {1e-6, 1e-4, 1e-3, 3e-3, 0.01, 0.1, 0.5, 1.0, 2.0, 4.0, 30.0, 200.0, 249.9, 249.999, 249.9999999}) {
      sig::Sos sos;
      try {
        sos = sig::butter_sos(order, fc, fs);
      } catch (const std::invalid_argument& e) {
        ++refused;
        EXPECT_NE(std::string(e.what()).find(fmt::format("order {}, {} Hz", order, fc)), std::string::npos) << e.what();
        EXPECT_TRUE(fc < 0.01 || fc > 249.99) << "refused in the documented range: " << e.what();
        continue;
      }
      ++accepted;
      for (Eigen::Index i = 0; i < sos.rows(); ++i) {  // stability triangle |a2| < 1, |a1| < 1 + a2
        EXPECT_LT(std::abs(sos(i, 5)), 1.0) << order << " " << fc;
        EXPECT_LT(std::abs(sos(i, 4)), 1.0 + sos(i, 5)) << order << " " << fc;
      }
      // DC gain 1 within the documented rounding bound; -3 dB at the cutoff.
      EXPECT_NEAR(std::abs(sig::frequency_response(sos, 0.0, fs)), 1.0, sig::kMaxDcGainError) << order << " " << fc;
      EXPECT_NEAR(std::abs(sig::frequency_response(sos, fc, fs)), 1.0 / std::sqrt(2.0), 1e-6) << order << " " << fc;
    }
  EXPECT_GE(accepted, 8 * 10);
  EXPECT_GE(refused, 8);  // at least 1e-6 Hz at every order but the first... and near Nyquist
}

// The in-place filter of long logs runs the same code as sosfiltfilt, filtfilt
// and central_difference, so the results are equal bit for bit.
TEST(SignalInPlace, ZeroPhaseFilterAndDifferenceEqualTheCopyingVersions) {
  std::mt19937 rng(12);
  std::normal_distribution<double> N(0.0, 1.0);
  Eigen::VectorXd x(3001);
  for (Eigen::Index k = 0; k < x.size(); ++k) x(k) = std::sin(0.01 * static_cast<double>(k)) + 0.1 * N(rng);
  const sig::Sos butter = sig::butter_sos(4, 4.0, 500.0);
  const std::vector<double> fir = sig::fir_lowpass_blackmanharris(31, 4.0, 500.0);
  for (int kind = 0; kind < 2; ++kind) {
    sig::ZeroPhaseFilter zf = kind == 0 ? sig::ZeroPhaseFilter(butter) : sig::ZeroPhaseFilter(fir);
    for (int call = 0; call < 2; ++call) {  // the reused work space must not leak into the next call
      Eigen::VectorXd y = x;
      zf.apply(y.data(), y.size());
      EXPECT_EQ(y, kind == 0 ? sig::sosfiltfilt(butter, x) : sig::filtfilt(fir, x));
    }
    Eigen::VectorXd short_x = x.head(zf.padlen());
    EXPECT_THROW(zf.apply(short_x.data(), short_x.size()), std::invalid_argument);
  }
  Eigen::VectorXd d = x;
  sig::central_difference_inplace(d.data(), d.size(), 0.002);
  EXPECT_EQ(d, sig::central_difference(x, 0.002));
}

// The several-column apply interleaves the columns' recurrences (4 at a time,
// then the rest); each column must get exactly the one-column result, bit for
// bit, for every count (groups of 4, 3, 2, 1), for an odd order (a first-order
// section), for FIR, and with the work space reused.
TEST(SignalInPlace, SeveralColumnsEqualOneAtATime) {
  std::mt19937 rng(13);
  std::normal_distribution<double> N(0.0, 1.0);
  const Eigen::Index n = 2001;
  Eigen::MatrixXd x(n, 9);
  for (Eigen::Index j = 0; j < x.cols(); ++j)
    for (Eigen::Index k = 0; k < n; ++k)
      x(k, j) = std::sin(0.01 * static_cast<double>((j + 1) * k)) + 0.1 * N(rng) + static_cast<double>(j);
  sig::ZeroPhaseFilter filters[] = {sig::ZeroPhaseFilter(sig::butter_sos(4, 4.0, 500.0)),
                                    sig::ZeroPhaseFilter(sig::butter_sos(5, 10.0, 500.0)),
                                    sig::ZeroPhaseFilter(sig::fir_lowpass_blackmanharris(31, 4.0, 500.0))};
  for (auto& zf : filters) {
    Eigen::MatrixXd one = x;
    for (Eigen::Index j = 0; j < x.cols(); ++j) zf.apply(one.col(j).data(), n);
    for (int count = 1; count <= 9; ++count) {
      Eigen::MatrixXd many = x;
      std::vector<double*> cols;
      for (int j = 0; j < count; ++j) cols.push_back(many.col(j).data());
      zf.apply(cols.data(), count, n);
      for (int j = 0; j < 9; ++j) EXPECT_EQ(many.col(j), j < count ? one.col(j) : x.col(j)) << count << " " << j;
    }
    Eigen::MatrixXd short_x = x.topRows(zf.padlen());
    std::vector<double*> cols = {short_x.col(0).data(), short_x.col(1).data()};
    EXPECT_THROW(zf.apply(cols.data(), 2, short_x.rows()), std::invalid_argument);
  }
}

// signal::welch_psd against scipy.signal.welch (gen_welch_golden.py: Hann, 50 %
// overlap, mean removed per segment, density scaling). Tolerance 1e-10 relative to
// the largest density: both sum the same products, rounding differs at ~1e-15.
TEST(Spectrum, WelchMatchesScipy) {
  std::ifstream in(kDir + "welch_golden.json");
  ASSERT_TRUE(in) << kDir;
  const nlohmann::ordered_json j = nlohmann::ordered_json::parse(in);
  const auto xs = j["x"].get<std::vector<double>>();
  const auto want = j["psd"].get<std::vector<double>>();
  const Eigen::VectorXd x = Eigen::Map<const Eigen::VectorXd>(xs.data(), static_cast<Eigen::Index>(xs.size()));
  const std::vector<double> got = quadid::signal::welch_psd(x, j["fs"].get<double>(), j["nseg"].get<Eigen::Index>());
  ASSERT_EQ(got.size(), want.size());
  const double peak = *std::max_element(want.begin(), want.end());
  for (size_t k = 0; k < got.size(); ++k) EXPECT_NEAR(got[k], want[k], 1e-10 * peak) << "bin " << k;
  EXPECT_THROW(quadid::signal::welch_psd(x.head(10), 250.0, 128), std::invalid_argument);
}

// A quadratic sampled at 30 Hz and held in a 480 Hz log (16 log samples per
// sensor sample) is put back on its sample instants: between two samples the
// reconstruction is the chord, so it differs from the quadratic by at most
// a T^2 / 8 |x''| (closed form, T = 1/30 s), and it passes exactly through
// every sample. The held signal itself lags by half a period.
TEST(Unwrap, UndoesTheWrapAndLeavesAContinuousAngleAlone) {
  // A yaw turning 2.5 rad per sample forwards, then backwards (steps below
  // pi, so continuous), wrapped into (-pi, pi] by remainder: unwrap gives it
  // back. 1e-12 rad: a few roundings of 2 pi multiples of up to ~40 rad.
  constexpr Eigen::Index n = 40;
  std::vector<double> truth(n), a(n);
  for (Eigen::Index k = 0; k < n; ++k) {
    truth[static_cast<size_t>(k)] = k < 20 ? 0.3 + 2.5 * static_cast<double>(k) : 0.3 + 2.5 * static_cast<double>(38 - k);
    a[static_cast<size_t>(k)] = std::remainder(truth[static_cast<size_t>(k)], 2.0 * std::numbers::pi);
  }
  quadid::signal::unwrap(a.data(), n);
  for (Eigen::Index k = 0; k < n; ++k) EXPECT_NEAR(a[static_cast<size_t>(k)], truth[static_cast<size_t>(k)], 1e-12) << k;
  // Already continuous: the same bits.
  std::vector<double> b = truth;
  quadid::signal::unwrap(b.data(), n);
  EXPECT_EQ(b, truth);
  // Empty and one-sample series are left alone.
  quadid::signal::unwrap(nullptr, 0);
  double one = 3.0;
  quadid::signal::unwrap(&one, 1);
  EXPECT_EQ(one, 3.0);
}

TEST(HeldSamples, InterpolatesBetweenTheSampleInstants) {
  const double fs = 480.0, fm = 30.0, a = 0.7;  // x = a t^2
  const Eigen::Index n = 4800, per = 16;
  std::vector<double> x(static_cast<size_t>(n)), truth(static_cast<size_t>(n));
  for (Eigen::Index k = 0; k < n; ++k) {
    const double t = static_cast<double>(k) / fs;
    truth[static_cast<size_t>(k)] = a * t * t;
    const double ts = static_cast<double>(k / per) / fm;  // the sensor's last sample instant
    x[static_cast<size_t>(k)] = a * ts * ts;
  }
  const auto h = quadid::signal::interpolate_held_samples(x.data(), n);
  EXPECT_TRUE(h.held);
  EXPECT_EQ(h.median_run, 16.0);
  EXPECT_EQ(h.samples, n / per);
  EXPECT_EQ(h.long_runs, 0);
  const double chord = a * 2.0 / 8.0 / (fm * fm);  // T^2/8 |x''|
  for (Eigen::Index k = 0; k < n - per; ++k) {
    const size_t i = static_cast<size_t>(k);
    EXPECT_LE(std::abs(x[i] - truth[i]), chord * (1 + 1e-9) + 1e-12) << k;
    if (k % per == 0) {
      EXPECT_NEAR(x[i], truth[i], 1e-12) << k;
    }
  }
}

// A signal at the log's rate is left alone bit for bit, and a hold far longer
// than the sensor's period (the vehicle standing still) stays a hold.
TEST(HeldSamples, LeavesFreshSamplesAndLongStillsAlone) {
  std::vector<double> fresh(200);
  for (size_t k = 0; k < fresh.size(); ++k) fresh[k] = std::sin(0.1 * static_cast<double>(k));
  const auto before = fresh;
  const auto h = quadid::signal::interpolate_held_samples(fresh.data(), 200);
  EXPECT_FALSE(h.held);
  EXPECT_EQ(fresh, before);

  // Held 4 samples each, except a still of 40 samples at 1.0 in the middle.
  std::vector<double> x;
  for (int j = 0; j < 10; ++j)
    for (int r = 0; r < 4; ++r) x.push_back(0.1 * j);
  for (int r = 0; r < 40; ++r) x.push_back(1.0);
  for (int j = 11; j < 20; ++j)
    for (int r = 0; r < 4; ++r) x.push_back(0.1 * j);
  const auto g = quadid::signal::interpolate_held_samples(x.data(), static_cast<Eigen::Index>(x.size()));
  EXPECT_TRUE(g.held);
  EXPECT_EQ(g.long_runs, 1);
  for (size_t k = 40; k < 80; ++k) EXPECT_EQ(x[k], 1.0) << k;  // the still
  EXPECT_NEAR(x[2], 0.0 + 0.1 * 2.0 / 4.0, 1e-15);  // inside a hold: on the chord
  EXPECT_NEAR(x[82], 1.1 + 0.1 * 2.0 / 4.0, 1e-15);
}
