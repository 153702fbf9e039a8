// Online estimation (include/quadid/online.hpp, docs/follow.md): the
// square-root RLS against a batch QR, the causal filter and unwrap against
// their batch forms, the stream's rows against the rigid body they come from,
// and the estimator on known changes: a step, a slow drift, none.
#include "quadid/online.hpp"
#include "quadid/identification.hpp"
#include "quadid/simulation.hpp"

#include <gtest/gtest.h>

#include <random>
#include <sstream>

using namespace quadid;

namespace {

// --- RecursiveLeastSquares -------------------------------------------------------

// Rounding of a few hundred rotations of numbers of order 1 (the factor's entries).
constexpr double kRlsRounding = 1e-10;

TEST(RecursiveLeastSquares, EqualsTheBatchWeightedLeastSquaresWithForgetting) {
  std::mt19937_64 rng(7);
  std::normal_distribution<double> nd;
  const int n = 5, N = 300;
  const double lambda = 0.98;
  Eigen::MatrixXd G(N, n);
  Eigen::VectorXd y(N), w(N);
  RecursiveLeastSquares rls(n);
  for (int k = 0; k < N; ++k) {
    for (int j = 0; j < n; ++j) G(k, j) = nd(rng);
    y(k) = nd(rng);
    w(k) = 0.5 + std::abs(nd(rng));
    rls.forget(lambda);
    const Eigen::VectorXd gk = G.row(k).transpose();
    rls.add(gk.data(), y(k), w(k));
  }
  // Batch: row k weighted by w_k lambda^(N-1-k) (it was forgotten N-1-k times after it came).
  Eigen::VectorXd s(N);
  for (int k = 0; k < N; ++k) s(k) = std::sqrt(w(k) * std::pow(lambda, N - 1 - k));
  const Eigen::MatrixXd A = s.asDiagonal() * G;
  const Eigen::VectorXd b = s.asDiagonal() * y;
  const Eigen::VectorXd x = A.householderQr().solve(b);
  Eigen::VectorXd theta;
  Eigen::Index rank = 0;
  rls.solve(theta, &rank);
  EXPECT_EQ(rank, n);
  EXPECT_LT((theta - x).cwiseAbs().maxCoeff(), kRlsRounding);
  EXPECT_NEAR(rls.sse(), (A * x - b).squaredNorm(), kRlsRounding);
  const Eigen::MatrixXd inv = (A.transpose() * A).inverse();
  EXPECT_LT((rls.inverse_information() - inv).cwiseAbs().maxCoeff(), kRlsRounding * inv.cwiseAbs().maxCoeff());
}

TEST(RecursiveLeastSquares, AddingAnotherAccumulatorEqualsAddingItsRows) {
  std::mt19937_64 rng(3);
  std::normal_distribution<double> nd;
  const int n = 4;
  RecursiveLeastSquares a(n), b(n), all(n);
  Eigen::VectorXd g(n);
  for (int k = 0; k < 50; ++k) {
    for (int j = 0; j < n; ++j) g(j) = nd(rng);
    const double y = nd(rng);
    (k % 2 ? a : b).add(g.data(), y);
    all.add(g.data(), y, k % 2 ? 1.0 : 2.5);
  }
  a.add(b, 2.5);
  Eigen::VectorXd xa, xall;
  a.solve(xa);
  all.solve(xall);
  EXPECT_LT((xa - xall).cwiseAbs().maxCoeff(), kRlsRounding);
  EXPECT_NEAR(a.sse(), all.sse(), kRlsRounding);
}

TEST(RecursiveLeastSquares, LeavesADirectionWithoutInformationAtZero) {
  RecursiveLeastSquares r(3);
  const double g[3] = {1.0, 0.0, 0.0};
  r.add(g, 2.0);
  Eigen::VectorXd x;
  Eigen::Index rank = 0;
  r.solve(x, &rank);
  EXPECT_EQ(rank, 1);
  EXPECT_DOUBLE_EQ(x(0), 2.0);
  EXPECT_EQ(x(1), 0.0);
  EXPECT_THROW(r.forget(0.0), std::invalid_argument);
  EXPECT_THROW(r.add(g, 1.0, -1.0), std::invalid_argument);
}

// --- The causal pieces against their batch forms -------------------------------------

TEST(SosStream, EqualsSosfiltStartedInSteadyStateBitForBit) {
  const signal::Sos sos = signal::butter_sos(4, 4.0, 500.0);
  Eigen::VectorXd x(400), x2(400);
  for (int k = 0; k < 400; ++k) {
    x(k) = 1.0 + std::sin(0.05 * k) + 0.1 * std::cos(1.3 * k);
    x2(k) = -2.0 * x(k);
  }
  const Eigen::MatrixXd zi = signal::sosfilt_zi(sos);
  const Eigen::MatrixXd z1 = zi * x(0), z2 = zi * x2(0);
  const Eigen::VectorXd y1 = signal::sosfilt(sos, x, &z1), y2 = signal::sosfilt(sos, x2, &z2);
  signal::SosStream s(sos, 2);
  for (int k = 0; k < 400; ++k) {
    double v[2] = {x(k), x2(k)};
    s.step(v);
    ASSERT_EQ(v[0], y1(k)) << k;
    ASSERT_EQ(v[1], y2(k)) << k;
  }
}

TEST(Unwrapper, EqualsUnwrap) {
  Eigen::VectorXd a(200);
  for (int k = 0; k < 200; ++k) a(k) = std::remainder(0.21 * k, 2.0 * M_PI);
  Eigen::VectorXd b = a;
  signal::unwrap(b.data(), b.size());
  signal::Unwrapper u;
  for (int k = 0; k < 200; ++k) ASSERT_EQ(u.step(a(k)), b(k)) << k;
}

// --- The stream's rows ------------------------------------------------------------

SimulationResult fly(double duration, std::uint64_t seed, std::vector<PayloadChange> changes = {},
                     bool noise = true) {
  SimulationOptions o;
  o.duration = duration;
  o.sensors.seed = seed;
  if (!noise) o.sensors.noise = NoiseSigmas::none();
  o.payload_changes = std::move(changes);
  return simulate(FourierTrajectory::table2(), o);
}

TEST(RegressionStream, RowsOfANoiseFreeFlightHoldTheTrueParameters) {
  // The moment rows are exact for the filtered rigid body (products filtered
  // as formed); what is left is the central difference's error at 500 Hz and
  // the 30 Hz motion capture held in the force row: a few 1e-3 of each row's RMS.
  const SimulationResult r = fly(20.0, 1, {}, false);
  RegressionStream st(ProcessingOptions{}, {});
  const StreamColumns c = StreamColumns::of(r.log);
  TermRow row(7);
  double t = 0.0;
  const Theta truth = SimulationOptions{}.plant.theta();
  Vec4 se = Vec4::Zero(), sy = Vec4::Zero();
  for (Eigen::Index k = 0; k < r.log.rows(); ++k) {
    if (!st.push(c.sample(r.log, k), row, t)) continue;
    EXPECT_NEAR(t, r.log.data(k, 0) - 2.0 * st.period(), 1e-9);
    if (t < 2.0) continue;  // the filter's start
    se += (row.G * truth - row.Y).cwiseAbs2();
    sy += row.Y.cwiseAbs2();
  }
  for (int i = 0; i < 4; ++i) EXPECT_LT(std::sqrt(se(i) / sy(i)), 0.02) << "row " << i;
}

TEST(RegressionStream, RefusesAGapNamingItsTime) {
  RegressionStream st(ProcessingOptions{}, {});
  TermRow row(7);
  double t = 0.0;
  StreamSample s;
  s.wrench(0) = 10.0;
  for (int k = 0; k < 5; ++k) {
    s.t = 0.002 * k;
    st.push(s, row, t);
  }
  s.t = 0.02;
  try {
    st.push(s, row, t);
    FAIL() << "a gap was accepted";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("t = 0.02 s"), std::string::npos) << e.what();
  }
}

// --- The estimator ---------------------------------------------------------------

struct Followed {
  std::vector<OnlineChange> changes;
  std::vector<OnlineSegment> segments;
  std::vector<std::pair<double, OnlineEstimate>> track;
};
Followed follow(const FlightLog& log, const OnlineOptions& opt = {}) {
  OnlineEstimator est(opt);
  Followed f;
  follow_log(est, log, [&](const OnlineEstimator& e) { f.track.emplace_back(e.time(), e.tracking()); });
  f.changes = est.changes();
  f.segments = est.segments();
  return f;
}

TEST(OnlineEstimator, APayloadStepIsFoundWithinThreeSecondsAndEachSegmentHasItsMass) {
  const double m0 = SimulationOptions{}.plant.m, dm = 0.2, t_change = 25.0;
  const SimulationResult r = fly(50.0, 1, {PayloadChange{t_change, dm}});
  const Followed f = follow(r.log);
  ASSERT_EQ(f.changes.size(), 1u);
  EXPECT_GE(f.changes[0].t_detected, t_change);
  EXPECT_LE(f.changes[0].t_detected, t_change + 3.0);
  ASSERT_EQ(f.segments.size(), 2u);
  EXPECT_NEAR(f.segments[0].estimate.params.m, m0, 0.02 * m0);
  EXPECT_NEAR(f.segments[1].estimate.params.m, m0 + dm, 0.02 * (m0 + dm));
  // The inertia after the change within the batch fit's accuracy on the same part of the flight.
  IdentificationOptions io;
  io.window = TimeWindow{f.segments[1].t_start + 1.0, 49.0};
  const IdentificationResult batch = identify(r.log, io);
  const Theta truth = SimulationOptions{}.plant.theta();
  for (int j : {1, 4, 6}) {
    const double online_err = std::abs(f.segments[1].estimate.value(j) - truth(j));
    const double batch_err = std::abs(batch.ls_standard.theta(j) - truth(j));
    EXPECT_LT(online_err, std::max(3.0 * batch_err, 0.02 * truth(j))) << kThetaNames[static_cast<size_t>(j)];
  }
}

TEST(OnlineEstimator, NoChangeNoAlarmOverManySeeds) {
  int alarms = 0;
  const int seeds = 12;
  for (int s = 1; s <= seeds; ++s) alarms += static_cast<int>(follow(fly(40.0, static_cast<std::uint64_t>(s)).log).changes.size());
  EXPECT_EQ(alarms, 0) << "false alarms in " << seeds << " flights of 40 s";
}

TEST(OnlineEstimator, ForgettingTracksASlowDrift) {
  // +0.3 kg in 30 steps of 10 g, one every second from 10 s: a slow drift.
  std::vector<PayloadChange> steps;
  for (int i = 0; i < 30; ++i) steps.push_back({10.0 + i, 0.01});
  const SimulationResult r = fly(50.0, 2, steps);
  OnlineOptions o;
  o.detect_changes = false;
  const Followed f = follow(r.log, o);
  const double m_end = SimulationOptions{}.plant.m + 0.3;
  ASSERT_FALSE(f.track.empty());
  EXPECT_NEAR(f.track.back().second.params.m, m_end, 0.02 * m_end);  // tracking: near the end's mass
  // The whole-flight estimate, which forgets nothing, lags it.
  EXPECT_LT(f.segments.back().estimate.params.m, m_end - 0.05);
}

}  // namespace

// --- The command ---------------------------------------------------------------------

#include "cli_fixture.hpp"
#include "shared_data.hpp"

#include <nlohmann/json.hpp>

namespace {

class CliFollow : public quadid::testing::CliTest {};

TEST_F(CliFollow, StdinGivesTheFilesResult) {
  ASSERT_EQ(run("simulate --trajectory table2 --duration 30 --payload-change 15:0.1 -o " + path("f.csv")).rc, 0);
  const auto file = run("follow " + path("f.csv") + " --json");
  ASSERT_EQ(file.rc, 0) << file.err;
  const auto piped = run("follow - --json < " + path("f.csv"));
  ASSERT_EQ(piped.rc, 0) << piped.err;
  nlohmann::ordered_json a = nlohmann::ordered_json::parse(file.out), b = nlohmann::ordered_json::parse(piped.out);
  a.erase("log");
  a.erase("wrench_source");
  EXPECT_EQ(a, b);
  ASSERT_EQ(a["changes"].size(), 1u);
  EXPECT_NEAR(a["changes"][0]["t"].get<double>(), 15.0, 0.5);
  // The text form prints one line per --every as the rows arrive, then the segments.
  const auto lines = run("follow - --every 5 < " + path("f.csv"));
  ASSERT_EQ(lines.rc, 0) << lines.err;
  EXPECT_NE(lines.out.find("change at t 15"), std::string::npos) << lines.out;
  EXPECT_NE(lines.out.find("segments:"), std::string::npos) << lines.out;
}

TEST_F(CliFollow, TrackAndResultFilesAreWritten) {
  ASSERT_EQ(run("simulate --trajectory table2 --duration 20 -o " + path("f.csv")).rc, 0);
  const auto r = run("follow " + path("f.csv") + " --every 2 --track " + path("t.csv") + " -o " + path("r.json") + " -q");
  ASSERT_EQ(r.rc, 0) << r.err;
  // Header t,m,m_se,Ixx,...; one row per 2 s; the standard errors empty until the scales are known
  // (warm-up 3 s + 6 blocks), then all there.
  std::istringstream track(read_file(path("t.csv")));
  std::string line;
  std::getline(track, line);
  EXPECT_EQ(line.rfind("t,m,m_se,Ixx,Ixx_se,", 0), 0u) << line;
  int rows = 0;
  std::string last;
  while (std::getline(track, line)) {
    ++rows;
    last = line;
  }
  EXPECT_GE(rows, 8);  // every 2 s of ~19 s of rows
  EXPECT_EQ(last.find(",,"), std::string::npos) << last;
  const auto j = nlohmann::ordered_json::parse(read_file(path("r.json")));
  EXPECT_EQ(j["segments"].size(), 1u);
}

TEST_F(CliFollow, BadInputNamesTheLineAndBatchOptionsAreRefused) {
  write("bad.csv", "t,x,y,z,phi,theta,psi,p,q,r,Fz,tau_phi,tau_theta,tau_psi\n0,0,0,1,0,0,0,0,0,0,17,0,0,0\n0.002,0,0,1,0,0,0,0,x,0,17,0,0,0\n");
  const auto r = run("follow - < " + path("bad.csv"));
  EXPECT_NE(r.rc, 0);
  EXPECT_NE(r.err.find("stdin:3:9"), std::string::npos) << r.err;
  write("nohead.csv", "t,x\n0,1\n");
  const auto h = run("follow - < " + path("nohead.csv"));
  EXPECT_NE(h.rc, 0);
  EXPECT_NE(h.err.find("no column 'y'"), std::string::npos) << h.err;
  ASSERT_EQ(run("simulate --trajectory table2 --duration 5 -o " + path("f.csv")).rc, 0);
  const auto w = run("follow " + path("f.csv") + " --window 1:2");
  EXPECT_NE(w.rc, 0);
  EXPECT_NE(w.err.find("--window"), std::string::npos) << w.err;
  EXPECT_NE(w.err.find("does not apply to follow"), std::string::npos) << w.err;
}

// The shared real Crazyflie flights: none changes its mass, and none may raise an alarm.
TEST_F(CliFollow, NoFalseAlarmOnTheRealCrazyflieFlights) {
  const std::filesystem::path dir = std::filesystem::path(QUADID_SHARED_DATA) / "crazyflie-usd";
  for (const char* f : {"jana00", "jana01", "jana04", "jana06"}) {
    QUADID_REQUIRE_SHARED_FILE(dir / f);
    const auto r = run("follow " + (dir / f).string() + " --vehicle crazyflie21 --json");
    ASSERT_EQ(r.rc, 0) << f << ": " << r.err;
    const auto j = nlohmann::ordered_json::parse(r.out);
    EXPECT_EQ(j["changes"].size(), 0u) << f << ": " << j["changes"].dump();
    EXPECT_NEAR(j["segments"][0]["estimate"]["m"].get<double>(), 0.035, 0.0035) << f;  // 10 %: the rotor model's kf
  }
}

}  // namespace
