// Parser of `kinemetric-dbb/1` DBB circular-test files (contract §1.1). Strict: every error is
// a km::InvalidInput naming the file, the line and the field; nothing is guessed.
#pragma once

#include <string>
#include <string_view>

#include "analysis/dbb/dbb_types.h"

namespace km::ingest {

inline constexpr const char* kDbbFormat = "kinemetric-dbb/1";

struct DbbParseOptions {
  std::size_t max_bytes = 32u << 20;
  std::size_t max_samples = 2'000'000;
};

dbb::DbbTest ParseDbb(std::string_view bytes, const std::string& file,
                      const DbbParseOptions& options = {});

}  // namespace km::ingest
