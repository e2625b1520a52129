// A real SQLite storage whose job updates can be made to fail on demand (a full disk, a locked
// database): every other call goes to the SQLite file unchanged.
#pragma once

#include <atomic>
#include <functional>
#include <mutex>
#include <string>

#include "analysis/core/errors.h"
#include "server/sqlite_storage.h"

namespace km::server::testing {

class FlakyStorage final : public Storage {
 public:
  explicit FlakyStorage(const std::string& path) : db_(path) {}

  // Decides, per update, whether it fails (called under a lock; may keep state).
  void FailUpdatesWhen(std::function<bool(const JobRecord&)> rule) {
    std::lock_guard lock(mu_);
    rule_ = std::move(rule);
  }
  int failed_updates() const { return failed_.load(); }

  PutOutcome PutMeasurement(const NewMeasurement& m, const std::vector<NewResult>& r) override {
    return db_.PutMeasurement(m, r);
  }
  std::optional<MeasurementRecord> GetMeasurement(std::int64_t id) override {
    return db_.GetMeasurement(id);
  }
  std::optional<std::int64_t> FindBySha256(const std::string& sha256) override {
    return db_.FindBySha256(sha256);
  }
  std::string GetRaw(std::int64_t id) override { return db_.GetRaw(id); }
  SampleBlock GetSamples(std::int64_t id) override { return db_.GetSamples(id); }
  MeasurementPage ListMeasurements(const MeasurementFilter& f) override {
    return db_.ListMeasurements(f);
  }
  std::vector<ResultRecord> GetResults(std::int64_t id) override { return db_.GetResults(id); }
  void PutResult(std::int64_t id, const NewResult& r) override { db_.PutResult(id, r); }
  std::vector<MachineSummary> ListMachines() override { return db_.ListMachines(); }
  std::int64_t CreateJob(const std::string& kind, const std::string& request_json) override {
    return db_.CreateJob(kind, request_json);
  }
  void UpdateJob(const JobRecord& job) override {
    {
      std::lock_guard lock(mu_);
      if (rule_ && rule_(job)) {
        ++failed_;
        throw Error("storage: disk I/O error (simulated) updating job " + std::to_string(job.id));
      }
    }
    db_.UpdateJob(job);
  }
  std::optional<JobRecord> GetJob(std::int64_t id) override { return db_.GetJob(id); }
  std::vector<JobRecord> ListJobs(std::int64_t limit) override { return db_.ListJobs(limit); }
  int FailInterruptedJobs(const std::string& reason) override {
    return db_.FailInterruptedJobs(reason);
  }
  std::int64_t CreateStream(const NewStream& s) override { return db_.CreateStream(s); }
  std::optional<StreamRecord> GetStream(std::int64_t id) override { return db_.GetStream(id); }
  std::vector<StreamRecord> ListStreams(const std::optional<std::string>& machine_id,
                                        std::int64_t limit) override {
    return db_.ListStreams(machine_id, limit);
  }
  void AppendStream(const std::vector<StreamChunk>& chunks,
                    const std::vector<StreamGap>& gaps) override {
    db_.AppendStream(chunks, gaps);
  }
  std::vector<StreamChannelSummary> StreamChannels(std::int64_t stream_id) override {
    return db_.StreamChannels(stream_id);
  }
  std::vector<StreamChunk> ReadStreamChunks(std::int64_t stream_id, std::int64_t channel,
                                            std::int64_t from_us, std::int64_t to_us,
                                            bool with_data) override {
    return db_.ReadStreamChunks(stream_id, channel, from_us, to_us, with_data);
  }
  std::string ReadStreamChunkData(std::int64_t stream_id, std::int64_t channel,
                                  std::int64_t first_counter) override {
    return db_.ReadStreamChunkData(stream_id, channel, first_counter);
  }
  std::vector<StreamGap> StreamGaps(std::int64_t stream_id, std::int64_t limit) override {
    return db_.StreamGaps(stream_id, limit);
  }
  std::int64_t CountTokens() override { return db_.CountTokens(); }
  void PutToken(const std::string& token_sha256, const std::string& role,
                const std::string& label) override {
    db_.PutToken(token_sha256, role, label);
  }
  std::optional<std::string> FindTokenRole(const std::string& token_sha256) override {
    return db_.FindTokenRole(token_sha256);
  }

 private:
  SqliteStorage db_;
  std::mutex mu_;
  std::function<bool(const JobRecord&)> rule_;
  std::atomic<int> failed_{0};
};

}  // namespace km::server::testing
