// Angle units. Angles are carried in radians inside the analysis; a file, a report or a
// caller's option may give degrees, converted with this one factor.
#pragma once

#include <numbers>

namespace km {

inline constexpr double kDeg = std::numbers::pi / 180.0;  // radians per degree

}  // namespace km
