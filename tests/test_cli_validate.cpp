// End-to-end tests of `quadid validate` and `quadid reproduce`.
#include "cli_fixture.hpp"
#include "quadid/io.hpp"

#include <fmt/format.h>
#include <nlohmann/json.hpp>

#include <fstream>

using quadid::testing::CliRun;
using quadid::testing::CliTest;

class CliValidate : public CliTest {};

TEST_F(CliValidate, JudgesAnIdentifyResultAsFourSetsPlusFiles) {
  ASSERT_EQ(run("simulate --trajectory table2 --duration 14 --noise default -o " + path("log.csv")).rc, 0);
  // A short window: gradient descent may end on an unphysical set, which is
  // still judged by its prediction error (with a warning), not refused.
  const CliRun id = run("identify " + path("log.csv") + " --window 4:14 -o " + path("result.json"));
  ASSERT_EQ(id.rc, 0) << id.err;
  const CliRun r = run("validate --log " + path("log.csv") + " --params " + path("result.json") +
                       " --params qball2-virtual --window 4:14 --json");
  ASSERT_EQ(r.rc, 0) << r.err;
  const auto j = nlohmann::ordered_json::parse(r.out);  // stdout holds only the JSON
  EXPECT_EQ(j["sets"].size(), 7u);  // the six sets of identify (PC, FMPC too) and the preset
  for (const char* k : {"LS", "GD", "FMLS", "FMGD", "PC", "FMPC", "qball2-virtual"}) EXPECT_TRUE(j["sets"].contains(k)) << k;
  EXPECT_EQ(j["simulation"]["rows"].size(), 7u);
  EXPECT_TRUE(j["prediction_error"].contains("standard"));
  EXPECT_TRUE(j["prediction_error"].contains("filtered"));
  // The text form prints the Table 4 layout and both prediction tables.
  const CliRun t = run("validate --log " + path("log.csv") + " --params qball2-virtual --window 4:14");
  ASSERT_EQ(t.rc, 0) << t.err;
  EXPECT_NE(t.out.find("e_tau_psi"), std::string::npos);
  EXPECT_NE(t.out.find("filtered regression"), std::string::npos);
}

TEST_F(CliValidate, RealFlightTermsWithoutAVehicleAreNamedAsNotApplied) {
  // A result identified with real-flight terms, judged on a log without a
  // vehicle: the paper's rows have no place for them, so the sets are judged
  // as bodies and stderr names the terms left out and what would apply them.
  ASSERT_EQ(run("simulate --trajectory table2 --duration 14 --noise default -o " + path("log.csv")).rc, 0);
  const CliRun id = run("identify " + path("log.csv") + " --window 4:14 --terms offsets,damping -o " + path("r.json"));
  ASSERT_EQ(id.rc, 0) << id.err;
  const CliRun r = run("validate --log " + path("log.csv") + " --params " + path("r.json") + " --no-simulation --json");
  ASSERT_EQ(r.rc, 0) << r.err;
  EXPECT_NE(r.err.find("LS: its real-flight terms (damping_x, damping_y, damping_z, offset_x, offset_y, offset_z) are "
                       "not applied"),
            std::string::npos)
      << r.err;
  EXPECT_NE(r.err.find("give the vehicle to judge it with them"), std::string::npos) << r.err;
  const auto j = nlohmann::ordered_json::parse(r.out);
  EXPECT_FALSE(j["prediction_error"]["real_flight_terms"].get<bool>());
  EXPECT_TRUE(j["sets"]["LS"]["extra"].contains("damping_x")) << j["sets"]["LS"].dump();
  EXPECT_FALSE(j["sets"]["GD"].contains("extra"));
}

TEST_F(CliValidate, LogWithoutMetadataSkipsSimulationWithANote) {
  ASSERT_EQ(run("simulate --trajectory table2 --duration 6 -o " + path("log.csv")).rc, 0);
  // Strip the '#' metadata, as a log from another tool would have none.
  std::ifstream in(path("log.csv"));
  std::ofstream out(path("plain.csv"));
  for (std::string line; std::getline(in, line);)
    if (line.empty() || line[0] != '#') out << line << "\n";
  out.close();
  const CliRun r = run("validate --log " + path("plain.csv") + " --params qball2-virtual --window 1:6");
  ASSERT_EQ(r.rc, 0) << r.err;
  EXPECT_NE(r.err.find("--trajectory"), std::string::npos);
  EXPECT_EQ(r.out.find("Table 4"), std::string::npos);
  // With --trajectory it re-flies with the default controller.
  const CliRun s = run("validate --log " + path("plain.csv") + " --params qball2-virtual --window 1:6 --trajectory table2");
  ASSERT_EQ(s.rc, 0) << s.err;
  EXPECT_NE(s.out.find("e_x"), std::string::npos);
}

// Issue 8 item 2: a log from another tool at 100 or 250 Hz, without quadid's
// metadata. Sensors follow the log's rate, the re-flight keeps a 1 ms step, and
// every set is flown: every Table 4 number is finite, no row says "diverged".
TEST_F(CliValidate, SimulateIdentifyAndValidateAtLogRatesWithoutMetadata) {
  for (const int rate : {100, 250}) {
    SCOPED_TRACE(rate);
    const std::string log = path("log" + std::to_string(rate) + ".csv");
    const std::string plain = path("plain" + std::to_string(rate) + ".csv");
    const std::string result = path("result" + std::to_string(rate) + ".json");
    // --rate alone: the IMU (500 Hz by default) is capped at the log rate.
    const CliRun sim = run("simulate --trajectory table2 --duration 30 --rate " + std::to_string(rate) + " -o " + log);
    ASSERT_EQ(sim.rc, 0) << sim.err;
    {
      std::ifstream in(log);
      std::ofstream out(plain);
      for (std::string line; std::getline(in, line);)
        if (line.empty() || line[0] != '#') out << line << "\n";
    }
    const CliRun id = run("identify " + plain + " --window 5:30 -o " + result);
    ASSERT_EQ(id.rc, 0) << id.err;
    const CliRun v = run("validate --log " + plain + " --params " + result + " --trajectory table2 --window 5:30 --json");
    ASSERT_EQ(v.rc, 0) << v.err;
    EXPECT_NE(v.err.find(fmt::format("at {} Hz", rate)), std::string::npos) << v.err;
    const auto j = nlohmann::ordered_json::parse(v.out);
    const auto& sim_j = j["simulation"];
    EXPECT_FALSE(sim_j["reference"].contains("failure")) << sim_j["reference"].dump();
    ASSERT_EQ(sim_j["rows"].size(), 6u);  // LS, GD, FMLS, FMGD, PC, FMPC
    for (const auto& row : sim_j["rows"]) {
      EXPECT_FALSE(row.contains("failure")) << row.dump();
      for (const auto& [signal, v] : row["rms"].items()) EXPECT_TRUE(v.is_number()) << row["name"] << " " << signal;
      for (const auto& [signal, v] : row["improvement_pct"].items())
        EXPECT_TRUE(v.is_number()) << row["name"] << " " << signal;
    }
    for (const auto& [signal, v] : sim_j["reference"]["rms"].items()) EXPECT_TRUE(v.is_number()) << signal;
    const CliRun t = run("validate --log " + plain + " --params " + result + " --trajectory table2 --window 5:30");
    ASSERT_EQ(t.rc, 0) << t.err;
    EXPECT_EQ(t.out.find("diverged"), std::string::npos) << t.out;
    EXPECT_EQ(t.out.find("nan"), std::string::npos) << t.out;
  }
}

TEST_F(CliValidate, BadInputNamesTheFile) {
  ASSERT_EQ(run("simulate --trajectory table2 --duration 3 -o " + path("log.csv")).rc, 0);
  std::ofstream(path("bad.json")) << "{\"m\": 1.8, \"Ixx\": -0.01, \"Iyy\": 0.01, \"Izz\": 0.02}";
  const CliRun r = run("validate --log " + path("log.csv") + " --params " + path("bad.json"));
  EXPECT_NE(r.rc, 0);
  EXPECT_NE(r.err.find("bad.json"), std::string::npos) << r.err;
  EXPECT_NE(r.err.find("positive definite"), std::string::npos) << r.err;
  const CliRun m = run("validate --log " + path("missing.csv") + " --params qball2-virtual");
  EXPECT_NE(m.rc, 0);
  EXPECT_NE(m.err.find("missing.csv"), std::string::npos);
  EXPECT_TRUE(m.out.empty());
}

class CliReproduce : public CliTest {};

// The paper's reproduction with the Table 2 trajectory (no design, so it takes
// about a second): the whole chain runs, the report holds every table and
// figure, and the estimated sets beat the nominal one in output prediction
// error on every flight and component (issue 5).
TEST_F(CliReproduce, Table2RunWritesACompleteReport) {
  const CliRun r = run("reproduce --trajectory table2 --out " + path("rep"));
  ASSERT_EQ(r.rc, 0) << r.err;
  for (int t = 3; t <= 12; ++t) EXPECT_NE(r.out.find("Table " + std::to_string(t) + "."), std::string::npos) << t;
  EXPECT_NE(r.err.find("identifying"), std::string::npos);  // progress goes to stderr
  for (const char* f : {"report.html", "summary.json", "trajectory.json", "identification.json", "evolution.csv",
                        "flight_identification.csv", "tables.md"})
    EXPECT_TRUE(std::filesystem::exists(path("rep/") + f)) << f;
  // Issue 13: the other flights' logs only with --full-logs (the folder stays small).
  for (const char* f : {"flight_circle1.csv", "simulation_LS.csv"})
    EXPECT_FALSE(std::filesystem::exists(path("rep/") + f)) << f;
  // Every estimate's error against the true plant is shown (Table 3 with "true" and "error %").
  EXPECT_NE(r.out.find("true"), std::string::npos);
  EXPECT_NE(r.out.find("err%"), std::string::npos);
  const std::string html = quadid::read_file(path("rep/report.html"));
  for (int f = 1; f <= 9; ++f) EXPECT_NE(html.find("Figure " + std::to_string(f) + "."), std::string::npos) << f;
  // One script only: the layout self-check, inert unless the page is opened as #layout-check.
  const auto script = html.find("<script");
  ASSERT_NE(script, std::string::npos);
  EXPECT_EQ(html.find("<script", script + 1), std::string::npos);
  EXPECT_NE(html.find("#layout-check", script), std::string::npos);
  EXPECT_EQ(html.find("nan"), std::string::npos);
  // Issue 8 item 8: the page ends by saying what to conclude, and the desired path is drawn.
  const auto concl = html.find("<div class=\"conclusions\" id=\"conclusions\">");
  ASSERT_NE(concl, std::string::npos);
  EXPECT_NE(html.find("<p><b>Use ", concl), std::string::npos);
  EXPECT_EQ(html.find("<h2>", concl), std::string::npos);  // the last section
  EXPECT_NE(html.find(">desired</text>"), std::string::npos);
  const auto s = nlohmann::ordered_json::parse(quadid::read_file(path("rep/summary.json")));
  auto all_improve = [](const nlohmann::ordered_json& table, const std::string& where) {
    for (const auto& row : table["sets"])
      for (const auto& p : row["improvement_pct"]) EXPECT_GT(p.get<double>(), 0.0) << where << " " << row["name"];
  };
  all_improve(s["identification"]["prediction_error"]["standard"], "identification standard");
  all_improve(s["identification"]["prediction_error"]["filtered"], "identification filtered");
  for (const auto& c : s["circles"]) {
    all_improve(c["standard"], c["name"].get<std::string>());
    all_improve(c["filtered"], c["name"].get<std::string>());
  }
}

// Same seed, same options: the same report and data, byte for byte (with
// --full-logs: every flight's log, though the flights run on two threads).
TEST_F(CliReproduce, SameSeedSameBytes) {
  for (const char* d : {"a", "b"}) {
    const CliRun r =
        run(std::string("reproduce --trajectory table2 --duration 20 --seed 5 --full-logs --out ") + path(d));
    ASSERT_EQ(r.rc, 0) << r.err;
  }
  for (const char* f : {"report.html", "summary.json", "identification.json", "flight_identification.csv",
                        "flight_circle1.csv", "flight_circle2.csv", "flight_circle3.csv", "simulation_nom.csv",
                        "simulation_FMGD.csv", "evolution.csv", "tables.md"})
    EXPECT_EQ(quadid::read_file(path("a/") + f), quadid::read_file(path("b/") + f)) << f;
}
