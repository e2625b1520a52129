// Starts a real kinemetricd on a free loopback port with its own data directory, and stops it.
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

class ServerProcess {
 public:
  ServerProcess(const std::string& binary, const std::string& data_dir, const std::string& token,
                const std::string& extra_args = "") {
    int fds[2];
    if (pipe(fds) != 0) throw std::runtime_error("pipe");
    pid_ = fork();
    if (pid_ == 0) {
      dup2(fds[1], STDOUT_FILENO);
      close(fds[0]);
      close(fds[1]);
      setenv("KINEMETRIC_BOOTSTRAP_TOKEN", token.c_str(), 1);
      const std::string cmd = "exec '" + binary + "' --listen 127.0.0.1:0 --data-dir '" + data_dir +
                              "' --threads 4 " + extra_args;
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
