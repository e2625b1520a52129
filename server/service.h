// The service core: turns uploaded bytes into a stored, analysed measurement, and answers the
// questions the API asks. The API layer is a thin mapping onto these calls.
#pragma once

#include <cstdint>
#include <functional>
#include <map>
#include <memory>
#include <string>
#include <string_view>

#include <nlohmann/json.hpp>

#include "analysis/dbb/dbb_types.h"
#include "server/jobs.h"
#include "server/storage.h"

namespace km::server {

// What one kind of measurement file turns into before it is stored.
struct Ingested {
  std::string kind;
  std::string machine_id, test_id, direction;
  std::optional<std::string> measured_at;  // as written in the file
  nlohmann::json metadata = nlohmann::json::object();
  SampleBlock samples;
  std::vector<NewResult> results;  // computed at upload, stored in the same transaction
};

// Parses and analyses one file of a format; throws km::InvalidInput naming file/line/field.
using KindHandler = std::function<Ingested(std::string_view bytes, const std::string& file)>;

struct ServiceOptions {
  std::size_t max_upload_bytes = 32u << 20;
};

struct UploadOutcome {
  std::int64_t id = 0;
  bool created = false;
  std::string sha256;
  std::string kind;
};

class Service {
 public:
  Service(std::unique_ptr<Storage> storage, ServiceOptions options);

  // Registers the handler of a format name (e.g. "kinemetric-dbb/1").
  void RegisterKind(const std::string& format, KindHandler handler);
  std::vector<std::string> Formats() const;

  // Validates, analyses and stores. Same bytes again → the existing id, created = false.
  // Nothing is stored when the input is bad (km::InvalidInput / km::TooLarge).
  UploadOutcome Upload(std::string_view bytes, const std::string& filename);

  // Results as the CLI prints them (the newest analysis version of each analysis).
  nlohmann::json Results(std::int64_t id);
  // DBB queries, recomputed from the stored bytes: the plot data of the evaluated turn; the
  // CW/CCW pair analysis with the opposite-direction test of the same machine and test_id
  // (null when there is none); the polar plot PNG (both directions when the partner exists).
  nlohmann::json DbbTrace(std::int64_t id);
  nlohmann::json DbbPairJson(std::int64_t id);
  std::string DbbPlotPng(std::int64_t id);
  nlohmann::json MeasurementJson(const MeasurementRecord& r) const;

  // Hexapod calibration study as a background job. Request (JSON): {"machine": {machine
  // definition, contract §2}, "measurement_ids": [DBB ids], "method": "absolute" |
  // "centre-corrected" (optional), "reduction_study_min_tests": N (optional),
  // "max_samples_per_test": N (optional)}. Validated now (InvalidInput / NotFound); returns
  // the job id. The job's result is the `hexapod calibrate` object plus the calibrated machine.
  std::int64_t SubmitCalibration(const nlohmann::json& request);
  nlohmann::json Job(std::int64_t id);
  nlohmann::json Jobs(std::int64_t limit);

  Storage& storage() { return *storage_; }

 private:
  dbb::DbbTest LoadDbb(std::int64_t id, MeasurementRecord* record = nullptr);
  std::optional<std::int64_t> DbbPartner(const MeasurementRecord& rec);

  std::unique_ptr<Storage> storage_;
  ServiceOptions options_;
  std::map<std::string, KindHandler> kinds_;
  std::unique_ptr<JobQueue> jobs_;  // last: stopped first
};

// The handlers of every measurement kind the product knows; call once at start-up.
void RegisterBuiltinKinds(Service& service);

}  // namespace km::server
