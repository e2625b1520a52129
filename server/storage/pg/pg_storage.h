// PostgreSQL backend of the storage interface, for fleets: several kinemetricd instances share
// one database. The same tables and answers as the SQLite backend
// (server/storage/sqlite/sqlite_storage.h): numbered migrations (table kinemetric_schema, run under
// an advisory lock), immutable rows guarded by triggers, a measurement and its results in one
// transaction, deduplication by SHA-256 across instances (INSERT … ON CONFLICT), machine model
// versions numbered under a per-machine advisory lock, jobs claimed with SELECT … FOR UPDATE SKIP
// LOCKED.
//
// Where it lives: server/pg_db.* (connections, the pool, statements, transactions, errors),
// server/pg_migrations.* (the schema), and the data access by table: pg_storage.cpp (opening;
// measurements, results, machines, tokens), pg_jobs.cpp (jobs and the job queue),
// pg_streams.cpp (streams), pg_machine_models.cpp (machine definitions), pg_access.cpp (tokens,
// audit log), pg_audits.cpp (accuracy audits).
#pragma once

#include <memory>
#include <string>

#include "server/storage/storage.h"

namespace km::server {

namespace pg {
class Pool;
}  // namespace pg

struct PgOptions {
  // How long a call waits for a row lock another transaction holds (lock_timeout), or for a
  // free connection of the pool, before it fails with a busy StorageError (HTTP 503).
  int busy_timeout_ms = 5000;
  // The longest a statement may run (statement_timeout; 0: no limit); then busy too.
  int statement_timeout_ms = 0;
  int pool_size = 8;  // connections at most
};

class PgStorage : public Storage {
 public:
  // Connects to the database of `url` (postgresql://… or postgres://…) and brings its schema
  // up to date. Messages never show the URL's password.
  explicit PgStorage(const std::string& url, PgOptions options = {});
  ~PgStorage() override;
  PgStorage(const PgStorage&) = delete;
  PgStorage& operator=(const PgStorage&) = delete;

  static int SchemaVersion();

  PutOutcome PutMeasurement(const NewMeasurement& m, const std::vector<NewResult>& r) override;
  std::optional<MeasurementRecord> GetMeasurement(MeasurementId id) override;
  std::optional<MeasurementId> FindBySha256(const std::string& sha256) override;
  std::string GetRaw(MeasurementId id) override;
  SampleBlock GetSamples(MeasurementId id) override;
  MeasurementPage ListMeasurements(const MeasurementFilter& f) override;
  std::vector<ResultRecord> GetResults(MeasurementId id) override;
  AnswerBasis GetAnswerBasis(MeasurementId id) override;
  void PutResult(MeasurementId id, const NewResult& r) override;
  std::vector<MachineSummary> ListMachines() override;
  MachineModelPut PutMachineModel(const NewMachineModel& m) override;  // pg_machine_models.cpp
  std::optional<MachineModelRecord> GetMachineModel(const std::string& machine_id,
                                                    std::optional<std::int64_t> version) override;
  std::vector<MachineModelRecord> ListMachineModels(const std::string& machine_id) override;
  JobId CreateJob(const std::string& kind, const std::string& request_json) override;
  void UpdateJob(const JobRecord& job) override;
  std::optional<JobRecord> GetJob(JobId id) override;
  std::vector<JobRecord> ListJobs(std::int64_t limit) override;
  int FailInterruptedJobs(const std::string& reason) override;
  std::map<std::string, std::int64_t> CountJobsByStatus() override;
  std::int64_t CountJobsWithStatus(JobStatus status) override;
  // The shared job queue: pg_jobs.cpp (with the job calls above).
  JobId QueueJob(const NewJob& job) override;
  std::optional<JobRecord> ClaimJob(const std::string& owner, std::int64_t now_ms,
                                    std::int64_t lease_ms, int max_attempts,
                                    const std::string& abandoned_error) override;
  bool RenewJob(JobId id, const std::string& owner, double progress, const std::string& stage,
                std::int64_t lease_until_ms) override;
  bool FinishJob(const JobRecord& job, const std::string& owner) override;
  int ReleaseJobs(const std::string& owner) override;
  bool CancelJob(JobId id, const std::string& reason) override;
  StreamId CreateStream(const NewStream& s) override;
  std::optional<StreamRecord> GetStream(StreamId id) override;
  std::vector<StreamRecord> ListStreams(const std::optional<std::string>& machine_id,
                                        std::int64_t limit) override;
  void AppendStream(const std::vector<StreamChunk>& chunks,
                    const std::vector<StreamGap>& gaps) override;
  std::vector<StreamChannelSummary> StreamChannels(StreamId stream_id) override;
  std::vector<StreamChunk> ReadStreamChunks(StreamId stream_id, std::int64_t channel,
                                            std::int64_t from_us, std::int64_t to_us,
                                            bool with_data) override;
  std::string ReadStreamChunkData(StreamId stream_id, std::int64_t channel,
                                  std::int64_t first_counter) override;
  std::vector<StreamGap> StreamGaps(StreamId stream_id, std::int64_t limit) override;
  std::int64_t CountTokens() override;
  void PutToken(const std::string& token_sha256, const std::string& role,
                const std::string& label) override;
  std::optional<std::string> FindTokenRole(const std::string& token_sha256) override;
  // Tokens and the audit log: pg_access.cpp.
  TokenId AddToken(const std::string& token_sha256, const std::string& role,
                   const std::string& name, const std::optional<std::string>& expires_at) override;
  std::optional<TokenRecord> FindToken(const std::string& token_sha256) override;
  std::vector<TokenRecord> ListTokens() override;
  bool RevokeToken(TokenId id, const TokensCheck& check) override;
  void TouchToken(TokenId id, const std::string& at) override;
  void AppendAudit(const AuditEntry& entry) override;
  AuditPage ListAudit(std::int64_t limit, std::int64_t offset) override;
  // Accuracy audits: pg_audits.cpp.
  void PutAuditConfig(const AuditConfigRecord& config) override;
  std::optional<AuditConfigRecord> GetAuditConfig(const std::string& machine_id) override;
  std::vector<AuditConfigRecord> ListAuditConfigs() override;
  void SetAuditRun(const std::string& machine_id, const std::optional<std::string>& last,
                   const std::optional<std::string>& next) override;
  bool ClaimAuditRun(const std::string& machine_id, const std::string& due, const std::string& last,
                     const std::optional<std::string>& next) override;
  AuditVerdictId AddAuditVerdict(const AuditVerdictRecord& verdict) override;
  std::optional<AuditVerdictRecord> GetAuditVerdict(AuditVerdictId id) override;
  std::vector<AuditVerdictRecord> ListAuditVerdicts(const AuditVerdictFilter& filter) override;
  void SetAuditWebhook(AuditVerdictId id, const std::string& status,
                       std::int64_t attempts) override;
  // Tolerance tables: pg_tolerances.cpp.
  ToleranceTablePut PutToleranceTable(const NewToleranceTable& table) override;
  std::optional<ToleranceTableRecord> GetToleranceTable(
      const std::string& machine_id, std::optional<std::int64_t> version) override;
  // The instrument register: pg_instruments.cpp.
  InstrumentVersionPut PutInstrument(const NewInstrumentVersion& instrument) override;
  std::optional<InstrumentVersionRecord> GetInstrument(
      const std::string& serial, std::optional<std::int64_t> version) override;
  std::vector<InstrumentVersionRecord> ListInstruments() override;
  // Report revisions and approvals: pg_reports.cpp.
  ReportRevisionPut PutReportRevision(const NewReportRevision& revision) override;
  std::vector<ReportRevisionRecord> ListReportRevisions(const std::string& subject) override;
  bool AddReportApproval(const ReportApprovalRecord& approval) override;
  std::optional<std::string> ReportApprovalPdf(const std::string& subject,
                                               std::int64_t revision) override;

 private:
  std::unique_ptr<pg::Pool> pool_;
};

}  // namespace km::server
