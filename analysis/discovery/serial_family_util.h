// Small helpers shared by the discovery engine and the serial machine family's files: which
// effects are spikes or cyclic errors, an RMS, and one printf-style number for a step's text.
#pragma once

#include <cmath>
#include <cstdio>
#include <string>

#include <Eigen/Core>

#include "analysis/serial_effects/registry.h"

namespace km::discovery::util {

inline bool IsSpike(serial_effects::EffectId id) {
  return id == serial_effects::EffectId::kReversalSpikeU ||
         id == serial_effects::EffectId::kReversalSpikeV;
}

inline bool IsCyclic(serial_effects::EffectId id) {
  return id == serial_effects::EffectId::kCyclicErrorU ||
         id == serial_effects::EffectId::kCyclicErrorV;
}

inline double Rms(const Eigen::VectorXd& v) {
  return v.size() > 0 ? std::sqrt(v.squaredNorm() / static_cast<double>(v.size())) : 0.0;
}

// `fmt` holds one double conversion (e.g. "%.3g").
inline std::string Format(const char* fmt, double v) {
  char buf[64];
  std::snprintf(buf, sizeof buf, fmt, v);
  return buf;
}

}  // namespace km::discovery::util
