// The one option table (quadid/pipeline/options.hpp): the command line and the
// JSON options accept the same names with the same defaults (both are read by
// OptionValues against the table, so they cannot drift), every old spelling
// works and warns, and range and choice errors name the flag on the command
// line and the key in JSON.
#include "cli_fixture.hpp"
#include "quadid/pipeline.hpp"

#include <fmt/format.h>
#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include <cmath>
#include <functional>
#include <string>

namespace {

using json = nlohmann::ordered_json;
using quadid::OptionDef;
using quadid::OptionKind;
using quadid::OptionScope;
using quadid::OptionSource;
using quadid::OptionValues;

/// A valid value of each kind: the default when there is one.
json sample(const OptionDef& d) {
  if (!d.default_value.empty() && d.kind != OptionKind::Flag) return d.default_value;
  switch (d.kind) {
    case OptionKind::Number: return d.has_range() && std::isfinite(d.min) ? d.min + 1.0 : 1.0;
    case OptionKind::Integer: return 1;
    case OptionKind::String: return d.choices.empty() ? json("x") : json(d.choices.front());
    case OptionKind::Window: return "1:2";
    case OptionKind::Flag: return true;
    case OptionKind::List: return json::array();
  }
  return nullptr;
}

/// The library's reader of a command's JSON options (the command line's too).
void call(const std::string& command, const json& j) {
  const OptionValues v(j, command);
  if (command == "identify" || command == "batch") (void)quadid::identify_request(v);
  else if (command == "simulate") (void)quadid::simulate_request(v);
  else if (command == "design") (void)quadid::design_request(v);
  else if (command == "check-trajectory") (void)quadid::check_request(v, "");
  else if (command == "validate") (void)quadid::validate_request(v);
  else if (command == "montecarlo") (void)quadid::montecarlo_request(v);
}

const char* kJsonCommands[] = {"identify", "simulate", "design", "check-trajectory", "validate", "montecarlo", "batch"};

std::string message_of(const std::function<void()>& f) {
  try {
    f();
  } catch (const std::exception& e) {
    return e.what();
  }
  return "no error";
}

}  // namespace

TEST(OptionTable, EveryCommandHasOneAndNamesAreUnique) {
  for (const auto& c : quadid::option_commands()) {
    const auto& t = quadid::option_table(c);  // make() throws on a name declared twice
    EXPECT_EQ(t.command, c);
    EXPECT_FALSE(t.options.empty()) << c;
    bool quiet = false;
    for (const auto& d : t.options) quiet |= d.name == "quiet" && d.short_name == "q";
    EXPECT_TRUE(quiet) << c << " has no -q/--quiet";
  }
  EXPECT_THROW((void)quadid::option_table("nope"), std::invalid_argument);
}

TEST(OptionsJson, EveryDeclaredOptionIsReadWithItsDeclaredKind) {
  // A value of the declared kind never hits OptionValues' logic_error (read as
  // another kind, or not in the table); a bad value may throw invalid_argument or InputError.
  for (const std::string command : kJsonCommands)
    for (const auto& d : quadid::option_table(command).options) {
      if (d.scope != OptionScope::Both) continue;
      json j = {{d.name, sample(d)}};
      if (command == "simulate" && d.name != "trajectory") j["trajectory"] = "table2";
      try {
        call(command, j);
      } catch (const std::logic_error& e) {
        if (dynamic_cast<const std::invalid_argument*>(&e) == nullptr) FAIL() << command << " --" << d.name << ": " << e.what();
      } catch (const std::exception&) {
      }
    }
}

TEST(OptionsJson, AcceptsTheTablesBothOptionsOnlyAndTheirDefaults) {
  for (const auto& command : quadid::option_commands()) {
    const auto& t = quadid::option_table(command);
    const OptionValues none(json::object(), command);
    for (const auto& d : t.options) {
      const json j = {{d.name, sample(d)}};
      if (d.scope == OptionScope::Cli) {
        EXPECT_NE(message_of([&] { OptionValues(j, command); }).find("unknown option '" + d.name + "'"),
                  std::string::npos)
            << command << " --" << d.name;
        EXPECT_NO_THROW(OptionValues(j, command, OptionSource::Cli)) << command << " --" << d.name;
        continue;
      }
      // Absent = the default given explicitly: one default, the table's.
      if (d.default_value.empty()) continue;
      const OptionValues given({{d.name, d.default_value}}, command);
      switch (d.kind) {
        case OptionKind::Number: EXPECT_EQ(*none.number(d.name), *given.number(d.name)) << d.name; break;
        case OptionKind::Integer: EXPECT_EQ(*none.integer(d.name), *given.integer(d.name)) << d.name; break;
        case OptionKind::String: EXPECT_EQ(*none.string(d.name), *given.string(d.name)) << d.name; break;
        case OptionKind::Window: EXPECT_EQ(*none.window(d.name), *given.window(d.name)) << d.name; break;
        default: break;
      }
    }
  }
}

class OptionNames : public quadid::testing::CliTest {};

TEST_F(OptionNames, TheCommandLineHasEveryOptionOfTheTableWithItsDefault) {
  for (const auto& command : quadid::option_commands()) {
    const auto r = run(command + " --help");
    ASSERT_EQ(r.rc, 0) << command;
    for (const auto& d : quadid::option_table(command).options) {
      if (d.hidden) {  // read, not offered (identify's batch options in follow): not listed
        EXPECT_EQ(r.out.find("  --" + d.name + " "), std::string::npos) << command << " lists hidden --" << d.name;
        continue;
      }
      EXPECT_NE(r.out.find("--" + d.name), std::string::npos) << command << " has no --" << d.name;
      for (const auto& a : d.aliases)  // old spellings work but are not listed
        EXPECT_EQ(r.out.find("--" + a + " "), std::string::npos) << command << " lists --" << a;
      if (d.kind == OptionKind::Flag || d.required) continue;
      const std::string& shown = d.default_text.empty() ? d.default_value : d.default_text;
      std::string want = "=";
      want.append(shown.empty() ? std::string("none") : shown.substr(0, 20));
      EXPECT_NE(r.out.find(want), std::string::npos)
          << command << " --" << d.name << " does not show its default " << shown;
    }
  }
}

TEST_F(OptionNames, EveryOldSpellingWorksAndWarnsOnce) {
  int aliases = 0;
  for (const auto& command : quadid::option_commands())
    for (const auto& d : quadid::option_table(command).options)
      for (const auto& a : d.aliases) {
        ++aliases;
        // The command line: the value goes to the new name, one warning on stderr.
        const json sv = sample(d);
        std::string value;
        if (d.kind != OptionKind::Flag) value = fmt::format(" {}", sv.is_string() ? sv.get<std::string>() : sv.dump());
        const auto r = run(command + " --" + a + value + " --help");
        EXPECT_EQ(r.rc, 0) << command << " --" << a << ": " << r.err;
        const std::string warning = "--" + a + " is now --" + d.name + "; the old spelling still works";
        EXPECT_NE(r.err.find(warning), std::string::npos) << command << " --" << a << ": " << r.err;
        EXPECT_EQ(r.err.find(warning), r.err.rfind(warning)) << "warned twice";
        // JSON and Python: the old key reads as the new one, and says so.
        if (d.scope != OptionScope::Both) continue;
        const OptionValues v({{a, sample(d)}}, command);
        EXPECT_TRUE(v.given(d.name)) << command << " " << a;
        ASSERT_EQ(v.deprecations().size(), 1u);
        EXPECT_EQ(v.deprecations()[0], warning);
      }
  EXPECT_GE(aliases, 9);
}

TEST_F(OptionNames, AnOldSpellingGivesTheNewOnesResult) {
  const auto a = run("check-trajectory table2 --tilt-max 6 --no-precision --json");
  const auto b = run("check-trajectory table2 --tilt-max-deg 6 --no-precision --json");
  ASSERT_EQ(a.rc, 0) << a.err;
  EXPECT_EQ(a.out, b.out);
  EXPECT_NE(a.err.find("--tilt-max is now --tilt-max-deg"), std::string::npos);
  EXPECT_TRUE(b.err.empty()) << b.err;
  const auto c = run("check-trajectory table2 --duration 5 --no-precision --json");
  const auto d = run("check-trajectory --trajectory table2 --check-span 5 --no-precision --json");
  ASSERT_EQ(c.rc, 0) << c.err;
  EXPECT_EQ(c.out, d.out);  // the input as a flag too
}

TEST_F(OptionNames, RangeAndChoiceErrorsNameTheFlag) {
  auto r = run("identify nowhere.csv --order 9");
  EXPECT_EQ(r.rc, 1);
  EXPECT_NE(r.err.find("--order: 9 is out of range (must be in [1, 8])"), std::string::npos) << r.err;
  r = run("identify nowhere.csv --filter median");
  EXPECT_NE(r.err.find("--filter: median: expected butter, fir"), std::string::npos) << r.err;
  r = run("design --regression fancy");
  EXPECT_NE(r.err.find("--regression: fancy: expected auto, paper, real"), std::string::npos) << r.err;
  r = run("simulate --trajectory table2 --seed -1");
  EXPECT_NE(r.err.find("--seed: "), std::string::npos) << r.err;
  r = run("montecarlo --nominal qball2-nominal --runs 0 -q");  // the old spelling names itself
  EXPECT_NE(r.err.find("--nominal is now --reference"), std::string::npos) << r.err;
}

TEST(OptionsJson, RangeAndChoiceErrorsNameTheKey) {
  auto message = [](const json& j) { return message_of([&] { (void)quadid::identify_options_from_json(j); }); };
  EXPECT_NE(message({{"order", 9}}).find("identify: option 'order': 9 is out of range (must be in [1, 8])"),
            std::string::npos)
      << message({{"order", 9}});
  EXPECT_NE(message({{"cutoff", 0}}).find("'cutoff': 0 is out of range (must be > 0 Hz)"), std::string::npos)
      << message({{"cutoff", 0}});
  EXPECT_NE(message({{"gd_gain", "fast"}}).find("'gd_gain': fast: expected auto, paper, normalized"),
            std::string::npos);
  EXPECT_NE(message({{"moment_highpass", -1}}).find("'moment_highpass': "), std::string::npos);
  EXPECT_NE(message_of([] { (void)quadid::design_options_from_json({{"tilt_max_deg", "x"}}); })
                .find("'tilt_max_deg': expected a number"),
            std::string::npos);
}

TEST(OptionsJson, EmptyObjectGivesTheCommandLinesDefaults) {
  // The defaults printed by `quadid identify --help` (the table's).
  const auto r = quadid::identify_options_from_json(json::object());
  EXPECT_EQ(r.options.window.t0, 10.0);
  EXPECT_EQ(r.options.window.t1, 50.0);
  EXPECT_FALSE(r.options.error_window.has_value());
  EXPECT_EQ(r.options.lambda, 30.0);
  EXPECT_EQ(r.options.gd.sigma, 30.0);
  EXPECT_EQ(r.options.processing.lowpass.cutoff_hz, 4.0);
  EXPECT_EQ(r.options.processing.lowpass.order, 4);
  EXPECT_EQ(r.options.processing.lowpass.kind, quadid::signal::LowpassOptions::Kind::Butterworth);
  EXPECT_TRUE(r.options.processing.exclude_edges);
  EXPECT_EQ(r.options.evolution_interval, 0.01);
  EXPECT_EQ(r.options.reference.params.theta(), quadid::Params::qball2_nominal().theta());
  EXPECT_EQ(r.options.reference.name, "nom");
  EXPECT_FALSE(r.options.gd_initial.has_value());
  EXPECT_FALSE(r.csv.keep_extra_columns);
  const auto d = quadid::design_options_from_json(nullptr);
  EXPECT_DOUBLE_EQ(d.wf, 36.0 * quadid::kDeg);
  EXPECT_EQ(d.limits.tilt_max, quadid::Constraints{}.tilt_max);
  EXPECT_EQ(d.limits.rate_max, quadid::Constraints{}.rate_max);
  // What only the command line read once: --rate-max-deg, the design vehicle policy, --ignore-input-errors.
  EXPECT_DOUBLE_EQ(quadid::design_options_from_json({{"rate_max_deg", 90}}).limits.rate_max, 90 * quadid::kDeg);
  const auto dv = quadid::design_options_from_json({{"vehicle", "crazyflie21"}});
  EXPECT_GT(dv.limits.rotor_mixer.rows(), 0);
  EXPECT_TRUE(quadid::identify_options_from_json({{"ignore_input_errors", true}}).options.ignore_input_errors);
}

TEST(OptionsJson, PythonSpellingsAndValues) {
  EXPECT_EQ(quadid::normalize_option_key("lambda_"), "lambda");
  EXPECT_EQ(quadid::normalize_option_key("gd_init"), "gd-init");
  EXPECT_EQ(quadid::normalize_option_key("--keep-edges"), "keep-edges");
  const auto r = quadid::identify_options_from_json(
      {{"lambda_", 20}, {"window", "5:15"}, {"cutoff", "3.5"}, {"keep_edges", true}, {"map", "tau_phi=tx"}});
  EXPECT_EQ(r.options.lambda, 20.0);
  EXPECT_EQ(r.options.window.t0, 5.0);
  EXPECT_EQ(r.options.processing.lowpass.cutoff_hz, 3.5);  // numeric text, as typed on a command line
  EXPECT_FALSE(r.options.processing.exclude_edges);
  EXPECT_EQ(r.csv.map.at("tau_phi"), "tx");
  // A window as [T0, T1] (Python's tuple), T1 null: to the end.
  const auto w = quadid::identify_options_from_json({{"window", {10, 50.5}}});
  EXPECT_EQ(w.options.window.t0, 10.0);
  EXPECT_EQ(w.options.window.t1, 50.5);
  EXPECT_TRUE(std::isinf(quadid::identify_options_from_json({{"window", {2, nullptr}}}).options.window.t1));
  EXPECT_EQ(quadid::identify_options_from_json({{"nominal", "qball2-virtual"}}).options.reference.name, "qball2-virtual");
  const auto s = quadid::simulate_options_from_json({{"trajectory", "circle"}, {"radius", 0.8}, {"g", 9.8}});
  EXPECT_EQ(s.options.g, 9.8);
  EXPECT_EQ(s.options.controller.g, 9.8);  // one gravity, as the CLI
  EXPECT_NE(s.trajectory->describe().find("0.8"), std::string::npos) << s.trajectory->describe();
}

TEST(OptionsJson, ErrorsNameTheOption) {
  auto message = [](const json& j) { return message_of([&] { (void)quadid::identify_options_from_json(j); }); };
  EXPECT_NE(message({{"cutof", 3}}).find("unknown option 'cutof'"), std::string::npos);
  EXPECT_NE(message({{"out", "x.json"}}).find("unknown option 'out'"), std::string::npos);  // the command line's only
  EXPECT_NE(message({{"order", 2.5}}).find("'order': expected an integer, got 2.5"), std::string::npos);
  EXPECT_NE(message({{"gd_init", 3}}).find("'gd_init': expected a string"), std::string::npos);
  EXPECT_NE(message({{"window", "9"}}).find("option 'window'"), std::string::npos) << message({{"window", "9"}});
  EXPECT_EQ(message({{"window", "9"}}).find("--"), std::string::npos) << message({{"window", "9"}});
  EXPECT_NE(message({{"lambda", -1}}).find("lambda = -1"), std::string::npos) << message({{"lambda", -1}});
  EXPECT_NE(message({{"lambda", 1}, {"lambda_", 2}}).find("given twice"), std::string::npos);
  EXPECT_NE(message({{"nominal", "qball2-nominal"}, {"reference", "qball2-nominal"}}).find("given twice"),
            std::string::npos);
  EXPECT_NE(message(json::array()).find("expected a JSON object"), std::string::npos);
  EXPECT_THROW((void)quadid::simulate_options_from_json(json::object()), std::invalid_argument);  // trajectory required
}

// Python and JSON callers read the library's advice in their own spelling
// (issue 37: CLI flags in Python errors): flags become keys.
TEST(OptionsJson, LibraryAdviceNamesKeysNotFlagsOutsideTheCommandLine) {
  const std::string m = "--known-mass 34.7 kg contradicts the flight; give --known-mass 0.0347, or --vehicle";
  EXPECT_EQ(quadid::with_option_names(m, quadid::OptionSource::Cli), m);
  EXPECT_EQ(quadid::with_option_names(m, quadid::OptionSource::Json),
            "known_mass=34.7 kg contradicts the flight; give known_mass=0.0347, or vehicle=...");
  EXPECT_EQ(quadid::with_option_names("LowpassOptions: cutoff_hz=300 must be below Nyquist", quadid::OptionSource::Json),
            "cutoff=300 must be below Nyquist");
  EXPECT_EQ(quadid::with_option_names("a-b --x-y -0.5 and well--known", quadid::OptionSource::Json),
            "a-b x_y=-0.5 and well--known");
  EXPECT_EQ(quadid::with_option_names("--summary-set XY: expected LS", quadid::OptionSource::Json),
            "summary_set=XY: expected LS");
}
