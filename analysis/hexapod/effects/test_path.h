// Preparation of DBB tests for effect evaluation: commanded poses and strut values of the
// controller's model, the time of every sample, and the statics at the commanded poses.
#pragma once

#include <optional>
#include <vector>

#include "analysis/dbb/dbb_types.h"
#include "analysis/hexapod/effects/effect.h"

namespace km::hexapod {

struct PreparedTests {
  EffectSetup setup;
  std::vector<TestPath> paths;
};

// start_time_s: per test, the start time in seconds on any common scale (e.g. Unix time) when
// the test carries a timestamp, else nullopt. Sample times follow the path at the test's feed;
// they are reported relative to the earliest start time. Throws km::InvalidInput (test, field)
// for a test without tool_length_mm, feed or samples.
PreparedTests PrepareTests(const HexapodGeometry& model, const MachinePhysics* physics,
                           const std::vector<dbb::DbbTest>& tests,
                           const std::vector<std::optional<double>>& start_time_s);

// The strut frames and gravity loads of every sample recomputed at its commanded pose on the
// machine's physical geometry (e.g. the calibrated one): the controller commands with its
// model, but the struts are loaded and deflect as the real machine is built. PrepareTests uses
// the model geometry.
void RefreshStatics(PreparedTests& tests, const HexapodGeometry& physical);

}  // namespace km::hexapod
