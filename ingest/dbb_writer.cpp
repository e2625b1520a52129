#include "ingest/dbb_writer.h"

#include <charconv>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <set>

#include "analysis/core/errors.h"

namespace km::ingest {

namespace {

std::string Num(double v) {
  // Shortest text that reads back as the same double (e.g. "150", "0.1", "-1050").
  char buf[64];
  const auto res = std::to_chars(buf, buf + sizeof(buf), v);
  return std::string(buf, res.ptr);
}

std::string Triple(const std::array<double, 3>& a) {
  return Num(a[0]) + ", " + Num(a[1]) + ", " + Num(a[2]);
}

const char* DirectionText(dbb::Direction d) {
  return d == dbb::Direction::kCw ? "cw" : "ccw";
}
const char* PlaneText(dbb::Plane p) {
  switch (p) {
    case dbb::Plane::kYZ:
      return "YZ";
    case dbb::Plane::kZX:
      return "ZX";
    case dbb::Plane::kXY:
    default:
      return "XY";
  }
}

void CheckFinite(double v, const std::string& field) {
  if (!std::isfinite(v)) throw InvalidInput("", 0, field, "value is not finite");
}

}  // namespace

std::string WriteDbb(const dbb::DbbTest& t) {
  if (t.angle_deg.size() != t.dr_um.size()) {
    throw InvalidInput("", 0, "dr_um", "angle_deg and dr_um differ in length");
  }
  if (t.machine_id.empty()) throw InvalidInput("", 0, "machine_id", "must not be empty");
  if (t.test_id.empty()) throw InvalidInput("", 0, "test_id", "must not be empty");
  std::string out = "# format: kinemetric-dbb/1\n";
  auto line = [&](const std::string& k, const std::string& v) {
    out += "# " + k + ": " + v + "\n";
  };
  line("machine_id", t.machine_id);
  line("test_id", t.test_id);
  line("direction", DirectionText(t.direction));
  line("plane", PlaneText(t.plane));
  line("bar_length_mm", Num(t.bar_length_mm));
  line("radius_mm", Num(t.radius_mm > 0.0 ? t.radius_mm : t.bar_length_mm));
  line("centre_mm", Triple(t.centre_mm));
  line("z_offset_mm", Num(t.z_offset_mm));
  line("feed_mm_min", Num(t.feed_mm_min));
  line("tilt_deg", Triple(t.tilt_deg));
  if (t.tool_length_mm) line("tool_length_mm", Num(*t.tool_length_mm));
  if (t.fixed_ball_mm) line("fixed_ball_mm", Triple(*t.fixed_ball_mm));
  if (t.timestamp) line("timestamp", *t.timestamp);
  if (t.temperature_c) line("temperature_c", Num(*t.temperature_c));
  static const std::set<std::string> kStandard = {
      "format",        "machine_id",     "test_id",       "direction",   "plane",
      "bar_length_mm", "radius_mm",      "centre_mm",     "z_offset_mm", "feed_mm_min",
      "tilt_deg",      "tool_length_mm", "fixed_ball_mm", "timestamp",   "temperature_c"};
  for (const auto& [k, v] : t.metadata) {
    if (kStandard.count(k) || k.empty() || k.find(':') != std::string::npos ||
        v.find('\n') != std::string::npos) {
      continue;
    }
    line(k, v);
  }
  out += "angle_deg,dr_um\n";
  char buf[96];
  for (std::size_t i = 0; i < t.dr_um.size(); ++i) {
    CheckFinite(t.angle_deg[i], "angle_deg");
    CheckFinite(t.dr_um[i], "dr_um");
    std::snprintf(buf, sizeof(buf), "%.9f,%.6f\n", t.angle_deg[i], t.dr_um[i]);
    out += buf;
  }
  return out;
}

}  // namespace km::ingest
