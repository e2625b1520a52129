// Compensation in LinuxCNC's trunnion kinematics (docs/methods.md §17.7): the exported pivot
// corrections applied to the model. The controller then turns the table about the corrected
// lines; the sphere is carried about the actual ones. With the corrections the displacements the
// position errors caused vanish (exactly with the true errors, to the identification's σ with
// those identified from an independent simulator's file); those of the direction errors remain —
// the ones listed "adjust mechanically".
#include <gtest/gtest.h>

#include <cmath>
#include <fstream>
#include <sstream>

#include "analysis/core/angles.h"
#include "analysis/core/errors.h"
#include "analysis/rotary/rotary_model.h"
#include "analysis/rotary/rotary_pivots.h"
#include "ingest/rotary/rotary_parser.h"
#include "tests/unit/rotary/rotary_sim.h"
#include "usecases/rotary/rotary_export.h"

namespace km::rotary {
namespace {

using Eigen::Vector3d;

// RMS (µm) over the poses of the sphere's displacement: carried about the lines of `machine`,
// the controller expecting it about the error-free lines of `controller`.
double RmsDisplacement(const RotaryTest& t, const AxisLines& machine,
                       const RotarySetup& controller) {
  const AxisLines expected = ActualLines(controller, LocationErrors{});
  const Vector3d s(t.setup.sphere_mm[0], t.setup.sphere_mm[1], t.setup.sphere_mm[2]);
  double sum = 0.0;
  for (const auto& p : t.poses) {
    const double a = p.tilt_deg * kDeg, c = p.c_deg * kDeg;
    sum += (1e3 * (SpherePosition(machine, s, a, c) - SpherePosition(expected, s, a, c)))
               .squaredNorm();
  }
  return std::sqrt(sum / double(t.poses.size()));
}

LocationErrors Only(const LocationErrors& e, bool angular) {
  LocationErrors out{};
  for (std::size_t i = 0; i < kLocationErrorCount; ++i) {
    if (IsAngularError(i) == angular) out[i] = e[i];
  }
  return out;
}

struct Case {
  ingest::RotaryFile file;
  LocationErrors truth{};
};

Case Load(const char* kinematics) {
  const auto f = test::Simulate(kinematics, "full", 31);
  std::ifstream in(f.path);
  std::stringstream text;
  text << in.rdbuf();
  Case c{ingest::ParseRotaryFile(text.str(), f.path), {}};
  const auto& names = LocationErrorNames(c.file.test.setup.kinematics);
  for (std::size_t i = 0; i < kLocationErrorCount; ++i)
    c.truth[i] = f.truth.at(std::string(names[i]));
  return c;
}

// LinuxCNC's trtfuncs.c turns C about (x-rot-point, y-rot-point) and the tilt axis about
// (y-rot-point + y-offset, z-rot-point + z-offset) for AC, (x-rot-point + x-offset,
// z-rot-point + z-offset) for BC (tool-offset 0): the corrected values put them on the
// corrected lines.
void ExpectModuleLines(const PivotCorrection& p) {
  const auto v = [&](std::size_t i) { return *p.params[i].corrected_mm; };
  const auto& s = p.corrected_setup;
  EXPECT_NEAR(v(0), s.c_axis_mm[0], 1e-12);
  EXPECT_NEAR(v(1), s.c_axis_mm[1], 1e-12);
  const bool ac = p.kinematics == Kinematics::kAcTrunnion;
  EXPECT_EQ(p.params[3].name, ac ? "y-offset" : "x-offset");
  EXPECT_NEAR((ac ? v(1) : v(0)) + v(3), s.tilt_axis_mm[0], 1e-12);
  EXPECT_NEAR(v(2) + v(4), s.tilt_axis_mm[1], 1e-12);
}

TEST(RotaryPivots, TrueCorrectionsLeaveExactlyTheDirectionErrors) {
  for (const char* k : {"AC", "BC"}) {
    const Case c = Load(k);
    const RotarySetup& setup = c.file.test.setup;
    std::array<bool, kLocationErrorCount> all{};
    all.fill(true);
    const PivotCorrection p = LinuxCncPivots(setup, c.truth, all);
    const AxisLines machine = ActualLines(setup, c.truth);
    const double before = RmsDisplacement(c.file.test, machine, setup);
    const double after = RmsDisplacement(c.file.test, machine, p.corrected_setup);
    const double positions =
        RmsDisplacement(c.file.test, ActualLines(setup, Only(c.truth, false)), setup);
    const double directions = RmsDisplacement(
        c.file.test, ActualLines(p.corrected_setup, Only(c.truth, true)), p.corrected_setup);
    std::printf(
        "  %s: RMS before %.3f um (positions alone %.3f), after %.3f um = directions %.3f\n", k,
        before, positions, after, directions);
    EXPECT_GT(positions, 5.0);
    EXPECT_NEAR(after, directions, 1e-6);
    EXPECT_LT(after, before);
    EXPECT_GT(directions, 1.0);  // what remains: adjust mechanically
    ExpectModuleLines(p);
  }
}

TEST(RotaryPivots, IdentifiedCorrectionsRemoveThePositionErrorsToTheirSigma) {
  for (const char* k : {"AC", "BC"}) {
    const Case c = Load(k);
    const auto report = usecases::AnalyzeRotary(c.file);
    const PivotCorrection p = usecases::RotaryPivots(report);
    const RotarySetup& setup = c.file.test.setup;
    const AxisLines machine = ActualLines(setup, c.truth);
    const double after = RmsDisplacement(c.file.test, machine, p.corrected_setup);
    const double directions = RmsDisplacement(
        c.file.test, ActualLines(p.corrected_setup, Only(c.truth, true)), p.corrected_setup);
    std::printf(
        "  %s: after the exported corrections %.3f um, the direction errors alone %.3f um\n", k,
        after, directions);
    EXPECT_NEAR(after, directions, 0.3);
    EXPECT_EQ(p.mechanical, (std::vector<std::size_t>{2, 3, 6, 7}));
  }
}

TEST(RotaryPivots, LinuxCncLinesNameTheModulesPins) {
  const Case c = Load("AC");
  const std::string text = usecases::ExportRotary(usecases::AnalyzeRotary(c.file), "linuxcnc");
  std::printf("%s", text.c_str());
  for (const char* pin : {"x-rot-point", "y-rot-point", "z-rot-point", "y-offset", "z-offset"}) {
    EXPECT_NE(text.find(std::string("setp xyzac-trt-kins.") + pin + " "), std::string::npos) << pin;
  }
  for (const char* e : {"BOA", "COA", "AOC", "BOC"}) {
    EXPECT_NE(text.find(std::string("# ") + e), std::string::npos) << e;
  }
  EXPECT_NE(text.find("adjust mechanically"), std::string::npos);
  EXPECT_THROW(usecases::ExportRotary(usecases::AnalyzeRotary(c.file), "fanuc"), InvalidInput);
}

}  // namespace
}  // namespace km::rotary
