// Linear positioning figures of a numerically controlled axis: ISO 230-2:2014 clause 2 and, as
// an extension, VDI/DGQ 3441 (docs/methods.md §15.3, §15.4).
//
// Readings: in run j the axis approaches each target P_i in the positive direction (↑, motion
// towards larger coordinates) and in the negative direction (↓); x_ij = P_ij − P_i is the
// positional deviation in µm. The cycle (linear, pendulum, step) only orders the readings; the
// figures depend on target, run and direction alone. With n runs and m targets ([ISO 230-2]
// 2.10 … 2.23):
//   x̄_i↑ = (1/n) Σ_j x_ij↑,            s_i↑ = sqrt( Σ_j (x_ij↑ − x̄_i↑)² / (n − 1) ), ↓ alike
//   B_i = x̄_i↑ − x̄_i↓,                 x̄_i = (x̄_i↑ + x̄_i↓) / 2
//   R_i↑ = 4 s_i↑, R_i↓ = 4 s_i↓,       R_i = max(2 s_i↑ + 2 s_i↓ + |B_i|, R_i↑, R_i↓)
//   B = max_i |B_i|,                    B̄ = (1/m) Σ_i B_i
//   R↑ = max_i R_i↑, R↓ = max_i R_i↓,   R = max_i R_i
//   E↑ = max_i x̄_i↑ − min_i x̄_i↑, E↓ alike,
//   E  = max(max_i x̄_i↑, max_i x̄_i↓) − min(min_i x̄_i↑, min_i x̄_i↓)
//   M  = max_i x̄_i − min_i x̄_i
//   A↑ = max_i (x̄_i↑ + 2 s_i↑) − min_i (x̄_i↑ − 2 s_i↑), A↓ alike,
//   A  = max over i and both directions of (x̄ + 2 s) − min over i and both directions of (x̄ − 2 s)
// R is bidirectional (it holds the reversal and both spreads) and E's minimum is taken over both
// directions, as the standard defines them.
//
// VDI/DGQ 3441 ([VDI/DGQ 3441]), per target: s̄_i = (s_i↑ + s_i↓) / 2, position scatter
// Ps_i = 6 s̄_i, reversal span U_i = |x̄_i↑ − x̄_i↓|; per axis Ps = max Ps_i, U = max U_i,
// position deviation Pa = max_i x̄_i − min_i x̄_i and position uncertainty
// P = max_i (x̄_i + (U_i + Ps_i)/2) − min_i (x̄_i − (U_i + Ps_i)/2).
//
// Validation (km::InvalidInput naming the file, the line of a reading and the field): every
// target approached in both directions, every run of the same number of readings, every target
// read once in each direction of every run, at least 2 runs. Fewer than 5 runs or 5 targets is
// allowed but not a test to ISO 230-2: `iso230_2_compliant` is false and a warning says why.
#pragma once

#include <cstddef>
#include <string>
#include <vector>

namespace km::positioning {

struct Reading {
  long run = 0;
  int direction = 1;  // +1: ↑ (towards larger coordinates), −1: ↓
  double target_mm = 0.0;
  double deviation_um = 0.0;
  std::size_t line = 0;  // line of the reading in its file (0: not from a file)
};

struct TargetFigures {
  double target_mm = 0.0;
  double mean_up_um = 0.0, mean_down_um = 0.0;  // x̄_i↑, x̄_i↓
  double s_up_um = 0.0, s_down_um = 0.0;        // s_i↑, s_i↓
  double reversal_um = 0.0;                     // B_i
  double mean_bidirectional_um = 0.0;           // x̄_i
  double repeatability_um = 0.0;                // R_i
};

struct Iso230Figures {
  double reversal_value_um = 0.0;       // B
  double mean_reversal_value_um = 0.0;  // B̄
  double repeatability_up_um = 0.0, repeatability_down_um = 0.0, repeatability_um = 0.0;
  double systematic_deviation_up_um = 0.0, systematic_deviation_down_um = 0.0;
  double systematic_deviation_um = 0.0;  // E
  double mean_deviation_range_um = 0.0;  // M
  double accuracy_up_um = 0.0, accuracy_down_um = 0.0, accuracy_um = 0.0;
};

struct Vdi3441Figures {
  double position_uncertainty_um = 0.0;                // P
  double position_scatter_um = 0.0;                    // Ps (max)
  double reversal_span_um = 0.0;                       // U (max)
  double position_deviation_um = 0.0;                  // Pa
  std::vector<double> position_scatter_per_target_um;  // Ps_i
  std::vector<double> reversal_span_per_target_um;     // U_i
};

struct PositioningFigures {
  std::vector<TargetFigures> targets;  // ascending target_mm
  Iso230Figures iso;
  Vdi3441Figures vdi;
  std::size_t runs = 0;
  std::size_t readings = 0;
  bool iso230_2_compliant = false;
  std::vector<std::string> warnings;
};

// Minimum runs and targets of a test to ISO 230-2 (fewer: a warning, not an error).
inline constexpr std::size_t kIsoMinRuns = 5;
inline constexpr std::size_t kIsoMinTargets = 5;

// Checks and evaluates the readings (any order). `file` names the source in errors.
PositioningFigures EvaluatePositioning(const std::vector<Reading>& readings,
                                       const std::string& file = "");

// The axis figures from per-target figures alone (used by EvaluatePositioning and to evaluate
// a table after compensation).
Iso230Figures AxisFigures(const std::vector<TargetFigures>& targets);
Vdi3441Figures VdiFigures(const std::vector<TargetFigures>& targets);

}  // namespace km::positioning
