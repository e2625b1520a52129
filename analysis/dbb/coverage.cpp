#include "analysis/dbb/coverage.h"

#include <algorithm>
#include <cmath>
#include <cstdio>

namespace km::dbb {

namespace {

std::string Deg(double v) {
  char buf[32];
  std::snprintf(buf, sizeof buf, "%.6g", v);
  return buf;
}

}  // namespace

Coverage CheckCoverage(const std::vector<double>& a, Direction direction,
                       std::optional<double> declared) {
  Coverage c;
  const std::size_t n = a.size();
  const double sign = direction == Direction::kCcw ? 1.0 : -1.0;
  if (n < 2) {
    c.reason = "a test needs samples around the circle; the file has " + std::to_string(n);
    c.reason_sample = n == 0 ? 0 : n - 1;
    return c;
  }
  double max_step = 0.0;
  std::size_t max_at = 1;
  for (std::size_t i = 1; i < n; ++i) {
    const double step = sign * (a[i] - a[i - 1]);
    if (!(step > 0.0)) {
      c.reason = std::string("angles must ") + (sign > 0 ? "increase (ccw)" : "decrease (cw)") +
                 " strictly from sample to sample; sample " + std::to_string(i + 1) +
                 " breaks this";
      c.reason_sample = i;
      return c;
    }
    if (step > max_step) {
      max_step = step;
      max_at = i;
    }
  }
  c.span_deg = sign * (a[n - 1] - a[0]);
  c.largest_gap_deg = max_step;
  c.largest_gap_sample = max_at;
  if (declared) {
    c.arc_declared = true;
    if (!(*declared >= kMinArcDeg && *declared <= 360.0)) {
      c.reason = "arc_deg " + Deg(*declared) + " is outside " + Deg(kMinArcDeg) +
                 " … 360 degrees (a partial arc of at least " + Deg(kMinArcDeg) +
                 " degrees, or 360 for a full turn)";
      c.field = "arc_deg";
      return c;
    }
    c.full_turn = *declared >= 360.0;
  } else {
    c.full_turn = c.span_deg >= 360.0 - kMaxGapDeg;
  }
  // The gap at the end: the closing gap of a turn, the missing end of a declared arc.
  double end_gap = 0.0;
  if (c.full_turn) {
    c.arc_deg = 360.0;
    end_gap = std::max(0.0, 360.0 - c.span_deg);
  } else {
    c.arc_deg = declared ? *declared : c.span_deg;
    end_gap = std::max(0.0, c.arc_deg - c.span_deg);
  }
  if (end_gap > c.largest_gap_deg) {
    c.largest_gap_deg = end_gap;
    c.largest_is_closing = true;
    c.largest_gap_sample = n - 1;
  }
  if (!c.full_turn && c.arc_deg < kMinArcDeg) {
    c.reason = "the samples cover " + Deg(c.span_deg) +
               " degrees: not a full turn (the closing gap back to the first sample is " +
               Deg(360.0 - c.span_deg) + " degrees, at most " + Deg(kMaxGapDeg) +
               " is accepted) and shorter than a partial arc of at least " + Deg(kMinArcDeg) +
               " degrees";
    c.reason_sample = n - 1;
    return c;
  }
  if (c.largest_gap_deg > kMaxGapDeg + 1e-9) {
    if (c.largest_is_closing) {
      c.reason = c.full_turn ? "the samples cover " + Deg(c.span_deg) +
                                   " degrees of the full turn: the closing gap from the last "
                                   "sample back to the first is " +
                                   Deg(end_gap) + " degrees"
                             : "the samples cover " + Deg(c.span_deg) + " degrees of the " +
                                   Deg(c.arc_deg) + "-degree arc: " + Deg(end_gap) +
                                   " degrees are missing at its end";
      c.reason_sample = n - 1;
    } else {
      c.reason = "gap of " + Deg(max_step) + " degrees between samples " + std::to_string(max_at) +
                 " and " + std::to_string(max_at + 1);
      c.reason_sample = max_at;
    }
    c.reason +=
        "; every gap, the closing gap included, must be at most " + Deg(kMaxGapDeg) + " degrees";
    return c;
  }
  c.ok = true;
  return c;
}

}  // namespace km::dbb
