#include "ingest/servo_parser.h"

#include <algorithm>
#include <cctype>
#include <cmath>
#include <cstdio>
#include <set>

#include "analysis/core/errors.h"

namespace km::ingest {
namespace {

// Forces beyond 10 MN and positions beyond 1 km are not servo loads of a machine tool.
constexpr double kMaxForceN = 1e7;
constexpr double kMaxPositionMm = 1e6;
constexpr double kMaxAngleDeg = 360.0;

std::string Lower(std::string s) {
  for (char& c : s) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  return s;
}

std::string Upper(std::string s) {
  for (char& c : s) c = static_cast<char>(std::toupper(static_cast<unsigned char>(c)));
  return s;
}

void CheckRange(const TextTable& t, std::size_t column, double limit, const char* what) {
  const auto& v = t.Column(column);
  for (std::size_t i = 0; i < v.size(); ++i) {
    if (std::abs(v[i]) > limit) {
      throw InvalidInput(t.file, t.row_lines[i], t.columns[column],
                         "value is too large for " + std::string(what));
    }
  }
}

// Times strictly increasing; enough rows.
void CheckTimes(const TextTable& t, std::size_t it) {
  if (t.NumRows() < kMinServoRows) {
    const std::size_t line = t.row_lines.empty() ? t.columns_line : t.row_lines.back();
    throw InvalidInput(t.file, line, "t_s",
                       "found " + std::to_string(t.NumRows()) + " data rows; at least " +
                           std::to_string(kMinServoRows) + " are needed");
  }
  const auto& ts = t.Column(it);
  for (std::size_t i = 1; i < ts.size(); ++i) {
    if (!(ts[i] > ts[i - 1])) {
      throw InvalidInput(t.file, t.row_lines[i], "t_s",
                         "times must be strictly increasing (previous value on line " +
                             std::to_string(t.row_lines[i - 1]) + ")");
    }
  }
}

// A position that moves between two samples at least this far (mm)…
constexpr double kJumpMinMm = 0.01;
// …this many times as far and as fast as the samples around it usually do (the median of the
// five steps either side)…
constexpr double kJumpRatio = 10.0;
constexpr std::size_t kJumpAround = 5;
// …with an acceleration above this from their speed (mm/s², 50 m/s² ≈ 5 g, beyond a
// machine-tool drive), is no motion of the machine: two recordings joined, or a glitch.
constexpr double kJumpAccelMmS2 = 5e4;

std::string Fixed(double v, int decimals) {
  char buf[64];
  std::snprintf(buf, sizeof buf, "%.*f", decimals, v);
  return buf;
}

double MedianOf(std::vector<double>& v) {
  if (v.empty()) return 0.0;
  std::nth_element(v.begin(), v.begin() + static_cast<std::ptrdiff_t>(v.size() / 2), v.end());
  return v[v.size() / 2];
}

// Refuses a jump of the position column between consecutive samples (see the constants above),
// naming the line after the jump, its size and the time it took.
void CheckNoJump(const TextTable& t, std::size_t column, const std::vector<double>& ts) {
  const auto& x = t.Column(column);
  const std::size_t n = x.size();
  const auto step = [&](std::size_t i) { return std::abs(x[i] - x[i - 1]); };  // i >= 1
  std::vector<double> steps, speeds;
  for (std::size_t i = 1; i < n; ++i) {
    const double d = step(i), dt = ts[i] - ts[i - 1];
    if (!(d >= kJumpMinMm)) continue;
    // Steps around a tenth of this one or less: half of them for a jump (counted first; the
    // medians only where it may be one).
    const std::size_t lo = i > kJumpAround ? i - kJumpAround : 1;
    const std::size_t hi = std::min(n, i + kJumpAround + 1);
    std::size_t small = 0;
    for (std::size_t k = lo; k < hi; ++k) small += k != i && kJumpRatio * step(k) < d;
    if (2 * small < hi - lo - 1) continue;
    steps.clear();
    speeds.clear();
    for (std::size_t k = lo; k < hi; ++k) {
      if (k == i) continue;
      steps.push_back(step(k));
      speeds.push_back(step(k) / (ts[k] - ts[k - 1]));
    }
    const double d_ref = MedianOf(steps), v_ref = MedianOf(speeds);
    const double v = d / dt, accel = 4.0 * (d - v_ref * dt) / (dt * dt);
    if (d > kJumpRatio * d_ref && v > kJumpRatio * v_ref && accel > kJumpAccelMmS2) {
      throw InvalidInput(
          t.file, t.row_lines[i], t.columns[column],
          "the position jumps by " + Fixed(d, 3) + " mm in " + Fixed(1e3 * dt, 3) +
              " ms from line " + std::to_string(t.row_lines[i - 1]) + " (" + Fixed(v, 0) +
              " mm/s, where the samples around move at " + Fixed(v_ref, 1) +
              " mm/s): no machine moves so; two recordings joined, or a glitch of the position "
              "signal? Give each recording as its own file");
    }
  }
}

// Force constants (N/A), one per force column, when the file gives currents; ones otherwise.
std::vector<double> ForceScale(const TextTable& t, std::size_t count, const std::string& unit) {
  if (unit == "n") {
    if (t.Has("force_constant_N_per_A")) {
      throw InvalidInput(t.file, t.KeyLine("force_constant_N_per_A"), "force_constant_N_per_A",
                         "only with force_unit: current_A");
    }
    return std::vector<double>(count, 1.0);
  }
  if (!t.Has("force_constant_N_per_A")) {
    throw InvalidInput(
        t.file, t.KeyLine("force_unit"), "force_constant_N_per_A",
        "force_unit current_A needs force_constant_N_per_A (" + std::to_string(count) + " values)");
  }
  auto k = t.RequireNumbers("force_constant_N_per_A", count);
  for (double v : k) {
    if (!(v > 0.0 && v < 1e6)) {
      throw InvalidInput(t.file, t.KeyLine("force_constant_N_per_A"), "force_constant_N_per_A",
                         "force constants must be positive and below 1e6 N/A");
    }
  }
  return k;
}

void ReadHexapod(const TextTable& t, servo::ServoFile& f, const std::string& unit) {
  f.tool_length_mm = t.RequireNumber("tool_length_mm");
  if (!(f.tool_length_mm >= 0.0 && f.tool_length_mm < 1e4)) {
    throw InvalidInput(t.file, t.KeyLine("tool_length_mm"), "tool_length_mm",
                       "must be between 0 and 10000 mm");
  }
  static const char* kPose[] = {"x_mm", "y_mm", "z_mm", "a_deg", "b_deg", "c_deg"};
  std::array<std::size_t, 6> pc{};
  std::array<std::size_t, 6> fc{};
  for (int k = 0; k < 6; ++k) {
    pc[k] = t.RequireColumn(kPose[k]);
    CheckRange(t, pc[k], k < 3 ? kMaxPositionMm : kMaxAngleDeg,
               k < 3 ? "a position in mm" : "an angle in degrees (|angle| <= 360)");
    if (k < 3) CheckNoJump(t, pc[k], f.t_s);
    fc[k] = t.RequireColumn("f" + std::to_string(k + 1));
  }
  const auto scale = ForceScale(t, 6, unit);
  for (int k = 0; k < 6; ++k) CheckRange(t, fc[k], kMaxForceN / scale[k], "a strut force");
  f.samples.resize(t.NumRows());
  for (std::size_t i = 0; i < t.NumRows(); ++i) {
    auto& s = f.samples[i];
    s.t_s = f.t_s[i];
    for (int k = 0; k < 3; ++k) {
      s.tip_mm[k] = t.Column(pc[k])[i];
      s.abc_deg[k] = t.Column(pc[k + 3])[i];
    }
    for (int k = 0; k < 6; ++k) s.force_N[k] = scale[k] * t.Column(fc[k])[i];
  }
}

void ReadSerial(const TextTable& t, servo::ServoFile& f, const std::string& unit) {
  const std::string first = Upper(t.RequireString("axis"));
  static const std::set<std::string> kAxes{"X", "Y", "Z", "U", "V", "W"};
  if (!kAxes.count(first)) {
    throw InvalidInput(t.file, t.KeyLine("axis"), "axis",
                       Quote(first) + " is not an axis (X, Y, Z, U, V or W)");
  }
  std::vector<std::pair<std::size_t, std::size_t>> cols{
      {t.RequireColumn("pos_mm"), t.RequireColumn("force")}};
  std::vector<std::string> names{first};
  for (const char* axis : {"X", "Y", "Z", "U", "V", "W"}) {
    const std::string a = axis;
    const std::string pos = "pos_" + Lower(a) + "_mm";
    const std::string force = "force_" + Lower(a);
    const bool has_pos = t.ColumnIndex(pos) >= 0, has_force = t.ColumnIndex(force) >= 0;
    if (!has_pos && !has_force) continue;
    if (a == first) {
      throw InvalidInput(t.file, t.columns_line, pos,
                         "axis " + a + " is the file's axis; its columns are pos_mm,force");
    }
    cols.emplace_back(t.RequireColumn(pos), t.RequireColumn(force));
    names.push_back(a);
  }
  const auto scale = ForceScale(t, cols.size(), unit);
  for (std::size_t a = 0; a < cols.size(); ++a) {
    CheckRange(t, cols[a].first, kMaxPositionMm, "a position in mm");
    CheckNoJump(t, cols[a].first, f.t_s);
    CheckRange(t, cols[a].second, kMaxForceN / scale[a], "a drive force");
    servo::AxisTrace tr;
    tr.axis = names[a];
    tr.pos_mm = t.Column(cols[a].first);
    tr.force_N = t.Column(cols[a].second);
    for (double& v : tr.force_N) v *= scale[a];
    f.axes.push_back(std::move(tr));
  }
}

}  // namespace

TextLimits DefaultServoLimits() {
  TextLimits l;
  l.max_rows = 2'000'000;
  l.max_columns = 64;
  return l;
}

servo::ServoFile ParseServoFile(std::string_view bytes, const std::string& file,
                                const TextLimits& limits) {
  ReadOptions options;
  static_cast<TextLimits&>(options) = limits;
  TextTable t = ReadTextTable(bytes, file, options);
  if (t.format != kServoFormat) {
    throw InvalidInput(file, t.format_line, "format",
                       std::string("expected '") + kServoFormat + "', found " + Quote(t.format));
  }
  if (!t.markers.empty()) {
    throw InvalidInput(file, t.markers.front().line, t.markers.front().key,
                       "header lines must come before the column-header row");
  }
  servo::ServoFile f;
  f.file = file;
  f.machine_id = t.RequireMachineId();
  f.test_id = t.RequireString("test_id");
  f.motion = t.RequireOneOf("motion", {"circle", "path"});
  if (f.motion == "circle" || t.Has("direction")) {
    f.direction = t.RequireOneOf("direction", {"cw", "ccw"});
  }
  f.force_unit = t.RequireString("force_unit");
  const std::string unit = Lower(f.force_unit);
  if (unit != "n" && unit != "current_a") {
    throw InvalidInput(file, t.KeyLine("force_unit"), "force_unit",
                       Quote(f.force_unit) + " is not one of N, current_A");
  }
  f.metadata = t.Metadata();
  f.hexapod = !t.Has("axis");
  const std::size_t it = t.RequireColumn("t_s");
  CheckTimes(t, it);
  f.t_s = t.Column(it);
  if (f.hexapod) {
    ReadHexapod(t, f, unit);
  } else {
    ReadSerial(t, f, unit);
  }
  f.lines.reserve(t.NumRows());
  for (std::size_t i = 0; i < t.NumRows(); ++i) f.lines.push_back(t.row_lines[i]);
  return f;
}

}  // namespace km::ingest
