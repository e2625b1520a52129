// Fixture for tests of `kinemetric` commands run in-process: a temporary directory per test
// (removed afterwards), a writer of input files into it, and the arguments of a `--json` run.
#pragma once

#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <string>
#include <vector>

#include "cli/command.h"

namespace km::cli::test {

class CliTest : public ::testing::Test {
 protected:
  void SetUp() override {
    const auto* info = ::testing::UnitTest::GetInstance();
    dir_ = std::filesystem::temp_directory_path() /
           ("km_cli_" + std::to_string(info->random_seed()) + "_" +
            info->current_test_info()->test_suite_name() + "_" + info->current_test_info()->name());
    std::filesystem::create_directories(dir_);
  }
  void TearDown() override { std::filesystem::remove_all(dir_); }

  std::string Write(const std::string& name, const std::string& text) {
    const std::filesystem::path p = dir_ / name;
    std::ofstream(p) << text;
    return p.string();
  }

  static Args JsonArgs(std::vector<std::string> files) {
    Args args;
    args.positional = std::move(files);
    args.options["--json"] = "";
    args.json = true;
    return args;
  }

  std::filesystem::path dir_;
};

}  // namespace km::cli::test
