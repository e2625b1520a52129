// The accuracy-audit scheduler: a thread of the service that sleeps until the next audit is
// due (a condition variable, woken early when a schedule changes or the service stops), runs
// the due audits with trigger "schedule", and hands verdicts of level 2 and 3 to the webhook
// queue. Due times are stored (audit_configs.next_run_at), so an audit whose time passed
// while the server was down runs once when it starts again, not once per missed time.
#pragma once

#include <condition_variable>
#include <cstdint>
#include <functional>
#include <memory>
#include <mutex>
#include <string>
#include <thread>

#include <nlohmann/json.hpp>

#include "server/audits/audit_source.h"
#include "server/audits/webhook.h"
#include "server/storage/storage.h"

namespace km::server {

struct AuditOptions {
  std::string webhook_url;  // empty: no webhook
  int webhook_attempts = 5;
  int webhook_first_delay_ms = 1000;
  int webhook_timeout_s = 5;           // the whole of one attempt
  std::string webhook_secret;          // empty: deliveries unsigned
  bool webhook_allow_private = false;  // loopback and private targets (refused by default)
};

// How long a claimed scheduled run stays claimed: an instance that dies between the claim and
// the stored verdict leaves the run due again this much later (for any instance).
constexpr std::int64_t kAuditLeaseSeconds = 300;

// Whole Unix seconds now (replaceable in tests).
using AuditClock = std::function<std::int64_t()>;
std::int64_t SystemUnixSeconds();

class AuditScheduler {
 public:
  AuditScheduler(AuditSource& service, AuditOptions options, AuditClock clock = SystemUnixSeconds);
  ~AuditScheduler();
  AuditScheduler(const AuditScheduler&) = delete;
  AuditScheduler& operator=(const AuditScheduler&) = delete;

  // Starts the scheduler thread and the webhook queue (with the verdicts a previous stop left
  // undelivered); Stop joins both (also the destructor).
  void Start();
  void Stop();

  // Stores a machine's rules and schedule (server/audits/audit_service.h) and wakes the thread.
  nlohmann::json PutConfig(const std::string& machine_id, const nlohmann::json& body);
  // Runs a machine's audit now, records the run and queues the webhook for level 2 and 3.
  nlohmann::json Run(const std::string& machine_id, const std::string& trigger);
  // Runs every scheduled audit due now, once each, and stores its next due time; how many ran.
  // Each due run is claimed first, so of several instances on one database one runs it, and
  // a claim lapses after kAuditLeaseSeconds, so a run is never lost to an instance's death.
  int RunDue();

 private:
  void Loop();
  bool ClaimDue(const AuditConfigRecord& config, std::int64_t now);
  void ReleaseClaim(const AuditConfigRecord& config, std::int64_t now);
  // One scheduled run, recorded in the audit log; false when the audit failed (logged).
  bool RunScheduled(const std::string& machine_id);
  // Queues the webhook of verdicts a previous stop left "pending" (among the newest 1000).
  void ResendPending();
  // The earliest stored due time (Unix seconds); nullopt when nothing is scheduled.
  std::optional<std::int64_t> NextDue();

  AuditSource& service_;
  AuditOptions options_;
  AuditClock clock_;
  std::unique_ptr<WebhookSender> webhook_;
  std::mutex mu_;
  std::condition_variable cv_;
  bool stop_ = false, changed_ = false;
  std::thread thread_;
};

}  // namespace km::server
