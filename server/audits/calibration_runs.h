// The hexapod calibrations of a machine as audits (kind "calibration") and trends read them:
// the machine's finished calibration jobs, newest first, each with the one before it.
#pragma once

#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "server/audits/accuracy_audit.h"
#include "server/audits/audit_source.h"

namespace km::server {

// At most this many of the newest jobs are looked through for a machine's calibrations.
inline constexpr std::int64_t kCalibrationJobScan = 500;

// A hexapod calibration an audit (kind "calibration") and a trend take as evidence.
struct CalibrationRun {
  JobId job_id;
  std::string finished_at;  // the job's updated_at
  std::int64_t at = 0;      // the same, Unix seconds
  nlohmann::json result;    // the job's result (docs/formats.md §5)
  nlohmann::json previous;  // the result of the machine's calibration before it; null for none
};

// The machine's calibrations: done hexapod_calibration jobs whose request names the machine
// (machine_id) and whose verdict is not "failed" (server/jobs/jobs.h), newest first by when they
// finished, among the newest kCalibrationJobScan jobs.
std::vector<CalibrationRun> MachineCalibrations(AuditSource& service,
                                                const std::string& machine_id);
// A metric of kind "calibration" at one calibration; nullopt when it does not hold it (the
// change metric: also the oldest calibration, which has none before it).
std::optional<double> CalibrationMetricValue(const AuditMetric& metric, const CalibrationRun& run);

}  // namespace km::server
