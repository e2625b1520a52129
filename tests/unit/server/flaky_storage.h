// A real SQLite storage whose job writes (progress with the lease, outcome) can be made to fail
// on demand (a full disk, a locked database): every other call goes to the SQLite file
// unchanged.
#pragma once

#include <atomic>
#include <functional>
#include <mutex>
#include <string>

#include "analysis/core/errors.h"
#include "server/storage/sqlite/sqlite_storage.h"

namespace km::server::test {

class FlakyStorage final : public SqliteStorage {
 public:
  explicit FlakyStorage(const std::string& path) : SqliteStorage(path) {}

  // Decides, per write, whether it fails (called under a lock; may keep state). A progress
  // report is seen as the job with status "running", its progress and stage.
  void FailUpdatesWhen(std::function<bool(const JobRecord&)> rule) {
    std::lock_guard lock(mu_);
    rule_ = std::move(rule);
  }
  int failed_updates() const { return failed_.load(); }

  void UpdateJob(const JobRecord& job) override {
    MaybeFail(job);
    SqliteStorage::UpdateJob(job);
  }
  bool RenewJob(JobId id, const std::string& owner, double progress, const std::string& stage,
                std::int64_t lease_until_ms) override {
    JobRecord j;
    j.id = id;
    j.status = JobStatus::kRunning;
    j.progress = progress;
    j.stage = stage;
    MaybeFail(j);
    return SqliteStorage::RenewJob(id, owner, progress, stage, lease_until_ms);
  }
  bool FinishJob(const JobRecord& job, const std::string& owner) override {
    MaybeFail(job);
    return SqliteStorage::FinishJob(job, owner);
  }

 private:
  void MaybeFail(const JobRecord& job) {
    std::lock_guard lock(mu_);
    if (rule_ && rule_(job)) {
      ++failed_;
      throw Error("storage: disk I/O error (simulated) updating job " + to_string(job.id));
    }
  }
  std::mutex mu_;
  std::function<bool(const JobRecord&)> rule_;
  std::atomic<int> failed_{0};
};

}  // namespace km::server::test
