// Child processes and sockets for the Modbus acquisition tests: a server process started with
// fork/exec (killed in the destructor, so a failing test never leaks one), a free loopback
// port, a silent TCP listener that accepts connections but never answers, and one that
// accepts and drops every connection.
#pragma once

#include <arpa/inet.h>
#include <netinet/in.h>
#include <poll.h>
#include <signal.h>
#include <sys/socket.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cstdio>
#include <fstream>
#include <memory>
#include <random>
#include <stdexcept>
#include <string>
#include <thread>
#include <vector>

namespace km::test {

// Binds a loopback socket to port 0 and returns the port the kernel chose (then closes it).
inline int FreeLoopbackPort() {
  const int fd = socket(AF_INET, SOCK_STREAM, 0);
  sockaddr_in a{};
  a.sin_family = AF_INET;
  a.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
  a.sin_port = 0;
  if (fd < 0 || bind(fd, reinterpret_cast<sockaddr*>(&a), sizeof a) != 0) {
    throw std::runtime_error("cannot bind a loopback socket");
  }
  socklen_t len = sizeof a;
  getsockname(fd, reinterpret_cast<sockaddr*>(&a), &len);
  close(fd);
  return ntohs(a.sin_port);
}

// True once a TCP connection to 127.0.0.1:port succeeds (polls until `timeout`).
inline bool WaitForListener(int port, std::chrono::milliseconds timeout) {
  const auto end = std::chrono::steady_clock::now() + timeout;
  while (std::chrono::steady_clock::now() < end) {
    const int fd = socket(AF_INET, SOCK_STREAM, 0);
    sockaddr_in a{};
    a.sin_family = AF_INET;
    a.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
    a.sin_port = htons(static_cast<std::uint16_t>(port));
    const bool ok = connect(fd, reinterpret_cast<sockaddr*>(&a), sizeof a) == 0;
    close(fd);
    if (ok) return true;
    std::this_thread::sleep_for(std::chrono::milliseconds(50));
  }
  return false;
}

class ChildProcess {
 public:
  // Starts argv[0] with its stdout on a pipe.
  explicit ChildProcess(const std::vector<std::string>& argv) {
    int fds[2];
    if (pipe(fds) != 0) throw std::runtime_error("pipe");
    pid_ = fork();
    if (pid_ < 0) throw std::runtime_error("fork");
    if (pid_ == 0) {
      dup2(fds[1], STDOUT_FILENO);
      close(fds[0]);
      close(fds[1]);
      std::vector<char*> args;
      for (const std::string& a : argv) args.push_back(const_cast<char*>(a.c_str()));
      args.push_back(nullptr);
      execv(args[0], args.data());
      _exit(127);
    }
    close(fds[1]);
    out_ = fdopen(fds[0], "r");
  }
  ~ChildProcess() { Kill(SIGKILL); }
  ChildProcess(const ChildProcess&) = delete;
  ChildProcess& operator=(const ChildProcess&) = delete;

  // The next line of the child's stdout ("" at end of file).
  std::string ReadLine() {
    char line[256];
    if (!out_ || !std::fgets(line, sizeof line, out_)) return "";
    return line;
  }

  void Kill(int sig) {
    if (pid_ > 0) {
      kill(pid_, sig);
      int status = 0;
      waitpid(pid_, &status, 0);
      pid_ = -1;
    }
    if (out_) {
      std::fclose(out_);
      out_ = nullptr;
    }
  }

 private:
  pid_t pid_ = -1;
  std::FILE* out_ = nullptr;
};

// A libmodbus test server (km_modbus_test_server) on `port` (0: any); port() after start.
class TestServer {
 public:
  TestServer(const std::string& binary, int port)
      : child_({binary, "--port", std::to_string(port)}) {
    const std::string line = child_.ReadLine();
    if (line.rfind("listening ", 0) != 0) throw std::runtime_error("test server did not start");
    port_ = std::stoi(line.substr(10));
  }
  int port() const { return port_; }
  void Kill() { child_.Kill(SIGKILL); }

  // A server on a free port below the kernel's ephemeral range, for a test that kills it and
  // starts it again on the same port: a port the kernel hands out (to another test's listener,
  // or as the source port of a connection) could be taken while the server is down.
  static std::unique_ptr<TestServer> BelowEphemeralRange(const std::string& binary) {
    int low = 32768;
    std::ifstream("/proc/sys/net/ipv4/ip_local_port_range") >> low;
    std::mt19937 pick(std::random_device{}());
    std::uniform_int_distribution<int> ports(std::min(10000, low - 1), low - 1);
    for (int attempt = 0; attempt < 50; ++attempt) {
      try {
        return std::make_unique<TestServer>(binary, ports(pick));
      } catch (const std::runtime_error&) {  // taken: another port
      }
    }
    throw std::runtime_error("no free port below the ephemeral range");
  }

 private:
  ChildProcess child_;
  int port_ = 0;
};

// Accepts TCP connections (the kernel completes them from the backlog) and never reads or
// answers: every Modbus request times out.
class SilentListener {
 public:
  SilentListener() {
    fd_ = socket(AF_INET, SOCK_STREAM, 0);
    sockaddr_in a{};
    a.sin_family = AF_INET;
    a.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
    if (fd_ < 0 || bind(fd_, reinterpret_cast<sockaddr*>(&a), sizeof a) != 0 ||
        listen(fd_, 128) != 0) {
      throw std::runtime_error("cannot listen");
    }
    socklen_t len = sizeof a;
    getsockname(fd_, reinterpret_cast<sockaddr*>(&a), &len);
    port_ = ntohs(a.sin_port);
  }
  ~SilentListener() { close(fd_); }
  int port() const { return port_; }
  int fd() const { return fd_; }

 private:
  int fd_ = -1;
  int port_ = 0;
};

// Accepts every connection and closes it at once (a device that drops its clients).
class ResettingListener {
 public:
  ResettingListener() : port_(listener_.port()) {
    thread_ = std::thread([this] {
      while (!stop_) {
        pollfd p{listener_.fd(), POLLIN, 0};
        if (poll(&p, 1, 20) > 0) {
          const int c = accept(listener_.fd(), nullptr, nullptr);
          if (c >= 0) {
            ++accepted_;
            close(c);
          }
        }
      }
    });
  }
  ~ResettingListener() {
    stop_ = true;
    thread_.join();
  }
  int port() const { return port_; }
  int accepted() const { return accepted_; }

 private:
  SilentListener listener_;
  int port_;
  std::atomic<bool> stop_{false};
  std::atomic<int> accepted_{0};
  std::thread thread_;
};

}  // namespace km::test
