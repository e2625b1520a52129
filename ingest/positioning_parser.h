// Parser of the laser positioning file `# format: kinemetric-positioning/1` (docs/formats.md
// §1.8), built on the generic reader of ingest/text_format.h.
//
// Header: machine_id, axis (X, Y, Z, U, V, W), cycle (linear | pendulum | step), datum_mm (where
// the laser was zeroed), air_compensated (yes | no); with `no` also air_temperature_c,
// air_pressure_pa, air_humidity_pct and laser_wavelength_nm (checked against the range of the
// refractive-index equation, analysis/positioning/air.h); optional timestamp, and
// material_temperature_c with expansion_ppm_per_k (both or neither), and the optional standard
// uncertainties u_laser_ppm, u_air_* (raw readings only: refused with air_compensated: yes),
// u_material_temperature_c and u_expansion_ppm_per_k (refused without the material correction),
// kept in `metadata` (usecases/positioning_report.h reads them). Columns
// run,direction,target_mm,measured_mm or run,direction,target_mm,deviation_um, rows in the order
// measured; `direction` is `+` (motion towards larger coordinates) or `-`; `run` an integer.
// Every error is a km::InvalidInput naming file, line and field. The per-target checks (both
// directions, runs of equal length, every target in every run) are made where the readings are
// evaluated (km::positioning::EvaluatePositioning), with the same naming.
#pragma once

#include <map>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "analysis/positioning/air.h"
#include "analysis/positioning/figures.h"
#include "ingest/text_format.h"

namespace km::ingest {

inline constexpr std::string_view kPositioningFormat = "kinemetric-positioning/1";

struct PositioningFile {
  std::string file;  // name used in messages
  std::string machine_id;
  std::string axis;  // upper case
  std::string timestamp;
  std::string cycle;         // linear | pendulum | step
  std::string value_column;  // measured_mm | deviation_um
  std::map<std::string, std::string> metadata;
  // datum, air (when air_compensated is no) and material temperature, as the file gives them.
  positioning::CorrectionSettings corrections;
  bool air_compensated = true;
  // In file order; deviation_um is the reading as recorded minus the target (no correction yet).
  std::vector<positioning::Reading> readings;
};

// 1 000 000 readings, lines of 4 KiB, 16 columns.
TextLimits DefaultPositioningLimits();

PositioningFile ParsePositioningFile(std::string_view bytes, const std::string& file,
                                     const TextLimits& limits = DefaultPositioningLimits());

}  // namespace km::ingest
