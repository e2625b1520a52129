// The text of a JSON answer (HTTP bodies, kept answers): compact, and invalid UTF-8 from clients
// or old rows replaced by U+FFFD instead of thrown.
#pragma once

#include <string>

#include <nlohmann/json.hpp>

namespace km::server {

std::string AnswerText(const nlohmann::json& j);

}  // namespace km::server
