#include "server/storage/open_storage.h"

#include <algorithm>
#include <filesystem>

#include "analysis/core/errors.h"
#include "server/base/data_dir.h"
#include "server/base/database_url.h"
#include "server/storage/pg/pg_storage.h"
#include "server/storage/sqlite/sqlite_storage.h"

namespace km::server {
namespace {

bool IsPostgres(const std::string& url) {
  return url.rfind("postgresql://", 0) == 0 || url.rfind("postgres://", 0) == 0;
}

std::string SqlitePath(const ServerConfig& cfg) {
  return (std::filesystem::path(cfg.data_dir) / "kinemetric.db").string();
}

}  // namespace

std::unique_ptr<Storage> OpenStorage(const ServerConfig& cfg) {
  if (IsPostgres(cfg.database)) {
    PgOptions o;
    o.busy_timeout_ms = cfg.db_busy_timeout_ms;
    o.pool_size = cfg.db_pool_size;
    o.statement_timeout_ms = cfg.db_statement_timeout_ms;
    return std::make_unique<PgStorage>(cfg.database, o);
  }
  if (!cfg.database.empty() && cfg.database != "sqlite:") {
    throw InvalidInput("", 0, "database",
                       "'" + MaskPassword(cfg.database).substr(0, 80) +
                           "' is not a database: use sqlite: or postgresql://…");
  }
  PrepareDataDir(cfg.data_dir);
  SqliteOptions o;
  o.busy_timeout_ms = cfg.db_busy_timeout_ms;
  return std::make_unique<SqliteStorage>(SqlitePath(cfg), o);
}

std::string DescribeDatabase(const ServerConfig& cfg) {
  if (IsPostgres(cfg.database)) return "PostgreSQL " + MaskPassword(cfg.database);
  return "SQLite " + SqlitePath(cfg);
}

}  // namespace km::server
