// The server's data directory holds the database (measurements, token hashes): it is made
// readable by its owner only.
#pragma once

#include <string>

namespace km::server {

// Creates `path` (and missing parents) with mode 0700, or tightens an existing directory to
// 0700. Throws km::InvalidInput for an empty path and km::Error when `path` exists but is not a
// directory or cannot be created or changed.
void PrepareDataDir(const std::string& path);

}  // namespace km::server
