// Uncertainty of the location errors of an R-test from the stated uncertainty of the sensor
// readings (`u_reading_um`, k = 1, normal, independent per reading; docs/formats.md §1.10),
// propagated by Monte Carlo ([JCGM 101] §7, analysis/uncertainty/) through the identification
// itself (docs/methods.md §17.8), not through a linearised formula.
//
// Each draw adds an independent N(0, u²) to each of dx, dy, dz of every pose (one group input,
// one budget entry) and re-identifies the errors with the identification's own Gauss–Newton
// (Reidentification, rotary_identify.h) over the directions the poses determine, warm-started
// from the file's solution. Only the determined errors are outputs. The machine's own scatter
// (the residual, σ of the result) is what the errors describe; it is not an input.
//
// The first-order check ([JCGM 100] §5.1) beside it: u²·(JᵀJ)⁻¹ on the determined directions,
// u_gum = u · SigmaPerUnitReading().
#pragma once

#include <cstddef>
#include <cstdint>
#include <vector>

#include "analysis/rotary/rotary_identify.h"
#include "analysis/rotary/rotary_types.h"
#include "analysis/uncertainty/monte_carlo.h"

namespace km::rotary {

struct ReadingUncertaintyOptions {
  // M = 500 draws (the standard error of u about 1/√(2M) = 3.2 % of u); above `large_poses`
  // poses M = 200 (4.9 %), fewer where M × poses would pass `max_pose_draws`, never below
  // `min_draws` (10 %): a re-identification costs about 0.7 µs a pose, so 1 000 poses take about
  // 0.35 s, 5 000 (M = 200) 0.7 s and 20 000 (M = 50) 0.7 s.
  std::size_t draws = 500;
  std::size_t large_draws = 200;
  std::size_t large_poses = 2000;
  std::size_t max_pose_draws = 1'000'000;
  std::size_t min_draws = 50;
  std::uint64_t seed = 1710;
  void Check() const;
};

// M for a test of `poses` poses.
std::size_t ReadingDraws(std::size_t poses, const ReadingUncertaintyOptions& options = {});

struct ReadingUncertainty {
  uncertainty::McResult mc;         // one output per determined error, in `errors` order
  std::vector<std::size_t> errors;  // the determined errors (LocationErrors indices)
  std::vector<double> u_gum;        // first-order u per output (µm or µrad)
  std::size_t readings = 0;         // the readings drawn (3 per pose)
  std::size_t unconverged_draws = 0;
};

// The propagation of u_reading_um (> 0) through the identification of `test`. Throws
// km::InvalidInput for bad options or a test the identification refuses.
ReadingUncertainty PropagateReadingUncertainty(const RotaryTest& test, double u_reading_um,
                                               const ReadingUncertaintyOptions& options = {},
                                               const IdentifyOptions& identify = {});

}  // namespace km::rotary
