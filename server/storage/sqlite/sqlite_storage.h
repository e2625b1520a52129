// Embedded SQLite backend of the storage interface: WAL journal, synchronous=FULL,
// foreign_keys=ON, numbered migrations (PRAGMA user_version), RAII transactions that roll back
// unless committed, raw measurements protected against UPDATE/DELETE by triggers.
//
// Where it lives: server/sqlite_db.* (statements, the statement cache, transactions, errors),
// server/sqlite_migrations.* (the schema), and the data access by table: sqlite_storage.cpp
// (opening; measurements, results, machines, tokens), sqlite_jobs.cpp (the job queue),
// sqlite_streams.cpp (streams),
// sqlite_machine_models.cpp (machine definitions), sqlite_access.cpp (tokens, audit log),
// sqlite_audits.cpp (accuracy audits).
#pragma once

#include <memory>
#include <mutex>
#include <string>

#include "server/storage/storage.h"

struct sqlite3;

namespace km::server {

namespace sqlite {
class StatementCache;
class CachedStatement;
}  // namespace sqlite

struct SqliteOptions {
  // How long a call waits for a lock another connection holds before it fails with a busy
  // StorageError (HTTP 503 with Retry-After).
  int busy_timeout_ms = 5000;
};

class SqliteStorage : public Storage {  // tests wrap single calls of it
 public:
  // Opens (creating if needed) the database file and brings its schema up to date.
  explicit SqliteStorage(const std::string& path, SqliteOptions options = {});
  ~SqliteStorage() override;
  SqliteStorage(const SqliteStorage&) = delete;
  SqliteStorage& operator=(const SqliteStorage&) = delete;

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
  MachineModelPut PutMachineModel(const NewMachineModel& m) override;  // sqlite_machine_models.cpp
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
  // The shared job queue: sqlite_jobs.cpp (with the job calls above).
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
  // Tokens and the audit log: sqlite_access.cpp.
  TokenId AddToken(const std::string& token_sha256, const std::string& role,
                   const std::string& name, const std::optional<std::string>& expires_at) override;
  std::optional<TokenRecord> FindToken(const std::string& token_sha256) override;
  std::vector<TokenRecord> ListTokens() override;
  bool RevokeToken(TokenId id, const TokensCheck& check) override;
  void TouchToken(TokenId id, const std::string& at) override;
  void AppendAudit(const AuditEntry& entry) override;
  AuditPage ListAudit(std::int64_t limit, std::int64_t offset) override;
  // Accuracy audits: sqlite_audits.cpp.
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
  // Tolerance tables: sqlite_tolerances.cpp.
  ToleranceTablePut PutToleranceTable(const NewToleranceTable& table) override;
  std::optional<ToleranceTableRecord> GetToleranceTable(
      const std::string& machine_id, std::optional<std::int64_t> version) override;
  // The instrument register: sqlite_instruments.cpp.
  InstrumentVersionPut PutInstrument(const NewInstrumentVersion& instrument) override;
  std::optional<InstrumentVersionRecord> GetInstrument(
      const std::string& serial, std::optional<std::int64_t> version) override;
  std::vector<InstrumentVersionRecord> ListInstruments() override;
  // Report revisions and approvals: sqlite_reports.cpp.
  ReportRevisionPut PutReportRevision(const NewReportRevision& revision) override;
  std::vector<ReportRevisionRecord> ListReportRevisions(const std::string& subject) override;
  bool AddReportApproval(const ReportApprovalRecord& approval) override;
  std::optional<std::string> ReportApprovalPdf(const std::string& subject,
                                               std::int64_t revision) override;

 private:
  // The connection's prepared statement of this SQL, leased until the result goes out of scope.
  sqlite::CachedStatement Prepared(const std::string& sql);
  void InsertResult(MeasurementId id, const std::string& sha, const NewResult& r);
  void Close();
  sqlite3* db_ = nullptr;
  std::unique_ptr<sqlite::StatementCache> statements_;  // prepared once, reused
  std::mutex mu_;  // one connection, used by one thread at a time
};

}  // namespace km::server
