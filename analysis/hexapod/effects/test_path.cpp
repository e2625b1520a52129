#include "analysis/hexapod/effects/test_path.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <numbers>
#include <string>

#include <Eigen/Geometry>

#include "analysis/core/errors.h"
#include "analysis/hexapod/dbb_geometry.h"

namespace km::hexapod {
namespace {

// The commanded motion must go one way around the circle (angles increase for ccw, decrease
// for cw, docs/formats.md §1.1): friction and time are read from it. Returns whether the
// motion is one closed turn (its last sample one step short of the first).
bool ReadMotion(const dbb::DbbTest& t) {
  const double sense = t.direction == dbb::Direction::kCcw ? 1.0 : -1.0;
  const auto& a = t.angle_deg;
  for (std::size_t i = 1; i < a.size(); ++i) {
    if (!std::isfinite(a[i]) || sense * (a[i] - a[i - 1]) < -1e-9) {
      throw InvalidInput(t.test_id, 0, "angle_deg",
                         "the commanded motion turns back at sample " + std::to_string(i + 1) +
                             "; a hexapod test must move one way around its circle (angles " +
                             std::string(sense > 0 ? "increasing for ccw" : "decreasing for cw") +
                             ")");
    }
  }
  const double span = std::abs(a.back() - a.front());
  if (a.size() < 2 || !(span > 0.0))
    throw InvalidInput(t.test_id, 0, "angle_deg", "the test's samples do not move");
  const double step = span / static_cast<double>(a.size() - 1);
  return std::abs(span + step - 360.0) <= 0.5 * step;
}

// Changes of the gravity axial forces per kg of platform mass at the file's centre of gravity
// and per kg·mm of m_P·Δc along each platform axis.
void PlatformGravityColumns(const MachinePhysics& m, const StrutFrame& f, const Pose& pose,
                            double tool_length_mm, TestPath& p) {
  const Eigen::Matrix3d r = RotationABC(pose.abc_rad);
  const Eigen::Vector3d cog = r * (m.platform_cog_mm + Eigen::Vector3d(0.0, 0.0, tool_length_mm));
  p.gravity_per_kg.push_back(TensionsForWrench(f, m.g_m_s2, cog.cross(m.g_m_s2)));
  std::array<Vector6d, 3> per;
  for (int k = 0; k < 3; ++k)
    per[k] = TensionsForWrench(f, Eigen::Vector3d::Zero(), r.col(k).cross(m.g_m_s2));
  p.gravity_per_kg_mm.push_back(per);
}

// Strut frames and gravity loads of every sample at its commanded pose on `physical`.
void Statics(const HexapodGeometry& physical, const MachinePhysics* physics, TestPath& p) {
  p.frame.clear();
  p.gravity_N.clear();
  p.gravity_per_kg.clear();
  p.gravity_per_kg_mm.clear();
  const bool gravity = physics && physics->has_gravity;
  for (const auto& pose : p.pose) {
    p.frame.push_back(StrutFrameAt(physical, pose, p.tool_length_mm));
    if (!gravity) continue;
    p.gravity_N.push_back(GravityAxialForces(*physics, p.frame.back(), pose, p.tool_length_mm));
    PlatformGravityColumns(*physics, p.frame.back(), pose, p.tool_length_mm, p);
  }
}

TestPath PathOf(const HexapodGeometry& model, const MachinePhysics* physics, const dbb::DbbTest& t,
                double start_s) {
  if (!t.tool_length_mm)
    throw InvalidInput(t.test_id, 0, "tool_length_mm", "hexapod tests need the tool length");
  if (t.angle_deg.empty()) throw InvalidInput(t.test_id, 0, "samples", "the test has no samples");
  if (!(t.feed_mm_min > 0.0))
    throw InvalidInput(t.test_id, 0, "feed_mm_min", "must be positive for a hexapod test");
  TestPath p;
  p.closed_turn = ReadMotion(t);
  p.test_id = t.test_id;
  p.direction = t.direction;
  p.tool_length_mm = *t.tool_length_mm;
  p.feed_mm_min = t.feed_mm_min;
  p.radius_mm = t.radius_mm;
  p.temperature_c = t.temperature_c;
  const std::size_t n = t.angle_deg.size();
  const double speed = t.feed_mm_min / 60.0;
  const double theta0 = t.angle_deg.front() * std::numbers::pi / 180.0;
  for (std::size_t i = 0; i < n; ++i) {
    const double theta = t.angle_deg[i] * std::numbers::pi / 180.0;
    const Pose pose = CommandedDbbPose(t, theta);
    p.pose.push_back(pose);
    p.strut_mm.push_back(InverseKinematics(model, pose, p.tool_length_mm));
    p.time_s.push_back(start_s + t.radius_mm * std::abs(theta - theta0) / speed);
  }
  Statics(model, physics, p);
  return p;
}

}  // namespace

void RefreshStatics(PreparedTests& tests, const HexapodGeometry& physical) {
  for (auto& p : tests.paths) Statics(physical, tests.setup.physics, p);
}

PreparedTests PrepareTests(const HexapodGeometry& model, const MachinePhysics* physics,
                           const std::vector<dbb::DbbTest>& tests,
                           const std::vector<std::optional<double>>& start_time_s) {
  PreparedTests out;
  out.setup.physics = physics;
  out.setup.all_timed = !tests.empty();
  out.setup.all_temperatures = !tests.empty();
  auto start_of = [&](std::size_t k) {
    return k < start_time_s.size() ? start_time_s[k] : std::optional<double>();
  };
  double t_ref = std::numeric_limits<double>::infinity();
  for (std::size_t k = 0; k < tests.size(); ++k) {
    out.setup.all_timed = out.setup.all_timed && start_of(k).has_value();
    out.setup.all_temperatures = out.setup.all_temperatures && tests[k].temperature_c.has_value();
    if (start_of(k)) t_ref = std::min(t_ref, *start_of(k));
  }
  double earliest = std::numeric_limits<double>::infinity();
  for (std::size_t k = 0; k < tests.size(); ++k) {
    const double start = start_of(k) ? *start_of(k) - t_ref : 0.0;
    out.paths.push_back(PathOf(model, physics, tests[k], start));
    out.paths.back().timed = start_of(k).has_value();
    const double l = *tests[k].tool_length_mm;
    auto& tools = out.setup.tool_lengths_mm;
    if (std::none_of(tools.begin(), tools.end(), [&](double x) { return std::abs(x - l) < 1e-9; }))
      tools.push_back(l);
    if (out.setup.all_temperatures && start < earliest) {
      earliest = start;
      out.setup.reference_temperature_c = *tests[k].temperature_c;
    }
  }
  std::sort(out.setup.tool_lengths_mm.begin(), out.setup.tool_lengths_mm.end());
  return out;
}

}  // namespace km::hexapod
