// `quadid batch` (the built program) and the library's identify_batch: JSON
// Lines in input order, each line the result of `quadid identify --json` on
// that log, failing logs reported without stopping the others, exit codes.
#include "cli_fixture.hpp"
#include "quadid/batch.hpp"
#include "quadid/estimation.hpp"
#include "quadid/io.hpp"
#include "quadid/report.hpp"
#include "quadid/simulation.hpp"

#include <fmt/format.h>
#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include <array>
#include <cmath>
#include <map>
#include <mutex>
#include <sstream>
#include <string>
#include <vector>

namespace {

// A short flight keeps the test fast: 12 s of Table 2, estimated over 2-10 s.
constexpr const char* kWindow = "2:10";

const quadid::FlightLog& flight(int seed) {
  static std::map<int, quadid::FlightLog> logs;
  static std::mutex mu;
  std::lock_guard lock(mu);
  auto it = logs.find(seed);
  if (it == logs.end()) {
    quadid::SimulationOptions o;
    o.record_truth = false;
    o.duration = 12.0;
    o.sensors.seed = static_cast<std::uint64_t>(seed);
    it = logs.emplace(seed, quadid::simulate(quadid::FourierTrajectory::table2(), o).log).first;
  }
  return it->second;
}

std::vector<nlohmann::ordered_json> lines(const std::string& out) {
  std::vector<nlohmann::ordered_json> v;
  std::istringstream in(out);
  for (std::string l; std::getline(in, l);) v.push_back(nlohmann::ordered_json::parse(l));  // one object per line
  return v;
}

class CliBatch : public quadid::testing::CliTest {
 protected:
  void SetUp() override {
    CliTest::SetUp();
    quadid::write_flight_log(flight(1), path("a.csv"));
    quadid::write_flight_log(flight(2), path("b.csv"));
    write("corrupt.csv", "t,x\n0,1\n");  // no required columns
  }
  nlohmann::ordered_json identify_json(const std::string& log, const std::string& opts) const {
    const auto r = run("identify " + path(log) + " --json --window " + kWindow + " " + opts);
    EXPECT_EQ(r.rc, 0) << r.err;
    return nlohmann::ordered_json::parse(r.out);
  }
};

}  // namespace

TEST_F(CliBatch, OneLinePerLogInInputOrderEqualToIdentify) {
  // Non-default options: the batch reads them with the same names as identify.
  const std::string opts = "--cutoff 3 --lambda 20";
  const auto r = run("batch --threads 2 --window " + std::string(kWindow) + " " + opts + " " + path("b.csv") + " " +
                     path("corrupt.csv") + " " + path("a.csv") + " " + path("missing.csv") + " " + path("b.csv"));
  EXPECT_EQ(r.rc, 2) << "some logs failed: exit status 2\n" << r.err;
  const auto v = lines(r.out);
  ASSERT_EQ(v.size(), 5u) << r.out;
  const std::vector<std::string> order = {"b.csv", "corrupt.csv", "a.csv", "missing.csv", "b.csv"};
  const nlohmann::ordered_json ja = identify_json("a.csv", opts), jb = identify_json("b.csv", opts);
  for (size_t i = 0; i < v.size(); ++i) {
    EXPECT_EQ(v[i]["path"], path(order[i])) << i;
    const bool ok = i != 1 && i != 3;
    EXPECT_EQ(v[i]["ok"], ok) << i;
    if (!ok) {
      EXPECT_EQ(v[i].size(), 3u) << v[i].dump();  // path, ok, error
      EXPECT_NE(v[i]["error"].get<std::string>().find(path(order[i])), std::string::npos) << v[i]["error"];
      continue;
    }
    nlohmann::ordered_json expected = (order[i] == "a.csv") ? ja : jb;
    expected["path"] = path(order[i]);
    expected["ok"] = true;
    EXPECT_EQ(v[i], expected) << i;  // the same code on the same bytes: equal, not just close
  }
  EXPECT_NE(r.err.find("missing required column"), std::string::npos) << r.err;
  EXPECT_NE(r.err.find("[5/5]"), std::string::npos) << r.err;
  EXPECT_NE(r.err.find("5 logs, 3 ok, 2 failed"), std::string::npos) << r.err;
}

TEST_F(CliBatch, ListFileAndOutputFileAndExitZeroWhenAllSucceed) {
  write("list.txt", "# flights of the day\n" + path("a.csv") + "\n\n   " + path("b.csv") + "  \n");
  const auto r = run("batch -q --window " + std::string(kWindow) + " --list " + path("list.txt") + " -o " +
                     path("out.jsonl"));
  ASSERT_EQ(r.rc, 0) << r.err;
  EXPECT_EQ(r.out, "");
  EXPECT_EQ(r.err, "");  // -q
  const auto v = lines(quadid::read_file(path("out.jsonl")));
  ASSERT_EQ(v.size(), 2u);
  EXPECT_EQ(v[0]["path"], path("a.csv"));
  EXPECT_EQ(v[1]["path"], path("b.csv"));
}

TEST_F(CliBatch, BadOptionOrNoLogsIsExitOneWithNothingWritten) {
  auto r = run("batch --cutoff fast " + path("a.csv"));
  EXPECT_EQ(r.rc, 1);
  EXPECT_EQ(r.out, "");
  EXPECT_NE(r.err.find("--cutoff: expected a number, got \"fast\""), std::string::npos) << r.err;
  r = run("batch --threads 1");
  EXPECT_EQ(r.rc, 1);
  EXPECT_NE(r.err.find("no logs"), std::string::npos) << r.err;
  r = run("batch --list " + path("nope.txt"));
  EXPECT_EQ(r.rc, 1);
  EXPECT_NE(r.err.find("nope.txt"), std::string::npos) << r.err;
}

// The batch's defaults are identify's: a logger clock jittering by +-0.2 % of
// the period (steps within 0.4 %, inside the default 1 % tolerance) is read by
// both. The batch once defaulted to 0.1 % and refused it.
TEST_F(CliBatch, DefaultsAreIdentifysOnAJitteredClock) {
  quadid::FlightLog log = flight(1);
  const Eigen::Index t = log.find("t");
  for (Eigen::Index k = 1; k < log.rows(); ++k) log.data(k, t) += ((k % 2) ? 0.002 : -0.002) * 0.002;
  quadid::write_flight_log(log, path("jitter.csv"));
  const nlohmann::ordered_json single = identify_json("jitter.csv", "");
  const auto r = run("batch -q --window " + std::string(kWindow) + " " + path("jitter.csv"));
  ASSERT_EQ(r.rc, 0) << r.out << r.err;
  const auto v = lines(r.out);
  ASSERT_EQ(v.size(), 1u);
  nlohmann::ordered_json expected = single;
  expected["path"] = path("jitter.csv");
  expected["ok"] = true;
  EXPECT_EQ(v[0], expected);
}

TEST(IdentifyBatch, SinkSeesInputOrderWhateverTheCompletionOrder) {
  // 9 missing files fail fast, one real log takes longer: with 3 threads the
  // completion order differs from the input order, the sink's must not.
  const auto dir = std::filesystem::temp_directory_path() / ("quadid_batch_order_" + std::to_string(::getpid()));
  std::filesystem::create_directories(dir);
  quadid::write_flight_log(flight(1), dir / "real.csv");
  std::vector<std::string> paths;
  paths.push_back((dir / "real.csv").string());
  for (int i = 0; i < 9; ++i) paths.push_back((dir / ("none" + std::to_string(i) + ".csv")).string());
  quadid::IdentifyRequest req = quadid::identify_options_from_json({{"window", kWindow}});
  std::vector<size_t> sunk, completed;
  quadid::BatchOptions opt;
  opt.threads = 3;
  const auto s = quadid::identify_batch(
      paths, req, opt, [&](size_t i, const quadid::BatchRecord& r) {
        sunk.push_back(i);
        EXPECT_EQ(r.path, paths[i]);
      },
      [&](size_t done, size_t total, const quadid::BatchRecord&) {
        completed.push_back(done);
        EXPECT_EQ(total, paths.size());
      });
  std::filesystem::remove_all(dir);
  std::vector<size_t> expected(paths.size());
  for (size_t i = 0; i < expected.size(); ++i) expected[i] = i;
  EXPECT_EQ(sunk, expected);
  EXPECT_EQ(completed.size(), paths.size());
  EXPECT_EQ(s.ok, 1u);
  EXPECT_EQ(s.failed, 9u);
  EXPECT_EQ(s.threads, 3);
}

namespace {

// A batch record as to_json(BatchRecord) writes it, with the LS set `theta`
// (m, Ixx, Ixy, Ixz, Iyy, Iyz, Izz), its standard errors `se`, and PC = LS.
nlohmann::ordered_json record(const std::string& path, const std::array<double, 7>& theta, double se,
                      const std::string& recommended = "PC") {
  nlohmann::ordered_json est = nlohmann::ordered_json::object(), unc = nlohmann::ordered_json::object();
  for (size_t j = 0; j < 7; ++j) {
    est[quadid::kThetaNames[j]] = theta[j];
    unc[quadid::kThetaNames[j]] = {{"std_error", se}, {"ci95", {theta[j] - 2 * se, theta[j] + 2 * se}}};
  }
  return {{"path", path},
          {"ok", true},
          {"estimates", {{"LS", est}, {"PC", est}}},
          {"uncertainty", {{"LS", unc}, {"FMLS", unc}}},
          {"recommended", {{"set", recommended}, {"reason", "test"}}}};
}

std::array<double, 7> body(double m) { return {m, 0.012, -0.0008, 0.0001, 0.015, -0.0006, 0.083}; }

}  // namespace

// Six flights (set LS); only the mass varies, the sixth carries a 30 % payload. Against
// the other five (mean 1.0, sd sqrt(6.25e-5)), its t is 0.3 / (sd sqrt(1 + 1/5))
// = 34.64 (closed form), beyond the critical value for 6 tests at 1 % with 4
// degrees of freedom; each other flight, judged against a sample that holds
// the heavy one, is far inside it. The critical value is where the two-sided
// tail equals 0.01 / 6 (to the bisection's 1e-12 relative).
TEST(FleetSummary, LeaveOneOutTFlagsThePayloadFlightOnly) {
  const std::vector<double> masses = {1.0, 1.01, 0.99, 1.005, 0.995, 1.3};
  std::vector<nlohmann::ordered_json> recs;
  for (size_t i = 0; i < masses.size(); ++i) recs.push_back(record(fmt::format("f{}", i), body(masses[i]), 1e-4));
  quadid::FleetSummaryOptions ls;
  ls.set = "LS";
  const quadid::FleetSummary s = quadid::summarize_fleet(recs, ls);
  EXPECT_EQ(s.flights, 6u);
  EXPECT_EQ(s.parameters[0].median_std_error, 1e-4);
  ASSERT_EQ(s.parameters.size(), 7u);
  EXPECT_FALSE(s.parameters[0].fixed);
  for (size_t j = 1; j < 7; ++j) EXPECT_TRUE(s.parameters[j].fixed) << j;
  EXPECT_NEAR(s.parameters[0].mean, 6.3 / 6.0, 1e-15);
  EXPECT_NEAR(1.0 - quadid::student_t_two_sided_cdf(s.critical_t, 4), 0.01 / 6.0, 1e-12 * 0.01);
  ASSERT_EQ(s.outliers.size(), 1u) << s.table();
  EXPECT_EQ(s.outliers[0].path, "f5");
  EXPECT_EQ(s.outliers[0].parameter, "m");
  EXPECT_NEAR(s.outliers[0].others_mean, 1.0, 1e-14);
  EXPECT_NEAR(s.outliers[0].t, 0.3 / (std::sqrt(6.25e-5) * std::sqrt(1.2)), 1e-9);
  // The note: the flights spread far beyond their standard errors (1e-4).
  ASSERT_FALSE(s.notes.empty());
  EXPECT_NE(s.notes.back().find("m: the flights' standard deviation is"), std::string::npos) << s.notes.back();
  const std::string table = s.table();
  EXPECT_NE(table.find("f5"), std::string::npos) << table;
  EXPECT_NE(table.find("fixed"), std::string::npos) << table;
  const nlohmann::ordered_json j = quadid::to_json(s);
  EXPECT_EQ(j["outliers"][0]["path"], "f5");
  EXPECT_EQ(j["parameters"]["Ixx"]["fixed"], true);
  // The recommended set here is PC: the same flags, but no standard errors
  // (LS's do not stand for the projection's), so no note about them.
  const quadid::FleetSummary pc = quadid::summarize_fleet(recs);
  ASSERT_EQ(pc.outliers.size(), 1u);
  EXPECT_TRUE(std::isnan(pc.parameters[0].median_std_error));
  EXPECT_TRUE(pc.notes.empty()) << pc.notes.front();
  EXPECT_TRUE(quadid::to_json(pc)["parameters"]["m"]["median_std_error"].is_null());
}

// Four flights that scatter by 1-2 %: no flight is flagged (flight 0's t is
// 1.24, the critical value 49). A robust rule with a fixed threshold,
// |x - median| > 4 x 1.4826 MAD of the others, flags flight 0 at 67: two of
// the other three agree to 1e-4, so their MAD is 1e-4 (bench/fleet_outliers.py:
// such a rule flags some flight of nearly every fleet of 4).
TEST(FleetSummary, FewFlightsThatAgreeLooselyAreNotFlagged) {
  const std::vector<double> masses = {1.01, 1.0, 1.0001, 0.98};
  std::vector<nlohmann::ordered_json> recs;
  for (size_t i = 0; i < masses.size(); ++i) recs.push_back(record(fmt::format("f{}", i), body(masses[i]), 1e-4));
  const quadid::FleetSummary s = quadid::summarize_fleet(recs);
  EXPECT_TRUE(s.outliers.empty()) << s.table();
  EXPECT_NE(s.table().find("No flight departs from the others"), std::string::npos);
}

// A far outlier holds nearly all of the sum of squares: the others' spread
// (sd 1e-9 about 1.0) is then summed again, not taken as a difference of two
// sums that cancel to 1e-16 relative. Closed form: the others are 1 - 1e-9,
// 1, 1 + 1e-9, 1 (mean 1, sd sqrt(2e-18 / 3)), t = 999 / (sd sqrt(1 + 1/4)).
TEST(FleetSummary, AFarOutlierKeepsTheOthersSpreadExact) {
  const std::vector<double> masses = {1.0 - 1e-9, 1.0, 1.0 + 1e-9, 1.0, 1000.0};
  std::vector<nlohmann::ordered_json> recs;
  for (size_t i = 0; i < masses.size(); ++i) recs.push_back(record(fmt::format("f{}", i), body(masses[i]), 1e-4));
  const quadid::FleetSummary s = quadid::summarize_fleet(recs);
  ASSERT_EQ(s.outliers.size(), 1u) << s.table();
  EXPECT_EQ(s.outliers[0].path, "f4");
  EXPECT_NEAR(s.outliers[0].others_mean, 1.0, 1e-15);
  const double expected = 999.0 / (std::sqrt(2e-18 / 3.0) * std::sqrt(1.25));
  EXPECT_NEAR(s.outliers[0].t / expected, 1.0, 1e-6);  // the 1e-9 steps are exact only to ~1e-7 of themselves
}

TEST(FleetSummary, FailedAndIncompleteRecordsAreSkippedAndSmallOrMixedFleetsNoted) {
  std::vector<nlohmann::ordered_json> recs = {record("a", body(1.0), 1e-4), record("b", body(1.01), 1e-4, "FMPC"),
                                      {{"path", "c"}, {"ok", false}, {"error", "bad"}}};
  nlohmann::ordered_json no_fm = record("d", body(1.0), 1e-4, "FMPC");
  recs.push_back(no_fm);  // recommends FMPC but has no such estimate
  recs[1]["estimates"]["FMPC"] = recs[1]["estimates"]["PC"];
  const quadid::FleetSummary s = quadid::summarize_fleet(recs);
  EXPECT_EQ(s.flights, 2u);
  ASSERT_EQ(s.skipped.size(), 2u);
  EXPECT_EQ(s.skipped[0], "c: not identified");
  EXPECT_NE(s.skipped[1].find("d: no FMPC estimate"), std::string::npos) << s.skipped[1];
  const std::string notes = nlohmann::ordered_json(s.notes).dump();
  EXPECT_NE(notes.find("recommended sets differ (FMPC 1, PC 1)"), std::string::npos) << notes;
  EXPECT_NE(notes.find("2 flights: outliers need 3 or more"), std::string::npos) << notes;
  EXPECT_TRUE(s.outliers.empty());
  EXPECT_TRUE(std::isnan(s.critical_t));
  // One set on every flight: d's LS counts.
  quadid::FleetSummaryOptions ls;
  ls.set = "LS";
  EXPECT_EQ(quadid::summarize_fleet(recs, ls).flights, 3u);
}

TEST(FleetSummary, BadOptionsNameTheirFlag) {
  quadid::FleetSummaryOptions o;
  o.set = "XY";
  EXPECT_THROW(
      try { quadid::summarize_fleet({}, o); } catch (const std::invalid_argument& e) {
        EXPECT_NE(std::string(e.what()).find("--summary-set XY"), std::string::npos) << e.what();
        throw;
      },
      std::invalid_argument);
  o = {};
  o.level = 0.0;
  EXPECT_THROW(quadid::summarize_fleet({}, o), std::invalid_argument);
}

TEST_F(CliBatch, BadSummaryOptionsFailBeforeAnyLogIsRead) {
  auto r = run("batch --outlier-level 2 " + path("a.csv"));
  EXPECT_EQ(r.rc, 1);
  EXPECT_EQ(r.out, "");
  EXPECT_NE(r.err.find("--outlier-level 2"), std::string::npos) << r.err;
  r = run("batch --summary-set best " + path("a.csv"));
  EXPECT_EQ(r.rc, 1);
  EXPECT_NE(r.err.find("--summary-set best: expected recommended, LS"), std::string::npos) << r.err;
}

// The command line end to end: four simulated flights of the QBall, the
// fourth with 10 % more mass in the plant. The table goes to stderr, the JSON
// to --summary; the heavy flight is flagged on m and no other flight is.
TEST_F(CliBatch, ComparesTheFlightsAndFlagsTheHeavyOne) {
  quadid::write_flight_log(flight(3), path("c.csv"));
  quadid::SimulationOptions o;
  o.record_truth = false;
  o.duration = 12.0;
  o.sensors.seed = 4;
  o.plant.m *= 1.1;
  quadid::write_flight_log(quadid::simulate(quadid::FourierTrajectory::table2(), o).log, path("heavy.csv"));
  const auto r = run("batch --window " + std::string(kWindow) + " --summary " + path("summary.json") + " " +
                     path("a.csv") + " " + path("b.csv") + " " + path("c.csv") + " " + path("heavy.csv") + " -o " +
                     path("out.jsonl"));
  ASSERT_EQ(r.rc, 0) << r.err;
  EXPECT_NE(r.err.find("Flights compared: 4 flights, set recommended"), std::string::npos) << r.err;
  const nlohmann::ordered_json s = nlohmann::ordered_json::parse(quadid::read_file(path("summary.json")));
  EXPECT_EQ(s["flights"], 4);
  ASSERT_EQ(s["outliers"].size(), 1u) << s.dump(1);
  EXPECT_EQ(s["outliers"][0]["path"], path("heavy.csv"));
  EXPECT_EQ(s["outliers"][0]["parameter"], "m");
  EXPECT_NEAR(s["outliers"][0]["value"].get<double>() / s["outliers"][0]["others_mean"].get<double>(), 1.1, 0.01);
}

// batch --report DIR: the fleet page shows --summary's numbers (read back from
// the cells' data-value), links every identified log to its own page (which
// exists and is identify --report's page for that log), and lists a failed
// log with the reason, so a person sees the fleet and each flight at a glance.
TEST_F(CliBatch, ReportWritesTheFleetPageAndOnePagePerLog) {
  quadid::write_flight_log(flight(3), path("c.csv"));
  const auto r = run("batch --window " + std::string(kWindow) + " --summary " + path("summary.json") + " --report " +
                     path("fleet") + " " + path("a.csv") + " " + path("b.csv") + " " + path("c.csv") + " " +
                     path("corrupt.csv") + " -o " + path("out.jsonl"));
  ASSERT_EQ(r.rc, 2) << r.err;  // one log failed; the others and the pages are written
  const std::string page = quadid::read_file(path("fleet/index.html"));
  const auto s = nlohmann::ordered_json::parse(quadid::read_file(path("summary.json")));
  for (const char* p : {"m", "Ixx", "Izz"}) {
    const double mean = s["parameters"][p]["mean"].get<double>();
    EXPECT_NE(page.find(fmt::format("data-value=\"{:.17g}\"", mean)), std::string::npos) << p << " mean " << mean;
  }
  for (const auto& [k, log] : std::vector<std::pair<int, std::string>>{{1, "a"}, {2, "b"}, {3, "c"}}) {
    const std::string rel = fmt::format("flights/{:03d}-{}.html", k, log);
    EXPECT_NE(page.find("href=\"" + rel + "\""), std::string::npos) << rel;
    const std::string own = quadid::read_file(path("fleet/" + rel));
    EXPECT_NE(own.find("Recommended set"), std::string::npos) << rel;
    EXPECT_NE(own.find(path(log + ".csv")), std::string::npos) << rel;
  }
  EXPECT_FALSE(std::filesystem::exists(path("fleet/flights/004-corrupt.html")));
  EXPECT_NE(page.find("FAILED: " + quadid::report::html_escape(path("corrupt.csv"))), std::string::npos);
  EXPECT_NE(page.find("3 of 4 logs identified"), std::string::npos);
}

TEST_F(CliBatch, ReportIntoAFileIsRefusedBeforeAnyLogIsRead) {
  write("taken", "x");
  const auto r = run("batch --report " + path("taken") + " " + path("a.csv"));
  EXPECT_EQ(r.rc, 1);
  EXPECT_EQ(r.out, "");
  EXPECT_NE(r.err.find("--report"), std::string::npos) << r.err;
}
