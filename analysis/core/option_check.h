// One-line checks of an options struct, in the style of Ceres' OPTION_GT (solver.cc):
//
//   void CalibrationOptions::Check() const {
//     KM_OPTION_GE(max_iterations, 1);
//     KM_OPTION_GT(function_tolerance, 0.0);
//     KM_OPTION_IN_OPEN(rank_tolerance, 0.0, 1.0);
//   }
//
// Each throws km::InvalidInput whose field is the option's name and whose reason states the bound
// it breaks ("must be > 0.0"). A NaN breaks every bound.
#pragma once

#include <string>

#include "analysis/core/errors.h"

namespace km::internal {

inline void CheckOption(bool ok, const char* name, const std::string& reason) {
  if (!ok) throw InvalidInput("", 0, name, reason);
}

}  // namespace km::internal

#define KM_OPTION_GT(x, y) ::km::internal::CheckOption((x) > (y), #x, "must be > " #y)
#define KM_OPTION_GE(x, y) ::km::internal::CheckOption((x) >= (y), #x, "must be ≥ " #y)
#define KM_OPTION_LE(x, y) ::km::internal::CheckOption((x) <= (y), #x, "must be ≤ " #y)
#define KM_OPTION_IN_OPEN(x, lo, hi) \
  ::km::internal::CheckOption((x) > (lo) && (x) < (hi), #x, "must lie in (" #lo ", " #hi ")")
#define KM_OPTION_IN_HALF_OPEN(x, lo, hi) \
  ::km::internal::CheckOption((x) >= (lo) && (x) < (hi), #x, "must lie in [" #lo ", " #hi ")")
#define KM_OPTION_IN(x, lo, hi) \
  ::km::internal::CheckOption((x) >= (lo) && (x) <= (hi), #x, "must lie in [" #lo ", " #hi "]")
