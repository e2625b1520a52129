// Stored result documents parsed once. The answers of a measurement's results (the most asked
// query of the dashboards) parse the stored text every time; this keeps the parsed documents,
// keyed by their text: the same text always parses to the same document, so an entry can never
// be stale (nothing to invalidate when results are added, and nothing another instance on the
// same database can change). Bounded by the bytes of text it holds, the least recently used
// dropped first; a document larger than a tenth of the bound is parsed and not kept.
#pragma once

#include <cstddef>
#include <list>
#include <memory>
#include <mutex>
#include <string>
#include <unordered_map>

#include <nlohmann/json.hpp>

namespace km::server {

class ParsedResults {
 public:
  explicit ParsedResults(std::size_t max_text_bytes = 8u << 20) : max_bytes_(max_text_bytes) {}
  ParsedResults(const ParsedResults&) = delete;
  ParsedResults& operator=(const ParsedResults&) = delete;

  // The stored result document `text`, parsed as ingest::ParseJsonText parses a stored document
  // (its errors thrown as they are, nothing kept then).
  std::shared_ptr<const nlohmann::json> Parse(const std::string& text);

  std::size_t size() const;        // documents kept
  std::size_t text_bytes() const;  // bytes of their texts

 private:
  using Lru = std::list<const std::string*>;  // the entries' keys, the most recently used first
  struct Entry {
    std::shared_ptr<const nlohmann::json> document;
    Lru::iterator at;
  };
  void Keep(const std::string& text, std::shared_ptr<const nlohmann::json> document);

  const std::size_t max_bytes_;
  mutable std::mutex mu_;
  Lru lru_;
  std::unordered_map<std::string, Entry> entries_;
  std::size_t bytes_ = 0;
};

}  // namespace km::server
