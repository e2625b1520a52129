// Writes the analysis JSON (usecases::DbbReportJson) of the benchmark's synthetic DBB pairs and
// of the DBB files given, one file per case in OUT_DIR, so that two builds' figures can be
// compared number by number (tests/bench/dbb/compare_figures.py).
//
//   dbb_figures_dump OUT_DIR [FILE...]   (files are analysed one pair at a time: cw, ccw)
#include <cstdio>
#include <exception>
#include <fstream>
#include <sstream>
#include <string>
#include <vector>

#include "analysis/dbb/full_analysis.h"
#include "analysis/dbb/serial_sim.h"
#include "ingest/file_formats.h"
#include "usecases/dbb_report.h"

namespace km::dbb {
namespace {

using serial_effects::EffectId;

std::vector<DbbTest> SimPair(std::vector<SimEffect> eff, unsigned seed) {
  SerialDbbSimOptions o;
  o.step_deg = 0.1;
  o.noise_um = 0.1;
  o.fixed_ball_offset_um = {4.0, -3.0};
  o.effects = std::move(eff);
  o.seed = seed;
  std::vector<DbbTest> v;
  o.direction = Direction::kCcw;
  v.push_back(SimulateSerialDbbTest(o));
  o.direction = Direction::kCw;
  o.seed = seed + 1;
  v.push_back(SimulateSerialDbbTest(o));
  return v;
}

struct Case {
  std::string name;
  std::vector<SimEffect> effects;
};

std::vector<Case> Cases() {
  const std::vector<SimEffect> mixed = {{EffectId::kSquareness, {25.0}},
                                        {EffectId::kServoMismatch, {0.25}},
                                        {EffectId::kBacklashU, {3.0}},
                                        {EffectId::kReversalSpikeV, {2.0, 2.0}},
                                        {EffectId::kCyclicErrorU, {0.5, 0.3, 10.0}}};
  return {{"sim_mixed", mixed},
          {"sim_clean", {}},
          {"sim_spike_narrow", {{EffectId::kReversalSpikeU, {3.0, 1.0, 1.0}}}},
          {"sim_spike_wide_sq", {{EffectId::kReversalSpikeV, {2.5, 4.0, 2.0}}}},
          {"sim_stick_slip", {{EffectId::kStickSlip, {0.8, 3.0}}, {EffectId::kBacklashV, {2.0}}}},
          {"sim_cyclic_play",
           {{EffectId::kCyclicErrorV, {0.4, -0.2, 5.0}}, {EffectId::kLateralPlayU, {1.5}}}}};
}

void Write(const std::string& path, const std::vector<DbbTest>& tests) {
  const auto j = usecases::DbbReportJson(tests, AnalyzeDbbSet(tests));
  std::ofstream(path) << j.dump(1) << "\n";
}

std::string ReadAll(const std::string& path) {
  std::ifstream f(path, std::ios::binary);
  std::ostringstream s;
  s << f.rdbuf();
  return s.str();
}

}  // namespace
}  // namespace km::dbb

int main(int argc, char** argv) {
  if (argc < 2) {
    std::fprintf(stderr, "usage: dbb_figures_dump OUT_DIR [FILE...]\n");
    return 2;
  }
  const std::string out = argv[1];
  unsigned seed = 1;
  for (const auto& c : km::dbb::Cases()) {
    km::dbb::Write(out + "/" + c.name + ".json", km::dbb::SimPair(c.effects, seed));
    seed += 2;
  }
  std::vector<km::dbb::DbbTest> all;
  for (int i = 2; i < argc; ++i) {
    const std::string path = argv[i];
    try {
      all.push_back(km::ingest::ReadDbb(km::dbb::ReadAll(path), path));
      const auto slash = path.find_last_of('/');
      km::dbb::Write(
          out + "/file_" + std::to_string(i - 1) + "_" + path.substr(slash + 1) + ".json",
          {all.back()});
    } catch (const std::exception& e) {
      std::fprintf(stderr, "%s: %s\n", path.c_str(), e.what());
      if (!all.empty() && all.back().test_id.empty()) all.pop_back();
    }
  }
  if (!all.empty()) km::dbb::Write(out + "/files_all.json", all);
  return 0;
}
