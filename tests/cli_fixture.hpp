// A GoogleTest fixture for end-to-end tests of the built program (QUADID_EXE):
// a scratch directory per test and a runner that captures stdout, stderr and
// the exit code.
#pragma once

#include "quadid/io.hpp"

#include <gtest/gtest.h>

#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <string>
#include <sys/wait.h>
#include <unistd.h>

namespace quadid::testing {

struct CliRun {
  int rc = -1;
  std::string out, err;
};

class CliTest : public ::testing::Test {
 protected:
  void SetUp() override {
    const auto* info = ::testing::UnitTest::GetInstance()->current_test_info();
    dir_ = std::filesystem::temp_directory_path() /
           (std::string("quadid_") + info->test_suite_name() + "_" + info->name() + "_" + std::to_string(::getpid()));
    std::filesystem::create_directories(dir_);
  }
  void TearDown() override { std::filesystem::remove_all(dir_); }

  std::string path(const std::string& name) const { return (dir_ / name).string(); }

  void write(const std::string& name, const std::string& text) const {
    std::ofstream(path(name)) << text;
  }

  /// Runs `quadid <prefix_><args>` (args are passed to the shell as written).
  CliRun run(const std::string& args) const {
    const std::string o = path(".stdout"), e = path(".stderr");
    const std::string cmd =
        std::string("\"") + QUADID_EXE + "\" " + prefix_ + args + " >\"" + o + "\" 2>\"" + e + "\"";
    const int status = std::system(cmd.c_str());
    CliRun r;
    r.rc = WIFEXITED(status) ? WEXITSTATUS(status) : -1;
    r.out = read_file(o);
    r.err = read_file(e);
    return r;
  }

  std::filesystem::path dir_;
  std::string prefix_;  // e.g. "identify " for a fixture that tests one subcommand
};

}  // namespace quadid::testing
