// A small Modbus TCP server for the acquisition tests, built on libmodbus:
//   km_modbus_test_server --port P      (P = 0: any free port)
// Prints "listening <port>" on stdout once bound, then serves any number of clients (poll()).
// Holding and input registers 0..199 hold modbus_pattern.h's Entries(); registers 100..101
// count milliseconds since start and 102..103 the requests served (uint32, ABCD), refreshed
// before every reply. Other addresses are answered with ILLEGAL DATA ADDRESS.
#include <modbus/modbus.h>
#include <netinet/in.h>
#include <poll.h>
#include <sys/socket.h>
#include <unistd.h>

#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <string>
#include <vector>

#include "tests/integration/modbus/modbus_pattern.h"

namespace mp = km::test::modbus_pattern;

namespace {

void PutU32(std::uint16_t* regs, std::uint32_t address, std::uint32_t v) {
  regs[address] = static_cast<std::uint16_t>(v >> 16);
  regs[address + 1] = static_cast<std::uint16_t>(v & 0xFFFF);
}

}  // namespace

int main(int argc, char** argv) {
  int port = -1;
  for (int i = 1; i + 1 < argc; i += 2) {
    if (std::strcmp(argv[i], "--port") == 0) port = std::atoi(argv[i + 1]);
  }
  if (port < 0 || port > 65535) {
    std::fprintf(stderr, "usage: km_modbus_test_server --port P\n");
    return 2;
  }
  modbus_t* ctx = modbus_new_tcp("127.0.0.1", port);
  modbus_mapping_t* map = modbus_mapping_new(0, 0, mp::kMappedRegisters, mp::kMappedRegisters);
  if (!ctx || !map) {
    std::fprintf(stderr, "libmodbus: %s\n", modbus_strerror(errno));
    return 1;
  }
  for (const mp::Entry& e : mp::Entries()) {
    const std::vector<std::uint16_t> w = mp::WireWords(e);
    for (std::size_t r = 0; r < w.size(); ++r) {
      map->tab_registers[e.address + r] = w[r];
      map->tab_input_registers[e.address + r] = w[r];
    }
  }
  const int listener = modbus_tcp_listen(ctx, 32);
  if (listener < 0) {
    std::fprintf(stderr, "listen: %s\n", modbus_strerror(errno));
    return 1;
  }
  sockaddr_in addr{};
  socklen_t len = sizeof addr;
  getsockname(listener, reinterpret_cast<sockaddr*>(&addr), &len);
  std::printf("listening %d\n", ntohs(addr.sin_port));
  std::fflush(stdout);

  const auto start = std::chrono::steady_clock::now();
  std::uint32_t requests = 0;
  std::vector<pollfd> fds = {{listener, POLLIN, 0}};
  std::vector<std::uint8_t> query(MODBUS_TCP_MAX_ADU_LENGTH);
  while (true) {
    if (poll(fds.data(), fds.size(), -1) < 0) {
      if (errno == EINTR) continue;
      return 1;
    }
    if (fds[0].revents & POLLIN) {
      const int client = accept(listener, nullptr, nullptr);
      if (client >= 0) fds.push_back({client, POLLIN, 0});
    }
    for (std::size_t i = 1; i < fds.size();) {
      if (fds[i].revents == 0) {
        ++i;
        continue;
      }
      modbus_set_socket(ctx, fds[i].fd);
      const int rc = modbus_receive(ctx, query.data());
      if (rc > 0) {
        const auto ms = std::chrono::duration_cast<std::chrono::milliseconds>(
                            std::chrono::steady_clock::now() - start)
                            .count();
        ++requests;
        for (std::uint16_t* regs : {map->tab_registers, map->tab_input_registers}) {
          PutU32(regs, mp::kMillisAddress, static_cast<std::uint32_t>(ms));
          PutU32(regs, mp::kRequestsAddress, requests);
        }
        modbus_reply(ctx, query.data(), rc, map);
      } else if (rc == -1) {
        close(fds[i].fd);
        fds.erase(fds.begin() + static_cast<std::ptrdiff_t>(i));
        continue;
      }
      fds[i].revents = 0;
      ++i;
    }
  }
}
