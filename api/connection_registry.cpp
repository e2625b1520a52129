#include "api/connection_registry.h"

#include <utility>

namespace km::api {

bool ConnectionRegistry::Admit(const std::string& address, std::size_t max_total,
                               std::size_t max_per_client) {
  Evict evict;
  {
    std::lock_guard lock(mu_);
    const auto it = per_address_.find(address);
    const std::size_t mine = it == per_address_.end() ? 0 : it->second;
    std::uint64_t victim = 0;
    if (mine >= max_per_client) {
      victim = OldestWaiting(&address);
    } else if (connections_.size() >= max_total) {
      victim = VictimForTotal();
    } else {
      return true;
    }
    if (victim == 0) return false;
    auto& c = connections_.at(victim);
    c.waiting = false;  // chosen once
    evict = std::move(c.evict);
  }
  if (evict) evict();
  return true;
}

std::uint64_t ConnectionRegistry::Open(const std::string& address) {
  std::lock_guard lock(mu_);
  const std::uint64_t id = next_id_++;
  connections_[id].address = address;
  ++per_address_[address];
  return id;
}

void ConnectionRegistry::Close(std::uint64_t id) {
  std::lock_guard lock(mu_);
  const auto it = connections_.find(id);
  if (it == connections_.end()) return;
  const auto a = per_address_.find(it->second.address);
  if (a != per_address_.end() && --a->second == 0) per_address_.erase(a);
  connections_.erase(it);
}

void ConnectionRegistry::Waiting(std::uint64_t id, Evict evict) {
  std::lock_guard lock(mu_);
  const auto it = connections_.find(id);
  if (it == connections_.end()) return;
  it->second.waiting = true;
  it->second.waiting_since = next_wait_++;
  it->second.evict = std::move(evict);
}

void ConnectionRegistry::Busy(std::uint64_t id) {
  std::lock_guard lock(mu_);
  const auto it = connections_.find(id);
  if (it == connections_.end()) return;
  it->second.waiting = false;
  it->second.evict = nullptr;
}

std::size_t ConnectionRegistry::Total() const {
  std::lock_guard lock(mu_);
  return connections_.size();
}

std::size_t ConnectionRegistry::OfAddress(const std::string& address) const {
  std::lock_guard lock(mu_);
  const auto it = per_address_.find(address);
  return it == per_address_.end() ? 0 : it->second;
}

std::uint64_t ConnectionRegistry::OldestWaiting(const std::string* address) const {
  std::uint64_t best = 0, since = 0;
  for (const auto& [id, c] : connections_) {
    if (!c.waiting || (address && c.address != *address)) continue;
    if (best == 0 || c.waiting_since < since) {
      best = id;
      since = c.waiting_since;
    }
  }
  return best;
}

// The oldest waiting connection of the address holding the most connections (of those that
// have a waiting one).
std::uint64_t ConnectionRegistry::VictimForTotal() const {
  std::uint64_t best = 0, since = 0;
  std::size_t best_count = 0;
  for (const auto& [id, c] : connections_) {
    if (!c.waiting) continue;
    const std::size_t count = per_address_.at(c.address);
    if (best == 0 || count > best_count || (count == best_count && c.waiting_since < since)) {
      best = id;
      since = c.waiting_since;
      best_count = count;
    }
  }
  return best;
}

}  // namespace km::api
