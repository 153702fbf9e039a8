// Options from JSON keyed by the command line's names (options_json.hpp): every
// declared option is read, names are the CLI's, defaults are the CLI's, and bad
// keys or values name the option.
#include "cli_fixture.hpp"
#include "quadid/pipeline.hpp"

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include <string>

namespace {

using nlohmann::json;

/// A valid value of each kind (the tables' options are all optional here).
json sample(const quadid::OptionSpec& s) {
  switch (s.kind) {
    case quadid::OptionKind::Number: return 1.0;
    case quadid::OptionKind::Integer: return 1;
    case quadid::OptionKind::String: return "x";
    case quadid::OptionKind::Flag: return true;
    case quadid::OptionKind::List: return json::array();
  }
  return nullptr;
}

void call(const std::string& command, const json& j) {
  if (command == "identify") (void)quadid::identify_options_from_json(j);
  else if (command == "simulate") (void)quadid::simulate_options_from_json(j);
  else if (command == "design") (void)quadid::design_options_from_json(j);
  else if (command == "check-trajectory") (void)quadid::check_options_from_json(j);
  else (void)quadid::validate_options_from_json(j);
}

const char* kCommands[] = {"identify", "simulate", "design", "check-trajectory", "validate"};

}  // namespace

TEST(OptionsJson, EveryDeclaredOptionIsReadWithItsDeclaredKind) {
  // A value of the declared kind never hits the Reader's logic_error (read as
  // another kind); a bad value may throw invalid_argument or InputError.
  for (const std::string command : kCommands)
    for (const auto& s : quadid::command_option_specs(command)) {
      json j = {{s.name, sample(s)}};
      if (command == "simulate" && s.name != "trajectory") j["trajectory"] = "table2";
      try {
        call(command, j);
      } catch (const std::logic_error& e) {
        if (dynamic_cast<const std::invalid_argument*>(&e) == nullptr) FAIL() << command << " --" << s.name << ": " << e.what();
      } catch (const std::exception&) {
      }
    }
}

class OptionNames : public quadid::testing::CliTest {};

TEST_F(OptionNames, AreTheCommandLinesLongOptions) {
  for (const std::string command : kCommands) {
    const auto r = run(command + " --help");
    ASSERT_EQ(r.rc, 0) << command;
    for (const auto& s : quadid::command_option_specs(command))
      EXPECT_NE(r.out.find("--" + s.name), std::string::npos) << command << " has no --" << s.name;
  }
}

TEST(OptionsJson, EmptyObjectGivesTheCommandLinesDefaults) {
  // The defaults printed by `quadid identify --help` (apps/quadid/cmd_identify.cpp, common.cpp).
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
  EXPECT_FALSE(r.options.gd_initial.has_value());
  EXPECT_FALSE(r.csv.keep_extra_columns);
  const auto d = quadid::design_options_from_json(nullptr);
  EXPECT_DOUBLE_EQ(d.wf, 36.0 * quadid::kDeg);
  EXPECT_DOUBLE_EQ(d.limits.tilt_max, quadid::Constraints{}.tilt_max);
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
  const auto s = quadid::simulate_options_from_json({{"trajectory", "circle"}, {"radius", 0.8}, {"g", 9.8}});
  EXPECT_EQ(s.options.g, 9.8);
  EXPECT_EQ(s.options.controller.g, 9.8);  // one gravity, as the CLI
  EXPECT_NE(s.trajectory->describe().find("0.8"), std::string::npos) << s.trajectory->describe();
}

TEST(OptionsJson, ErrorsNameTheOption) {
  auto message = [](const json& j) {
    try {
      (void)quadid::identify_options_from_json(j);
    } catch (const std::invalid_argument& e) {
      return std::string(e.what());
    }
    return std::string("no error");
  };
  EXPECT_NE(message({{"cutof", 3}}).find("unknown option 'cutof'"), std::string::npos);
  EXPECT_NE(message({{"order", 2.5}}).find("'order' (--order): expected an integer, got 2.5"), std::string::npos);
  EXPECT_NE(message({{"gd_init", 3}}).find("'gd_init' (--gd-init): expected a string"), std::string::npos);
  EXPECT_NE(message({{"window", "9"}}).find("(--window)"), std::string::npos) << message({{"window", "9"}});
  EXPECT_NE(message({{"lambda", -1}}).find("--lambda = -1"), std::string::npos) << message({{"lambda", -1}});
  EXPECT_NE(message({{"lambda", 1}, {"lambda_", 2}}).find("given twice"), std::string::npos);
  EXPECT_NE(message(json::array()).find("expected a JSON object"), std::string::npos);
  EXPECT_THROW((void)quadid::simulate_options_from_json(json::object()), std::invalid_argument);  // trajectory required
}
