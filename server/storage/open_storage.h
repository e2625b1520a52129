// The storage backend of a configuration: the embedded SQLite file (the default) or a
// PostgreSQL database shared by several instances (ServerConfig::database).
#pragma once

#include <memory>
#include <string>

#include "server/base/config.h"
#include "server/storage/storage.h"

namespace km::server {

// Empty or "sqlite:": SqliteStorage on <data_dir>/kinemetric.db (the data directory is made
// first); "postgresql://…" or "postgres://…": PgStorage with db_pool_size connections. Both
// wait db_busy_timeout_ms for locks. Anything else: km::InvalidInput naming the option.
std::unique_ptr<Storage> OpenStorage(const ServerConfig& cfg);

// Where the data is, for the log: "SQLite <path>" or the URL without its password.
std::string DescribeDatabase(const ServerConfig& cfg);

}  // namespace km::server
