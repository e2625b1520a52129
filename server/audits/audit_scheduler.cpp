#include "server/audits/audit_scheduler.h"

#include <algorithm>
#include <chrono>
#include <iostream>
#include <optional>

#include "server/audits/audit_schedule.h"
#include "server/audits/audit_service.h"

namespace km::server {
namespace {

// The longest the thread sleeps without looking again (a clock set in tests, a time zone or
// clock change of the host).
constexpr std::int64_t kMaxSleepS = 60;
// Verdicts looked through at a start for webhooks a stop left undelivered.
constexpr std::int64_t kMaxResent = 1000;

}  // namespace

std::int64_t SystemUnixSeconds() {
  return std::chrono::duration_cast<std::chrono::seconds>(
             std::chrono::system_clock::now().time_since_epoch())
      .count();
}

AuditScheduler::AuditScheduler(AuditSource& service, AuditOptions options, AuditClock clock)
    : service_(service), options_(std::move(options)), clock_(std::move(clock)) {
  if (!options_.webhook_url.empty()) {
    WebhookOptions w;
    w.url = options_.webhook_url;
    w.attempts = options_.webhook_attempts;
    w.first_delay = std::chrono::milliseconds(options_.webhook_first_delay_ms);
    w.timeout = std::chrono::seconds(options_.webhook_timeout_s);
    w.secret = options_.webhook_secret;
    w.allow_private = options_.webhook_allow_private;
    AuditStore* storage = &service_.audit_store();
    webhook_ = std::make_unique<WebhookSender>(
        w, [storage](AuditVerdictId id, const std::string& status, std::int64_t attempts) {
          try {
            storage->SetAuditWebhook(id, status, attempts);
          } catch (const std::exception& e) {
            std::cerr << "kinemetricd: audit " << id << " webhook status: " << e.what()
                      << std::endl;
          }
        });
  }
}

AuditScheduler::~AuditScheduler() {
  Stop();
}

void AuditScheduler::Start() {
  std::lock_guard lock(mu_);
  if (thread_.joinable() || stop_) return;
  if (webhook_) {
    ResendPending();
    webhook_->Start();
  }
  thread_ = std::thread([this] { Loop(); });
}

void AuditScheduler::ResendPending() {
  AuditVerdictFilter f;
  f.limit = kMaxResent;
  const auto verdicts = service_.audit_store().ListAuditVerdicts(f);
  for (auto v = verdicts.rbegin(); v != verdicts.rend(); ++v) {  // oldest first
    if (v->webhook_status == "pending") webhook_->Enqueue(v->id, VerdictJson(*v).dump());
  }
}

void AuditScheduler::Stop() {
  {
    std::lock_guard lock(mu_);
    stop_ = true;
  }
  cv_.notify_all();
  if (thread_.joinable()) thread_.join();
  if (webhook_) webhook_->Stop();
}

nlohmann::json AuditScheduler::PutConfig(const std::string& machine_id,
                                         const nlohmann::json& body) {
  auto out = PutAuditConfig(service_, machine_id, body, clock_());
  {
    std::lock_guard lock(mu_);
    changed_ = true;
  }
  cv_.notify_all();
  return out;
}

nlohmann::json AuditScheduler::Run(const std::string& machine_id, const std::string& trigger) {
  const std::int64_t now = clock_();
  auto verdict = RunAccuracyAudit(service_, machine_id, trigger, now);
  if (trigger == "manual") {
    const auto config = service_.audit_store().GetAuditConfig(machine_id);
    service_.audit_store().SetAuditRun(machine_id, IsoFromUnixSeconds(now),
                                       config ? config->next_run_at : std::nullopt);
  }
  if (webhook_ && verdict["level"].get<int>() >= 2) {
    const auto id = verdict["id"].get<AuditVerdictId>();
    service_.audit_store().SetAuditWebhook(id, "pending", 0);
    verdict["webhook"] = {{"status", "pending"}, {"attempts", 0}};
    webhook_->Enqueue(id, verdict.dump());
  }
  return verdict;
}

// Claims a due run for this instance: only while the stored due time is still the one read
// (another instance on the same database may have claimed it first), the due time becomes the
// lease's end, so the run is due again then if this instance dies before its verdict is stored.
// false: not this instance's run, or the claim could not be stored.
bool AuditScheduler::ClaimDue(const AuditConfigRecord& c, std::int64_t now) {
  try {
    return service_.audit_store().ClaimAuditRun(c.machine_id, *c.next_run_at,
                                                IsoFromUnixSeconds(now),
                                                IsoFromUnixSeconds(now + kAuditLeaseSeconds));
  } catch (const std::exception& e) {
    std::cerr << "kinemetricd: accuracy audit of machine '" << c.machine_id
              << "': the due run could not be claimed: " << e.what() << std::endl;
    return false;
  }
}

// After a claimed run (verdict stored, or the audit failed): the next due time by the schedule
// replaces the lease, unless the schedule was changed meanwhile.
void AuditScheduler::ReleaseClaim(const AuditConfigRecord& c, std::int64_t now) {
  try {
    std::optional<std::string> next;
    if (const auto t = NextAuditRun(ParseAuditSchedule(*c.schedule), now)) {
      next = IsoFromUnixSeconds(*t);
    }
    service_.audit_store().ClaimAuditRun(c.machine_id, IsoFromUnixSeconds(now + kAuditLeaseSeconds),
                                         IsoFromUnixSeconds(now), next);
  } catch (const std::exception& e) {
    std::cerr << "kinemetricd: accuracy audit of machine '" << c.machine_id
              << "': the next due time could not be stored: " << e.what() << std::endl;
  }
}

int AuditScheduler::RunDue() {
  const std::int64_t now = clock_();
  int ran = 0;
  for (const auto& c : service_.audit_store().ListAuditConfigs()) {
    if (!c.schedule || !c.next_run_at) continue;
    const auto due = UnixSecondsFromIso(*c.next_run_at);
    if (due && *due > now) continue;
    if (!ClaimDue(c, now)) continue;
    if (RunScheduled(c.machine_id)) ++ran;
    ReleaseClaim(c, now);
  }
  return ran;
}

bool AuditScheduler::RunScheduled(const std::string& machine_id) {
  try {
    const auto verdict = Run(machine_id, "schedule");
    // In the audit log beside the runs asked for over HTTP (no token: the scheduler).
    AuditEntry e;
    e.token_name = "scheduler";
    e.method = "SCHEDULE";
    e.path = "/api/v1/machines/" + machine_id + "/audit/run";
    e.status = 201;
    e.subject = "machine " + machine_id + ", audit " + verdict["id"].dump();
    service_.access_store().AppendAudit(e);
    return true;
  } catch (const std::exception& e) {
    std::cerr << "kinemetricd: scheduled accuracy audit of machine '" << machine_id
              << "' failed: " << e.what() << std::endl;
    return false;
  }
}

std::optional<std::int64_t> AuditScheduler::NextDue() {
  std::optional<std::int64_t> best;
  for (const auto& c : service_.audit_store().ListAuditConfigs()) {
    if (!c.schedule || !c.next_run_at) continue;
    const auto t = UnixSecondsFromIso(*c.next_run_at);
    if (t && (!best || *t < *best)) best = t;
  }
  return best;
}

void AuditScheduler::Loop() {
  std::unique_lock lock(mu_);
  while (!stop_) {
    changed_ = false;
    lock.unlock();
    std::int64_t sleep_s = kMaxSleepS;
    try {
      RunDue();
      if (const auto next = NextDue())
        sleep_s = std::clamp<std::int64_t>(*next - clock_(), 0, kMaxSleepS);
    } catch (const std::exception& e) {
      std::cerr << "kinemetricd: accuracy-audit scheduler: " << e.what() << std::endl;
    }
    lock.lock();
    // Wake at the due second (a little after it: due times are whole seconds).
    const auto wake = std::chrono::system_clock::now() + std::chrono::seconds(sleep_s) +
                      std::chrono::milliseconds(sleep_s > 0 ? 20 : 200);
    cv_.wait_until(lock, wake, [this] { return stop_ || changed_; });
  }
}

}  // namespace km::server
