// The server's storage interface. Everything the service keeps goes through it, so a
// PostgreSQL backend for fleets can sit beside the embedded SQLite default.
//
// Invariants every backend keeps:
//  * a measurement is stored once, immutable, keyed by the SHA-256 of its bytes;
//  * a measurement and the results computed at upload are written in one transaction;
//  * results carry the analysis name and version and the input's content hash;
//  * a machine definition is versioned: a new version is appended, none is overwritten.
#pragma once

#include <cstdint>
#include <functional>
#include <map>
#include <optional>
#include <ostream>
#include <string>
#include <string_view>
#include <vector>

#include "analysis/core/errors.h"
#include "server/base/ids.h"
#include "server/storage/report_store.h"

namespace km::server {

// A failure of the storage backend. code() is the backend's result code (SQLite: the primary
// result code, e.g. SQLITE_BUSY = 5; PostgreSQL: the SQLSTATE read as a base-36 number,
// server/storage/pg/pg_db.h); busy() is true when another connection held the database locked for
// longer than the busy timeout (PostgreSQL also: a serialization failure, a deadlock, a statement
// timeout, a lost connection, a server shutting down), so the same request may succeed a little
// later (the API answers 503 with Retry-After). The message is for the server log, not for
// clients.
class StorageError : public Error {
 public:
  StorageError(const std::string& message, int code, bool busy)
      : Error(message), code_(code), busy_(busy) {}
  int code() const { return code_; }
  bool busy() const { return busy_; }

 private:
  int code_;
  bool busy_;
};

// Raw samples, stored compactly as one blob per measurement.
struct SampleBlock {
  std::vector<std::string> columns;
  std::vector<double> values;  // row-major, columns.size() values a row

  std::size_t rows() const { return columns.empty() ? 0 : values.size() / columns.size(); }
  std::vector<double> Column(std::size_t c) const;
};

std::string EncodeSamples(const SampleBlock& block);
SampleBlock DecodeSamples(const std::string& blob);

struct NewResult {
  std::string analysis;          // e.g. "dbb"
  std::string analysis_version;  // e.g. "dbb/1.0"
  std::string result_json;
};

struct NewMeasurement {
  std::string sha256;
  std::string kind;    // dbb, tracker, straightness, flatness, parallelism
  std::string format;  // e.g. kinemetric-dbb/1
  std::string machine_id;
  std::string test_id;
  std::string direction;
  std::optional<std::string> measured_at;  // UTC ISO 8601, from the file
  std::string filename;
  std::string metadata_json;  // header keys → values
  std::string raw;            // the file's bytes, exactly as uploaded
  SampleBlock samples;
};

struct MeasurementRecord {
  MeasurementId id;
  std::string sha256, kind, format, machine_id, test_id, direction;
  std::optional<std::string> measured_at;
  std::string uploaded_at, filename, metadata_json;
  std::int64_t sample_count = 0;
};

struct ResultRecord {
  MeasurementId measurement_id;
  std::string analysis, analysis_version, input_sha256, created_at, result_json;
};

// What a measurement's stored results are at one moment: their number and the largest result
// id (both 0 when it has none). Results are only ever appended, so a different stamp means a
// different set; the count also changes when another instance commits a smaller id late.
struct ResultsStamp {
  std::int64_t count = 0;
  std::int64_t newest_id = 0;
  bool operator==(const ResultsStamp&) const = default;
};

// What the answers about a measurement are made from: the stamp of its results and the newest
// version of its machine's tolerance table (0 when it has none).
struct AnswerBasis {
  ResultsStamp results;
  std::int64_t table_version = 0;
  bool operator==(const AnswerBasis&) const = default;
};

struct MeasurementFilter {
  std::optional<std::string> machine_id;
  std::optional<std::string> kind;
  std::optional<std::string> test_id;
  std::optional<std::string> direction;  // DBB: cw or ccw
  std::optional<std::string> from;       // UTC ISO 8601, inclusive (measured_at, else uploaded_at)
  std::optional<std::string> to;         // exclusive
  // Free text: a measurement matches when its file name, test_id, direction or kind contains
  // it (case-insensitive), or when it is the measurement's id ("#258" or "258").
  std::optional<std::string> text;
  // Order of the items: kOldest (measurement time, else upload time, ascending; the default),
  // kNewest (the same, descending), kUploaded (newest upload first, by id).
  enum class Order { kOldest, kNewest, kUploaded };
  Order order = Order::kOldest;
  std::int64_t limit = 50;
  std::int64_t offset = 0;
};

struct MeasurementPage {
  std::vector<MeasurementRecord> items;
  std::int64_t total = 0;
};

struct MachineSummary {
  std::string machine_id;
  std::int64_t measurement_count = 0;
  std::optional<std::string> last_time;  // newest measurement
  std::int64_t model_versions = 0;       // stored versions of its machine definition
};

// One version of a machine definition (a "kinemetric-machine/1" document). Versions of a
// machine are numbered 1, 2, … in the order they were stored; none is ever changed or removed.
struct NewMachineModel {
  std::string machine_id;
  std::string source;    // "upload", "calibration job N", "discovery job N"
  std::string note;      // free text from whoever stored it
  std::string document;  // the document's bytes, exactly as stored
  std::string sha256;    // of document
};

struct MachineModelRecord {
  std::string machine_id;
  std::int64_t version = 0;
  std::string created_at, source, note, sha256;
  std::string document;  // empty in lists
};

struct MachineModelPut {
  MachineModelRecord record;  // without the document
  bool created = false;
};

struct PutOutcome {
  MeasurementId id;
  bool created = false;
};

// Where a job is: waiting for a worker, running, or ended (done, failed, cancelled). Stored and
// shown (GET /api/v1/jobs/{id} `status`, web/static/contract.js JOB_STATUS) as its ToString.
enum class JobStatus { kQueued, kRunning, kDone, kFailed, kCancelled };

inline const char* ToString(JobStatus s) {
  switch (s) {
    case JobStatus::kQueued:
      return "queued";
    case JobStatus::kRunning:
      return "running";
    case JobStatus::kDone:
      return "done";
    case JobStatus::kFailed:
      return "failed";
    case JobStatus::kCancelled:
      return "cancelled";
  }
  return "";
}

inline std::ostream& operator<<(std::ostream& os, JobStatus s) {
  return os << ToString(s);
}

// The status of its spelling; nullopt for any other text.
inline std::optional<JobStatus> ParseJobStatus(std::string_view text) {
  for (JobStatus s : {JobStatus::kQueued, JobStatus::kRunning, JobStatus::kDone, JobStatus::kFailed,
                      JobStatus::kCancelled}) {
    if (text == ToString(s)) return s;
  }
  return std::nullopt;
}

// The status of a stored row; a text no status spells is a damaged database (StorageError).
inline JobStatus StoredJobStatus(std::string_view text) {
  if (const auto s = ParseJobStatus(text)) return *s;
  throw StorageError("a stored job has the unknown status '" + std::string(text) + "'", 0, false);
}

// A background job (e.g. a hexapod calibration study) and its stored outcome.
struct JobRecord {
  JobId id;
  std::string kind;  // as registered with the job queue (server/jobs/jobs.h kCalibrationJob, …)
  JobStatus status = JobStatus::kQueued;
  double progress = 0.0;
  std::string stage;
  std::string request_json;
  std::string result_json;  // when done
  std::string error;        // when failed
  std::string created_at, updated_at;
  // The job queue shared by every instance on the database (server/jobs/jobs.h): what a worker
  // needs to run the job (the checked request with the machine resolved), the instance running it
  // and until when its lease holds (Unix ms), and how many times it was started.
  std::string plan_json;
  std::string lease_owner;
  std::int64_t lease_until_ms = 0;
  std::int64_t attempts = 0;
  // The access token that submitted the job (none: not known, e.g. queued before it was kept).
  std::optional<TokenId> owner_token_id;
  // The machine definition a finished job produced (a calibrated or updated machine), exactly as
  // the machine writer wrote it and stored unchanged when it is saved as a model; empty when the
  // job produced none or finished before it was kept (migration 14).
  std::string machine_document;
};

// A job as queued: request_json is what the API shows, plan_json what a worker runs.
struct NewJob {
  std::string kind;
  std::string request_json;
  std::string plan_json;
  std::optional<TokenId> owner_token_id = std::nullopt;
};

// Capacitance-sensor streams (docs/streams.md). A stream belongs to a machine and has a source
// (an HTTP client, or a Modbus device); its samples are kept per channel in immutable chunks of
// consecutive counters, never a row per sample. Gaps (counter jumps) are recorded as found.
struct NewStream {
  std::string machine_id;
  std::string name;
  std::string source;         // "http" or "modbus:<device name>"
  std::string metadata_json;  // channel descriptions and anything the client sent
};

struct StreamRecord {
  StreamId id;
  std::string machine_id, name, source, metadata_json, created_at;
};

// One stored chunk: counters first_counter … first_counter + n − 1 of one channel.
struct StreamChunk {
  StreamId stream_id;
  std::int64_t channel = 0;
  std::int64_t first_counter = 0;
  std::int64_t n = 0;
  std::int64_t t_first_us = 0, t_last_us = 0;
  double value_min = 0.0, value_max = 0.0, value_sum = 0.0;
  std::int64_t flagged = 0;  // samples with a non-zero status
  std::string data;  // encoded samples (server/streams/stream_chunks.h); empty when not read
};

struct StreamGap {
  StreamId stream_id;
  std::int64_t channel = 0;
  std::int64_t first_missing = 0;  // first counter that never arrived
  std::int64_t missing = 0;        // how many counters
  std::int64_t t_before_us = 0;    // last sample before the gap
  std::int64_t t_after_us = 0;     // first sample after it
  std::string detected_at;
};

struct StreamChannelSummary {
  std::int64_t channel = 0;
  std::int64_t samples = 0, chunks = 0, flagged = 0;
  std::int64_t first_t_us = 0, last_t_us = 0;
  // One past the highest stored counter (counters are 0 … 2⁶³ − 1, so this may be 2⁶³).
  std::uint64_t next_counter = 0;
  std::int64_t gaps = 0, missing = 0;
};

// An access token as stored (never the secret, nor its hash once read back for a list).
struct TokenRecord {
  TokenId id;
  std::string role;
  std::string name;
  std::string created_at;
  std::optional<std::string> expires_at;  // ISO 8601 UTC; none: never expires
  std::optional<std::string> revoked_at;
  std::optional<std::string> last_used_at;  // to within a minute (NoteTokenUse); none: not yet
};

// One state-changing request: who (token), what (method, path, status, subject), when.
struct AuditEntry {
  AuditEntryId id;                  // set by the storage
  std::string at;                   // ISO 8601 UTC; the storage sets it when empty
  std::optional<TokenId> token_id;  // none: no valid token was presented
  std::string token_name;
  std::string role;
  std::string method;
  std::string path;
  int status = 0;
  std::string subject;  // e.g. "measurement 7", "job 3", "token 4"; empty when none
};

struct AuditPage {
  std::vector<AuditEntry> items;  // newest first
  std::int64_t total = 0;
};

// The accuracy audit of one machine (server/audits/accuracy_audit.h): its rules (JSON array, as
// validated) and schedule (none: run only on request), with the times of the last and next run.
struct AuditConfigRecord {
  std::string machine_id;
  std::optional<std::string> schedule;
  std::string rules_json;
  std::string updated_at;
  std::optional<std::string> last_run_at, next_run_at;  // ISO 8601 UTC
};

// One run of an accuracy audit: the verdict (level 1 normal, 2 warn, 3 stop) and its findings.
struct AuditVerdictRecord {
  AuditVerdictId id;
  std::string machine_id;
  int level = 1;
  std::string trigger;     // "manual" or "schedule"
  std::string created_at;  // ISO 8601 UTC; the storage sets it when empty
  std::string verdict_json;
  std::string webhook_status;  // "", "pending", "delivered", "failed"
  std::int64_t webhook_attempts = 0;
};

struct AuditVerdictFilter {
  std::optional<std::string> machine_id;
  std::optional<std::string> from;  // created_at, inclusive
  std::optional<std::string> to;    // exclusive
  std::int64_t limit = 100;
  std::int64_t offset = 0;  // verdicts skipped (in the listing's order) before the first
  // Set: the listing ends after the verdict whose verdict_json takes the bytes listed past it
  // (that verdict included), so a page of large verdicts never loads more than about this much.
  std::optional<std::int64_t> max_bytes;
};

// One version of a machine's tolerance table (server/tolerances/tolerances.h). Versions of a
// machine are numbered 1, 2, … in the order they were stored; none is ever changed or removed.
struct NewToleranceTable {
  std::string machine_id;
  std::string tolerances_json;  // the entries as validated, in the order given
  std::string sha256;           // of the entries in any order (the same table again)
};

struct ToleranceTableRecord {
  std::string machine_id;
  std::int64_t version = 0;
  std::string created_at;
  std::string tolerances_json;
  std::string sha256;
};

struct ToleranceTablePut {
  ToleranceTableRecord record;
  bool created = false;
};

// One version of an instrument of the register (server/instruments/instruments.h). Versions of
// a serial are numbered 1, 2, … in the order they were stored; none is ever changed or removed.
struct NewInstrumentVersion {
  std::string serial;
  std::string instrument_json;  // the entry as validated
  std::string sha256;           // of instrument_json (the same entry again)
};

struct InstrumentVersionRecord {
  std::string serial;
  std::int64_t version = 0;
  std::string created_at;
  std::string instrument_json;
  std::string sha256;
};

struct InstrumentVersionPut {
  InstrumentVersionRecord record;
  bool created = false;
};

// The storage of the service, one role a group of tables; each back-end (sqlite/, pg/)
// implements every role in one class (Storage). A part of the service that needs one role takes
// that role only (the job queue a JobStore, the audit scheduler an AuditStore, …).

// Measurements (immutable, keyed by the SHA-256 of their bytes), their samples and results.
class MeasurementStore {
 public:
  virtual ~MeasurementStore() = default;

  // Stores the measurement and its results atomically; the same bytes stored before give the
  // existing id and created = false (nothing is written then).
  virtual PutOutcome PutMeasurement(const NewMeasurement& m, const std::vector<NewResult>& r) = 0;
  virtual std::optional<MeasurementRecord> GetMeasurement(MeasurementId id) = 0;
  virtual std::optional<MeasurementId> FindBySha256(const std::string& sha256) = 0;
  virtual std::string GetRaw(MeasurementId id) = 0;      // throws NotFound
  virtual SampleBlock GetSamples(MeasurementId id) = 0;  // throws NotFound
  virtual MeasurementPage ListMeasurements(const MeasurementFilter& f) = 0;
  virtual std::vector<ResultRecord> GetResults(MeasurementId id) = 0;
  // The basis of the answers about the measurement: one query of indexes, no document read
  // ({} for a measurement that does not exist).
  virtual AnswerBasis GetAnswerBasis(MeasurementId id) = 0;
  // Adds a result computed later (e.g. by a newer analysis version); keeps older ones.
  virtual void PutResult(MeasurementId id, const NewResult& r) = 0;
  // Machines with stored measurements or a stored model.
  virtual std::vector<MachineSummary> ListMachines() = 0;
};

// Machine definitions (models), versioned.
class ModelStore {
 public:
  virtual ~ModelStore() = default;

  // Machine definitions, versioned. PutMachineModel appends the next version of the machine
  // atomically; when the newest version holds the same bytes (same sha256), that version is
  // answered with created = false and nothing is written. GetMachineModel: the given version, or
  // the newest without one; nullopt when there is none. ListMachineModels: every version, oldest
  // first, without the documents (empty when the machine has none).
  virtual MachineModelPut PutMachineModel(const NewMachineModel& m) = 0;
  virtual std::optional<MachineModelRecord> GetMachineModel(
      const std::string& machine_id, std::optional<std::int64_t> version) = 0;
  virtual std::vector<MachineModelRecord> ListMachineModels(const std::string& machine_id) = 0;
};

// Background jobs and the job queue shared by every instance on the database.
class JobStore {
 public:
  virtual ~JobStore() = default;

  // Background jobs.
  virtual JobId CreateJob(const std::string& kind, const std::string& request_json) = 0;
  virtual void UpdateJob(const JobRecord& job) = 0;  // status, progress, stage, result, error
  virtual std::optional<JobRecord> GetJob(JobId id) = 0;
  virtual std::vector<JobRecord> ListJobs(std::int64_t limit) = 0;
  // Marks jobs left queued or running by a previous process as failed; returns how many.
  virtual int FailInterruptedJobs(const std::string& reason) = 0;
  // How many jobs are in each status (queued, running, done, failed); statuses with none are
  // absent.
  virtual std::map<std::string, std::int64_t> CountJobsByStatus() = 0;
  // How many jobs have one status (read from the status index: the cost follows that count,
  // not the years of finished jobs).
  virtual std::int64_t CountJobsWithStatus(JobStatus status) = 0;

  // The job queue shared by every instance on the database. QueueJob stores a job as queued
  // (the new id). ClaimJob takes the oldest job to run — queued, or running under a lease that
  // ended before now_ms (its instance stopped) with attempts < max_attempts — marks it running
  // for owner until now_ms + lease_ms with attempts + 1, and returns it with its plan; nullopt
  // when there is none. Concurrent callers (threads, instances) never take the same job. In the
  // same transaction, running jobs whose lease ended after max_attempts starts are failed with
  // abandoned_error.
  virtual JobId QueueJob(const NewJob& job) = 0;
  virtual std::optional<JobRecord> ClaimJob(const std::string& owner, std::int64_t now_ms,
                                            std::int64_t lease_ms, int max_attempts,
                                            const std::string& abandoned_error) = 0;
  // Progress of owner's running job, its lease extended to lease_until_ms; false (nothing
  // written) when the job is no longer owner's or no longer running.
  virtual bool RenewJob(JobId id, const std::string& owner, double progress,
                        const std::string& stage, std::int64_t lease_until_ms) = 0;
  // The outcome of owner's running job (status done or failed, progress, stage, result_json,
  // error); the lease ends (lease_owner stays: the instance that ran it). false when the job is
  // no longer owner's (nothing written).
  virtual bool FinishJob(const JobRecord& job, const std::string& owner) = 0;
  // owner's running jobs go back to the queue (a stopping instance): queued, lease cleared,
  // attempts kept; how many.
  virtual int ReleaseJobs(const std::string& owner) = 0;
  // A queued or running job becomes cancelled (stage "cancelled", error = reason, lease ended):
  // no instance claims it again, and the instance running it has its next RenewJob and
  // FinishJob refused. false (nothing written) when the job is not queued or running.
  virtual bool CancelJob(JobId id, const std::string& reason) = 0;
};

// Capacitance-sensor streams: chunks of samples and gaps.
class StreamStore {
 public:
  virtual ~StreamStore() = default;

  // Streams. AppendStream writes chunks and gaps in one transaction; a chunk whose
  // (stream, channel, first_counter) is stored already is refused (InvalidInput).
  virtual StreamId CreateStream(const NewStream& s) = 0;
  virtual std::optional<StreamRecord> GetStream(StreamId id) = 0;
  virtual std::vector<StreamRecord> ListStreams(const std::optional<std::string>& machine_id,
                                                std::int64_t limit) = 0;
  virtual void AppendStream(const std::vector<StreamChunk>& chunks,
                            const std::vector<StreamGap>& gaps) = 0;
  virtual std::vector<StreamChannelSummary> StreamChannels(StreamId stream_id) = 0;
  // Chunks of one channel overlapping [from_us, to_us), in counter order; with_data = false
  // leaves StreamChunk::data empty (the per-chunk statistics suffice for coarse plots).
  virtual std::vector<StreamChunk> ReadStreamChunks(StreamId stream_id, std::int64_t channel,
                                                    std::int64_t from_us, std::int64_t to_us,
                                                    bool with_data) = 0;
  // The encoded samples of one chunk (NotFound when there is none at that first counter).
  virtual std::string ReadStreamChunkData(StreamId stream_id, std::int64_t channel,
                                          std::int64_t first_counter) = 0;
  virtual std::vector<StreamGap> StreamGaps(StreamId stream_id, std::int64_t limit) = 0;
};

// Access: tokens (as hashes) and the audit log of state-changing requests.
class AccessStore {
 public:
  virtual ~AccessStore() = default;

  // Access tokens are stored only as SHA-256 hashes.
  virtual std::int64_t CountTokens() = 0;
  virtual void PutToken(const std::string& token_sha256, const std::string& role,
                        const std::string& label) = 0;
  virtual std::optional<std::string> FindTokenRole(const std::string& token_sha256) = 0;
  // Named tokens with a role and an optional expiry (server/access/access.h); the new token's id.
  virtual TokenId AddToken(const std::string& token_sha256, const std::string& role,
                           const std::string& name,
                           const std::optional<std::string>& expires_at) = 0;
  // The token of a hash, also when it is expired or revoked (the caller decides).
  virtual std::optional<TokenRecord> FindToken(const std::string& token_sha256) = 0;
  virtual std::vector<TokenRecord> ListTokens() = 0;  // by id
  // Revokes a token from now on; false when there is no such token (a second revocation keeps
  // the first time). `check` sees every token as stored at that moment and throws to refuse;
  // the check and the revocation are one transaction, also against other instances.
  using TokensCheck = std::function<void(const std::vector<TokenRecord>&)>;
  virtual bool RevokeToken(TokenId id, const TokensCheck& check) = 0;
  // Records that a token was used at `at` (ISO 8601 UTC); an earlier time never replaces a later.
  virtual void TouchToken(TokenId id, const std::string& at) = 0;
  // The audit log of state-changing requests, appended only; listed newest first.
  virtual void AppendAudit(const AuditEntry& entry) = 0;
  virtual AuditPage ListAudit(std::int64_t limit, std::int64_t offset) = 0;
};

// Accuracy audits: each machine's rules and schedule, and the verdicts of the runs.
class AuditStore {
 public:
  virtual ~AuditStore() = default;

  // Accuracy audits. PutAuditConfig stores (or replaces) a machine's rules and schedule;
  // ListAuditConfigs: every machine's, by machine_id. SetAuditRun records a run's time and the
  // next due time (none: not scheduled).
  virtual void PutAuditConfig(const AuditConfigRecord& config) = 0;
  virtual std::optional<AuditConfigRecord> GetAuditConfig(const std::string& machine_id) = 0;
  virtual std::vector<AuditConfigRecord> ListAuditConfigs() = 0;
  virtual void SetAuditRun(const std::string& machine_id, const std::optional<std::string>& last,
                           const std::optional<std::string>& next) = 0;
  // Claims a scheduled run for one instance: sets last_run_at = last and next_run_at = next only
  // while next_run_at still equals due; false when another instance claimed it first.
  virtual bool ClaimAuditRun(const std::string& machine_id, const std::string& due,
                             const std::string& last, const std::optional<std::string>& next) = 0;
  // Verdicts are appended (the new id) and never deleted; listed newest first.
  virtual AuditVerdictId AddAuditVerdict(const AuditVerdictRecord& verdict) = 0;
  virtual std::optional<AuditVerdictRecord> GetAuditVerdict(AuditVerdictId id) = 0;
  virtual std::vector<AuditVerdictRecord> ListAuditVerdicts(const AuditVerdictFilter& filter) = 0;
  virtual void SetAuditWebhook(AuditVerdictId id, const std::string& status,
                               std::int64_t attempts) = 0;
};

// Tolerance tables: each machine's specification of its figures, versioned.
class ToleranceStore {
 public:
  virtual ~ToleranceStore() = default;

  // PutToleranceTable appends the next version of the machine's table atomically; when the
  // newest version has the same sha256, that version is answered with created = false and
  // nothing is written. GetToleranceTable: the given version, or the newest without one;
  // nullopt when there is none.
  virtual ToleranceTablePut PutToleranceTable(const NewToleranceTable& table) = 0;
  virtual std::optional<ToleranceTableRecord> GetToleranceTable(
      const std::string& machine_id, std::optional<std::int64_t> version) = 0;
};

// The instrument register: each instrument's uncertainties and calibration, versioned.
class InstrumentStore {
 public:
  virtual ~InstrumentStore() = default;

  // PutInstrument appends the next version of the serial atomically; when the newest version
  // has the same sha256, that version is answered with created = false and nothing is written.
  // GetInstrument: the given version, or the newest without one; nullopt when there is none.
  // ListInstruments: the newest version of each serial, by serial.
  virtual InstrumentVersionPut PutInstrument(const NewInstrumentVersion& instrument) = 0;
  virtual std::optional<InstrumentVersionRecord> GetInstrument(
      const std::string& serial, std::optional<std::int64_t> version) = 0;
  virtual std::vector<InstrumentVersionRecord> ListInstruments() = 0;
};

// Every role, as one back-end implements them.
class Storage : public MeasurementStore,
                public ModelStore,
                public JobStore,
                public StreamStore,
                public AccessStore,
                public AuditStore,
                public ToleranceStore,
                public InstrumentStore,
                public ReportStore {};

}  // namespace km::server
