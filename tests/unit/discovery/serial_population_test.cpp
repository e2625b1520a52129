// `kinemetric discover` (serial family on the shared engine) judged against the independent
// truth simulator (serial_truth.h) on random serial machines: 0–3 effects among the eight
// product effects, cw and ccw, one or two test ids, noise 0.2–0.5 µm. Passes when every
// injected effect above 3× its uncertainty is named, false discoveries stay within 2 of 50
// (none in the 10-machine form) and machines without effects add nothing.
// KM_POPULATION_MACHINES machines (10 in the default run, 50 under the label `long`); the
// 10-machine form is the first 10 machines of the 50.
#include <gtest/gtest.h>

#include <chrono>
#include <cstdio>
#include <random>
#include <set>
#include <string>
#include <vector>

#include "ingest/dbb_parser.h"
#include "tests/unit/discovery/serial_truth.h"
#include "usecases/discovery_report.h"

#ifndef KM_POPULATION_MACHINES
#define KM_POPULATION_MACHINES 10
#define KM_POPULATION_NAME TenRandomMachines
#endif

namespace km {
namespace {

nlohmann::json Discover(const test::truth::Machine& m) {
  usecases::DiscoveryStudy study;
  for (const auto& t : m.tests) {
    const std::string name = m.machine_id + "_" + t.test_id + (t.direction > 0 ? "_ccw" : "_cw");
    study.tests.push_back(ingest::ParseDbb(test::truth::DbbFile(m, t), name));
    study.names.push_back(name);
  }
  return usecases::RunDiscoveryStudy(study).report;
}

TEST(SerialDiscoveryPopulation, KM_POPULATION_NAME) {
  const int machines = KM_POPULATION_MACHINES;
  std::mt19937 rng(20261124u);
  int injected = 0, detectable = 0, named = 0, missed = 0, false_discoveries = 0;
  int null_machines = 0, null_with_steps = 0, misfit = 0, wrong_sign = 0;
  double seconds = 0.0;
  for (int i = 0; i < machines; ++i) {
    const auto m = test::truth::RandomMachine(rng, i % 4, "m" + std::to_string(i));
    const auto t0 = std::chrono::steady_clock::now();
    const auto j = Discover(m);
    seconds += std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    std::set<std::string> added;
    for (const auto& s : j["steps"]) added.insert(s["added_effect"].get<std::string>());
    std::string line = m.machine_id + " " + m.plane + " noise " + std::to_string(m.noise_um) +
                       " tests " + std::to_string(m.tests.size()) + " |";
    std::set<std::string> truth;
    for (std::size_t k = 0; k < m.effects.size(); ++k) {
      const auto& e = m.effects[k];
      const std::string n = test::truth::Name(e, m.plane);
      const double z = test::truth::Detectability(m, k);
      truth.insert(n);
      ++injected;
      const bool found = added.count(n) > 0;
      named += found ? 1 : 0;
      char buf[160];
      std::snprintf(buf, sizeof buf, " %s=%.3g (z %.0f)%s", n.c_str(), test::truth::Value(e), z,
                    found ? "" : " MISSED");
      line += buf;
      if (z > 3.0) {
        ++detectable;
        if (!found) ++missed;
        EXPECT_TRUE(found) << m.machine_id << ": " << n << " (z " << z << ") not named";
      }
      for (const auto& f : j["final_model"]) {
        if (f["effect"] != n) continue;
        const double v =
            f["value"].is_array() ? f["value"][0].get<double>() : f["value"].get<double>();
        if (e.kind != test::truth::Kind::kCyclicError && v * test::truth::Value(e) < 0.0)
          ++wrong_sign;
      }
    }
    line += " | named:";
    for (const auto& a : added) {
      line += " " + a;
      if (!truth.count(a)) {
        ++false_discoveries;
        line += " (FALSE)";
      }
    }
    char tail[160];
    std::snprintf(tail, sizeof tail, " | %s, unexplained %.3f floor %.3f",
                  j["verdict"].get<std::string>().c_str(), j["unexplained_rms_um"].get<double>(),
                  j["noise_floor_um"].get<double>());
    line += tail;
    if (j["verdict"] != "complete") ++misfit;
    if (m.effects.empty()) {
      ++null_machines;
      if (!j["steps"].empty()) ++null_with_steps;
      EXPECT_TRUE(j["steps"].empty()) << line;
    }
    std::printf("%s\n", line.c_str());
  }
  std::printf(
      "machines %d: injected %d, detectable (z > 3) %d, named %d, missed detectable %d, false "
      "discoveries %d, null machines %d (with steps %d), verdict not complete %d, wrong sign %d, "
      "%.2f s per machine\n",
      machines, injected, detectable, named, missed, false_discoveries, null_machines,
      null_with_steps, misfit, wrong_sign, seconds / machines);
  RecordProperty("false_discoveries", false_discoveries);
  RecordProperty("named", named);
  RecordProperty("detectable", detectable);
  EXPECT_EQ(missed, 0);
  EXPECT_LE(false_discoveries, 2 * machines / 50);
  EXPECT_EQ(null_with_steps, 0);
  EXPECT_EQ(wrong_sign, 0);
}

}  // namespace
}  // namespace km
