// A real SQLite storage whose job updates can be made to fail on demand (a full disk, a locked
// database): every other call goes to the SQLite file unchanged.
#pragma once

#include <atomic>
#include <functional>
#include <mutex>
#include <string>

#include "analysis/core/errors.h"
#include "server/sqlite_storage.h"

namespace km::server::test {

class FlakyStorage final : public SqliteStorage {
 public:
  explicit FlakyStorage(const std::string& path) : SqliteStorage(path) {}

  // Decides, per update, whether it fails (called under a lock; may keep state).
  void FailUpdatesWhen(std::function<bool(const JobRecord&)> rule) {
    std::lock_guard lock(mu_);
    rule_ = std::move(rule);
  }
  int failed_updates() const { return failed_.load(); }

  void UpdateJob(const JobRecord& job) override {
    {
      std::lock_guard lock(mu_);
      if (rule_ && rule_(job)) {
        ++failed_;
        throw Error("storage: disk I/O error (simulated) updating job " + std::to_string(job.id));
      }
    }
    SqliteStorage::UpdateJob(job);
  }

 private:
  std::mutex mu_;
  std::function<bool(const JobRecord&)> rule_;
  std::atomic<int> failed_{0};
};

}  // namespace km::server::test
