#include "server/discovery_report.h"

#include <cmath>
#include <map>

#include "analysis/core/errors.h"
#include "analysis/dbb/circular_test.h"
#include "analysis/dbb/discovery.h"
#include "analysis/discovery/hexapod_family.h"
#include "analysis/hexapod/dbb_geometry.h"
#include "ingest/iso8601.h"
#include "server/discovery_json.h"
#include "server/effect_calibration.h"

namespace km::server {
namespace {

using nlohmann::json;

// The machine's stored effects resolved against this test set (unknown names refused; the
// parameters of tools not used here are left at their defaults).
std::vector<hexapod::ActiveEffect> KnownEffects(const ingest::MachineDefinition& m,
                                                const hexapod::EffectSetup& setup) {
  std::vector<hexapod::ActiveEffect> out;
  for (std::size_t i = 0; i < m.effects.size(); ++i) {
    const auto& me = m.effects[i];
    const auto* e = hexapod::FindHexapodEffect(me.effect);
    const std::string field = "effects[" + std::to_string(i) + "].effect";
    if (!e) {
      throw InvalidInput(
          m.machine_id, 0, field,
          "'" + me.effect + "' is not a hexapod effect (" + hexapod::HexapodEffectNames() + ")");
    }
    hexapod::ActiveEffect a{e, e->Parameters(setup)};
    if (a.params.empty()) {
      throw InvalidInput(m.machine_id, 0, field,
                         me.effect +
                             " cannot be evaluated for these tests (missing masses, "
                             "timestamps or temperatures)");
    }
    for (const auto& [name, value] : me.parameters)
      for (auto& p : a.params)
        if (p.name == name) p.value = std::clamp(value, p.lower, p.upper);
    out.push_back(std::move(a));
  }
  return out;
}

DiscoveryOutcome HexapodDiscovery(const DiscoveryStudy& study,
                                  const DiscoveryProgressFn& progress) {
  const ingest::MachineDefinition& machine = *study.machine;
  bool absolute = true;
  for (const auto& t : study.tests) absolute = absolute && t.fixed_ball_mm.has_value();
  const auto method = absolute ? hexapod::CalibrationMethod::kAbsolute
                               : hexapod::CalibrationMethod::kCentreCorrected;
  const hexapod::MachinePhysics* physics = machine.physics ? &*machine.physics : nullptr;
  hexapod::EffectFitData data;
  try {
    data = hexapod::PrepareEffectFit(machine.geometry, physics, study.tests,
                                     TestStartTimes(study.tests, study.names), method,
                                     study.max_samples_per_test);
  } catch (const InvalidInput& e) {
    // Name the file rather than the test id.
    for (std::size_t k = 0; k < study.tests.size() && k < study.names.size(); ++k)
      if (study.tests[k].test_id == e.file())
        throw InvalidInput(study.names[k], e.line(), e.field(), e.reason());
    throw;
  }
  discovery::HexapodFamily family(data, KnownEffects(machine, data.prepared.setup));
  const int max_steps = discovery::EngineOptions{}.max_steps;
  const auto r = discovery::RunDiscovery(family, {}, [&](int step, const std::string& what) {
    if (progress) progress(std::min(0.95, step / static_cast<double>(max_steps + 1)), what);
  });
  DiscoveryOutcome out;
  out.report = HexapodDiscoveryJson(machine, data, family.History(), r, study.names);
  out.updated_machine = UpdatedMachine(machine, family.History().back());
  if (progress) progress(1.0, "done");
  return out;
}

DiscoveryOutcome SerialDiscovery(const DiscoveryStudy& study) {
  if (study.tests.empty()) throw InvalidInput("", 0, "FILE", "no DBB test given");
  std::vector<dbb::DiagnosisTrace> traces;
  for (std::size_t k = 0; k < study.tests.size(); ++k) {
    const dbb::DbbTest& t = study.tests[k];
    const std::string name = k < study.names.size() ? study.names[k] : t.test_id;
    try {
      traces.push_back(dbb::MakeDiagnosisTrace(t, dbb::AnalyzeCircularTest(t)));
    } catch (const InvalidInput& e) {
      throw InvalidInput(name, e.line(), e.field(), e.reason());
    }
    if (t.plane != study.tests.front().plane) {
      throw InvalidInput(name, 0, "plane",
                         std::string("all files must be in one plane (") +
                             dbb::ToString(study.tests.front().plane) + " in " +
                             (study.names.empty() ? study.tests.front().test_id : study.names[0]) +
                             ")");
    }
  }
  const dbb::Plane plane = study.tests.front().plane;
  DiscoveryOutcome out;
  out.report = SerialDiscoveryJson(dbb::DiscoverSerialDbb(traces, plane), plane);
  return out;
}

}  // namespace

DiscoveryOutcome RunDiscoveryStudy(const DiscoveryStudy& study,
                                   const DiscoveryProgressFn& progress) {
  if (study.tests.empty()) throw InvalidInput("", 0, "FILE", "no DBB test given");
  if (study.machine && study.machine->kind == "hexapod") return HexapodDiscovery(study, progress);
  DiscoveryOutcome out = SerialDiscovery(study);
  if (progress) progress(1.0, "done");
  return out;
}

}  // namespace km::server
