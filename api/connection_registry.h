// Who holds the server's connections, so that no client can shut the others out (docs/http.md,
// "Connections"). Every open connection is registered with its client's address; a connection
// that waits for a request's headers (a new connection, an idle keep-alive one, or a client
// sending its headers slowly) is "waiting" and may be closed to make room for a newcomer:
//   - a client address that holds `max_per_client` connections gets a new one only by giving up
//     its own oldest waiting connection;
//   - when the server holds `max_total`, the newcomer takes the place of the oldest waiting
//     connection of the address that holds the most connections.
// A newcomer is refused (503) only when every connection it could replace is busy with a
// request. A request under way is never cut off for a newcomer.
#pragma once

#include <cstddef>
#include <cstdint>
#include <functional>
#include <map>
#include <mutex>
#include <string>
#include <unordered_map>

namespace km::api {

class ConnectionRegistry {
 public:
  using Evict = std::function<void()>;

  // Whether a new connection from `address` may be served; when room had to be made, the
  // connection chosen to leave is told (its Evict runs, outside the registry's lock).
  bool Admit(const std::string& address, std::size_t max_total, std::size_t max_per_client);

  // A served connection from `address`; its id for the calls below.
  std::uint64_t Open(const std::string& address);
  // The connection ended (also after it was evicted).
  void Close(std::uint64_t id);
  // The connection waits for a request's headers; `evict` closes it (from any thread).
  void Waiting(std::uint64_t id, Evict evict);
  // The connection's headers arrived: it may no longer be chosen to leave.
  void Busy(std::uint64_t id);

  std::size_t Total() const;
  std::size_t OfAddress(const std::string& address) const;

 private:
  struct Connection {
    std::string address;
    bool waiting = false;
    std::uint64_t waiting_since = 0;  // order of entering the waiting state
    Evict evict;
  };
  // The oldest waiting connection of `address` (any address when empty), or 0.
  std::uint64_t OldestWaiting(const std::string* address) const;
  std::uint64_t VictimForTotal() const;

  mutable std::mutex mu_;
  std::unordered_map<std::uint64_t, Connection> connections_;
  std::map<std::string, std::size_t> per_address_;
  std::uint64_t next_id_ = 1;
  std::uint64_t next_wait_ = 1;
};

}  // namespace km::api
