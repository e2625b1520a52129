#include "server/measurements/parsed_results.h"

#include "ingest/json_text.h"

namespace km::server {

std::shared_ptr<const nlohmann::json> ParsedResults::Parse(const std::string& text) {
  {
    std::lock_guard lock(mu_);
    if (const auto it = entries_.find(text); it != entries_.end()) {
      lru_.splice(lru_.begin(), lru_, it->second.at);
      return it->second.document;
    }
  }
  auto document = std::make_shared<const nlohmann::json>(
      ingest::ParseJsonText(text, "stored document"));  // outside the lock: the slow part
  if (text.size() <= max_bytes_ / 10) Keep(text, document);
  return document;
}

void ParsedResults::Keep(const std::string& text, std::shared_ptr<const nlohmann::json> document) {
  std::lock_guard lock(mu_);
  if (entries_.count(text)) return;  // another thread parsed it meanwhile
  const auto it = entries_.emplace(text, Entry{std::move(document), {}}).first;
  lru_.push_front(&it->first);  // a key's address holds while its entry is in the map
  it->second.at = lru_.begin();
  bytes_ += text.size();
  while (bytes_ > max_bytes_ && !lru_.empty()) {
    const std::string* oldest = lru_.back();
    bytes_ -= oldest->size();
    lru_.pop_back();
    entries_.erase(entries_.find(*oldest));
  }
}

std::size_t ParsedResults::size() const {
  std::lock_guard lock(mu_);
  return entries_.size();
}

std::size_t ParsedResults::text_bytes() const {
  std::lock_guard lock(mu_);
  return bytes_;
}

}  // namespace km::server
