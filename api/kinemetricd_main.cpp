// kinemetricd — the kinemetric service. Thin main: configuration, storage, routes, serve.
#include <algorithm>
#include <atomic>
#include <chrono>
#include <csignal>
#include <cstdlib>
#include <filesystem>
#include <iostream>
#include <thread>

#include <unistd.h>

#include "analysis/core/allocator.h"
#include "analysis/core/errors.h"
#include "api/http_server.h"
#include "api/metrics.h"
#include "api/routes.h"
#include "server/base/config.h"
#include "server/base/data_dir.h"
#include "server/base/sha256.h"
#include "server/demo/demo_data.h"
#include "server/service.h"
#include "server/storage/open_storage.h"

namespace fs = std::filesystem;

namespace {

std::string DefaultWebRoot() {
  std::error_code ec;
  const fs::path exe = fs::read_symlink("/proc/self/exe", ec);
  for (fs::path dir = exe.parent_path(); !ec && !dir.empty() && dir != dir.root_path();
       dir = dir.parent_path()) {
    if (fs::exists(dir / "web" / "static" / "index.html")) return (dir / "web" / "static").string();
  }
  return "web/static";
}

// The HTTP layer's options from the server configuration (docs/http.md).
km::api::HttpOptions HttpOptionsOf(const km::server::ServerConfig& cfg) {
  km::api::HttpOptions ho;
  ho.host = cfg.host;
  ho.port = cfg.port;
  // A little above the upload limit, so the service answers with its own precise 413.
  ho.max_payload_bytes = cfg.max_upload_bytes + (1u << 20);
  ho.header_timeout_s = cfg.header_timeout_s;
  ho.read_timeout_s = cfg.read_timeout_s;
  ho.write_timeout_s = cfg.write_timeout_s;
  ho.keep_alive_max_count = cfg.keep_alive_max_count;
  ho.keep_alive_timeout_s = cfg.keep_alive_timeout_s;
  ho.threads = cfg.threads;
  ho.io_threads = cfg.io_threads;
  ho.queue_limit = cfg.queue_limit;
  ho.max_connections = cfg.max_connections;
  ho.max_connections_per_client = cfg.max_connections_per_client;
  ho.backlog = cfg.backlog;
  ho.max_header_bytes = cfg.max_header_bytes;
  ho.cors_origins = cfg.cors_origins;
  ho.static_root = cfg.web_root.empty() ? DefaultWebRoot() : cfg.web_root;
  return ho;
}

// kinemetricd --reset-admin: a new admin token without expiry, for the operator with shell
// access to the server when no admin token is left (docs/operations.md). The server may run.
int ResetAdmin(km::server::Storage& storage) {
  const std::string token = km::server::NewRandomToken();
  const auto id = storage.AddToken(km::server::Sha256Hex(token), "admin",
                                   "recovery (kinemetricd --reset-admin)", std::nullopt);
  std::cout << "kinemetricd: new admin token " << id << " (shown once): " << token << std::endl;
  return 0;
}

}  // namespace

// Demo data on a fresh database (when configured), and the Modbus devices of the configuration.
static void LoadDemoDataAndDevices(km::server::Service& service,
                                   const km::server::ServerConfig& cfg) {
  if (cfg.demo_data && service.measurements().Machines().empty()) {
    int n = 0;
    for (const auto& f : km::server::DemoDbbFiles()) {
      service.measurements().Upload(f.bytes, f.name);
      ++n;
    }
    const auto positioning = km::server::DemoPositioningFile();
    service.measurements().Upload(positioning.bytes, positioning.name);
    ++n;
    const auto stream = km::server::LoadDemoStream(service.streams());
    std::cout << "kinemetricd: loaded " << n + 1 << " demo measurements and demo stream " << stream
              << std::endl;
  }

  service.streams().acquisition().SetLimits({cfg.max_devices, cfg.device_networks});
  if (!cfg.modbus_config.empty()) {
    service.streams().acquisition().StartFromFile(cfg.modbus_config);
    std::cout << "kinemetricd: acquiring from " << service.streams().acquisition().Devices().size()
              << " Modbus devices" << std::endl;
  }
}

int main(int argc, char** argv) {
  km::RetainFreedMemory();
  km::server::ServerConfig cfg;
  try {
    cfg = km::server::ParseServerArgs(std::vector<std::string>(argv + 1, argv + argc));
  } catch (const km::InvalidInput& e) {
    std::cerr
        << "kinemetricd: " << e.what() << "\n"
        << "usage: kinemetricd --listen HOST:PORT --data-dir DIR [--config FILE] "
           "[--web-root DIR] [--demo-data] [--reset-admin] [--threads N] [--max-upload-bytes N] "
           "[--database sqlite:|postgresql://USER@HOST:PORT/DB] [--db-pool-size N] "
           "[--modbus-config FILE] [--io-threads N] [--queue-limit N] [--max-connections N] "
           "[--header-timeout-s S] [--cors-origin ORIGIN] [--max-devices N] "
           "[--device-network CIDR] [--access-log FILE|-|off] [--metrics-public] "
           "[--shutdown-timeout-s S] [--job-workers N] [--job-lease-s S] … (docs/http.md, "
           "docs/operations.md)\n";
    return 2;
  }
  // SIGINT / SIGTERM are taken by a waiting thread that stops the server cleanly.
  sigset_t signals;
  sigemptyset(&signals);
  sigaddset(&signals, SIGINT);
  sigaddset(&signals, SIGTERM);
  pthread_sigmask(SIG_BLOCK, &signals, nullptr);
  try {
    km::server::PrepareDataDir(cfg.data_dir);
    auto storage = km::server::OpenStorage(cfg);
    if (cfg.reset_admin) return ResetAdmin(*storage);
    km::server::ServiceOptions so;
    so.max_upload_bytes = cfg.max_upload_bytes;
    km::server::ApplyUploadLimits(cfg, so.upload_limits);
    so.max_calibration_tests = cfg.max_calibration_tests;
    so.max_calibration_samples = cfg.max_calibration_samples;
    so.audits.webhook_url = cfg.audit_webhook_url;
    so.audits.webhook_attempts = cfg.audit_webhook_attempts;
    so.audits.webhook_first_delay_ms = cfg.audit_webhook_first_delay_ms;
    so.audits.webhook_secret = cfg.audit_webhook_secret;
    so.audits.webhook_timeout_s = cfg.audit_webhook_timeout_s;
    so.audits.webhook_allow_private = cfg.audit_webhook_allow_private;
    so.jobs.workers = cfg.job_workers;
    so.jobs.lease_ms = std::int64_t{cfg.job_lease_s} * 1000;
    so.jobs.max_queued = cfg.max_queued_jobs;
    km::server::Service service(std::move(storage), so);
    km::server::RegisterBuiltinKinds(service.measurements());

    const char* bootstrap = std::getenv("KINEMETRIC_BOOTSTRAP_TOKEN");
    const std::string generated = service.access().EnsureAdminToken(bootstrap ? bootstrap : "");
    if (!generated.empty()) {
      std::cout << "kinemetricd: first start; admin token (shown once): " << generated << std::endl;
    }
    if (bootstrap && *bootstrap && !service.access().TokenKnown(km::server::Sha256Hex(bootstrap))) {
      std::cout << "kinemetricd: KINEMETRIC_BOOTSTRAP_TOKEN is ignored: the database already has "
                   "tokens and this is not one of them (it is used only on the first start)"
                << std::endl;
    }
    LoadDemoDataAndDevices(service, cfg);

    km::api::Router router;
    km::api::AddRoutes(router, service);
    router.SetHook(km::api::TokenHook(service));
    router.SetObserver(km::api::AuditHook(service));
    // Scheduled accuracy audits (an audit missed while the server was down runs once now).
    service.audits().Start();
    if (cfg.metrics_public) router.SetRole("GET", "/metrics", km::server::Role::kPublic);
    km::api::AccessLog access_log(cfg.access_log);

    km::api::HttpOptions ho = HttpOptionsOf(cfg);
    if (access_log.enabled()) {
      ho.on_answer = [&access_log](const km::api::RequestRecord& r) { access_log.Write(r); };
    }
    km::api::HttpServer http(router, ho);
    const int port = http.Bind();
    std::atomic<bool> serving{true};
    std::thread waiter(
        [&http, &service, &serving, signals, grace = cfg.shutdown_timeout_s]() mutable {
          int sig = 0;
          sigwait(&signals, &sig);
          if (!serving.load()) return;
          std::cout << "kinemetricd: stopping (" << (sig == SIGINT ? "SIGINT" : "SIGTERM")
                    << "): no new connections, waiting up to " << grace << " s for "
                    << http.InFlight() << " requests in flight" << std::endl;
          // Reports being made give up a second before the deadline, so their requests are answered
          // (503) within it; waiting and new ones are refused now.
          service.reports().Stop(std::chrono::steady_clock::now() +
                                 std::chrono::milliseconds(std::max(0, grace * 1000 - 1000)));
          const auto left = http.Shutdown(std::chrono::seconds(grace));
          if (left > 0) {
            std::cout << "kinemetricd: " << left << " requests were still in flight after " << grace
                      << " s; closing them" << std::endl;
          }
        });
    std::cout << "kinemetricd: listening on http://" << cfg.host << ":" << port << "/ (data in "
              << km::server::DescribeDatabase(cfg) << ")" << std::endl;
    http.Serve();
    // Serve returned: stopped by a signal, or by an error. Wake the waiter if needed.
    serving = false;
    pthread_kill(waiter.native_handle(), SIGTERM);
    waiter.join();
    service.audits().Stop();
    std::cout << "kinemetricd: stopped" << std::endl;
    return 0;
  } catch (const km::InvalidInput& e) {
    std::cerr << "kinemetricd: " << e.what() << "\n";
    return 2;
  } catch (const std::exception& e) {
    std::cerr << "kinemetricd: error: " << e.what() << "\n";
    return 1;
  }
}
