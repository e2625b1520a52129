// Compensation tables a controller loads, from an analysed positioning file (docs/formats.md
// §3.15, docs/methods.md §15.5):
//   linuxcnc   LinuxCNC screw compensation, COMP_FILE_TYPE = 1 ([LinuxCNC docs], INI
//              configuration, [JOINT_n] COMP_FILE): one line `nominal forward-trim reverse-trim`
//              per target in machine units (mm), nominal ascending; a trim is added to the
//              commanded position, so trim = −(mean unidirectional deviation).
//   sinumerik  SINUMERIK 840D leadscrew error compensation ([SINUMERIK docs], LEC) as a part
//              program: $AA_ENC_COMP_STEP, _MIN, _MAX and $AA_ENC_COMP[0,N,AX1] in mm on an even
//              grid (uneven targets are interpolated onto it, said in a comment). The control
//              alters the actual value by the compensation value and "a positive compensation
//              value causes the machine axis to move in the negative direction": the value is
//              the mean bidirectional deviation x̄_i itself (+10 µm overshoot → +0.010).
//   csv        target_mm,forward_um,reverse_um,mean_bidirectional_um: the table of the JSON
//              result, one row per target.
#pragma once

#include <string>

#include "usecases/positioning_report.h"

namespace km::usecases {

std::string ExportLinuxCnc(const PositioningReport& report);
std::string ExportSinumerik(const PositioningReport& report);
std::string ExportCompensationCsv(const PositioningReport& report);

// `format` is linuxcnc, sinumerik or csv; anything else is km::InvalidInput naming `--format`.
std::string ExportCompensation(const PositioningReport& report, const std::string& format);

}  // namespace km::usecases
