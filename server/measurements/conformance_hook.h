// How the measurement service has a measurement judged against its machine's tolerances without
// knowing them: the service that keeps the tolerance tables (server/tolerances/) gives a
// factory of judges, wired in server/service.cpp. A judge serves one answer (an upload, one
// measurement, one page of the list) and may keep each machine's newest table for as long as
// it lives, so a page of one machine reads its table once.
#pragma once

#include <functional>
#include <string>

#include <nlohmann/json.hpp>

namespace km::server {

// The set-up a measurement was made in.
struct ConformanceSubject {
  std::string machine_id, kind, test_id, direction;
};

// The measurement's conformance from its own result (docs/http.md "Tolerances and
// conformance"); the result is null when the measurement has none.
using ConformanceJudge =
    std::function<nlohmann::json(const ConformanceSubject& subject, const nlohmann::json& result)>;
using ConformanceJudges = std::function<ConformanceJudge()>;

}  // namespace km::server
