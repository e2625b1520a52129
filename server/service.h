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

#include "analysis/core/errors.h"
#include "analysis/dbb/dbb_types.h"
#include "ingest/machine_json.h"
#include "ingest/text_format.h"
#include "render/polar_plot.h"
#include "server/audits/audit_scheduler.h"
#include "server/audits/audit_source.h"
#include "server/jobs/jobs.h"
#include "server/measurements/formats.h"
#include "server/storage/storage.h"
#include "server/streams/acquisition.h"
#include "server/streams/streams.h"

namespace km::server {

// What an upload of each format may hold, by format name (e.g. "kinemetric-dbb/1"): data rows,
// line length, columns, values, header and marker lines (ingest/text_format.h). The defaults
// keep the analysis done at upload within about 2 s of CPU and the parse within about 2× the
// file size: DBB 500 000 samples (the analysis costs about 3 µs and 400 bytes a sample);
// straightness 100 000 points (its periodic-component search costs about 10 µs a point);
// parallelism and flatness 1 000 000 points; tracker 10 000 points, 24 columns and 80 000
// values in all (the self-calibration costs about 0.15 ms a point with 4 to 8 trackers, 0.45 ms
// with 16). Every format: lines of at most 4 KiB, 1 000 header lines, 1 000 '#' lines among the
// data.
std::map<std::string, ingest::TextLimits> DefaultUploadLimits();

struct ServiceOptions {
  std::size_t max_upload_bytes = 32u << 20;
  // Checked in one pass before anything is parsed; an upload beyond them is refused with
  // km::TooLarge (HTTP 413) naming the file and the first line beyond the limit. A format
  // without an entry gets the TextLimits defaults.
  std::map<std::string, ingest::TextLimits> upload_limits = DefaultUploadLimits();
  // Hexapod calibration requests: at most this many DBB tests (a study uses tens), and at most
  // this many samples in all of them (the running job holds every test in memory).
  std::size_t max_calibration_tests = 500;
  std::size_t max_calibration_samples = 2'000'000;
  // Accuracy audits: the webhook of verdicts of level 2 and 3 (server/audits/audit_scheduler.h).
  AuditOptions audits;
  // Background jobs: workers of this instance, lease, queue bound (server/jobs/jobs.h).
  JobQueueOptions jobs;
};

// The largest machine definition the service stores (a hexapod document with gravity,
// friction and discovered effects is a few KiB).
inline constexpr std::size_t kMaxMachineModelBytes = 1u << 20;

// One stored version of a machine definition.
struct MachineModelStored {
  std::string machine_id;
  std::int64_t version = 0;
  std::string created_at;
  bool created = false;  // false: the bytes were those of the newest version already
};

// What the request asks cannot be done in the present state of the record it names (HTTP
// 409), e.g. saving the machine of a job that is not finished or produced none.
class Conflict : public Error {
 public:
  using Error::Error;
};

// Who asks to cancel a job (Service::CancelJob): the caller's token and whether it is an admin.
struct JobCanceller {
  std::int64_t token_id = 0;
  std::string token_name;
  bool admin = false;
};

struct UploadOutcome {
  std::int64_t id = 0;
  bool created = false;
  std::string sha256;
  std::string kind;
};

class Service;
struct CalibrationPlan;
struct DiscoveryPlan;

// One body of stream frames being received: Feed stores every complete frame as it arrives;
// Finish answers what was received (frames, samples, stored, duplicates, gaps). Samples of
// frames before a bad frame are kept; the bad frame is reported (InvalidInput). Used by the
// HTTP layer, which feeds pieces as they come off the socket.
class FrameIngestion {
 public:
  // Throws NotFound when the stream does not exist.
  FrameIngestion(Service& service, std::int64_t stream_id, const std::string& content_type);
  ~FrameIngestion();
  void Feed(std::string_view piece);
  // complete = false: the body ended early; what was stored stays, InvalidInput says so.
  nlohmann::json Finish(bool complete);

 private:
  struct State;
  std::unique_ptr<State> state_;
};

class Service : public AuditSource {
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
  nlohmann::json DbbPairJson(std::int64_t id) override;
  std::string DbbPlotPng(std::int64_t id, const render::PolarPlotOptions& options = {});
  // Straightness reversal of a stored profile with the other set-up of its pair (same machine
  // and pair_id, measured nearest in time): {partner_id, reversal{...}, profiles[]}; null when
  // the other set-up is not stored.
  nlohmann::json StraightnessReversalJson(std::int64_t id);
  nlohmann::json MeasurementJson(const MeasurementRecord& r) const;
  // Measurement metadata matching the filter: {"items": [MeasurementJson…], "total"}.
  nlohmann::json ListMeasurements(const MeasurementFilter& filter);
  // One measurement: MeasurementJson plus "metadata" and "samples" (one array per column);
  // NotFound when there is none.
  nlohmann::json MeasurementWithSamples(std::int64_t id);
  // Machines with stored measurements or a stored model.
  std::vector<MachineSummary> Machines();

  // Access tokens, stored as SHA-256 hashes only. TokenKnown: is this hash a stored token?
  // EnsureAdminToken: on a database without tokens, stores the bootstrap token (when given) or
  // a new random one, which is returned (to be shown once); otherwise returns "".
  bool TokenKnown(const std::string& token_sha256);
  std::string EnsureAdminToken(const std::string& bootstrap);

  // Hexapod calibration study as a background job. Request (JSON): {"machine": {machine
  // definition, docs/formats.md §2}, "measurement_ids": [DBB ids], "method": "absolute" |
  // "centre-corrected" (optional), "reduction_study_min_tests": N (optional),
  // "max_samples_per_test": N (optional)}. Validated now from the stored records, without
  // reading any file (InvalidInput / NotFound): at most max_calibration_tests ids, each listed
  // once (a repeated id is refused), each a DBB test with a tool length, at most
  // max_calibration_samples samples in all. Returns the job id; the job reads each test once
  // when it runs. The job's result is the `hexapod calibrate` object plus the calibrated
  // machine.
  // Instead of "machine", the request may name a stored model: "machine_id" (and optionally
  // "machine_version", else the newest); the job's request then records the version used.
  // The tests must be of one machine, and the reduction study is refused together with
  // effects (named, or the stored model's own). owner_token_id: the token submitting the job,
  // who may cancel it (CancelJob).
  std::int64_t SubmitCalibration(const nlohmann::json& request, std::int64_t owner_token_id = 0);
  // Model-gap discovery study (usecases/discovery_report.h) as a background job. Request:
  // {"machine_id"?, "machine_version"?, "measurement_ids": [DBB ids], "max_samples_per_test"?}.
  // Checked like a calibration request (at most max_calibration_tests ids, each once, each a
  // DBB test, samples bounded), and the tests must be of one machine. Without machine_id: the
  // serial study of the DBB tests' machine; with it: the stored model (a hexapod's tests need
  // the tool length). The job's result is the `kinemetric discover` object, plus
  // "updated_machine" when the study produced one.
  std::int64_t SubmitDiscovery(const nlohmann::json& request, std::int64_t owner_token_id = 0);
  nlohmann::json Job(std::int64_t id);
  // Cancels a queued or running job for its owner (the token that submitted it) or an admin;
  // answers the job, status "cancelled" (its error says by whom). A running job stops at its
  // next progress report (server/jobs/jobs.h). NotFound: no such job; Forbidden: `by` neither owns
  // it nor is an admin; Conflict: the job is done, failed or cancelled already.
  nlohmann::json CancelJob(std::int64_t id, const JobCanceller& by);
  nlohmann::json Jobs(std::int64_t limit);
  // The jobs of one machine, newest first, as Jobs: those whose request names the machine
  // (machine_id) or whose DBB tests are of it; among the newest `scan` jobs.
  nlohmann::json JobsOfMachine(const std::string& machine_id, std::int64_t limit,
                               std::int64_t scan = 5000);

  // Machine definitions ("kinemetric-machine/1", docs/formats.md §2), versioned
  // (machine_models.cpp). StoreMachineModel validates the document (ingest::ParseMachineJson:
  // InvalidInput naming `file` and the field; TooLarge beyond kMaxMachineModelBytes) and appends it
  // as the next version of its machine_id, with its source ("upload", "calibration job N",
  // "discovery job N") and note. The bytes of the newest version again → that version, created =
  // false.
  MachineModelStored StoreMachineModel(std::string_view bytes, const std::string& source,
                                       const std::string& note,
                                       const std::string& file = "machine");
  // A version with its document (the newest without one); NotFound names machine and version.
  MachineModelRecord GetMachineModel(const std::string& machine_id,
                                     std::optional<std::int64_t> version = std::nullopt);
  // {"machine_id", "versions": [{"version", "created_at", "source", "note", "sha256"}]},
  // oldest first; NotFound when the machine has no stored model.
  nlohmann::json ListMachineModels(const std::string& machine_id);
  // Stores the machine a finished job produced (a calibration's calibrated machine, a
  // discovery's updated machine) as the next version of its model, source "calibration job N"
  // or "discovery job N". NotFound: no such job; Conflict: the job is not done, or produced no
  // machine.
  MachineModelStored SaveJobMachine(std::int64_t job_id, const std::string& note);

  // Capacitance-sensor streams (docs/streams.md). CreateStream: {"machine_id", "name"?,
  // "channels"?: [{"channel", "name"?, "unit"?, "rate_hz"?}], …} → the stream id.
  // IngestFrames decodes frames as the body arrives (format from the Content-Type), stores
  // them and answers what was received, stored, dropped as duplicate, and the gaps found.
  // Samples of frames before a bad frame are kept; the bad frame is reported (InvalidInput).
  using BodyReader = std::function<bool(const std::function<bool(std::string_view)>&)>;
  std::int64_t CreateStream(const nlohmann::json& request, const std::string& source = "http");
  nlohmann::json IngestFrames(std::int64_t stream_id, const std::string& content_type,
                              const BodyReader& read_body);
  nlohmann::json StreamJson(std::int64_t stream_id);
  nlohmann::json ListStreams(const std::optional<std::string>& machine_id, std::int64_t limit);
  nlohmann::json StreamGapsJson(std::int64_t stream_id, std::int64_t limit);
  nlohmann::json StreamSamples(std::int64_t stream_id, std::int64_t channel,
                               std::optional<std::int64_t> from_us,
                               std::optional<std::int64_t> to_us, std::size_t max_points);
  // Turns a stretch of one channel into a straightness profile (position from an encoder
  // channel or from feed × time), stores it as a kinemetric-straightness/1 measurement and
  // analyses it like an upload. Request: see docs/streams.md.
  UploadOutcome StreamProfile(std::int64_t stream_id, const nlohmann::json& request);
  StreamHub& streams() { return *streams_; }
  // Modbus TCP devices (server/streams/acquisition.h).
  Acquisition& acquisition() { return *acquisition_; }
  // Accuracy audits: rules, runs and the scheduler thread (started by the server, Start()).
  AuditScheduler& audits() { return *audits_; }

  // The storage itself, for tests and tools; the API's routes use the calls above.
  Storage& storage() override { return *storage_; }

 private:
  friend class FrameIngestion;
  dbb::DbbTest LoadDbb(std::int64_t id, MeasurementRecord* record = nullptr);
  // The stored model named by a request's "machine_id" / "machine_version" (newest without a
  // version), parsed; `version` is set to the version used (machine_models.cpp).
  ingest::MachineDefinition RequestedMachine(const nlohmann::json& request, std::int64_t& version);
  // The "measurement_ids" of a study request, checked from the stored records alone (no file is
  // read): at most max_calibration_tests, each once, each a DBB test (with a tool length and,
  // when asked, a fixed ball), all of one machine, at most max_calibration_samples samples in
  // all (calibration_jobs.cpp).
  std::vector<std::int64_t> CheckedDbbIds(const nlohmann::json& request, const std::string& study,
                                          bool need_tool_length, bool need_fixed_ball);
  // Study requests checked into what a job runs (calibration_jobs.cpp, discovery_jobs.cpp), and
  // the jobs' runners (from the stored plan, on whichever instance takes the job).
  std::shared_ptr<CalibrationPlan> CheckCalibration(const nlohmann::json& request,
                                                    std::int64_t& stored_version);
  std::shared_ptr<DiscoveryPlan> CheckDiscovery(const nlohmann::json& request,
                                                std::int64_t& version);
  nlohmann::json RunCalibrationJob(const nlohmann::json& plan, const ProgressFn& p);
  nlohmann::json RunDiscoveryJob(const nlohmann::json& plan, const ProgressFn& p);
  std::optional<std::int64_t> DbbPartner(const MeasurementRecord& rec);
  std::optional<std::int64_t> NearestPartner(const MeasurementRecord& rec,
                                             const std::string& other_direction);

  std::unique_ptr<Storage> storage_;
  ServiceOptions options_;
  std::map<std::string, KindHandler> kinds_;
  std::unique_ptr<StreamHub> streams_;
  std::unique_ptr<Acquisition> acquisition_;  // after streams_: stopped before it
  std::unique_ptr<JobQueue> jobs_;            // stopped before the streams
  std::unique_ptr<AuditScheduler> audits_;    // last: stopped first
};

// The admin token of a database without tokens (Service::EnsureAdminToken).
std::string EnsureAdminToken(AccessStore& storage, const std::string& bootstrap);

// The handlers of every measurement kind the product knows; call once at start-up.
void RegisterBuiltinKinds(Service& service);

}  // namespace km::server
