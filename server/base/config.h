// Server configuration: defaults, then the config file (JSON), then command-line options.
#pragma once

#include <cstddef>
#include <map>
#include <string>
#include <vector>

#include "ingest/text_format.h"

namespace km::server {

struct ServerConfig {
  std::string host = "127.0.0.1";
  int port = 8080;
  std::string data_dir = "./var";
  std::string web_root;    // empty: <repo>/web/static found next to the binary
  bool demo_data = false;  // load demo data when the database is empty
  // --reset-admin: add a new admin token to the database, print it and exit (recovery when
  // every admin token is lost; docs/operations.md).
  bool reset_admin = false;
  std::size_t max_upload_bytes = 32u << 20;
  // The HTTP layer (docs/http.md).
  int threads = 8;
  int io_threads = 1;
  std::size_t queue_limit = 64;  // requests waiting for a thread; more are refused
  std::size_t max_connections = 4096;
  std::size_t max_connections_per_client = 1024;
  int backlog = 1024;
  std::size_t max_header_bytes = 16u << 10;
  int header_timeout_s = 10;
  int read_timeout_s = 10;
  int write_timeout_s = 10;
  int keep_alive_max_count = 1000;
  int keep_alive_timeout_s = 5;
  // Uploads: per-format limits replacing the defaults (config key upload_limits:
  // {"kinemetric-dbb/1": {"max_rows": N, "max_line_bytes": N, "max_columns": N, "max_cells": N,
  // "max_header_lines": N, "max_markers": N}, …}; fields not given keep their defaults), and
  // hexapod calibration requests.
  std::map<std::string, std::map<std::string, std::size_t>> upload_limits;
  std::size_t max_calibration_tests = 500;
  std::size_t max_calibration_samples = 2'000'000;
  std::string modbus_config;  // Modbus TCP devices to acquire from (docs/modbus.md); empty: none
  // How long a database call waits for a lock held by another connection before the request
  // is answered 503 with Retry-After.
  int db_busy_timeout_ms = 5000;
  // The database (docs/operations.md): empty or "sqlite:" — the SQLite file kinemetric.db in
  // data_dir; "postgresql://USER[:PASSWORD]@HOST:PORT/DATABASE" (or postgres://…) — a PostgreSQL
  // database shared by several instances, with at most db_pool_size connections (1–1000).
  std::string database;
  int db_pool_size = 8;
  // PostgreSQL: the longest one statement may run (statement_timeout) before the request is
  // answered 503 with Retry-After; 0 (the default): no limit. SQLite: not applicable.
  int db_statement_timeout_ms = 0;
  // Access from other web origins (config key cors_origins: ["https://dash.example:8443"], option
  // --cors-origin ORIGIN, repeatable): only these get CORS headers; default none.
  std::vector<std::string> cors_origins;
  // Modbus devices added through the API (server/streams/acquisition.h DeviceLimits): at most
  // max_devices (0–10 000) running, hosts within device_networks (config key: a list of CIDR
  // ranges replacing the default; option --device-network CIDR adds one).
  std::size_t max_devices = 16;
  std::vector<std::string> device_networks = {"127.0.0.0/8", "::1/128"};
  // Accuracy audits (docs/http.md): verdicts of level 2 and 3 are POSTed to
  // audit_webhook_url (http:// only; empty: none), retried after audit_webhook_first_delay_ms,
  // then twice, four times as long…, up to audit_webhook_attempts attempts in all; each attempt
  // ends after audit_webhook_timeout_s in all. A target in a loopback or private range (written
  // as such or resolved to one) is refused unless audit_webhook_allow_private
  // (--audit-webhook-allow-private).
  std::string audit_webhook_url;
  int audit_webhook_attempts = 5;
  int audit_webhook_first_delay_ms = 1000;
  int audit_webhook_timeout_s = 5;
  bool audit_webhook_allow_private = false;
  // Key of the deliveries' X-Kinemetric-Signature (HMAC-SHA256; 16–1024 bytes): config key
  // audit_webhook_secret, else the environment variable KINEMETRIC_AUDIT_WEBHOOK_SECRET (kept
  // off the command line, where other users of the host could read it). Empty: unsigned.
  std::string audit_webhook_secret;
  // Operations (docs/operations.md): the access log ("-": stderr, "off": none, else a file
  // appended to), GET /metrics without a token (default: viewer), and how long a stop (SIGTERM,
  // SIGINT) waits for the requests in flight.
  std::string access_log = "-";
  bool metrics_public = false;
  int shutdown_timeout_s = 10;
  // Background jobs (server/jobs/jobs.h), queued in the database for every instance on it: how many
  // this instance runs at once (0: none, an instance that only answers requests), how long a
  // running job stays this instance's without a renewal (an instance that died loses its jobs
  // to the others after this), and how many may wait in the queue.
  int job_workers = 1;
  int job_lease_s = 30;
  std::size_t max_queued_jobs = 16;
};

// Applies a JSON config file (// comments allowed): keys listen ("HOST:PORT"), data_dir, web_root,
// database, demo_data, modbus_config, access_log, metrics_public, the audit_webhook_* keys, and
// the whole numbers
// max_upload_bytes, threads, io_threads, queue_limit, max_connections,
// max_connections_per_client, backlog,
// max_header_bytes, header_timeout_s, read_timeout_s, write_timeout_s, keep_alive_max_count,
// keep_alive_timeout_s, db_busy_timeout_ms, db_pool_size, db_statement_timeout_ms,
// shutdown_timeout_s, job_workers,
// job_lease_s, max_queued_jobs (each also a command-line option, e.g. --header-timeout-s).
// Unknown keys are an error (typos are not ignored). Numbers must be whole and within range:
// threads 1–256, io_threads 1–64, queue_limit, keep_alive_max_count, max_connections and
// max_connections_per_client 1–1 000 000, backlog 1–65535, max_header_bytes 1 KiB–1 MiB, timeouts
// 1–3600 s, job_workers 0–64, max_queued_jobs 1–1 000 000, db_busy_timeout_ms 0–600 000 ms,
// db_pool_size 1–1000, db_statement_timeout_ms 0–3 600 000 ms, audit_webhook_timeout_s 1–300 s,
// max_upload_bytes 1 B–4 GiB, port 0–65535 (0: any free port); data_dir must not be empty;
// database empty, sqlite: or a postgresql:// URL. Anything else is km::InvalidInput naming the
// option or key.
void ApplyConfigFile(ServerConfig& cfg, const std::string& path);
// Applies "HOST:PORT".
void ApplyListen(ServerConfig& cfg, const std::string& listen, const std::string& where);
// Applies the upload_limits overrides of a config onto per-format limits.
void ApplyUploadLimits(const ServerConfig& cfg, std::map<std::string, ingest::TextLimits>& limits);
// Parses argv (after the program name); throws km::InvalidInput on a bad option, and on a
// webhook URL whose host is a loopback or private address without audit_webhook_allow_private
// (naming the option, or the config file and its key).
ServerConfig ParseServerArgs(const std::vector<std::string>& args);

}  // namespace km::server
