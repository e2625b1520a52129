#include "tests/unit/server/pg_test_server.h"

#include <gtest/gtest.h>
#include <libpq-fe.h>
#include <unistd.h>

#include <array>
#include <cstdio>
#include <cstdlib>
#include <memory>
#include <mutex>
#include <optional>
#include <stdexcept>
#include <vector>

namespace km::server::test {
namespace {

const std::string kScript = std::string(KINEMETRIC_SOURCE_DIR) + "/tests/tools/pg_cluster.sh";

// Runs a shell command; its standard output, nullopt when it failed.
std::optional<std::string> Run(const std::string& cmd) {
  std::unique_ptr<FILE, int (*)(FILE*)> p(::popen(cmd.c_str(), "r"), ::pclose);
  if (!p) return std::nullopt;
  std::string out;
  std::array<char, 256> buf{};
  while (std::fgets(buf.data(), buf.size(), p.get())) out += buf.data();
  if (::pclose(p.release()) != 0) return std::nullopt;
  while (!out.empty() && (out.back() == '\n' || out.back() == ' ')) out.pop_back();
  return out;
}

struct Server {
  std::string url;  // of the server's "postgres" (or given) database
  std::string dir;  // the private cluster's directory; empty when the server is given
  std::string error;
  std::vector<std::string> databases;  // made on a given server: dropped at the end

  Server() {
    if (const char* given = std::getenv("KINEMETRIC_TEST_DATABASE"); given && *given) {
      url = given;
      return;
    }
    char tmpl[] = "/tmp/km-pgtest-XXXXXX";
    if (!::mkdtemp(tmpl)) {
      error = "cannot make a temporary directory";
      return;
    }
    dir = tmpl;
    const auto out =
        Run("sh " + kScript + " start " + dir + " --watch " + std::to_string(::getpid()));
    if (!out || out->rfind("postgresql://", 0) != 0) {
      error = "tests/tools/pg_cluster.sh could not start a PostgreSQL cluster";
      return;
    }
    url = *out;
  }
  ~Server() {
    for (const auto& db : databases)
      ExecSql(url, "DROP DATABASE IF EXISTS " + db + " WITH (FORCE)");
    if (!dir.empty()) {
      Run("sh " + kScript + " stop " + dir + " >/dev/null 2>&1");
      Run("rm -rf " + dir);
    }
  }
};

Server& TheServer() {
  static Server server;
  return server;
}

// The URL of another database on the same server.
std::string WithDatabase(const std::string& url, const std::string& db) {
  const auto start = url.find("://") + 3;
  const auto slash = url.find('/', start);
  const auto query = url.find('?', start);
  const std::string params = query == std::string::npos ? "" : url.substr(query);
  const auto host_end = slash != std::string::npos ? slash : query;
  return url.substr(0, host_end == std::string::npos ? url.size() : host_end) + "/" + db + params;
}

}  // namespace

std::string ExecSql(const std::string& url, const std::string& sql) {
  PGconn* c = PQconnectdb(url.c_str());
  std::string err;
  if (PQstatus(c) != CONNECTION_OK) {
    err = PQerrorMessage(c);
  } else {
    PQsetNoticeProcessor(
        c, [](void*, const char*) {}, nullptr);
    PGresult* r = PQexec(c, sql.c_str());
    const auto st = PQresultStatus(r);
    if (st != PGRES_COMMAND_OK && st != PGRES_TUPLES_OK) err = PQresultErrorMessage(r);
    PQclear(r);
  }
  PQfinish(c);
  return err;
}

std::string QueryValue(const std::string& url, const std::string& sql) {
  PGconn* c = PQconnectdb(url.c_str());
  std::string out;
  if (PQstatus(c) == CONNECTION_OK) {
    PGresult* r = PQexec(c, sql.c_str());
    if (PQresultStatus(r) == PGRES_TUPLES_OK && PQntuples(r) > 0) out = PQgetvalue(r, 0, 0);
    PQclear(r);
  }
  PQfinish(c);
  return out;
}

std::string FreshDatabaseUrl() {
  static std::mutex mu;
  static int counter = 0;
  std::lock_guard lock(mu);
  Server& s = TheServer();
  const char* ci = std::getenv("KINEMETRIC_CI");
  const bool must = ci && std::string(ci) == "1";
  if (s.url.empty()) {
    if (must) ADD_FAILURE() << "no PostgreSQL server: " << s.error;
    return "";
  }
  const std::string name =
      "km_test_" + std::to_string(::getpid()) + "_" + std::to_string(++counter);
  const std::string err = ExecSql(s.url, "CREATE DATABASE " + name);
  if (!err.empty()) {
    ADD_FAILURE() << "CREATE DATABASE " << name << ": " << err;
    return "";
  }
  if (s.dir.empty()) s.databases.push_back(name);
  return WithDatabase(s.url, name);
}

bool OwnCluster() {
  return !TheServer().dir.empty() && !TheServer().url.empty();
}

void StopServer() {
  if (!Run("sh " + kScript + " pause " + TheServer().dir)) {
    throw std::runtime_error("pg_cluster.sh pause failed");
  }
}

void StartServer() {
  if (!Run("sh " + kScript + " resume " + TheServer().dir)) {
    throw std::runtime_error("pg_cluster.sh resume failed");
  }
}

void RestartServer() {
  if (!Run("sh " + kScript + " restart " + TheServer().dir)) {
    throw std::runtime_error("pg_cluster.sh restart failed");
  }
}

}  // namespace km::server::test
