// `quadid batch` (the built program) and the library's identify_batch: JSON
// Lines in input order, each line the result of `quadid identify --json` on
// that log, failing logs reported without stopping the others, exit codes.
#include "cli_fixture.hpp"
#include "quadid/batch.hpp"
#include "quadid/io.hpp"
#include "quadid/simulation.hpp"

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

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

std::vector<nlohmann::json> lines(const std::string& out) {
  std::vector<nlohmann::json> v;
  std::istringstream in(out);
  for (std::string l; std::getline(in, l);) v.push_back(nlohmann::json::parse(l));  // one object per line
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
  nlohmann::json identify_json(const std::string& log, const std::string& opts) const {
    const auto r = run("identify " + path(log) + " --json --window " + kWindow + " " + opts);
    EXPECT_EQ(r.rc, 0) << r.err;
    return nlohmann::json::parse(r.out);
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
  const nlohmann::json ja = identify_json("a.csv", opts), jb = identify_json("b.csv", opts);
  for (size_t i = 0; i < v.size(); ++i) {
    EXPECT_EQ(v[i]["path"], path(order[i])) << i;
    const bool ok = i != 1 && i != 3;
    EXPECT_EQ(v[i]["ok"], ok) << i;
    if (!ok) {
      EXPECT_EQ(v[i].size(), 3u) << v[i].dump();  // path, ok, error
      EXPECT_NE(v[i]["error"].get<std::string>().find(path(order[i])), std::string::npos) << v[i]["error"];
      continue;
    }
    nlohmann::json expected = (order[i] == "a.csv") ? ja : jb;
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
  EXPECT_NE(r.err.find("'cutoff' (--cutoff): expected a number, got \"fast\""), std::string::npos) << r.err;
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
  const nlohmann::json single = identify_json("jitter.csv", "");
  const auto r = run("batch -q --window " + std::string(kWindow) + " " + path("jitter.csv"));
  ASSERT_EQ(r.rc, 0) << r.out << r.err;
  const auto v = lines(r.out);
  ASSERT_EQ(v.size(), 1u);
  nlohmann::json expected = single;
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
