// JSON text read one way everywhere — request bodies, machine files, stream lines and documents
// read back from storage. Besides the syntax, a document is refused (km::InvalidInput naming
// the file, the line and the field as a path such as `effects[0].params`) when
//   - arrays and objects nest deeper than `max_depth` (a deep document would exhaust the stack
//     of any recursive reader later: a copy, a comparison, a dump);
//   - an object repeats a key (the last one would silently win: {"role":"viewer","role":"admin"});
//   - a number does not fit a double (1e999).
// The parser itself is iterative, so no input can exhaust the stack while it is read.
#pragma once

#include <cstddef>
#include <string>
#include <string_view>

#include <nlohmann/json.hpp>

namespace km::ingest {

// Deep enough for every document the product defines (the deepest, a machine with effects,
// nests 4 levels), shallow enough for any recursive reader.
inline constexpr std::size_t kMaxJsonDepth = 64;

struct JsonTextLimits {
  std::size_t max_depth = kMaxJsonDepth;
};

// Parses `text` as one JSON document; `file` names it in errors ("request", a file name, …).
nlohmann::json ParseJsonText(std::string_view text, const std::string& file,
                             JsonTextLimits limits = {});

// A document read back from storage or from a peer where a broken one is skipped, not an error:
// the document, or a discarded value (is_discarded()) when ParseJsonText would refuse it.
nlohmann::json ParseJsonTextOrDiscarded(std::string_view text);

}  // namespace km::ingest
