// ArduPilot DataFlash reader (docs/ardupilot.md). References: records packed
// by our writer from known numbers (every format character), and, for the two
// real ArduCopter logs in ../shared/data/ardupilot-real, the listings of an
// independent Python reader written from ArduPilot's format description
// (tests/data/ardupilot/dataflash_listing.py, committed beside its output).
#include "quadid/logs.hpp"

#include "cli_fixture.hpp"
#include "mutations.hpp"
#include "shared_data.hpp"

#include <fmt/format.h>
#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include <cmath>
#include <cstring>
#include <unistd.h>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <random>
#include <sstream>

namespace quadid::logs {
namespace {

namespace fs = std::filesystem;

std::span<const std::uint8_t> bytes_of(const std::string& s) {
  return {reinterpret_cast<const std::uint8_t*>(s.data()), s.size()};
}

// A log with every numeric format character, a text of each size, units and
// parameters (one logged twice).
std::string rich_log(DataFlashWriter& w) {
  w.define(70, "ALLN", "QbBhHiIfdcCeELMq", "TimeUS,b,B,h,H,i,I,f,d,c,C,e,E,L,M,q",
           {"s", "", "", "", "", "", "", "m", "m/s", "deg", "deg", "", "", "deglatitude", "", ""});
  w.define(73, "BIG", "QQ", "TimeUS,Q", {"s", ""});
  w.define(71, "TXT", "QnNZ", "TimeUS,Four,Sixteen,SixtyFour");
  w.define(72, "IMU", "QBff", "TimeUS,I,GyrX,AccX", {"s", "instance", "rad/s", "m/s/s"});
  w.parameter(1000, "MOT_PWM_MIN", 1000.0f);
  w.parameter(1000, "MOT_THST_HOVER", 0.35f);
  for (int k = 0; k < 5; ++k)
    w.record(70, {1e6 + k * 1e4, -12, 200, -30000, 60000, -2000000000.0, 4000000000.0, 0.1 * k, 1.0 / 3.0 + k, -1.25,
                  655.35, -21474836.48, 42949672.95, 51.4545678, 3, -9.0e15});
  w.record(73, {1e6, 1.8e19});
  w.record(71, {2e6}, {"ab", "sixteen-chars-ok", std::string(64, 'z')});
  for (int k = 0; k < 30; ++k) w.record(72, {1e6 + 4e4 * (k / 3), static_cast<double>(k % 3), 0.01 * k, -9.81});
  w.parameter(3e6, "MOT_THST_HOVER", 0.41f);
  return w.bytes();
}

TEST(DataFlash, WriterRoundTripEveryFormatCharacter) {
  DataFlashWriter w;
  const DataFlashLog log = parse_dataflash(bytes_of(rich_log(w)), "rich");
  EXPECT_EQ(log.skipped_bytes, 0u);
  EXPECT_EQ(log.trailing_bytes, 0u);
  EXPECT_TRUE(log.problems.empty());
  const DataFlashMessages* a = log.find("ALLN");
  ASSERT_NE(a, nullptr);
  ASSERT_EQ(a->count(), 5u);
  // Each column back as written (integers exactly; c C e E in hundredths, L
  // in 1e-7 degrees, f as the float nearest, q Q within a double's rounding).
  const auto at = [&](const char* c, int i) { return a->column(c)(i); };
  EXPECT_EQ(at("b", 2), -12);
  EXPECT_EQ(at("B", 2), 200);
  EXPECT_EQ(at("h", 2), -30000);
  EXPECT_EQ(at("H", 2), 60000);
  EXPECT_EQ(at("i", 2), -2000000000.0);
  EXPECT_EQ(at("I", 2), 4000000000.0);
  EXPECT_EQ(at("f", 3), static_cast<double>(0.3f));
  EXPECT_EQ(at("d", 3), 1.0 / 3.0 + 3);
  EXPECT_EQ(at("c", 0), -1.25);
  EXPECT_EQ(at("C", 0), 655.35);
  EXPECT_EQ(at("e", 0), -21474836.48);
  EXPECT_EQ(at("E", 0), 42949672.95);
  EXPECT_NEAR(at("L", 0), 51.4545678, 1e-12);
  EXPECT_EQ(at("M", 0), 3);
  EXPECT_EQ(at("q", 0), -9.0e15);
  EXPECT_EQ(log.find("BIG")->column("Q")(0), 1.8e19);
  EXPECT_EQ(a->time_us()[4], 1040000u);
  // Units from FMTU through UNIT; no FMTU: none.
  EXPECT_EQ(a->format.units[0], "s");
  EXPECT_EQ(a->format.units[7], "m");
  EXPECT_EQ(a->format.units[13], "deglatitude");
  EXPECT_EQ(a->format.units[1], "");
  const DataFlashMessages* t = log.find("TXT");
  ASSERT_NE(t, nullptr);
  EXPECT_EQ(t->text("Four", 0), "ab");
  EXPECT_EQ(t->text("Sixteen", 0), "sixteen-chars-ok");
  EXPECT_EQ(t->text("SixtyFour", 0), std::string(64, 'z'));
  EXPECT_EQ(t->format.units[0], "");
  EXPECT_THROW(t->column("Four"), InputError);       // text, not a number
  EXPECT_THROW(a->column("nonesuch"), InputError);
  // Parameters: every record in order, the last value of each name.
  ASSERT_EQ(log.parameters.size(), 3u);
  EXPECT_EQ(log.parameter("MOT_THST_HOVER"), static_cast<double>(0.41f));
  EXPECT_EQ(log.parameter("MOT_PWM_MIN"), 1000.0);
  EXPECT_FALSE(log.parameter("NOPE"));
}

TEST(DataFlash, CorruptBytesAreSkippedAndACutLastRecordIsCounted) {
  DataFlashWriter w;
  w.define(72, "IMU", "QBff", "TimeUS,I,GyrX,AccX");
  for (int k = 0; k < 10; ++k) w.record(72, {1e3 * k, 0, 0.5, -9.8});
  const std::size_t garbage_at = w.bytes().size();
  w.raw(std::string("\x01\x02\xA3\x95\xEE\x07", 6));  // noise, and a header of a type no FMT defines
  for (int k = 10; k < 20; ++k) w.record(72, {1e3 * k, 0, 0.5, -9.8});
  const std::string good = w.bytes();
  const DataFlashLog log = parse_dataflash(bytes_of(good), "c");
  EXPECT_EQ(log.find("IMU")->count(), 20u);
  EXPECT_EQ(log.skipped_bytes, 6u);
  EXPECT_EQ(log.resyncs, 1u);
  EXPECT_EQ(log.first_skip_offset, garbage_at);
  // Cut 5 bytes into the last record (a crash, a power loss): the 19 before it
  // are read, the cut one is counted with its offset.
  const std::size_t record = 3 + 8 + 1 + 4 + 4;
  const std::string cut = good.substr(0, good.size() - record + 5);
  const DataFlashLog c = parse_dataflash(bytes_of(cut), "cut");
  EXPECT_EQ(c.find("IMU")->count(), 19u);
  EXPECT_EQ(c.trailing_bytes, 5u);
  EXPECT_EQ(c.trailing_offset, good.size() - record);
  EXPECT_EQ(c.skipped_bytes, 6u);
  // Cut inside a header: trailing too, not corrupt.
  const DataFlashLog h = parse_dataflash(bytes_of(good.substr(0, good.size() - record + 2)), "cut2");
  EXPECT_EQ(h.trailing_bytes, 2u);
  EXPECT_EQ(h.skipped_bytes, 6u);
}

TEST(DataFlash, AnFmtThatDisagreesWithItselfIsNamedWithItsOffset) {
  DataFlashWriter w;
  w.define(72, "IMU", "QBff", "TimeUS,I,GyrX,AccX");
  std::string b = w.bytes();
  b[3 + 1] = 30;  // the FMT's Length byte: 30, but QBff takes 17 + 3
  DataFlashWriter rest;
  rest.define(72, "IMU", "QBff", "TimeUS,I,GyrX,AccX");  // a second, right definition later
  rest.record(72, {1.0, 0, 0, 0});
  b += rest.bytes();
  const DataFlashLog log = parse_dataflash(bytes_of(b), "bad");
  ASSERT_EQ(log.problems.size(), 1u);
  EXPECT_NE(log.problems[0].find("byte 0: FMT of IMU (type 72): length 30 but its format 'QBff' takes 17 bytes"),
            std::string::npos)
      << log.problems[0];
  EXPECT_EQ(log.find("IMU")->count(), 1u);  // the right definition reads its record
  // A format character ArduPilot does not define.
  DataFlashWriter x;
  x.raw(std::string("\xA3\x95\x80\x48\x0c", 5) + std::string("ABCD", 4) + std::string("QX", 2) + std::string(14, '\0') +
        std::string("TimeUS,Y", 8) + std::string(56, '\0'));
  const DataFlashLog xl = parse_dataflash(bytes_of(x.bytes()), "x");
  ASSERT_EQ(xl.problems.size(), 1u);
  EXPECT_NE(xl.problems[0].find("format character 'X' is not one ArduPilot defines"), std::string::npos);
}

TEST(DataFlash, BytesWithoutAnFmtRecordAreNotADataFlashLog) {
  try {
    parse_dataflash(bytes_of(std::string("\xA3\x95\x01hello world", 14)), "junk.bin");
    FAIL() << "no error";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("junk.bin: byte 0: not an ArduPilot DataFlash log: no FMT record"),
              std::string::npos)
        << e.what();
  }
  EXPECT_TRUE(is_dataflash(bytes_of("\xA3\x95")));
  EXPECT_FALSE(is_dataflash(bytes_of("ULog")));
}

// Every mutated file must parse or end in an InputError: no crash, no hang,
// no other exception (truncation at every 7th byte, bit flips, 16-bit runs
// overwritten, seeded). The reader resynchronises, so most parse.
TEST(DataFlash, MutatedFilesEndInSuccessOrInputError) {
  DataFlashWriter w;
  const std::string good = rich_log(w);
  int errors = 0, oks = 0;
  quadid::testing::mutate_and_parse(
      good,
      [](const std::string& b) {
        const DataFlashLog log = parse_dataflash(bytes_of(b), "m");
        (void)format_dataflash_info(log, true);
        (void)dataflash_info_json(log).dump();  // names from corrupt bytes are made printable
      },
      4242, &errors, &oks, 600, 400);
  EXPECT_GT(errors, 0);  // cut before the first FMT: not a log
  EXPECT_GT(oks, 900);
}

// --- The real ArduCopter logs against the independent Python listing --------------

#ifdef QUADID_SHARED_DATA
const fs::path kShared = QUADID_SHARED_DATA;
#else
const fs::path kShared = "/nonexistent";
#endif

// gzip -dc into a temporary file (the shared logs are compressed).
std::string gunzip(const fs::path& gz) {
  const fs::path out = fs::temp_directory_path() / fmt::format("quadid_df_{}_{}", ::getpid(), gz.stem().string());
  const std::string cmd = fmt::format("gzip -dc '{}' > '{}'", gz.string(), out.string());
  if (std::system(cmd.c_str()) != 0) throw std::runtime_error("gzip failed: " + cmd);
  std::ifstream in(out, std::ios::binary);
  std::stringstream ss;
  ss << in.rdbuf();
  fs::remove(out);
  return ss.str();
}

void expect_number(const nlohmann::ordered_json& want, double got, const std::string& what) {
  if (want.is_string()) {  // the listing's "nan", "inf", "-inf"
    const std::string w = want.get<std::string>();
    if (w == "nan") EXPECT_TRUE(std::isnan(got)) << what;
    else EXPECT_EQ(got, w == "inf" ? HUGE_VAL : -HUGE_VAL) << what;
    return;
  }
  ASSERT_FALSE(want.is_null()) << what;
  const double w = want.get<double>();
  // Both readers widen the same float or integer to double: agreement to the
  // last bit but for the Python reader's /100 against ours (one rounding).
  EXPECT_NEAR(got, w, 1e-12 * std::max(1.0, std::abs(w))) << what;
}

void compare_with_listing(const std::string& stem) {
  const fs::path gz = kShared / "ardupilot-real" / (stem + ".bin.gz");
  QUADID_REQUIRE_SHARED_FILE(gz);
  const fs::path listing = fs::path(QUADID_TEST_DATA) / "ardupilot" / (stem + ".listing.json");
  ASSERT_TRUE(fs::exists(listing)) << listing;
  std::ifstream in(listing);
  const nlohmann::ordered_json want = nlohmann::ordered_json::parse(in);
  const std::string bytes = gunzip(gz);
  const DataFlashLog log = parse_dataflash(bytes_of(bytes), stem);
  EXPECT_EQ(log.bytes, want.at("bytes").get<std::size_t>());
  EXPECT_EQ(log.skipped_bytes, want.at("skipped_bytes").get<std::size_t>());
  EXPECT_EQ(log.trailing_bytes, want.at("trailing_bytes").get<std::size_t>());
  // Every type with records: its count, definition, units and time span.
  std::size_t types = 0;
  for (const auto& [name, count] : want.at("counts").items()) {
    if (count.get<std::size_t>() == 0) continue;
    ++types;
    const DataFlashMessages* m = log.find(name);
    ASSERT_NE(m, nullptr) << name;
    EXPECT_EQ(m->count(), count.get<std::size_t>()) << name;
    const nlohmann::ordered_json& f = want.at("formats").at(name);
    EXPECT_EQ(m->format.format, f.at("format").get<std::string>()) << name;
    EXPECT_EQ(m->format.columns, f.at("columns").get<std::vector<std::string>>()) << name;
    const nlohmann::ordered_json& units = f.at("units");
    ASSERT_EQ(units.size(), m->format.units.size()) << name;
    for (std::size_t c = 0; c < units.size(); ++c)
      EXPECT_EQ(m->format.units[c], units[c].is_null() ? "" : units[c].get<std::string>()) << name << " " << c;
    const nlohmann::ordered_json& mults = f.at("multipliers");
    ASSERT_EQ(mults.size(), m->format.multipliers.size()) << name;
    for (std::size_t c = 0; c < mults.size(); ++c)
      if (mults[c].is_null()) EXPECT_TRUE(std::isnan(m->format.multipliers[c])) << name << " " << c;
      else EXPECT_EQ(m->format.multipliers[c], mults[c].get<double>()) << name << " " << c;  // the stored double
    if (want.at("first_time_us").contains(name)) {
      const auto t = m->time_us();
      ASSERT_FALSE(t.empty()) << name;
      EXPECT_EQ(t.front(), want.at("first_time_us").at(name).get<std::uint64_t>()) << name;
      EXPECT_EQ(t.back(), want.at("last_time_us").at(name).get<std::uint64_t>()) << name;
    }
  }
  EXPECT_EQ(log.messages.size(), types);
  // Parameters: the number of records and every name's last value.
  EXPECT_EQ(log.parameters.size(), want.at("parameter_messages").get<std::size_t>());
  for (const auto& [name, v] : want.at("parameters").items()) {
    const auto got = log.parameter(name);
    ASSERT_TRUE(got) << name;
    expect_number(v, *got, name);
  }
  // The first and last record of the flight's main messages, every column.
  std::size_t compared = 0;
  for (const auto& [name, s] : want.at("samples").items()) {
    const DataFlashMessages* m = log.find(name);
    ASSERT_NE(m, nullptr) << name;
    for (const char* which : {"first", "last"}) {
      const std::size_t i = std::string(which) == "first" ? 0 : m->count() - 1;
      for (const auto& [col, v] : s.at(which).items()) {
        const int c = m->format.column(col);
        ASSERT_GE(c, 0) << name << "." << col;
        const char ch = m->format.format[static_cast<std::size_t>(c)];
        if (ch == 'n' || ch == 'N' || ch == 'Z') EXPECT_EQ(m->text(col, i), v.get<std::string>()) << name << "." << col;
        else if (ch != 'a') expect_number(v, m->column(col)(static_cast<Eigen::Index>(i)), name + "." + col + " " + which);
        ++compared;
      }
    }
  }
  EXPECT_GT(compared, 200u);  // ten message types, first and last, every column
  EXPECT_GT(types, 60u);
}

TEST(DataFlashReal, FirstLogAgreesWithThePythonListing) { compare_with_listing("2023-07-06_10-12-18"); }
TEST(DataFlashReal, SecondLogAgreesWithThePythonListing) { compare_with_listing("2023-07-06_10-18-44"); }

// --- Command line -------------------------------------------------------------------

class DataFlashCli : public quadid::testing::CliTest {};

TEST_F(DataFlashCli, LogInfoListsTypesUnitsRatesAndParameters) {
  DataFlashWriter w;
  rich_log(w);
  {
    std::ofstream out(path("flight.bin"), std::ios::binary);
    out << w.bytes();
  }
  const auto r = run("log-info " + path("flight.bin"));
  ASSERT_EQ(r.rc, 0) << r.err;
  EXPECT_NE(r.out.find("ArduPilot DataFlash log"), std::string::npos) << r.out;
  // IMU: 30 records, 3 instances of 10 records over 0.36 s: no rate under 1 s.
  EXPECT_NE(r.out.find("IMU"), std::string::npos);
  EXPECT_NE(r.out.find("GyrX [rad/s]"), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("MOT_THST_HOVER   0.41"), std::string::npos) << r.out;
  const auto j = run("log-info " + path("flight.bin") + " --json");
  ASSERT_EQ(j.rc, 0) << j.err;
  const nlohmann::ordered_json js = nlohmann::ordered_json::parse(j.out);
  EXPECT_EQ(js.at("kind"), "dataflash");
  EXPECT_EQ(js.at("messages").at("IMU").at("count"), 30);
  EXPECT_EQ(js.at("messages").at("IMU").at("instances"), 3);
  EXPECT_EQ(js.at("messages").at("IMU").at("instance_column"), "I");
  EXPECT_NEAR(js.at("parameters").at("MOT_THST_HOVER").get<double>(), 0.41, 1e-7);
  // identify of a log without the messages it needs names them and log-info.
  const auto id = run("identify " + path("flight.bin"));
  EXPECT_NE(id.rc, 0);
  EXPECT_NE(id.err.find("no XKF1 or POS messages"), std::string::npos) << id.err;
  EXPECT_NE(id.err.find("quadid log-info"), std::string::npos) << id.err;
}

}  // namespace
}  // namespace quadid::logs
