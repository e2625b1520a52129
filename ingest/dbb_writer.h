// Writer of `kinemetric-dbb/1` DBB circular-test files (docs/formats.md §1.1) from a
// km::dbb::DbbTest. Columns `angle_deg,dr_um`; angle with 9 decimals, dr_um with 6 decimals
// (lossless at 1e-6 µm), header numbers with up to 17 significant digits. Metadata keys that are
// not standard header keys are written back as extra header lines.
#pragma once

#include <string>

#include "analysis/dbb/dbb_types.h"

namespace km::ingest {

// Throws km::InvalidInput when angle_deg and dr_um differ in length or a value is not finite.
std::string WriteDbb(const dbb::DbbTest& test);

}  // namespace km::ingest
