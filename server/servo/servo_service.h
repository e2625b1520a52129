// The servo analyses of stored `kinemetric-servo/1` measurements (docs/formats.md §5), run by
// the service for the routes of api/servo_routes: the identification of a machine's masses and
// friction (optionally stored as the next version of its model), the joint resistance and
// health of its legs, and the external force of one record. The JSON is that of the CLI
// (usecases/servo_report.h).
//
// Requests: {"machine_id", "machine_version"?, "measurement_ids": [ids of servo measurements of
// that machine]} and for identify "save"?: bool, "note"?; for joints "previous"?: an earlier
// joints result (its legs[].resistance_Nm), "level2_ratio"?, "level3_ratio"?,
// "increase_warn"?, "increase_stop"?. Bad requests are km::InvalidInput with file "request" and
// the field; unknown ids NotFound.
#pragma once

#include <cstdint>
#include <optional>

#include <nlohmann/json.hpp>

#include "server/measurements/analyses.h"
#include "server/measurements/measurement_service.h"
#include "server/models/model_service.h"
#include "server/streams/stream_service.h"

namespace km::server {

// At most this many measurements, and samples in all of them, a request (the analyses hold
// about 1.5 kB of motion a sample: 200 000 samples ≈ 300 MB; the jig plan at 720 samples a
// circle is 21 600).
inline constexpr std::size_t kMaxServoMeasurements = 200;
inline constexpr std::size_t kMaxServoSamples = 200'000;

class ServoService {
 public:
  ServoService(MeasurementStore& store, MeasurementService& measurements, ModelService& models,
               StreamService& streams)
      : store_(store), measurements_(measurements), models_(models), streams_(streams) {}

  // The identify JSON; with "save": true also "saved" {machine_id, version, created}.
  nlohmann::json Identify(const nlohmann::json& request);
  // The joints JSON, stored as described at kJointsAnalysis (analyses.h); adds
  // "measurement_ids".
  nlohmann::json Joints(const nlohmann::json& request);
  // The history of a machine's stored joints estimates, oldest first: {"machine_id", "limits"
  // (of the newest: level2_ratio, level3_ratio, increase_warn, increase_stop, reference_Nm[6],
  // reference_source; null without an estimate), "estimates": [{"result_id",
  // "measurement_ids", "estimated_at", "machine_version", "legs": [{"leg", "resistance_Nm",
  // "sigma_Nm", "reference_Nm", "ratio", "level", "evidence"}], "level", "limits"}]}. NotFound
  // for a machine with neither measurements nor a model.
  nlohmann::json JointHealth(const std::string& machine_id);
  // The force JSON of one stored servo measurement with its machine's model (newest version,
  // or the one given).
  nlohmann::json Force(MeasurementId measurement_id, std::optional<std::int64_t> machine_version);

  // A stretch of a stream turned into a feed-drive servo record (docs/formats.md §1.7) and
  // uploaded like a file: {"axes": [{"axis", "position_channel", "force_channel"}, …],
  // "force_unit"? ("N" | "current_A"), "force_constant_N_per_A"? [one per axis], "test_id"?,
  // "from_us"?, "to_us"?}. The rows are the samples of the first axis's position channel (µm,
  // written in mm); the other channels are interpolated linearly in time to them (rows outside
  // any channel's time span are left out). Force channels carry N (or A) in their value field.
  UploadOutcome FromStream(StreamId stream_id, const nlohmann::json& request);

 private:
  MeasurementStore& store_;
  MeasurementService& measurements_;
  ModelService& models_;
  StreamService& streams_;
};

}  // namespace km::server
