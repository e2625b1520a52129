#include "ingest/rotary/rotary_parser.h"

#include <cmath>
#include <set>

#include "analysis/core/errors.h"
#include "ingest/iso8601.h"

namespace km::ingest {
namespace {

using rotary::Kinematics;

// "an AC-trunnion" / "a BC-trunnion".
std::string WithArticle(Kinematics k) {
  return (k == Kinematics::kAcTrunnion ? "an " : "a ") + std::string(rotary::KinematicsName(k));
}

constexpr double kMaxCoordinateMm = 100'000.0;   // 100 m: no machine's
constexpr double kMaxDisplacementUm = 10'000.0;  // 10 mm: beyond any R-test's range
constexpr double kMaxTiltDeg = 360.0;
constexpr double kMaxCDeg = 1080.0;  // three turns
constexpr double kMaxReadingUncertaintyUm = 100.0;
constexpr std::size_t kMinPoses = 4;

bool IsRotaryColumn(std::string_view name) {
  return name == "a_deg" || name == "b_deg" || name == "c_deg" || name == "dx_um" ||
         name == "dy_um" || name == "dz_um" || name == "time_s";
}

TextTable ReadRotaryTable(std::string_view bytes, const std::string& file,
                          const TextLimits& limits) {
  ReadOptions options;
  static_cast<TextLimits&>(options) = limits;
  options.keep_column = IsRotaryColumn;
  TextTable t = ReadTextTable(bytes, file, options);
  if (t.format != kRotaryFormat) {
    throw InvalidInput(file, t.format_line, "format",
                       "expected '" + std::string(kRotaryFormat) + "', found '" + t.format + "'");
  }
  if (!t.markers.empty()) {
    throw InvalidInput(file, t.markers.front().line, t.markers.front().key,
                       "header lines must come before the column-header row");
  }
  return t;
}

std::vector<double> Coordinates(const TextTable& t, const std::string& key, std::size_t count) {
  const auto v = t.RequireNumbers(key, count);
  for (double x : v) {
    if (std::abs(x) > kMaxCoordinateMm) {
      throw InvalidInput(t.file, t.KeyLine(key), key, "a coordinate must be within ±100 000 mm");
    }
  }
  return v;
}

Kinematics ReadKinematics(const TextTable& t) {
  const std::string k = t.RequireOneOf("kinematics", {"ac-trunnion", "bc-trunnion"});
  return k == "ac-trunnion" ? Kinematics::kAcTrunnion : Kinematics::kBcTrunnion;
}

void ReadAxes(const TextTable& t, rotary::RotarySetup& s) {
  const bool ac = s.kinematics == Kinematics::kAcTrunnion;
  const std::string own = ac ? "a_axis_mm" : "b_axis_mm";
  const std::string other = ac ? "b_axis_mm" : "a_axis_mm";
  if (t.Has(other)) {
    throw InvalidInput(t.file, t.KeyLine(other), other,
                       "belongs to " +
                           WithArticle(ac ? Kinematics::kBcTrunnion : Kinematics::kAcTrunnion) +
                           " file; " + WithArticle(s.kinematics) + " file gives " + own);
  }
  if (!t.Has(own)) {
    throw InvalidInput(t.file, t.KeyLine("kinematics"), own,
                       WithArticle(s.kinematics) + " file must give the nominal tilt-axis line " +
                           own + (ac ? ": y, z" : ": x, z"));
  }
  const auto tilt = Coordinates(t, own, 2);
  s.tilt_axis_mm = {{tilt[0], tilt[1]}};
  const auto c = Coordinates(t, "c_axis_mm", 2);
  s.c_axis_mm = {{c[0], c[1]}};
  const auto sphere = Coordinates(t, "sphere_mm", 3);
  s.sphere_mm = {{sphere[0], sphere[1], sphere[2]}};
}

void ReadHeader(const TextTable& t, RotaryFile& f) {
  f.machine_id = t.RequireMachineId();
  f.test_id = t.RequireString("test_id");
  if (t.Has("timestamp")) {
    f.timestamp = t.RequireString("timestamp");
    if (!ParseIso8601(f.timestamp)) {
      throw InvalidInput(t.file, t.KeyLine("timestamp"), "timestamp",
                         Quote(f.timestamp, 40) + " is not an ISO 8601 date or date-time");
    }
  }
  f.test.setup.kinematics = ReadKinematics(t);
  ReadAxes(t, f.test.setup);
  f.u_reading_um = t.OptionalNumber("u_reading_um");
  if (f.u_reading_um && !(*f.u_reading_um >= 0.0 && *f.u_reading_um <= kMaxReadingUncertaintyUm)) {
    throw InvalidInput(t.file, t.KeyLine("u_reading_um"), "u_reading_um",
                       "a standard uncertainty must be within 0 … 100 µm");
  }
  f.metadata = t.Metadata();
}

// The column set of the kinematics: the tilt angle's own, c_deg, dx_um, dy_um, dz_um, time_s.
void CheckColumns(const TextTable& t, Kinematics k) {
  const bool ac = k == Kinematics::kAcTrunnion;
  const std::string tilt = ac ? "a_deg" : "b_deg";
  for (const auto& c : t.columns) {
    if (c == (ac ? "b_deg" : "a_deg")) {
      throw InvalidInput(t.file, t.columns_line, c,
                         "is a column of " + std::string(ac ? "BC" : "AC") + "-trunnion files; " +
                             WithArticle(k) + " file has " + tilt);
    }
    if (!IsRotaryColumn(c)) {
      throw InvalidInput(t.file, t.columns_line, c,
                         "unknown column: the columns are " + tilt +
                             ", c_deg, dx_um, dy_um, dz_um and optionally time_s");
    }
  }
  for (const auto& c : {tilt, std::string("c_deg"), std::string("dx_um"), std::string("dy_um"),
                        std::string("dz_um")}) {
    t.RequireColumn(c);
  }
}

void CheckCell(const TextTable& t, std::size_t row, const std::string& field, double v,
               double limit, const char* text) {
  if (!(std::abs(v) <= limit)) {
    throw InvalidInput(t.file, t.row_lines[row], field, std::string("must be within ") + text);
  }
}

void ReadPoses(const TextTable& t, RotaryFile& f) {
  const bool ac = f.test.setup.kinematics == Kinematics::kAcTrunnion;
  const std::string tilt_name = ac ? "a_deg" : "b_deg";
  const auto& tilt = t.Column(t.RequireColumn(tilt_name));
  const auto& c = t.Column(t.RequireColumn("c_deg"));
  const std::vector<double>* d[3] = {&t.Column(t.RequireColumn("dx_um")),
                                     &t.Column(t.RequireColumn("dy_um")),
                                     &t.Column(t.RequireColumn("dz_um"))};
  static const char* kD[3] = {"dx_um", "dy_um", "dz_um"};
  const int time_col = t.ColumnIndex("time_s");
  for (std::size_t r = 0; r < t.NumRows(); ++r) {
    CheckCell(t, r, tilt_name, tilt[r], kMaxTiltDeg, "±360°");
    CheckCell(t, r, "c_deg", c[r], kMaxCDeg, "±1080° (three turns)");
    rotary::RotaryPose pose;
    pose.tilt_deg = tilt[r];
    pose.c_deg = c[r];
    for (int k = 0; k < 3; ++k) {
      CheckCell(t, r, kD[k], (*d[k])[r], kMaxDisplacementUm, "±10 000 µm");
      pose.d_um[std::size_t(k)] = (*d[k])[r];
    }
    f.test.poses.push_back(pose);
    f.lines.push_back(t.row_lines[r]);
    if (time_col >= 0) f.time_s.push_back(t.Column(std::size_t(time_col))[r]);
  }
}

void CheckPoseSet(const TextTable& t, const RotaryFile& f) {
  const auto& poses = f.test.poses;
  if (poses.size() < kMinPoses) {
    throw InvalidInput(t.file, poses.empty() ? t.columns_line : f.lines.back(), "poses",
                       "at least 4 poses are needed (the zero pose and three more), found " +
                           std::to_string(poses.size()));
  }
  const bool ac = f.test.setup.kinematics == Kinematics::kAcTrunnion;
  const std::string tilt = ac ? "a_deg" : "b_deg";
  for (const auto& [field, value] :
       {std::pair{tilt, poses[0].tilt_deg}, std::pair{std::string("c_deg"), poses[0].c_deg}}) {
    if (value != 0.0) {
      throw InvalidInput(t.file, f.lines[0], field,
                         "the first pose must be at zero angles, where the sensors are zeroed "
                         "with the sphere's centre at the nest");
    }
  }
}

}  // namespace

TextLimits DefaultRotaryLimits() {
  TextLimits l;
  l.max_rows = 20'000;
  l.max_columns = 16;
  return l;
}

RotaryFile ParseRotaryFile(std::string_view bytes, const std::string& file,
                           const TextLimits& limits) {
  const TextTable t = ReadRotaryTable(bytes, file, limits);
  RotaryFile f;
  f.file = file;
  ReadHeader(t, f);
  CheckColumns(t, f.test.setup.kinematics);
  ReadPoses(t, f);
  CheckPoseSet(t, f);
  return f;
}

}  // namespace km::ingest
