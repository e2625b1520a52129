// The bodies of the study requests (POST /api/v1/calibrations, POST /api/v1/discoveries; a
// queued job's stored plan is the same JSON), parsed into types where they enter the service:
// each field's JSON type and range is checked here, and an error names the field (file
// "request"). What needs the stored records (the tests exist, are DBB tests of one machine, the
// stored model exists, the limits of a study) is checked by StudyService.
#pragma once

#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "analysis/hexapod/calibration.h"
#include "server/models/model_service.h"

namespace km::server {

struct CalibrationRequest {
  // Exactly one: a hexapod machine definition given inline (docs/formats.md §2), or a stored
  // model ("machine_id", "machine_version").
  std::optional<nlohmann::json> machine;
  std::optional<ModelRef> model;
  std::vector<std::int64_t> measurement_ids;  // DBB tests, whole numbers from 1
  // "absolute" | "centre-corrected"; unset: absolute when every test has its fixed ball.
  std::optional<hexapod::CalibrationMethod> method;
  std::optional<int> reduction_study_min_tests;  // 1 to 1000 ([PM-600 report] §5.2.3)
  std::optional<int> max_samples_per_test;       // 0 to 10 000 000 (0: every sample)
  std::vector<std::string> effects;  // hexapod effects fitted with the kinematics, each once

  static CalibrationRequest Parse(const nlohmann::json& body);
  nlohmann::json ToJson() const;  // the fields given, as Parse reads them
};

struct DiscoveryRequest {
  std::optional<ModelRef> model;  // none: the serial study of the tests' machine
  std::vector<std::int64_t> measurement_ids;
  std::optional<int> max_samples_per_test;

  static DiscoveryRequest Parse(const nlohmann::json& body);
  nlohmann::json ToJson() const;
};

}  // namespace km::server
