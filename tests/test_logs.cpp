// Autopilot logs: ULog reader/writer, Crazyflie uSD reader, listings, import.
// Reference values: pyulog's listings of the PX4 samples (../shared/data/px4-ulog,
// an implementation that is not ours), tests/data/logs/usd_reference.py (Python
// struct + zlib) for the real Crazyflie logs, CRC-32's published check value,
// and closed-form signals written with our writer.
#include "quadid/logs.hpp"
#include "quadid/pipeline.hpp"

#include "cli_fixture.hpp"
#include "mutations.hpp"

#include <fmt/format.h>
#include <gtest/gtest.h>

#include "px4_sim_log.hpp"
#include "shared_data.hpp"

#include <cmath>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <numbers>
#include <random>
#include <sstream>

namespace quadid::logs {
namespace {

namespace fs = std::filesystem;
constexpr double kPi = std::numbers::pi;

#ifdef QUADID_SHARED_DATA
const fs::path kShared = QUADID_SHARED_DATA;
#else
const fs::path kShared = "/nonexistent";
#endif

std::span<const std::uint8_t> bytes_of(const std::string& s) {
  return {reinterpret_cast<const std::uint8_t*>(s.data()), s.size()};
}

LoadOptions no_required_check() {
  LoadOptions o;
  o.check_required = false;
  return o;
}

std::vector<std::string> lines_of(const std::string& text) {
  std::vector<std::string> v;
  std::istringstream in(text);
  for (std::string l; std::getline(in, l);) v.push_back(l);
  return v;
}

// --- ULog writer -> reader round trip -----------------------------------------

// A file with every message kind: nested type, arrays, interior and trailing
// padding (data messages leave the trailing padding out), multi ids.
std::string rich_ulog() {
  ULogWriter w(1'000'000);
  w.format("vec3:float[3] v;uint8_t flag;uint8_t[3] _padding0;");
  w.format("esc_report:int32_t esc_rpm;uint8_t[4] _padding0;");
  w.format("sensor:uint64_t timestamp;vec3 acc;int16_t[2] raw;bool ok;uint8_t[5] _padding0;");
  w.format("esc_status:uint64_t timestamp;esc_report[2] esc;uint8_t esc_count;uint8_t[7] _padding0;");
  w.info("sys_name", "PX4");
  w.info("ver_data_format", std::uint32_t{1});
  w.info("time_ref_utc", std::int32_t{-7});
  w.info_multiple("boot", "part one", false);
  w.info_multiple("boot", "part two", true);
  w.info_multiple("boot", "second", false);
  w.parameter("MC_ROLL_P", 6.5f);
  w.parameter("CA_ROTOR_COUNT", std::int32_t{4});
  w.default_parameter(1, "MC_ROLL_P", 6.0f);
  w.default_parameter(3, "MPC_XY_P", 0.95f);
  const auto s0 = w.subscribe("sensor", 0);
  const auto s1 = w.subscribe("sensor", 1);
  const auto esc = w.subscribe("esc_status", 0);
  for (int k = 0; k < 10; ++k) {
    const std::uint64_t t = 2'000'000 + 10'000u * static_cast<std::uint64_t>(k);
    ULogPayload p;
    // sensor: timestamp, acc.v[3], acc.flag, acc._padding0[3], raw[2], ok; trailing padding left out
    p.put(t).put(0.5f * k).put(-1.0f).put(9.81f).put(std::uint8_t{1}).pad(3).put(std::int16_t(-k)).put(std::int16_t(300)).put(std::uint8_t{1});
    w.data(s0, p.str());
    if (k % 2 == 0) {
      ULogPayload q;  // the full size, with its trailing padding
      q.put(t + 1).put(1.0f).put(2.0f).put(3.0f).put(std::uint8_t{0}).pad(3).put(std::int16_t(7)).put(std::int16_t(8)).put(std::uint8_t{0}).pad(5);
      w.data(s1, q.str());
    }
    ULogPayload e;
    e.put(t).put(std::int32_t(10000 + k)).pad(4).put(std::int32_t(-20000 - k)).pad(4).put(std::uint8_t{2});
    w.data(esc, e.str());
    if (k == 3) {
      w.dropout(42);
      w.logged('4', t, "low battery");
      w.parameter("MC_ROLL_P", 7.0f);
    }
    if (k == 5) {
      w.logged_tagged('6', 17, t, "tagged hello");
      w.sync();
      w.raw('Z', "future message type");
    }
  }
  return w.bytes();
}

TEST(ULog, WriterRoundTripAllMessageKinds) {
  const ULog log = parse_ulog(bytes_of(rich_ulog()), "rich");
  EXPECT_EQ(log.start_timestamp, 1'000'000u);
  EXPECT_EQ(log.last_timestamp, 2'090'000u);
  EXPECT_EQ(log.info.at("sys_name").to_string(), "PX4");
  EXPECT_EQ(log.info.at("ver_data_format").to_string(), "1");
  EXPECT_EQ(log.info.at("time_ref_utc").number().value(), -7.0);
  ASSERT_EQ(log.info_multiple.at("boot").size(), 2u);
  EXPECT_EQ(log.info_multiple.at("boot")[0].size(), 2u);  // continued
  EXPECT_EQ(log.info_multiple.at("boot")[0][1].bytes, "part two");
  EXPECT_EQ(log.parameters.at("MC_ROLL_P").number().value(), 6.5);
  EXPECT_EQ(log.parameter("MC_ROLL_P").value(), 7.0);  // changed in flight
  ASSERT_EQ(log.changed_parameters.size(), 1u);
  EXPECT_EQ(log.changed_parameters[0].timestamp, 2'030'000u);
  EXPECT_EQ(log.default_parameters_system.at("MC_ROLL_P").number().value(), 6.0);
  EXPECT_EQ(log.default_parameters_config.count("MC_ROLL_P"), 0u);
  EXPECT_EQ(log.default_parameters_config.count("MPC_XY_P"), 1u);
  ASSERT_EQ(log.dropouts.size(), 1u);
  EXPECT_EQ(log.dropouts[0].duration_ms, 42);
  EXPECT_EQ(log.dropouts[0].timestamp, 2'030'000u);
  ASSERT_EQ(log.logged.size(), 2u);
  EXPECT_EQ(log.logged[0].level_name(), "WARNING");
  EXPECT_FALSE(log.logged[0].tag.has_value());
  EXPECT_EQ(log.logged[1].tag.value(), 17);
  EXPECT_EQ(log.logged[1].message, "tagged hello");
  EXPECT_EQ(log.sync_count, 1u);
  EXPECT_EQ(log.unknown_messages, 1u);

  ASSERT_EQ(log.topics.size(), 3u);  // esc_status0, sensor0, sensor1 (pyulog's order)
  EXPECT_EQ(log.topics[0].name, "esc_status");
  const ULogTopic* s0 = log.find_topic("sensor", 0);
  const ULogTopic* s1 = log.find_topic("sensor", 1);
  ASSERT_TRUE(s0 && s1);
  // 8 + 3*4 + 1 + 3 (interior padding) + 2*2 + 1 = 29; trailing padding dropped
  EXPECT_EQ(s0->size, 29u);
  EXPECT_EQ(s0->count(), 10u);
  EXPECT_EQ(s1->count(), 5u);
  EXPECT_EQ(s0->column("acc.v[0]")[4], 2.0);
  EXPECT_EQ(s0->column("acc.v[2]")[0], static_cast<double>(9.81f));
  EXPECT_EQ(s0->column("raw[0]")[9], -9.0);
  EXPECT_EQ(s0->column("ok")[3], 1.0);
  EXPECT_EQ(s1->column("raw[1]")[2], 8.0);
  EXPECT_EQ(s1->timestamps()[1], 2'020'001u);
  const ULogTopic* e = log.find_topic("esc_status");
  EXPECT_EQ(e->column("esc[1].esc_rpm")[7], -20007.0);
  EXPECT_EQ(e->column("esc_count")[0], 2.0);
  EXPECT_THROW(s0->column("nope"), InputError);
}

TEST(ULog, ListingHasPyulogLayout) {
  const ULog log = parse_ulog(bytes_of(rich_ulog()), "rich");
  const auto lines = lines_of(format_ulog_info(log, false));
  EXPECT_EQ(lines[0], "Logging start time: 0:00:01, duration: 0:00:01");
  EXPECT_EQ(lines[1], "Dropouts: count: 1, total duration: 0.0 s, max: 42 ms, mean: 42 ms");
  EXPECT_EQ(lines[6], "Info Multiple Messages: [boot: 2]");
  EXPECT_EQ(lines[9], " esc_status (0, 25)                            10        250");
  EXPECT_EQ(lines[10], " sensor (0, 29)                                10        290");
  const std::string text = format_ulog_info(log, true);
  EXPECT_NE(text.find(" boot: [['part one', 'part two'], ['second']]"), std::string::npos);
  EXPECT_NE(text.find(" MC_ROLL_P: 6.5  [default: 6.0]"), std::string::npos);
  EXPECT_NE(text.find("0:00:02 MC_ROLL_P: 7.0"), std::string::npos);
  EXPECT_NE(text.find("0:00:02 INFO: [tag 17] tagged hello"), std::string::npos);
  const auto j = ulog_info_json(log);
  EXPECT_EQ(j["topics"][1]["count"], 10);
  EXPECT_EQ(j["parameters"]["CA_ROTOR_COUNT"], 4.0);
}

TEST(ULog, AppendedDataIsReadAfterThePartialMessageBeforeIt) {
  ULogWriter w(0);
  w.format("t:uint64_t timestamp;float x;");
  const auto id = w.subscribe("t");
  for (int k = 0; k < 3; ++k) w.data(id, ULogPayload().put(std::uint64_t(k + 1)).put(1.0f * k).str());
  std::string b = w.bytes();
  b += std::string("\xc8\x00\x44\x00\x00\x09", 6);  // a data message of 200 bytes cut short by a crash
  const std::uint64_t offset = b.size();
  ULogPayload m;
  m.put(std::uint16_t{14}).put(std::uint8_t{'D'}).put(std::uint16_t{0}).put(std::uint64_t{99}).put(4.0f);
  b += m.str();
  // Without the flag the partial message is an error that names its offset.
  try {
    parse_ulog(bytes_of(b), "f");
    FAIL() << "expected InputError";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("byte " + std::to_string(offset - 6)), std::string::npos) << e.what();
  }
  // Flag bits: incompat[0] bit 0 (data appended) and the offset.
  b[16 + 3 + 8] = 1;
  std::memcpy(&b[16 + 3 + 16], &offset, 8);
  const ULog log = parse_ulog(bytes_of(b), "f");
  ASSERT_EQ(log.appended_offsets.size(), 1u);
  const ULogTopic* t = log.find_topic("t");
  ASSERT_EQ(t->count(), 4u);
  EXPECT_EQ(t->column("x")[3], 4.0);
  EXPECT_EQ(log.last_timestamp, 99u);
}

TEST(ULog, ErrorsNameTheOffsetAndWhatWasExpected) {
  const std::string good = rich_ulog();
  auto message_of = [](const std::string& b, const ULogReadOptions& o = {}) -> std::string {
    try {
      parse_ulog(bytes_of(b), "x.ulg", o);
    } catch (const InputError& e) {
      return e.what();
    }
    return "";
  };
  EXPECT_NE(message_of("ULog").find("x.ulg: byte 0"), std::string::npos);
  EXPECT_NE(message_of("PK\x03\x04 not a ulog file").find("not a ULog file"), std::string::npos);
  const std::string cut = good.substr(0, good.size() - 5);
  const std::string m = message_of(cut);
  EXPECT_NE(m.find("the file ends"), std::string::npos) << m;
  EXPECT_EQ(message_of(cut, {.allow_truncated = true}), "");
  std::string flags = good;
  flags[16 + 3 + 8] = 2;  // unknown incompatible flag
  EXPECT_NE(message_of(flags).find("unknown incompatible flag"), std::string::npos);
  // A format that nests itself ends at the depth limit, not in a stack overflow.
  ULogWriter w;
  w.format("loop:uint64_t timestamp;loop inner;");
  w.subscribe("loop");
  EXPECT_NE(message_of(w.bytes()).find("nested more than"), std::string::npos);
}

// --- The PX4 samples against pyulog's listings ----------------------------------

struct Sample {
  const char* name;
  bool has_info;
  bool verbose;
  std::vector<std::string> event_lines;  // reference lines decoded from PX4 events (not decoded here)
};

std::string slurp(const fs::path& p) {
  std::ifstream in(p, std::ios::binary);
  std::ostringstream ss;
  ss << in.rdbuf();
  return ss.str();
}

TEST(ULogSamples, ReproducePyulogListings) {
  const fs::path dir = kShared / "px4-ulog";
  QUADID_REQUIRE_SHARED_FILE(dir / "sample.ulg");
  const std::vector<Sample> samples = {
      {"sample", true, false, {}},
      {"sample_log_small", true, false, {}},
      {"sample_appended_multiple", true, true, {}},
      {"sample_px4_events",
       true,
       false,
       {"475214:49:10 INFO: logging: opening log file 2024-3-18/14_49_10.ulg",
        "475214:49:25 INFO: Armed by internal command", "475214:49:25 INFO: Using default takeoff altitude: 2.50 m",
        "475214:49:27 INFO: Takeoff detected", "475214:49:32 INFO: RTL: start return at 491 m (3 m above destination)",
        "475214:49:32 INFO: RTL: land at destination", "475214:49:38 INFO: Landing detected",
        "475214:49:40 INFO: Disarmed by landing"}},
      {"sample_logging_tagged_and_default_params",
       false,
       false,
       {"0:00:00 INFO: logging: opening log file 2022-4-29/8_45_27.ulg"}},
  };
  for (const auto& s : samples) {
    SCOPED_TRACE(s.name);
    const ULog log = read_ulog(dir / (std::string(s.name) + ".ulg"));
    const auto mine = lines_of(format_ulog_info(log, s.verbose));
    if (s.has_info) {
      // Header, dropouts, info, multi-info, every topic with multi id, size, count, bytes.
      const auto ref = lines_of(slurp(dir / (std::string(s.name) + "_info.txt")));
      ASSERT_GE(mine.size(), ref.size());
      for (std::size_t i = 0; i < ref.size(); ++i) EXPECT_EQ(mine[i], ref[i]) << "line " << i + 1;
    }
    // Logged messages as ulog_messages prints them: plain strings, except the
    // copies PX4 writes of events (ending in a tab), and the events themselves.
    std::vector<std::string> expected;
    for (const auto& l : lines_of(slurp(dir / (std::string(s.name) + "_messages.txt"))))
      if (std::find(s.event_lines.begin(), s.event_lines.end(), l) == s.event_lines.end()) expected.push_back(l);
    std::vector<std::string> got;
    for (const auto& m : log.logged) {
      if (m.tag || (!m.message.empty() && m.message.back() == '\t')) continue;
      const auto sec = m.timestamp / 1000000u;
      got.push_back(fmt::format("{}:{:02}:{:02} {}: {}", sec / 3600, (sec / 60) % 60, sec % 60, m.level_name(),
                                m.message));
    }
    EXPECT_EQ(got, expected);
  }
}

TEST(ULogSamples, TaggedLogHasDefaultParametersAndRotorGeometry) {
  const fs::path f = kShared / "px4-ulog" / "sample_logging_tagged_and_default_params.ulg";
  QUADID_REQUIRE_SHARED_FILE(f);
  const ULog log = read_ulog(f);
  EXPECT_FALSE(log.default_parameters_system.empty());
  std::size_t tagged = 0;
  for (const auto& m : log.logged) tagged += m.tag.has_value();
  EXPECT_EQ(tagged, 3u);  // the three "tagged message test" strings
}

TEST(ULogSamples, ImportOfTheSitlFlightClimbsUp) {
  // sample_px4_events: take-off to 2.5 m ("Using default takeoff altitude:
  // 2.50 m" in its messages) and landing, jMAVSim. With NED -> z up, z starts
  // near 0 on the ground and rises by more than 2 m; motors from actuator_motors.
  const fs::path f = kShared / "px4-ulog" / "sample_px4_events.ulg";
  QUADID_REQUIRE_SHARED_FILE(f);
  ImportReport rep;
  const FlightLog log = import_ulog(read_ulog(f), {}, &rep);
  const auto z = log.column("z");
  EXPECT_LT(std::abs(z[0]), 0.2);
  EXPECT_GT(z.maxCoeff(), 2.0);
  EXPECT_LT(z.maxCoeff(), 3.0);
  EXPECT_TRUE(log.has("actuator_motors.control[3]"));
  EXPECT_FALSE(log.has("actuator_motors.control[4]"));
  EXPECT_LE(log.column("actuator_motors.control[0]").maxCoeff(), 1.0);
  // The other samples import too (old logs: rates from vehicle_attitude).
  for (const char* name : {"sample.ulg", "sample_log_small.ulg"}) {
    const FlightLog g = import_ulog(read_ulog(kShared / "px4-ulog" / name));
    EXPECT_GT(g.rows(), 1000) << name;
  }
}

TEST(ULogSamples, SitlFlightAtDefaultLogRatesIsRefusedForIdentification) {
  // sample_px4_events was logged with PX4's default profile: pyulog's listing
  // (sample_px4_events_info.txt) counts 313 actuator_motors and 313
  // vehicle_local_position messages in 31 s (10 Hz) and 1558
  // vehicle_angular_velocity (50 Hz). Linear interpolation keeps ~2.5 Hz of a
  // 10 Hz topic; the moment rows use 8 Hz, the force row 4 Hz: both topics
  // are named, the gyro (50 Hz >= 4 x 8 Hz) is not.
  const fs::path f = kShared / "px4-ulog" / "sample_px4_events.ulg";
  QUADID_REQUIRE_SHARED_FILE(f);
  ImportReport rep;
  (void)import_ulog(read_ulog(f), {}, &rep);
  EXPECT_NEAR(rep.column_sources.at("actuator_motors.control[0]").rate_hz, 313.0 / 31.0, 0.5);
  EXPECT_EQ(rep.column_sources.at("x").topic, "vehicle_local_position");
  EXPECT_NEAR(rep.column_sources.at("p").rate_hz, 1558.0 / 31.0, 1.0);
  quadid::IdentifyRequest req;
  try {
    (void)quadid::prepare_identification(f.string(), req);
    FAIL() << "expected the sample-rate check to refuse the log";
  } catch (const quadid::InputError& e) {
    const std::string w = e.what();
    EXPECT_NE(w.find("actuator_motors (actuator_motors.control[0]) was logged at 10.0 Hz"), std::string::npos) << w;
    EXPECT_NE(w.find("vehicle_local_position (x) was logged at 10."), std::string::npos) << w;
    EXPECT_EQ(w.find("vehicle_angular_velocity"), std::string::npos) << w;
    EXPECT_NE(w.find("--ignore-input-errors"), std::string::npos) << w;
  }
  req.options.ignore_input_errors = true;
  const quadid::IdentificationInput in = quadid::prepare_identification(f.string(), req);
  ASSERT_FALSE(in.warnings.empty());
  bool named = false;
  for (const auto& w : in.warnings) named = named || w.find("input check sample rate: actuator_motors") == 0;
  EXPECT_TRUE(named);
}

TEST(ULogSamples, SourceRateFindingsAgainstTheCutoffs) {
  ImportReport rep;
  rep.column_sources["m1"] = {"esc_status", 10.0};
  rep.column_sources["p"] = {"vehicle_angular_velocity", 400.0};
  rep.column_sources["x"] = {"vehicle_local_position", 10.0};
  quadid::IdentificationOptions opt;  // cutoffs 4 Hz
  auto f = quadid::source_rate_findings(rep, {"m1"}, opt);
  ASSERT_EQ(f.size(), 2u);  // 10 Hz < 4 x 4 Hz for the rotors and the position
  EXPECT_EQ(f[0].rfind("esc_status (m1) was logged at 10.0 Hz", 0), 0u) << f[0];
  opt.moment_cutoff_hz = 2.5;  // 10 Hz >= 4 x 2.5 Hz: the rotors pass
  opt.force_cutoff_hz = 2.5;
  EXPECT_TRUE(quadid::source_rate_findings(rep, {"m1"}, opt).empty());
  EXPECT_TRUE(quadid::source_rate_findings(ImportReport{}, {"m1"}, opt).empty());  // a CSV: nothing known
}

// --- Rotor geometry from CA_ROTOR* ---------------------------------------------

TEST(ULog, RotorGeometryFromControlAllocationParameters) {
  ULogWriter w;
  w.parameter("CA_ROTOR_COUNT", std::int32_t{4});
  // PX4 quad X (FRD): rotor 0 front right CCW, 1 rear left CCW, 2 front left CW, 3 rear right CW.
  const float px[] = {0.15f, -0.15f, 0.15f, -0.15f}, py[] = {0.25f, -0.25f, -0.25f, 0.25f};
  const float km[] = {0.05f, 0.05f, -0.05f, -0.05f};
  for (int i = 0; i < 4; ++i) {
    w.parameter(fmt::format("CA_ROTOR{}_PX", i), px[i]);
    w.parameter(fmt::format("CA_ROTOR{}_PY", i), py[i]);
    w.parameter(fmt::format("CA_ROTOR{}_KM", i), km[i]);
    w.parameter(fmt::format("CA_ROTOR{}_CT", i), 6.5f);
  }
  w.parameter("CA_ROTOR2_PZ", 0.01f);
  const RotorGeometry g = px4_rotor_geometry(parse_ulog(bytes_of(w.bytes()), "g"));
  ASSERT_EQ(g.count, 4);
  // FRD -> FLU: y and z change sign.
  EXPECT_NEAR(g.position[0].x(), 0.15, 1e-7);
  EXPECT_NEAR(g.position[0].y(), -0.25, 1e-7);  // front right is y < 0 in FLU
  EXPECT_NEAR(g.position[2].z(), -0.01, 1e-7);
  EXPECT_EQ(g.axis[1], Eigen::Vector3d(0, 0, 1));  // default thrust axis -z FRD = +z FLU
  EXPECT_EQ(g.spin[0], "ccw");
  EXPECT_EQ(g.spin[3], "cw");
  EXPECT_NEAR(g.km[2], 0.05, 1e-7);
  EXPECT_NEAR(g.ct[1], 6.5, 1e-6);
  ULogWriter none;
  EXPECT_THROW(px4_rotor_geometry(parse_ulog(bytes_of(none.bytes()), "n")), InputError);
}

// --- Crazyflie uSD --------------------------------------------------------------

TEST(Usd, Crc32MatchesThePublishedCheckValue) {
  // CRC-32 (ISO-HDLC, zlib) of "123456789" is 0xCBF43926.
  EXPECT_EQ(crc32(bytes_of("123456789")), 0xCBF43926u);
  EXPECT_EQ(crc32(bytes_of("")), 0u);
  // Incremental equals whole.
  EXPECT_EQ(crc32(bytes_of("6789"), crc32(bytes_of("12345"))), 0xCBF43926u);
}

std::string usd_file(int version, int records) {
  std::string b;
  auto put = [&b](auto v) { b.append(reinterpret_cast<const char*>(&v), sizeof(v)); };
  b.push_back('\xBC');
  put(std::uint16_t(version));
  put(std::uint16_t{1});
  put(std::uint16_t{7});
  b += std::string("fixed", 6);
  put(std::uint16_t{3});
  b += std::string("gyro.x(f)", 10);
  b += std::string("rpm.m1(H)", 10);
  b += std::string("t.b(b)", 7);
  for (int k = 0; k < records; ++k) {
    put(std::uint16_t{7});
    if (version == 1) put(std::uint32_t(1000 + 2 * k));
    else put(std::uint64_t(1'000'000 + 2000 * k));
    put(float(0.5f * k));
    put(std::uint16_t(20000 + k));
    put(std::int8_t(-k));
  }
  const auto crc = crc32(bytes_of(b));
  put(crc);
  return b;
}

TEST(Usd, ReadsVersionsOneAndTwo) {
  for (int v : {1, 2}) {
    SCOPED_TRACE(v);
    const UsdLog log = parse_usd(bytes_of(usd_file(v, 20)), "u");
    EXPECT_EQ(log.version, v);
    ASSERT_EQ(log.events.size(), 1u);
    const UsdEvent& e = log.events[0];
    EXPECT_EQ(e.name, "fixed");
    EXPECT_EQ(e.count(), 20u);
    EXPECT_EQ(e.timestamps_us[3], 1'006'000u);  // v1: ms -> us
    EXPECT_EQ(e.column("gyro.x")[4], 2.0);
    EXPECT_EQ(e.column("rpm.m1")[19], 20019.0);
    EXPECT_EQ(e.column("t.b")[5], -5.0);
    EXPECT_EQ(e.variables[1].type, 'H');
  }
}

TEST(Usd, CorruptOrTruncatedFileIsAnInputErrorWithItsOffset) {
  std::string b = usd_file(2, 5);
  b[30] ^= 0x10;
  try {
    parse_usd(bytes_of(b), "cf.bin");
    FAIL();
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("CRC-32 mismatch"), std::string::npos) << e.what();
  }
  // A record cut short, with a CRC that is right for the cut file.
  std::string c = usd_file(2, 5);
  c.resize(c.size() - 4 - 3);
  const auto crc = crc32(bytes_of(c));
  c.append(reinterpret_cast<const char*>(&crc), 4);
  try {
    parse_usd(bytes_of(c), "cf.bin");
    FAIL();
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("the variables of event 'fixed'"), std::string::npos) << e.what();
  }
}

// tests/data/logs/usd_reference.txt, from usd_reference.py (Python struct + zlib).
TEST(UsdReal, CountsRatesGapAndCrcAgreeWithThePythonReference) {
  const fs::path dir = kShared / "crazyflie-usd";
  QUADID_REQUIRE_SHARED_FILE(dir / "jana00");
  std::ifstream ref(fs::path(QUADID_TEST_DATA) / "logs" / "usd_reference.txt");
  int checked = 0;
  for (std::string line; std::getline(ref, line);) {
    char file[16], crc_hex[16], event[32];
    unsigned long long count, t0, t1, largest;
    int version;
    ASSERT_EQ(std::sscanf(line.c_str(), "%15s v%d crc %15s %31[^:]: %llu records, t %llu..%llu us, largest interval %llu us",
                          file, &version, crc_hex, event, &count, &t0, &t1, &largest),
              8)
        << line;
    const UsdLog log = read_usd(dir / file);
    EXPECT_EQ(fmt::format("{:08x}", log.crc), crc_hex);
    const UsdEvent* e = log.find_event(event);
    ASSERT_TRUE(e) << event;
    EXPECT_EQ(e->count(), count);
    EXPECT_EQ(e->timestamps_us.front(), t0);
    EXPECT_EQ(e->timestamps_us.back(), t1);
    const double rate = static_cast<double>(count - 1) / (static_cast<double>(t1 - t0) * 1e-6);
    if (std::string(event) == "fixedFrequency") {
      EXPECT_NEAR(rate, 507.0, 3.0);  // README: about 507 Hz
      // README: one gap of 10-80 ms per log (and at most two here), found by find_gaps.
      std::vector<double> t(e->timestamps_us.begin(), e->timestamps_us.end());
      for (auto& x : t) x *= 1e-6;
      const auto gaps = find_gaps(t, 3.0);
      ASSERT_GE(gaps.size(), 1u);
      ASSERT_LE(gaps.size(), 2u);
      double longest = 0;
      for (const auto& g : gaps) longest = std::max(longest, g.duration);
      EXPECT_NEAR(longest, static_cast<double>(largest) * 1e-6, 1e-9);
    } else {
      EXPECT_GT(rate, 50.0);  // README: 55-100 Hz (the mean is near the low end)
      EXPECT_LT(rate, 100.0);
    }
    ++checked;
  }
  EXPECT_EQ(checked, 8);
}

TEST(UsdReal, ImportGivesSensibleRangesInSiUnits) {
  const fs::path dir = kShared / "crazyflie-usd";
  QUADID_REQUIRE_SHARED_FILE(dir / "jana01");
  ImportReport rep;
  const FlightLog log = load_any_log(dir / "jana01", no_required_check(), &rep);
  EXPECT_EQ(rep.kind, "usd");
  const auto z = log.column("z");
  EXPECT_GE(z.minCoeff(), 0.25);  // README: airborne, z >= 0.25 m
  EXPECT_LE(z.maxCoeff(), 1.0);
  // Roll/pitch rates up to ~215 deg/s = 3.75 rad/s (README): rad/s, not deg/s.
  const double pmax = std::max(log.column("p").cwiseAbs().maxCoeff(), log.column("q").cwiseAbs().maxCoeff());
  EXPECT_GT(pmax, 2.5);
  EXPECT_LT(pmax, 6.0);
  EXPECT_GT(log.column("rpm.m1").minCoeff(), 11000.0);  // README: rotors above 11,000 rpm
  // Uniform 250 Hz grid from t = 0.
  const auto t = log.column("t");
  EXPECT_EQ(t[0], 0.0);
  EXPECT_NEAR(t[1] - t[0], 0.004, 1e-12);
  // The yaw spins (trajectory yaw0): psi unwrapped, its slope the mean of r.
  const auto psi = log.column("psi");
  const double dpsi = psi[psi.size() - 1] - psi[0];
  EXPECT_GT(std::abs(dpsi), 2 * kPi);
  // Mocap yaw against the gyro: the mean of psi_dot = (sin(phi) q + cos(phi) r) / cos(theta)
  // (the inverse of W(eta), ZYX) equals psi's change over the log. 0.05 rad/s: a
  // MEMS gyro's bias (~1 deg/s = 0.017 rad/s) and scale error (~1 % of 1.9 rad/s);
  // leaving out the q term misses by 0.15 rad/s, deg/s by a factor 57.
  const auto phi = log.column("phi"), theta = log.column("theta"), q = log.column("q"), r = log.column("r");
  const Eigen::VectorXd psidot =
      (phi.array().sin() * q.array() + phi.array().cos() * r.array()) / theta.array().cos();
  EXPECT_NEAR(dpsi / t[t.size() - 1], psidot.mean(), 0.05);

  // Motion capture and the onboard estimate agree (README: ~1 mm, ~1 deg,
  // mocap lagging by up to ~20 ms): same frames and quaternion convention.
  ImportOptions est;
  est.crazyflie_pose = "estimate";
  const FlightLog e = import_usd(read_usd(dir / "jana01"), est);
  const Eigen::Index n = std::min(e.rows(), log.rows());
  for (const char* c : {"x", "y", "z"})
    EXPECT_LT((e.column(c).head(n) - log.column(c).head(n)).cwiseAbs().maxCoeff(), 0.03) << c;
  for (const char* c : {"phi", "theta"})
    EXPECT_LT((e.column(c).head(n) - log.column(c).head(n)).cwiseAbs().maxCoeff(), 0.12) << c;
}

// --- Import of a synthetic ULog: frames, resampling, gaps -------------------------

struct Px4Flight {
  double duration = 4.0;
  double gap_at = -1, gap_len = 0;  // a hole in vehicle_angular_velocity
  double yaw_rate = 1.5;            // rad/s about NED z (down)
  int motors_every_ms = 10;         // actuator_motors' period
  double motor_command = 0.4;       // rotor i at motor_command + 0.01 i (0: all stopped)
};

// A PX4-like log: vehicle_local_position (NED) at 100 Hz, vehicle_attitude
// at 200 Hz, vehicle_angular_velocity (FRD) at 1 kHz carrying a 3 Hz motion
// plus a 200 Hz vibration, actuator_motors at 100 Hz.
Px4Flight with_gap(double at, double len) {
  Px4Flight f;
  f.gap_at = at;
  f.gap_len = len;
  return f;
}
Px4Flight lasting(double duration) {
  Px4Flight f;
  f.duration = duration;
  return f;
}

std::string px4_flight(const Px4Flight& f) {
  ULogWriter w(0);
  w.format("vehicle_local_position:uint64_t timestamp;float x;float y;float z;");
  w.format("vehicle_attitude:uint64_t timestamp;float[4] q;");
  w.format("vehicle_angular_velocity:uint64_t timestamp;float[3] xyz;uint8_t[4] _padding0;");
  w.format("actuator_motors:uint64_t timestamp;float[12] control;");
  w.parameter("CA_ROTOR_COUNT", std::int32_t{4});
  const auto pos = w.subscribe("vehicle_local_position");
  const auto att = w.subscribe("vehicle_attitude");
  const auto rat = w.subscribe("vehicle_angular_velocity");
  const auto mot = w.subscribe("actuator_motors");
  const std::uint64_t t0 = 5'000'000;
  for (int k = 0; k <= static_cast<int>(f.duration * 1000); ++k) {
    const double t = k * 1e-3;
    const std::uint64_t ts = t0 + static_cast<std::uint64_t>(k) * 1000u;
    if (!(t > f.gap_at && t < f.gap_at + f.gap_len))
      w.data(rat, ULogPayload().put(ts).put(float(0.2 * std::sin(2 * kPi * 3 * t) + 0.3 * std::sin(2 * kPi * 200 * t)))
                      .put(0.1f).put(float(f.yaw_rate)).str());
    if (k % 5 == 0) {  // attitude: yaw psi_ned = yaw_rate t about down; roll 0.1 rad
      const double psi = f.yaw_rate * t, phi = 0.1;
      const double cy = std::cos(psi / 2), sy = std::sin(psi / 2), cr = std::cos(phi / 2), sr = std::sin(phi / 2);
      w.data(att, ULogPayload().put(ts).put(float(cy * cr)).put(float(cy * sr)).put(float(sy * sr)).put(float(sy * cr)).str());
    }
    if (k % 10 == 0) w.data(pos, ULogPayload().put(ts).put(float(t)).put(2.0f).put(float(-1.0 - 0.5 * t)).str());
    if (k % f.motors_every_ms == 0) {
      ULogPayload m;
      m.put(ts);
      const double c = f.motor_command;
      for (int i = 0; i < 12; ++i) m.put(i < 4 ? float(c > 0.0 ? c + 0.01 * i : 0.0) : NAN);
      w.data(mot, m.str());
    }
  }
  return w.bytes();
}

TEST(Import, Px4FramesConvertedToZUpFlu) {
  const ULog log = parse_ulog(bytes_of(px4_flight({})), "sim");
  ImportReport rep;
  const FlightLog f = import_ulog(log, {}, &rep);
  const std::vector<std::string> head(f.columns.begin(), f.columns.begin() + 14);
  EXPECT_EQ(head, (std::vector<std::string>{"t", "x", "y", "z", "phi", "theta", "psi", "p", "q", "r",
                                            "actuator_motors.control[0]", "actuator_motors.control[1]",
                                            "actuator_motors.control[2]", "actuator_motors.control[3]"}));
  EXPECT_EQ(f.columns.size(), 14u);  // CA_ROTOR_COUNT = 4: control[4..11] (NaN) not imported
  EXPECT_NEAR(rep.t0, 5.0, 1e-9);
  const Eigen::Index i = 500;  // t = 2 s on the 250 Hz grid
  const double t = f.data(i, 0);
  EXPECT_NEAR(t, 2.0, 1e-12);
  // Positions (x, -y, -z); float32 in the file: tolerance 1e-5 m.
  EXPECT_NEAR(f.data(i, 1), t, 1e-5);
  EXPECT_NEAR(f.data(i, 2), -2.0, 1e-5);
  EXPECT_NEAR(f.data(i, 3), 1.0 + 0.5 * t, 1e-5);
  // Quaternion (q0, q1, -q2, -q3): roll stays 0.1, yaw about up = -yaw about down.
  // Linear interpolation of the quaternion at 200 Hz between samples 7.5 mrad
  // apart: error below 1e-5 rad, plus float32.
  EXPECT_NEAR(f.data(i, 4), 0.1, 1e-5);
  EXPECT_NEAR(f.data(i, 5), 0.0, 1e-5);
  EXPECT_NEAR(f.data(i, 6), -1.5 * t, 1e-4);  // unwrapped: -3 rad is past -pi at t > 2.09 s
  EXPECT_NEAR(f.data(f.rows() - 1, 6), -1.5 * 4.0, 1e-4);
  // Rates (x, -y, -z).
  EXPECT_NEAR(f.data(i, 8), -0.1, 1e-6);
  EXPECT_NEAR(f.data(i, 9), -1.5, 1e-6);
  EXPECT_NEAR(f.data(i, 10), 0.4, 1e-6);
}

TEST(Import, AntiAliasingRemovesWhatTheGridCannotHold) {
  // p = 0.2 sin(2 pi 3 t) + 0.3 sin(2 pi 200 t) logged at 1 kHz. On a 250 Hz
  // grid, 200 Hz would alias to 50 Hz; the zero-phase Butterworth (order 4,
  // 100 Hz, applied twice) passes it by |H|^2 = 1/(1 + 2^8) = 0.0039, i.e.
  // 0.3 * 0.0039 = 1.2e-3; and 3 Hz by 1 - 1e-12. Tolerance 3e-3 rad/s: that
  // residual plus the filter's ends.
  const FlightLog f = import_ulog(parse_ulog(bytes_of(px4_flight({})), "sim"));
  double worst = 0;
  for (Eigen::Index i = 50; i < f.rows() - 50; ++i) {
    const double t = f.data(i, 0);
    worst = std::max(worst, std::abs(f.data(i, 7) - 0.2 * std::sin(2 * kPi * 3 * t)));
  }
  EXPECT_LT(worst, 3e-3);
  // Without the filter (--aa-fraction tiny is not allowed; emulate with a 1 kHz
  // grid): the vibration is kept, so the check above is not vacuous.
  ImportOptions fast;
  fast.rate_hz = 1000;
  const FlightLog g = import_ulog(parse_ulog(bytes_of(px4_flight({})), "sim"), fast);
  double big = 0;
  for (Eigen::Index i = 0; i < g.rows(); ++i)
    big = std::max(big, std::abs(g.data(i, 7) - 0.2 * std::sin(2 * kPi * 3 * g.data(i, 0))));
  EXPECT_GT(big, 0.25);
}

TEST(Import, ShortGapsBridgedLongGapsSplitOrRefused) {
  {
    ImportReport rep;
    const FlightLog f = import_ulog(parse_ulog(bytes_of(px4_flight(with_gap(1.0, 0.05))), "s"), {}, &rep);
    ASSERT_EQ(rep.gaps.size(), 1u);
    EXPECT_TRUE(rep.gaps[0].bridged);
    EXPECT_EQ(rep.gaps[0].topic, "vehicle_angular_velocity");
    EXPECT_NEAR(rep.gaps[0].gap.t, 5.0 + 1.0, 1.5e-3);
    EXPECT_NEAR(rep.gaps[0].gap.duration, 0.051, 1.5e-3);
    EXPECT_NEAR(f.data(f.rows() - 1, 0), 4.0, 1e-9);  // the whole log kept
  }
  {
    ImportReport rep;
    const FlightLog f = import_ulog(parse_ulog(bytes_of(px4_flight(with_gap(1.0, 0.5))), "s"), {}, &rep);
    ASSERT_EQ(rep.gaps.size(), 1u);
    EXPECT_FALSE(rep.gaps[0].bridged);
    // The longest part: after the gap, 1.5 s .. 4 s.
    EXPECT_NEAR(rep.t0, 5.0 + 1.501, 1.5e-3);
    EXPECT_NEAR(rep.duration, 2.5, 5e-3);
    ImportOptions refuse;
    refuse.on_gap = GapPolicy::Refuse;
    try {
      import_ulog(parse_ulog(bytes_of(px4_flight(with_gap(1.0, 0.5))), "s"), refuse);
      FAIL();
    } catch (const InputError& e) {
      EXPECT_NE(std::string(e.what()).find("vehicle_angular_velocity at 6.0"), std::string::npos) << e.what();
    }
  }
}

TEST(Import, FlightLogToPx4UlogAndBack) {
  // A closed-form flight (z up, FLU) at 250 Hz, written in PX4's topics and
  // frames, imported on the same grid: the same numbers within float32
  // (the file's type): 2e-6 relative, psi up to ~8 rad -> tolerance 1e-5.
  FlightLog f;
  f.columns = {"t", "x", "y", "z", "phi", "theta", "psi", "p", "q", "r", "w1", "w2", "w3", "w4"};
  const int n = 1000;
  f.data.resize(n, 14);
  for (int i = 0; i < n; ++i) {
    const double t = i / 250.0;
    f.data.row(i) << t, std::sin(t), 0.5 * std::cos(2 * t), 1.0 + 0.1 * t, 0.3 * std::sin(3 * t), -0.2 * std::cos(t),
        2.0 * t - 0.5, 0.9 * std::cos(3 * t), 0.2 * std::sin(t), 2.0, 400 + i, 410 + i, 420 + i, 430 + i;
  }
  Px4UlogWriteOptions wo;
  wo.motor_columns = {"w1", "w2", "w3", "w4"};
  wo.geometry.count = 4;
  for (int i = 0; i < 4; ++i) {
    wo.geometry.position.emplace_back(i < 2 ? 0.1 : -0.1, i % 2 ? 0.12 : -0.12, 0.01);
    wo.geometry.axis.emplace_back(0, 0, 1);
    wo.geometry.ct.push_back(5.0);
    wo.geometry.km.push_back(0.04);
    wo.geometry.spin.push_back(i == 0 || i == 3 ? "ccw" : "cw");
  }
  const ULog ulog = parse_ulog(bytes_of(px4_ulog_from_flight_log(f, wo)), "sim");
  const FlightLog g = import_ulog(ulog);
  ASSERT_EQ(g.rows(), n);
  for (const char* c : {"t", "x", "y", "z", "phi", "theta", "psi", "p", "q", "r"})
    EXPECT_LT((g.column(c) - f.column(c)).cwiseAbs().maxCoeff(), 1e-5) << c;
  EXPECT_EQ(g.column("actuator_motors.control[2]")[10], 430.0);
  const RotorGeometry back = px4_rotor_geometry(ulog);
  for (int i = 0; i < 4; ++i) {
    EXPECT_LT((back.position[i] - wo.geometry.position[i]).norm(), 1e-7);
    EXPECT_EQ(back.spin[i], wo.geometry.spin[i]);
  }
}

TEST(Import, OptionsValidateNamesTheOption) {
  ImportOptions o;
  o.rate_hz = -1;
  try {
    o.validate();
    FAIL();
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("--rate"), std::string::npos);
  }
  o = {};
  o.crazyflie_pose = "gps";
  EXPECT_THROW(o.validate(), std::invalid_argument);
}

TEST(Import, LoadAnyLogRecognisesTheKindByItsFirstBytes) {
  const fs::path dir = fs::temp_directory_path() / ("quadid_logs_" + std::to_string(::getpid()));
  fs::create_directories(dir);
  const auto ulg = dir / "flight.csv";  // a ULog with a misleading name
  write_file_atomic(ulg, px4_flight({}));
  EXPECT_EQ(detect_log_kind(ulg), LogKind::Ulog);
  const auto usd = dir / "log.ulg";
  write_file_atomic(usd, usd_file(2, 3));
  EXPECT_EQ(detect_log_kind(usd), LogKind::Usd);
  const FlightLog f = load_any_log(ulg, no_required_check());
  EXPECT_TRUE(f.has("psi"));
  // Without the wrench columns, the default required set names what is missing.
  try {
    load_any_log(ulg);
    FAIL();
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("no column Fz"), std::string::npos) << e.what();
  }
  // An imported log written as CSV reads back through the CSV path.
  const auto csv = dir / "out.csv";
  write_flight_log(f, csv);
  EXPECT_EQ(detect_log_kind(csv), LogKind::Csv);
  CsvReadOptions ro;
  ro.required = {"t", "x", "y", "z", "phi", "theta", "psi", "p", "q", "r"};
  LoadOptions lo;
  lo.csv = ro;
  const FlightLog back = load_any_log(csv, lo);
  EXPECT_EQ(back.rows(), f.rows());
  fs::remove_all(dir);
}

// --- Robustness: deterministic mutations ----------------------------------------

using quadid::testing::mutate_and_parse;  // mutations.hpp

TEST(Robustness, MutatedULogFilesEndInInputErrorOrSuccess) {
  int errors = 0, oks = 0;
  mutate_and_parse(rich_ulog(), [](const std::string& b) { parse_ulog(bytes_of(b), "m"); }, 1234, &errors, &oks);
  mutate_and_parse(px4_flight(lasting(0.05)), [](const std::string& b) {
    import_ulog(parse_ulog(bytes_of(b), "m"));
  }, 99, &errors, &oks);
  EXPECT_GT(errors, 100);  // the mutations do break files
  EXPECT_GT(oks, 10);
}

TEST(Robustness, MutatedUsdFilesEndInInputErrorOrSuccess) {
  int errors = 0, oks = 0;
  const std::string good = usd_file(2, 30);
  mutate_and_parse(good, [](const std::string& b) { parse_usd(bytes_of(b), "m"); }, 77, &errors, &oks);
  // Mutations with the CRC recomputed, so that the parser itself is exercised.
  auto fixed_crc = [](const std::string& b) {
    if (b.size() < 4) return parse_usd(bytes_of(b), "m"), void();
    std::string c = b.substr(0, b.size() - 4);
    const auto crc = crc32(bytes_of(c));
    c.append(reinterpret_cast<const char*>(&crc), 4);
    parse_usd(bytes_of(c), "m");
  };
  mutate_and_parse(good, fixed_crc, 78, &errors, &oks);
  EXPECT_GT(errors, 100);
  EXPECT_GT(oks, 10);
}

// --- Command line ----------------------------------------------------------------

class LogsCli : public quadid::testing::CliTest {};

TEST_F(LogsCli, ImportWarnsOfTopicsTooSlowForIdentify) {
  // The same finding as identify's (ULogSamples.SitlFlightAtDefaultLogRates...),
  // said at import time: the CSV no longer knows the topics' own rates.
  const fs::path f = kShared / "px4-ulog" / "sample_px4_events.ulg";
  QUADID_REQUIRE_SHARED_FILE(f);
  const auto r = run("import " + f.string() + " -o " + path("s.csv") + " --json");
  ASSERT_EQ(r.rc, 0) << r.err;
  const auto j = nlohmann::ordered_json::parse(r.out);
  int slow = 0;
  for (const auto& w : j.at("warnings"))
    if (w.get<std::string>().rfind("too slow for identify's default cutoffs: ", 0) == 0) ++slow;
  EXPECT_EQ(slow, 2) << j.at("warnings").dump();  // actuator_motors and vehicle_local_position, 10 Hz
}

TEST(Import, AVehicleThatDidNotFlyIsSaidBeforeItsSlowTopics) {
  // Motors stopped throughout and logged at 10 Hz: the root cause (it did not
  // fly) is the error, not the sample rate whose advice could not help.
  Px4Flight f;
  f.motors_every_ms = 100;
  f.motor_command = 0.0;
  const fs::path p = fs::temp_directory_path() / ("quadid_ground_" + std::to_string(::getpid()) + ".ulg");
  std::ofstream(p, std::ios::binary) << px4_flight(f);
  quadid::IdentifyRequest req;
  req.vehicle = quadid::testing::px4_test_vehicle();
  try {
    (void)quadid::prepare_identification(p.string(), req);
    ADD_FAILURE() << "expected an input error";
  } catch (const quadid::InputError& e) {
    const std::string w = e.what();
    EXPECT_NE(w.find("thrust-units: the thrust Fz is 0 N throughout the log"), std::string::npos) << w;
    EXPECT_EQ(w.find("sample rate"), std::string::npos) << w;
  }
  // Flying (the same rates), the sample rate is the finding.
  f.motor_command = 0.4;
  std::ofstream(p, std::ios::binary) << px4_flight(f);
  try {
    (void)quadid::prepare_identification(p.string(), req);
    ADD_FAILURE() << "expected an input error";
  } catch (const quadid::InputError& e) {
    EXPECT_NE(std::string(e.what()).find("sample rate: actuator_motors"), std::string::npos) << e.what();
  }
  fs::remove(p);
}

TEST_F(LogsCli, NoisyRotorSpeedsAreNotTakenForPointSampledTorques) {
  // 50 rpm of noise on a Crazyflie's rotor speeds leaves the rotor model's
  // fast torques as poorly followed by the gyro (R^2 about 0.4) as folded
  // content would, but their gain is the slow band's: no torque-sampling warning.
  ASSERT_EQ(run("simulate --vehicle crazyflie21 --trajectory table2 --duration 30 --sigma-rotor 50 --seed 1001 -o " +
                path("f.csv"))
                .rc,
            0);
  const auto r = run("identify " + path("f.csv") + " --vehicle crazyflie21 --terms paper --cutoffs fixed");
  ASSERT_EQ(r.rc, 0) << r.err;
  EXPECT_EQ(r.err.find("torque-sampling"), std::string::npos) << r.err;
}

TEST_F(LogsCli, ASlowGridIsRefusedAndBothWaysOutWork) {
  // A 30 Hz grid keeps ~7.5 Hz of each signal, below the 8 Hz moment rows:
  // refused, naming the rate that is enough; each advice, followed, gives
  // inertia inside its own 95 % interval of the simulated vehicle's truth.
  ASSERT_EQ(run("simulate --vehicle jmavsim-quad --trajectory table2 --duration 20 --ulog " + path("f.ulg")).rc, 0);
  auto r = run("import " + path("f.ulg") + " --rate 30 -o " + path("a.csv"));
  EXPECT_EQ(r.rc, 1);
  EXPECT_NE(r.err.find("give --rate 32 or more"), std::string::npos) << r.err;
  EXPECT_FALSE(fs::exists(path("a.csv")));
  const auto inside_truth = [&](const std::string& csv, const std::string& extra) {
    const auto id = run("identify " + csv + " --vehicle jmavsim-quad --json " + extra);
    ASSERT_EQ(id.rc, 0) << id.err;
    const auto j = nlohmann::ordered_json::parse(id.out);
    const auto& u = j.at("uncertainty").at("LS");
    for (const char* p : {"Ixx", "Iyy", "Izz"}) {
      const double truth = j.at("reference").at("params").at(p).get<double>();  // the vehicle file's, flown
      EXPECT_LE(u.at(p).at("ci95").at(0).get<double>(), truth) << csv << " " << p;
      EXPECT_GE(u.at(p).at("ci95").at(1).get<double>(), truth) << csv << " " << p;
    }
  };
  ASSERT_EQ(run("import " + path("f.ulg") + " --rate 32 -o " + path("b.csv")).rc, 0);
  inside_truth(path("b.csv"), "");
  ASSERT_EQ(run("import " + path("f.ulg") + " --rate 30 --allow-slow-rate -o " + path("c.csv")).rc, 0);
  inside_truth(path("c.csv"), "--cutoff-moment 7.5 --cutoff-force 4");
  // A CSV is not imported: it is identified as it is.
  r = run("import " + path("b.csv") + " -o " + path("d.csv"));
  EXPECT_EQ(r.rc, 1);
  EXPECT_NE(r.err.find("give it to identify as it is"), std::string::npos) << r.err;
}

TEST_F(LogsCli, LogInfoAndImport) {
  write("f.ulg", px4_flight({}));
  auto r = run("log-info " + path("f.ulg") + " --json");
  ASSERT_EQ(r.rc, 0) << r.err;
  const auto j = nlohmann::ordered_json::parse(r.out);
  EXPECT_EQ(j["kind"], "ulog");
  EXPECT_EQ(j["topics"].size(), 4u);
  r = run("import " + path("f.ulg") + " -o " + path("log.csv"));
  ASSERT_EQ(r.rc, 0) << r.err;
  CsvReadOptions ro;
  ro.required = {"t", "x", "y", "z", "phi", "theta", "psi", "p", "q", "r"};
  EXPECT_EQ(read_flight_log(path("log.csv"), ro).rows(), 1001);  // 4 s at 250 Hz
  // identify reads the ULog directly; without a rotor model it names the missing wrench.
  r = run("identify " + path("f.ulg"));
  EXPECT_EQ(r.rc, 1);
  EXPECT_NE(r.err.find("the imported log has no column Fz"), std::string::npos) << r.err;
  // A vehicle whose rotor columns the log lacks: the log's rotor-like columns are listed.
  r = run("identify " + path("f.ulg") + " --vehicle qball2");
  EXPECT_EQ(r.rc, 1);
  EXPECT_NE(r.err.find("look like rotor signals: actuator_motors.control[0], actuator_motors.control[1]"),
            std::string::npos)
      << r.err;
  EXPECT_NE(r.err.find("[rotors] columns"), std::string::npos) << r.err;
  const std::string good = px4_flight({});
  write("bad.ulg", good.substr(0, good.size() - 5));
  r = run("log-info " + path("bad.ulg"));
  EXPECT_EQ(r.rc, 1);
  EXPECT_NE(r.err.find("the file ends"), std::string::npos) << r.err;
  // import reads a cut file to its last complete message (a crashed
  // flight), saying where it stopped.
  r = run("import " + path("bad.ulg") + " -o " + path("bad.csv"));
  EXPECT_EQ(r.rc, 0) << r.err;
  EXPECT_NE(r.out.find("the file ends mid-record at byte"), std::string::npos) << r.out;
  EXPECT_TRUE(fs::exists(path("bad.csv")));
}

}  // namespace
}  // namespace quadid::logs
