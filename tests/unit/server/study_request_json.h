// Study requests written as JSON in the tests, submitted the way the API does: parsed where they
// enter (server/jobs/study_requests.h), then handed to the study service.
#pragma once

#include <cstdint>

#include <nlohmann/json.hpp>

#include "server/jobs/study_requests.h"
#include "server/service.h"

namespace km::test {

inline std::int64_t SubmitCalibrationJson(server::Service& service, const nlohmann::json& body,
                                          std::int64_t owner_token_id = 0) {
  return service.studies().SubmitCalibration(server::CalibrationRequest::Parse(body),
                                             owner_token_id);
}

inline std::int64_t SubmitDiscoveryJson(server::Service& service, const nlohmann::json& body,
                                        std::int64_t owner_token_id = 0) {
  return service.studies().SubmitDiscovery(server::DiscoveryRequest::Parse(body), owner_token_id);
}

}  // namespace km::test
