// A PostgreSQL server for storage tests: the server of KINEMETRIC_TEST_DATABASE (a
// postgresql:// URL) when set, else a private cluster started once per test process with
// tests/tools/pg_cluster.sh and stopped when the process ends. Each test gets a fresh database.
// When no server can be had the test is skipped, except under KINEMETRIC_CI=1, where that is a
// failure.
#pragma once

#include <string>

namespace km::server::test {

// A new, empty database (CREATE DATABASE with a unique name): its URL; empty when there is no
// server (the caller skips; a failure is recorded under KINEMETRIC_CI=1).
std::string FreshDatabaseUrl();

// Runs SQL on the database of url (libpq, no parameters); the error message, empty when it
// succeeded.
std::string ExecSql(const std::string& url, const std::string& sql);
// The first column of the first row of a query ("" when none).
std::string QueryValue(const std::string& url, const std::string& sql);

// Whether the server is the private cluster of this process (it can be stopped and restarted).
bool OwnCluster();
// pg_cluster.sh pause / resume / restart of the private cluster.
void StopServer();
void StartServer();
void RestartServer();

}  // namespace km::server::test
