// Starts a real kinemetricd on a free loopback port with its own data directory (and its own
// PostgreSQL database when KINEMETRIC_TEST_DATABASE is set), and stops it.
#pragma once

#include <signal.h>
#include <sys/wait.h>
#include <unistd.h>

#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <stdexcept>
#include <string>
#include <thread>

#include <httplib.h>

namespace km::test {

// The bytes of a file (a fixture, an example), empty when it cannot be read.
inline std::string ReadFileText(const std::string& path) {
  FILE* f = std::fopen(path.c_str(), "rb");
  std::string out;
  char buf[4096];
  std::size_t n = 0;
  while (f && (n = std::fread(buf, 1, sizeof buf, f)) > 0) out.append(buf, n);
  if (f) std::fclose(f);
  return out;
}

// The PostgreSQL database of a test server's data directory when KINEMETRIC_TEST_DATABASE names
// a PostgreSQL server (tests/tools/test_database.sh creates it; the tests run from the source
// directory); empty otherwise: the server keeps its SQLite file in the data directory.
inline std::string DatabaseUrl(const std::string& data_dir) {
  if (!std::getenv("KINEMETRIC_TEST_DATABASE")) return "";
  const std::string cmd = "tests/tools/test_database.sh '" + data_dir + "'";
  FILE* p = popen(cmd.c_str(), "r");
  if (!p) throw std::runtime_error("cannot run " + cmd);
  std::string url;
  char buf[512];
  while (std::fgets(buf, sizeof buf, p)) url += buf;
  if (pclose(p) != 0 || url.empty()) throw std::runtime_error(cmd + " failed");
  while (!url.empty() && (url.back() == '\n' || url.back() == '\r')) url.pop_back();
  return url;
}

inline std::string DatabaseArgs(const std::string& data_dir) {
  const std::string url = DatabaseUrl(data_dir);
  return url.empty() ? "" : " --database '" + url + "'";
}

// Whether the test servers keep their data in PostgreSQL (KINEMETRIC_TEST_DATABASE).
inline bool OnPostgresql() {
  return std::getenv("KINEMETRIC_TEST_DATABASE") != nullptr;
}

// Runs SQL on the PostgreSQL database of a data directory (psql); true when it succeeded.
inline bool RunPostgresql(const std::string& data_dir, const std::string& sql) {
  const std::string cmd =
      "psql -q -v ON_ERROR_STOP=1 -d '" + DatabaseUrl(data_dir) + "' -c \"" + sql + "\" >/dev/null";
  return std::system(cmd.c_str()) == 0;
}

class ServerProcess {
 public:
  ServerProcess(const std::string& binary, const std::string& data_dir, const std::string& token,
                const std::string& extra_args = "") {
    const std::string database = DatabaseArgs(data_dir);
    int fds[2];
    if (pipe(fds) != 0) throw std::runtime_error("pipe");
    pid_ = fork();
    if (pid_ == 0) {
      dup2(fds[1], STDOUT_FILENO);
      close(fds[0]);
      close(fds[1]);
      setenv("KINEMETRIC_BOOTSTRAP_TOKEN", token.c_str(), 1);
      const std::string cmd = "exec '" + binary + "' --listen 127.0.0.1:0 --data-dir '" + data_dir +
                              "' --threads 4" + database + " " + extra_args;
      execl("/bin/sh", "sh", "-c", cmd.c_str(), static_cast<char*>(nullptr));
      _exit(127);
    }
    close(fds[1]);
    out_ = fdopen(fds[0], "r");
    // The server prints "listening on http://127.0.0.1:PORT/ …" once it has bound.
    char line[512];
    while (std::fgets(line, sizeof line, out_)) {
      const std::string s = line;
      const auto at = s.find("listening on http://127.0.0.1:");
      if (at != std::string::npos) {
        port_ = std::stoi(s.substr(at + std::string("listening on http://127.0.0.1:").size()));
        break;
      }
    }
    if (port_ <= 0) {
      Stop();
      throw std::runtime_error("kinemetricd did not start");
    }
    // Drain the rest of stdout in the background so the server never blocks on a full pipe.
    drain_ = std::thread([f = out_] {
      char buf[512];
      while (std::fgets(buf, sizeof buf, f)) {
      }
    });
    httplib::Client c("127.0.0.1", port_);
    for (int i = 0; i < 100; ++i) {
      if (auto r = c.Get("/healthz"); r && r->status == 200) return;
      std::this_thread::sleep_for(std::chrono::milliseconds(50));
    }
    Stop();
    throw std::runtime_error("kinemetricd is not healthy");
  }
  ~ServerProcess() { Stop(); }

  int port() const { return port_; }

  // SIGTERM and wait; returns the exit status.
  int Stop() {
    int status = -1;
    if (pid_ > 0) {
      kill(pid_, SIGTERM);
      waitpid(pid_, &status, 0);
      pid_ = -1;
    }
    if (drain_.joinable()) drain_.join();
    if (out_) {
      std::fclose(out_);
      out_ = nullptr;
    }
    return status;
  }

 private:
  pid_t pid_ = -1;
  int port_ = 0;
  FILE* out_ = nullptr;
  std::thread drain_;
};

}  // namespace km::test
