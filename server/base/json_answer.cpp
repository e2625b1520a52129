#include "server/base/json_answer.h"

namespace km::server {

std::string AnswerText(const nlohmann::json& j) {
  return j.dump(-1, ' ', false, nlohmann::json::error_handler_t::replace);
}

}  // namespace km::server
