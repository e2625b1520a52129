#include "server/base/config.h"

#include <charconv>
#include <cmath>
#include <cstdint>
#include <cstdlib>
#include <fstream>
#include <sstream>

#include <nlohmann/json.hpp>

#include "analysis/core/errors.h"
#include "ingest/file_formats.h"
#include "server/base/database_url.h"
#include "server/base/net_ranges.h"
#include "server/base/webhook_url.h"

namespace km::server {
namespace {

// Ranges of the numeric settings; one table for the command line and the config file.
struct Range {
  std::int64_t lo, hi;
  const char* unit;
};
constexpr Range kThreads{1, 256, ""};
constexpr Range kQueueLimit{1, 1'000'000, ""};
constexpr Range kTimeout{1, 3600, " s"};
constexpr Range kKeepAliveCount{1, 1'000'000, ""};
constexpr Range kUploadBytes{1, std::int64_t{4} << 30, " bytes"};  // 4 GiB
constexpr Range kIoThreads{1, 64, ""};
constexpr Range kConnections{1, 1'000'000, ""};
constexpr Range kBacklog{1, 65535, ""};
constexpr Range kHeaderBytes{1024, 1 << 20, " bytes"};
constexpr Range kCount{1, std::int64_t{1} << 40, ""};
constexpr Range kBusyTimeout{0, 600'000, " ms"};
constexpr Range kDevices{0, 10'000, ""};
constexpr Range kWebhookAttempts{1, 20, ""};
constexpr Range kWebhookDelay{10, 600'000, " ms"};
constexpr Range kWebhookTimeout{1, 300, " s"};
constexpr Range kPoolSize{1, 1000, ""};
constexpr Range kStatementTimeout{0, 3'600'000, " ms"};
constexpr Range kJobWorkers{0, 64, ""};

// Every whole-number setting: its config-file key (the command-line option is "--" + key with
// '-' for '_'), its range and where it goes.
struct NumberOption {
  const char* key;
  Range range;
  void (*set)(ServerConfig&, std::int64_t);
};
const NumberOption kNumberOptions[] = {
    {"max_upload_bytes", kUploadBytes,
     [](ServerConfig& c, std::int64_t v) { c.max_upload_bytes = static_cast<std::size_t>(v); }},
    {"threads", kThreads, [](ServerConfig& c, std::int64_t v) { c.threads = static_cast<int>(v); }},
    {"io_threads", kIoThreads,
     [](ServerConfig& c, std::int64_t v) { c.io_threads = static_cast<int>(v); }},
    {"queue_limit", kQueueLimit,
     [](ServerConfig& c, std::int64_t v) { c.queue_limit = static_cast<std::size_t>(v); }},
    {"max_connections", kConnections,
     [](ServerConfig& c, std::int64_t v) { c.max_connections = static_cast<std::size_t>(v); }},
    {"max_connections_per_client", kConnections,
     [](ServerConfig& c, std::int64_t v) {
       c.max_connections_per_client = static_cast<std::size_t>(v);
     }},
    {"backlog", kBacklog, [](ServerConfig& c, std::int64_t v) { c.backlog = static_cast<int>(v); }},
    {"max_header_bytes", kHeaderBytes,
     [](ServerConfig& c, std::int64_t v) { c.max_header_bytes = static_cast<std::size_t>(v); }},
    {"header_timeout_s", kTimeout,
     [](ServerConfig& c, std::int64_t v) { c.header_timeout_s = static_cast<int>(v); }},
    {"read_timeout_s", kTimeout,
     [](ServerConfig& c, std::int64_t v) { c.read_timeout_s = static_cast<int>(v); }},
    {"write_timeout_s", kTimeout,
     [](ServerConfig& c, std::int64_t v) { c.write_timeout_s = static_cast<int>(v); }},
    {"keep_alive_max_count", kKeepAliveCount,
     [](ServerConfig& c, std::int64_t v) { c.keep_alive_max_count = static_cast<int>(v); }},
    {"max_calibration_tests", kCount,
     [](ServerConfig& c, std::int64_t v) {
       c.max_calibration_tests = static_cast<std::size_t>(v);
     }},
    {"max_calibration_samples", kCount,
     [](ServerConfig& c, std::int64_t v) {
       c.max_calibration_samples = static_cast<std::size_t>(v);
     }},
    {"keep_alive_timeout_s", kTimeout,
     [](ServerConfig& c, std::int64_t v) { c.keep_alive_timeout_s = static_cast<int>(v); }},
    {"db_busy_timeout_ms", kBusyTimeout,
     [](ServerConfig& c, std::int64_t v) { c.db_busy_timeout_ms = static_cast<int>(v); }},
    {"db_pool_size", kPoolSize,
     [](ServerConfig& c, std::int64_t v) { c.db_pool_size = static_cast<int>(v); }},
    {"db_statement_timeout_ms", kStatementTimeout,
     [](ServerConfig& c, std::int64_t v) { c.db_statement_timeout_ms = static_cast<int>(v); }},
    {"audit_webhook_attempts", kWebhookAttempts,
     [](ServerConfig& c, std::int64_t v) { c.audit_webhook_attempts = static_cast<int>(v); }},
    {"audit_webhook_first_delay_ms", kWebhookDelay,
     [](ServerConfig& c, std::int64_t v) { c.audit_webhook_first_delay_ms = static_cast<int>(v); }},
    {"audit_webhook_timeout_s", kWebhookTimeout,
     [](ServerConfig& c, std::int64_t v) { c.audit_webhook_timeout_s = static_cast<int>(v); }},
    {"max_devices", kDevices,
     [](ServerConfig& c, std::int64_t v) { c.max_devices = static_cast<std::size_t>(v); }},
    {"shutdown_timeout_s", kTimeout,
     [](ServerConfig& c, std::int64_t v) { c.shutdown_timeout_s = static_cast<int>(v); }},
    {"job_workers", kJobWorkers,
     [](ServerConfig& c, std::int64_t v) { c.job_workers = static_cast<int>(v); }},
    {"job_lease_s", kTimeout,
     [](ServerConfig& c, std::int64_t v) { c.job_lease_s = static_cast<int>(v); }},
    {"max_queued_jobs", kQueueLimit,
     [](ServerConfig& c, std::int64_t v) { c.max_queued_jobs = static_cast<std::size_t>(v); }},
};

const NumberOption* FindNumberOption(const std::string& key) {
  for (const auto& o : kNumberOptions) {
    if (key == o.key) return &o;
  }
  return nullptr;
}

// The database: empty or "sqlite:" (the SQLite file in the data directory), or a PostgreSQL URL.
// The message of a refused one shows no password.
std::string DatabaseUrl(const std::string& url, const std::string& where,
                        const std::string& field) {
  if (url.empty() || url == "sqlite:" || url.rfind("postgresql://", 0) == 0 ||
      url.rfind("postgres://", 0) == 0) {
    return url;
  }
  throw InvalidInput(where, 0, field,
                     "'" + MaskPassword(url).substr(0, 80) +
                         "' is not a database: use sqlite: (the default, a file in the data "
                         "directory) or postgresql://USER@HOST:PORT/DATABASE");
}

// "--max-upload-bytes" → "max_upload_bytes"; empty when not an option.
std::string KeyOfFlag(const std::string& flag) {
  if (flag.rfind("--", 0) != 0 || flag.find('_') != std::string::npos) return {};
  std::string key = flag.substr(2);
  for (auto& c : key) c = c == '-' ? '_' : c;
  return key;
}

std::string RangeText(const Range& r) {
  return "a whole number from " + std::to_string(r.lo) + " to " + std::to_string(r.hi) + r.unit;
}

// A whole number written in decimal digits (an optional leading '-'), nothing else.
std::int64_t WholeFromText(const std::string& text, const Range& r, const std::string& where,
                           const std::string& field) {
  std::int64_t v = 0;
  const char* end = text.data() + text.size();
  const auto [ptr, ec] = std::from_chars(text.data(), end, v);
  if (text.empty() || ec != std::errc() || ptr != end || v < r.lo || v > r.hi) {
    throw InvalidInput(where, 0, field, "'" + text.substr(0, 40) + "' is not " + RangeText(r));
  }
  return v;
}

// A JSON number that is a whole number within the range (4 and 4.0 both are).
std::int64_t WholeFromJson(const nlohmann::json& v, const Range& r, const std::string& where,
                           const std::string& field) {
  bool ok = false;
  std::int64_t out = 0;
  if (v.is_number_unsigned()) {
    const auto u = v.get<std::uint64_t>();
    ok = u <= static_cast<std::uint64_t>(r.hi);
    out = ok ? static_cast<std::int64_t>(u) : 0;
  } else if (v.is_number_integer()) {
    out = v.get<std::int64_t>();
    ok = true;
  } else if (v.is_number_float()) {
    const double d = v.get<double>();
    ok = std::isfinite(d) && std::floor(d) == d && d >= static_cast<double>(r.lo) &&
         d <= static_cast<double>(r.hi);
    out = ok ? static_cast<std::int64_t>(d) : 0;
  }
  if (!ok || out < r.lo || out > r.hi) {
    throw InvalidInput(where, 0, field, v.dump().substr(0, 40) + " is not " + RangeText(r));
  }
  return out;
}

// The fields of one format's upload limits, by config name.
std::size_t ingest::TextLimits::*LimitField(const std::string& name) {
  if (name == "max_rows") return &ingest::TextLimits::max_rows;
  if (name == "max_line_bytes") return &ingest::TextLimits::max_line_bytes;
  if (name == "max_columns") return &ingest::TextLimits::max_columns;
  if (name == "max_cells") return &ingest::TextLimits::max_cells;
  if (name == "max_header_lines") return &ingest::TextLimits::max_header_lines;
  if (name == "max_markers") return &ingest::TextLimits::max_markers;
  return nullptr;
}

bool IsFileFormat(const std::string& name) {
  for (const auto& f : ingest::FileFormats()) {
    if (f.name == name) return true;
  }
  return false;
}

void ReadUploadLimits(ServerConfig& cfg, const nlohmann::json& v, const std::string& path) {
  if (!v.is_object()) {
    throw InvalidInput(path, 0, "upload_limits", "must be an object of formats");
  }
  for (const auto& [format, fields] : v.items()) {
    const std::string where = "upload_limits." + format;
    if (!IsFileFormat(format)) {
      throw InvalidInput(path, 0, where, "not a file format; known: " + ingest::KnownFormats());
    }
    if (!fields.is_object()) throw InvalidInput(path, 0, where, "expected {limits}");
    for (const auto& [name, n] : fields.items()) {
      if (!LimitField(name)) throw InvalidInput(path, 0, where + "." + name, "unknown limit");
      cfg.upload_limits[format][name] =
          static_cast<std::size_t>(WholeFromJson(n, kCount, path, where + "." + name));
    }
  }
}

// A web origin: "http://host[:port]" or "https://host[:port]", nothing after.
std::string Origin(const std::string& v, const std::string& where, const std::string& field) {
  const auto scheme = v.find("://");
  const std::string rest = scheme == std::string::npos ? "" : v.substr(scheme + 3);
  const std::string s = scheme == std::string::npos ? "" : v.substr(0, scheme);
  if ((s != "http" && s != "https") || rest.empty() ||
      rest.find_first_of("/?#*@ ") != std::string::npos) {
    throw InvalidInput(where, 0, field,
                       "'" + v.substr(0, 80) + "' is not a web origin (http[s]://host[:port])");
  }
  return v;
}

std::string Cidr(const std::string& v, const std::string& where, const std::string& field) {
  if (!ParseNetwork(v)) {
    throw InvalidInput(where, 0, field,
                       "'" + v.substr(0, 80) + "' is not an address range (e.g. 10.0.0.0/24)");
  }
  return v;
}

std::vector<std::string> StringList(const nlohmann::json& v, const std::string& where,
                                    const std::string& key,
                                    std::string (*check)(const std::string&, const std::string&,
                                                         const std::string&)) {
  if (!v.is_array()) throw InvalidInput(where, 0, key, "must be a list of strings");
  std::vector<std::string> out;
  for (std::size_t i = 0; i < v.size(); ++i) {
    const std::string field = key + "[" + std::to_string(i) + "]";
    if (!v[i].is_string()) throw InvalidInput(where, 0, field, "must be a string");
    out.push_back(check(v[i].get<std::string>(), where, field));
  }
  return out;
}

std::string NonEmpty(const std::string& v, const std::string& where, const std::string& field) {
  if (v.empty()) throw InvalidInput(where, 0, field, "must not be empty");
  return v;
}

// check(value, field) for a value of the configuration file `path`; its error names the file.
void CheckInFile(const std::string& path, void (*check)(const std::string&, const std::string&),
                 const std::string& value, const std::string& field) {
  InFile(path, [&] { check(value, field); });
}

// The secret from the environment when the config has none, and the URL's host checked
// against the loopback and private ranges once audit_webhook_allow_private is known; url_file
// and url_field say where the URL was set.
void FinishAuditWebhook(ServerConfig& cfg, const std::string& url_file,
                        const std::string& url_field) {
  const char* secret = std::getenv("KINEMETRIC_AUDIT_WEBHOOK_SECRET");
  if (cfg.audit_webhook_secret.empty() && secret != nullptr && *secret != '\0') {
    cfg.audit_webhook_secret = secret;
    CheckWebhookSecret(cfg.audit_webhook_secret, "KINEMETRIC_AUDIT_WEBHOOK_SECRET");
  }
  if (!cfg.audit_webhook_url.empty()) {
    CheckWebhookTarget(cfg.audit_webhook_url, cfg.audit_webhook_allow_private, url_file, url_field);
  }
}

}  // namespace

void ApplyListen(ServerConfig& cfg, const std::string& listen, const std::string& where) {
  const auto colon = listen.rfind(':');
  if (colon == std::string::npos || colon == 0) {
    throw InvalidInput(where, 0, "listen", "expected HOST:PORT, got '" + listen + "'");
  }
  const std::string digits = listen.substr(colon + 1);
  int port = 0;
  const char* end = digits.data() + digits.size();
  const auto [ptr, ec] = std::from_chars(digits.data(), end, port);
  if (digits.empty() || digits[0] == '-' || ec != std::errc() || ptr != end) {
    throw InvalidInput(where, 0, "listen", "bad port in '" + listen + "'");
  }
  if (port < 0 || port > 65535) {
    throw InvalidInput(where, 0, "listen", "port out of range (0 to 65535; 0: any free port)");
  }
  cfg.host = listen.substr(0, colon);
  if (cfg.host.size() > 2 && cfg.host.front() == '[' && cfg.host.back() == ']') {
    cfg.host = cfg.host.substr(1, cfg.host.size() - 2);
  }
  cfg.port = port;
}

void ApplyConfigFile(ServerConfig& cfg, const std::string& path) {
  std::ifstream in(path);
  if (!in) throw InvalidInput(path, 0, "", "cannot open the config file");
  nlohmann::json j;
  try {
    j = nlohmann::json::parse(in, nullptr, true, /*ignore_comments=*/true);
  } catch (const nlohmann::json::parse_error& e) {
    throw InvalidInput(path, 0, "", std::string("not valid JSON: ") + e.what());
  }
  if (!j.is_object()) throw InvalidInput(path, 0, "", "the config file must be a JSON object");
  for (const auto& [key, v] : j.items()) {
    try {
      if (key == "listen") {
        ApplyListen(cfg, v.get<std::string>(), path);
      } else if (key == "data_dir") {
        cfg.data_dir = NonEmpty(v.get<std::string>(), path, key);
      } else if (key == "web_root") {
        cfg.web_root = v.get<std::string>();
      } else if (key == "demo_data") {
        cfg.demo_data = v.get<bool>();
      } else if (key == "access_log") {
        cfg.access_log = v.get<std::string>();
      } else if (key == "metrics_public") {
        cfg.metrics_public = v.get<bool>();
      } else if (key == "database") {
        cfg.database = DatabaseUrl(v.get<std::string>(), path, key);
      } else if (key == "audit_webhook_url") {
        cfg.audit_webhook_url = v.get<std::string>();
        if (!cfg.audit_webhook_url.empty())
          CheckInFile(path, CheckWebhookUrl, cfg.audit_webhook_url, key);
      } else if (key == "audit_webhook_allow_private") {
        cfg.audit_webhook_allow_private = v.get<bool>();
      } else if (key == "audit_webhook_secret") {
        cfg.audit_webhook_secret = v.get<std::string>();
        if (!cfg.audit_webhook_secret.empty())
          CheckInFile(path, CheckWebhookSecret, cfg.audit_webhook_secret, key);
      } else if (const auto* o = FindNumberOption(key)) {
        o->set(cfg, WholeFromJson(v, o->range, path, key));
      } else if (key == "upload_limits") {
        ReadUploadLimits(cfg, v, path);
      } else if (key == "modbus_config") {
        cfg.modbus_config = v.get<std::string>();
      } else if (key == "cors_origins") {
        cfg.cors_origins = StringList(v, path, key, Origin);
      } else if (key == "device_networks") {
        cfg.device_networks = StringList(v, path, key, Cidr);
      } else {
        throw InvalidInput(path, 0, key, "unknown configuration key");
      }
    } catch (const nlohmann::json::exception& e) {
      throw InvalidInput(path, 0, key, std::string("wrong type: ") + e.what());
    }
  }
}

void ApplyUploadLimits(const ServerConfig& cfg, std::map<std::string, ingest::TextLimits>& limits) {
  for (const auto& [format, fields] : cfg.upload_limits) {
    auto& l = limits[format];
    for (const auto& [name, n] : fields) l.*LimitField(name) = n;
  }
}

ServerConfig ParseServerArgs(const std::vector<std::string>& args) {
  ServerConfig cfg;
  // The config file first, so that command-line options override it.
  std::string url_file, url_field;  // where audit_webhook_url was set last
  for (std::size_t i = 0; i + 1 < args.size(); ++i) {
    if (args[i] != "--config") continue;
    const std::string before = cfg.audit_webhook_url;
    ApplyConfigFile(cfg, args[i + 1]);
    if (cfg.audit_webhook_url != before) {
      url_file = args[i + 1];
      url_field = "audit_webhook_url";
    }
  }
  for (std::size_t i = 0; i < args.size(); ++i) {
    const std::string& a = args[i];
    auto value = [&]() -> std::string {
      if (i + 1 >= args.size()) throw InvalidInput("", 0, a, "option needs a value");
      return args[++i];
    };
    if (a == "--listen") {
      const std::string v = value();
      try {
        ApplyListen(cfg, v, "");
      } catch (const InvalidInput& e) {
        throw InvalidInput("", 0, a, e.reason());
      }
    } else if (a == "--data-dir") {
      cfg.data_dir = NonEmpty(value(), "", a);
    } else if (a == "--config") {
      value();
    } else if (a == "--web-root") {
      cfg.web_root = value();
    } else if (a == "--modbus-config") {
      cfg.modbus_config = value();
    } else if (a == "--cors-origin") {
      cfg.cors_origins.push_back(Origin(value(), "", a));
    } else if (a == "--device-network") {
      cfg.device_networks.push_back(Cidr(value(), "", a));
    } else if (a == "--demo-data") {
      cfg.demo_data = true;
    } else if (a == "--reset-admin") {
      cfg.reset_admin = true;
    } else if (a == "--access-log") {
      cfg.access_log = value();
    } else if (a == "--metrics-public") {
      cfg.metrics_public = true;
    } else if (a == "--database") {
      cfg.database = DatabaseUrl(value(), "", a);
    } else if (a == "--audit-webhook-url") {
      cfg.audit_webhook_url = value();
      if (!cfg.audit_webhook_url.empty()) CheckWebhookUrl(cfg.audit_webhook_url, a);
      url_file.clear();
      url_field = a;
    } else if (a == "--audit-webhook-allow-private") {
      cfg.audit_webhook_allow_private = true;
    } else if (const auto* o = FindNumberOption(KeyOfFlag(a))) {
      o->set(cfg, WholeFromText(value(), o->range, "", a));
    } else {
      throw InvalidInput("", 0, a, "unknown option");
    }
  }
  FinishAuditWebhook(cfg, url_file, url_field);
  return cfg;
}

}  // namespace km::server
