// The measurement kinds the server accepts, one handler and the upload limits per format
// (docs/formats.md §1); the formats themselves are recognised by ingest/file_formats.h.
#include <cmath>
#include <cstdio>
#include <cstdlib>

#include "analysis/core/errors.h"
#include "analysis/dbb/circular_test.h"
#include "analysis/dbb/full_analysis.h"
#include "ingest/dbb_csv_parser.h"
#include "ingest/dbb_parser.h"
#include "ingest/file_formats.h"
#include "ingest/form_parsers.h"
#include "ingest/iso8601.h"
#include "ingest/positioning_parser.h"
#include "ingest/rotary/rotary_parser.h"
#include "ingest/servo_parser.h"
#include "ingest/tracker_parser.h"
#include "render/dbb_plot.h"
#include "server/base/finite_result.h"
#include "server/measurements/kinds.h"
#include "server/measurements/positioning_kinds.h"
#include "server/measurements/rotary_kinds.h"
#include "server/measurements/servo_kinds.h"
#include "usecases/dbb_json.h"
#include "usecases/dbb_report.h"
#include "usecases/form_report.h"
#include "usecases/tracker_report.h"

namespace km::server {
namespace {

// Magnitudes beyond these are not measurements of a machine tool; they would only make the
// analysis overflow. Checked after parsing, before the analysis (the DBB parser checks its own).
constexpr double kMaxPositionMm = 1e6;        // 1 km from the machine origin
constexpr double kMaxDeviationUm = 1e6;       // 1 m off a line or a plane
constexpr double kMaxTrackerReadingUm = 1e9;  // 1 km of interferometer travel

std::string Number(double v) {
  char buf[32];
  std::snprintf(buf, sizeof buf, "%g", v);
  return buf;
}

void RequireAtMost(const std::string& file, std::size_t line, const std::string& field, double v,
                   double limit, const std::string& what) {
  if (std::abs(v) > limit) {
    throw InvalidInput(
        file, line, field,
        Number(v) + " is too large to analyse: " + what + " must be within ±" + Number(limit));
  }
}

template <typename Lines>
std::size_t LineOf(const Lines& lines, std::size_t i) {
  return i < lines.size() ? lines[i] : 0;
}

template <typename Lines>
void CheckProfile(const std::string& file, const form::Profile& p, const Lines& lines) {
  for (std::size_t i = 0; i < p.position_mm.size(); ++i) {
    RequireAtMost(file, LineOf(lines, i), "position_mm", p.position_mm[i], kMaxPositionMm,
                  "a position in mm");
  }
  for (std::size_t i = 0; i < p.deviation_um.size(); ++i) {
    RequireAtMost(file, LineOf(lines, i), "deviation_um", p.deviation_um[i], kMaxDeviationUm,
                  "a deviation in µm");
  }
}

template <typename Lines>
void CheckGrid(const std::string& file, const form::Grid& g, const Lines& lines) {
  for (std::size_t i = 0; i < g.x_mm.size(); ++i) {
    const std::size_t line = LineOf(lines, i);
    RequireAtMost(file, line, "x_mm", g.x_mm[i], kMaxPositionMm, "a position in mm");
    if (i < g.y_mm.size()) {
      RequireAtMost(file, line, "y_mm", g.y_mm[i], kMaxPositionMm, "a position in mm");
    }
    if (i < g.z_um.size()) {
      RequireAtMost(file, line, "z_um", g.z_um[i], kMaxDeviationUm, "a deviation in µm");
    }
  }
}

// The tracker file keeps no line per point: the point id names the row.
void CheckTracker(const std::string& file, const tracker::TrackerReadings& r) {
  const char* axes[] = {"x_mm", "y_mm", "z_mm"};
  for (std::size_t i = 0; i < r.commanded_mm.size(); ++i) {
    const std::string point =
        "point " + std::to_string(i < r.point_ids.size() ? r.point_ids[i] : 0) + ": ";
    for (int k = 0; k < 3; ++k) {
      RequireAtMost(file, 0, axes[k], r.commanded_mm[i](k), kMaxPositionMm,
                    point + "a position in mm");
    }
    for (Eigen::Index j = 0; j < r.displacement_um.cols(); ++j) {
      if (static_cast<Eigen::Index>(i) >= r.displacement_um.rows()) break;
      const double d = r.displacement_um(static_cast<Eigen::Index>(i), j);
      if (!std::isfinite(d)) continue;  // a missing reading
      RequireAtMost(file, 0, "d" + std::to_string(j + 1) + "_um", d, kMaxTrackerReadingUm,
                    point + "a reading in µm");
    }
  }
}

Ingested IngestDbb(std::string_view bytes, const std::string& file,
                   const InstrumentHook& instruments) {
  dbb::DbbTest test = ingest::ReadDbb(bytes, file);  // any DBB format
  Ingested in;
  in.kind = "dbb";
  in.machine_id = test.machine_id;
  in.test_id = test.test_id;
  in.direction = dbb::ToString(test.direction);
  in.measured_at = test.timestamp;
  for (const auto& [k, v] : test.metadata) in.metadata[k] = v;  // the file's own keys
  const auto use = UseInstrument(instruments, test.metadata, test.timestamp);
  // Analysis-level problems name the file too.
  nlohmann::json result = InFile(file, [&] { return usecases::DbbTestJson(test); });
  RequireFiniteResult(result, file);
  AddInstrumentUse(use, result);
  in.samples.columns = {"angle_deg", "dr_um"};
  in.samples.values.reserve(2 * test.angle_deg.size());
  for (std::size_t i = 0; i < test.angle_deg.size(); ++i) {
    in.samples.values.push_back(test.angle_deg[i]);
    in.samples.values.push_back(test.dr_um[i]);
  }
  in.results.push_back(NewResult{"dbb", usecases::kDbbAnalysisVersion, result.dump()});
  return in;
}

// The file's own header keys and time; called before the register completes the keys.
template <typename File>
Ingested Common(const File& f, const std::string& kind) {
  Ingested in;
  in.kind = kind;
  in.machine_id = f.machine_id;
  for (const auto& [k, v] : f.metadata) in.metadata[k] = v;
  if (auto it = f.metadata.find("timestamp"); it != f.metadata.end()) in.measured_at = it->second;
  return in;
}

SampleBlock ProfileSamples(const form::Profile& p) {
  SampleBlock b;
  b.columns = {"position_mm", "deviation_um"};
  for (std::size_t i = 0; i < p.position_mm.size(); ++i) {
    b.values.push_back(p.position_mm[i]);
    b.values.push_back(p.deviation_um[i]);
  }
  return b;
}

constexpr const char* kFormAnalysisVersion = "form/1";

Ingested IngestStraightness(std::string_view bytes, const std::string& file,
                            const InstrumentHook& instruments) {
  auto f = ingest::ParseStraightnessFile(bytes, file);
  CheckProfile(file, f.profile, f.row_lines);
  Ingested in = Common(f, "straightness");
  const auto use = UseInstrument(instruments, f.metadata, in.measured_at);
  in.test_id = f.pair_id;
  in.direction = f.reversal;
  in.samples = ProfileSamples(f.profile);
  nlohmann::json result = usecases::StraightnessFilesToJson({f});
  RequireFiniteResult(result, file);
  AddInstrumentUse(use, result);
  in.results.push_back({"straightness", kFormAnalysisVersion, result.dump()});
  return in;
}

Ingested IngestFlatness(std::string_view bytes, const std::string& file,
                        const InstrumentHook& instruments) {
  auto f = ingest::ParseFlatnessFile(bytes, file);
  CheckGrid(file, f.grid, f.row_lines);
  Ingested in = Common(f, "flatness");
  const auto use = UseInstrument(instruments, f.metadata, in.measured_at);
  in.samples.columns = {"x_mm", "y_mm", "z_um"};
  for (std::size_t i = 0; i < f.grid.x_mm.size(); ++i) {
    in.samples.values.insert(in.samples.values.end(),
                             {f.grid.x_mm[i], f.grid.y_mm[i], f.grid.z_um[i]});
  }
  nlohmann::json result = usecases::FlatnessFileToJson(f);
  RequireFiniteResult(result, file);
  AddInstrumentUse(use, result);
  in.results.push_back({"flatness", kFormAnalysisVersion, result.dump()});
  return in;
}

Ingested IngestParallelism(std::string_view bytes, const std::string& file,
                           const InstrumentHook& instruments) {
  auto f = ingest::ParseParallelismFile(bytes, file);
  CheckProfile(file, f.profile, f.row_lines);
  Ingested in = Common(f, "parallelism");
  const auto use = UseInstrument(instruments, f.metadata, in.measured_at);
  in.test_id = f.axis;
  in.samples = ProfileSamples(f.profile);
  nlohmann::json result = usecases::ParallelismFileToJson(f);
  RequireFiniteResult(result, file);
  AddInstrumentUse(use, result);
  in.results.push_back({"parallelism", kFormAnalysisVersion, result.dump()});
  return in;
}

constexpr const char* kTrackerAnalysisVersion = "tracker/1";

// Self-calibration runs at upload (≈ 0.1 s for 1 000 points, ≈ 1 s for 10 000); an
// unobservable set-up is refused (NotObservable → 422) and nothing is stored.
Ingested IngestTracker(std::string_view bytes, const std::string& file,
                       const InstrumentHook& instruments) {
  auto f = ingest::ParseTrackerFile(bytes, file);
  CheckTracker(file, f.readings);
  Ingested in;
  in.kind = "tracker";
  in.machine_id = f.readings.machine_id;
  // The mode (simultaneous / sequential) stays in the metadata; direction is for DBB tests.
  for (const auto& [k, v] : f.metadata) in.metadata[k] = v;
  if (auto it = f.metadata.find("timestamp"); it != f.metadata.end()) in.measured_at = it->second;
  const auto use = UseInstrument(instruments, f.metadata, in.measured_at);
  const int n = f.readings.NumTrackers();
  in.samples.columns = {"point", "x_mm", "y_mm", "z_mm"};
  for (int j = 0; j < n; ++j) in.samples.columns.push_back("d" + std::to_string(j + 1) + "_um");
  for (int i = 0; i < f.readings.NumPoints(); ++i) {
    in.samples.values.push_back(f.readings.point_ids[static_cast<std::size_t>(i)]);
    for (int k = 0; k < 3; ++k) {
      in.samples.values.push_back(f.readings.commanded_mm[static_cast<std::size_t>(i)](k));
    }
    for (int j = 0; j < n; ++j) in.samples.values.push_back(f.readings.displacement_um(i, j));
  }
  nlohmann::json result = InFile(file, [&] { return usecases::AnalyzeTracker(f); });
  RequireFiniteResult(result, file);
  AddInstrumentUse(use, result);
  in.results.push_back({"tracker", kTrackerAnalysisVersion, result.dump()});
  return in;
}

// Upload limits: data rows and columns, lines of at most 4 KiB, 1 000 header lines and 1 000
// '#' lines among the data (what each format's analysis costs: measurement_service.h
// DefaultUploadLimits).
ingest::TextLimits Limits(std::size_t rows, std::size_t columns, std::size_t cells = 0) {
  ingest::TextLimits l;
  l.max_rows = rows;
  l.max_columns = columns;
  l.max_line_bytes = 4096;
  l.max_header_lines = 1000;
  l.max_markers = 1000;
  if (cells > 0) l.max_cells = cells;
  return l;
}

}  // namespace

std::vector<FormatRegistration> BuiltinFormats() {
  // Tracker: point, x, y, z, d1..d16 and a few more; 80 000 values: 10 000 points of 4
  // trackers, 4 000 of 16. Servo loads: t_s, pose and six forces (or positions and forces of a
  // few axes); the upload only summarises them (parsing holds about 300 bytes a row).
  return {
      {std::string(ingest::kTrackerFormat), Limits(10'000, 24, 80'000), IngestTracker},
      {ingest::kDbbFormat, Limits(500'000, 16), IngestDbb},
      {ingest::kDbbCsvFormat, Limits(500'000, 16), IngestDbb},
      {std::string(ingest::kStraightnessFormat), Limits(100'000, 16), IngestStraightness},
      {std::string(ingest::kFlatnessFormat), Limits(1'000'000, 16), IngestFlatness},
      {std::string(ingest::kParallelismFormat), Limits(1'000'000, 16), IngestParallelism},
      {ingest::kServoFormat, Limits(500'000, 32), IngestServo},
      {std::string(ingest::kPositioningFormat), Limits(1'000'000, 16), IngestPositioning},
      {std::string(ingest::kRotaryFormat), Limits(100'000, 16), IngestRotary},
  };
}

}  // namespace km::server
