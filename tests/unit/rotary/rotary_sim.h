// Test helper: an R-test file from the independent simulator tests/sim/rotary_truth.py and the
// true location errors it used.
#pragma once

#include <gtest/gtest.h>

#include <cstdio>
#include <filesystem>
#include <functional>
#include <map>
#include <nlohmann/json.hpp>
#include <string>

namespace km::rotary::test {

struct SimulatedFile {
  std::string path;
  std::map<std::string, double> truth;  // µm, µrad by name
  nlohmann::json hidden;                // the hidden effects and their values, by name
  std::string output;                   // the simulator's whole JSON output (e.g. "u_gum")
};

// kinematics "AC" or "BC"; poses "full", "tilt0", "on_axis" or "random"; `extra` more options
// of the simulator (e.g. "--hidden c_angle,drift --dt 60").
inline SimulatedFile Simulate(const std::string& kinematics, const std::string& poses, int seed,
                              int count = 1000, const std::string& extra = "") {
  const auto dir = std::filesystem::temp_directory_path() / "km_rotary_test";
  std::filesystem::create_directories(dir);
  SimulatedFile f;
  f.path =
      (dir / (kinematics + "_" + poses + "_" + std::to_string(seed) + "_" + std::to_string(count) +
              "_" + std::to_string(std::hash<std::string>{}(extra)) + ".txt"))
          .string();
  const std::string cmd = "/usr/bin/python3 tests/sim/rotary_truth.py --kinematics " + kinematics +
                          " --poses " + poses + " --seed " + std::to_string(seed) + " --count " +
                          std::to_string(count) + " " + extra + " --out '" + f.path + "'";
  FILE* p = popen(cmd.c_str(), "r");
  EXPECT_NE(p, nullptr);
  std::string out;
  char buf[4096];
  while (p && fgets(buf, sizeof buf, p)) out += buf;
  EXPECT_EQ(p ? pclose(p) : -1, 0) << out;
  const nlohmann::json truth = nlohmann::json::parse(out);
  for (const auto& [name, value] : truth.at("errors").items()) f.truth[name] = value.get<double>();
  EXPECT_EQ(f.truth.size(), 8u) << out;
  f.hidden = truth.at("hidden");
  f.output = out;
  return f;
}

}  // namespace km::rotary::test
