// Study requests written as JSON in the tests, submitted the way the API does: parsed where they
// enter (server/jobs/study_requests.h), then handed to the study service.
#pragma once

#include <cstdint>

#include <nlohmann/json.hpp>

#include "server/jobs/study_requests.h"
#include "server/service.h"

namespace km::test {

inline server::JobId SubmitCalibrationJson(
    server::Service& service, const nlohmann::json& body,
    std::optional<server::TokenId> owner_token_id = std::nullopt) {
  return service.studies().SubmitCalibration(server::CalibrationRequest::Parse(body),
                                             owner_token_id);
}

inline server::JobId SubmitDiscoveryJson(
    server::Service& service, const nlohmann::json& body,
    std::optional<server::TokenId> owner_token_id = std::nullopt) {
  return service.studies().SubmitDiscovery(server::DiscoveryRequest::Parse(body), owner_token_id);
}

}  // namespace km::test
