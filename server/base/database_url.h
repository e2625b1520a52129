// Database URLs as the log and error messages show them.
#pragma once

#include <string>

namespace km::server {

// The URL with its password (user:PASSWORD@…, or a password=… parameter) replaced by "***".
std::string MaskPassword(const std::string& url);

}  // namespace km::server
