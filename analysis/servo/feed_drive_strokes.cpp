// Strokes of the feed-drive analysis (feed_drive.h): every record's samples with their speed and
// acceleration, the reversals (turning points of the position) and the steady samples (the
// cruise of each stroke, measured against that stroke's own top speed).
#include <algorithm>
#include <cmath>
#include <string>

#include "analysis/core/errors.h"
#include "analysis/servo/feed_drive_detail.h"

namespace km::servo::detail {
namespace {

// A turn of the position counts as a reversal once the axis has come back this far (mm): more
// than an encoder's jitter at a standstill, far less than a stroke.
constexpr double kReversalHysteresisMm = 0.01;
// The top speed of a stroke: this quantile of its speeds in its direction (a single noisy
// speed does not set it; a cruise of 5 % of the stroke does).
constexpr double kTopSpeedQuantile = 0.95;

// Turning points of x[first, end): the first sample after each extreme that the position then
// leaves by more than the hysteresis in the other direction.
std::vector<std::size_t> TurningPoints(const std::vector<double>& x, std::size_t first,
                                       std::size_t end) {
  std::vector<std::size_t> out;
  int dir = 0;
  std::size_t hi = first, lo = first;  // extremes since the last turn
  for (std::size_t i = first; i < end; ++i) {
    if (x[i] >= x[hi]) hi = i;
    if (x[i] <= x[lo]) lo = i;
    if (dir >= 0 && x[hi] - x[i] > kReversalHysteresisMm) {  // moving back from a maximum
      if (dir > 0) out.push_back(hi + 1);
      dir = -1;
      lo = i;
      for (std::size_t k = hi + 1; k <= i; ++k)
        if (x[k] <= x[lo]) lo = k;
    } else if (dir <= 0 && x[i] - x[lo] > kReversalHysteresisMm) {  // moving on from a minimum
      if (dir < 0) out.push_back(lo + 1);
      dir = 1;
      hi = i;
      for (std::size_t k = lo + 1; k <= i; ++k)
        if (x[k] >= x[hi]) hi = k;
    }
  }
  return out;
}

// The top speed of the stroke [a, b) moving in direction `dir`.
double TopSpeed(const Strokes& s, std::size_t a, std::size_t b, double dir) {
  std::vector<double> speeds;
  for (std::size_t i = a; i < b; ++i)
    if (dir * s.v[i] > 0.0) speeds.push_back(dir * s.v[i]);
  if (speeds.empty()) return 0.0;
  const auto k =
      static_cast<std::size_t>(kTopSpeedQuantile * static_cast<double>(speeds.size() - 1));
  std::nth_element(speeds.begin(), speeds.begin() + static_cast<std::ptrdiff_t>(k), speeds.end());
  return speeds[k];
}

// Marks the steady samples of the record [first, end) whose reversals are `turns`.
void MarkSteady(Strokes& s, std::size_t first, std::size_t end,
                const std::vector<std::size_t>& turns, const FeedDriveOptions& o) {
  std::vector<std::size_t> bounds{first};
  bounds.insert(bounds.end(), turns.begin(), turns.end());
  bounds.push_back(end);
  for (std::size_t k = 0; k + 1 < bounds.size(); ++k) {
    const std::size_t a = bounds[k], b = bounds[k + 1];
    s.stroke.resize(b, s.stroke_top.size());
    const double dir = s.x[b - 1] >= s.x[a] ? 1.0 : -1.0;
    const double top = b > a + 1 ? TopSpeed(s, a, b, dir) : 0.0;
    s.stroke_top.push_back(top);
    if (!(top > 0.0)) continue;
    const double x0 = s.x[a];
    for (std::size_t i = a; i < b; ++i) {
      s.steady[i] =
          dir * s.v[i] >= o.min_speed_fraction * top && std::abs(s.x[i] - x0) >= o.reversal_skip_mm;
    }
  }
}

}  // namespace

std::size_t Strokes::SegmentOf(std::size_t i) const {
  return static_cast<std::size_t>(std::upper_bound(segment_end.begin(), segment_end.end(), i) -
                                  segment_end.begin());
}

double Strokes::Weight(std::size_t i, double mass_kg) const {
  if (!(noise_N > 0.0)) return 1.0;
  const double u = 0.5 * std::abs(mass_kg) * 1e-3 * a_change[i] / noise_N;
  return 1.0 / (1.0 + u * u);
}

namespace {
double StribeckShape(const LugreParameters& p, double v) {
  const double u = std::abs(v / p.vs_mm_s);
  if (p.stribeck_form == LugreParameters::Form::kLorentzian) return 1.0 / (1.0 + u * u);
  return std::exp(p.stribeck_exponent == 2.0 ? -u * u : -std::pow(u, p.stribeck_exponent));
}
}  // namespace

double StribeckG(const LugreParameters& p, double v) {
  return p.Fc_N + (p.Fs_N - p.Fc_N) * StribeckShape(p, v);
}

double StribeckRise(const LugreParameters& p, double v) {
  return (v > 0.0 ? 1.0 : (v < 0.0 ? -1.0 : 0.0)) * (p.Fs_N - p.Fc_N) * StribeckShape(p, v);
}

bool SetStribeck(Strokes& s, const LugreParameters& p) {
  s.known.assign(s.x.size(), 0.0);
  bool matters = false;
  for (std::size_t i = 0; i < s.x.size(); ++i) {
    s.known[i] = StribeckRise(p, s.v[i]);
    matters = matters || (s.steady[i] && std::abs(s.known[i]) > 1e-3 * s.noise_N);
  }
  return matters;
}

Strokes CollectStrokes(const std::vector<const ServoFile*>& files, const std::string& axis,
                       const FeedDriveOptions& o) {
  Strokes s;
  for (const ServoFile* file : files) {
    const AxisTrace* tr = nullptr;
    for (const auto& a : file->axes)
      if (a.axis == axis) tr = &a;
    if (!tr) throw InvalidInput(file->file, 0, "axis", "the record has no axis " + axis);
    const std::size_t n = tr->pos_mm.size(), first = s.x.size();
    const auto& x = tr->pos_mm;
    for (std::size_t i = 0; i < n; ++i) {  // speed by central differences, mm/s…
      const std::size_t a = i ? i - 1 : 0, b = i + 1 < n ? i + 1 : n - 1;
      const double dt = file->t_s[b] - file->t_s[a];
      // …but zero at a sample next to a standstill: it ends or starts there.
      const bool still = (i > 0 && x[i] == x[i - 1]) || (i + 1 < n && x[i] == x[i + 1]);
      s.t.push_back(file->t_s[i]);
      s.x.push_back(x[i]);
      s.v.push_back(dt > 0.0 && !still ? (x[b] - x[a]) / dt : 0.0);
      s.f.push_back(tr->force_N[i]);
    }
    for (std::size_t i = first; i < s.x.size(); ++i) {  // second differences, mm/s²
      const std::size_t c = std::clamp(i, first + 1, std::max(first + 1, s.x.size() - 2));
      const double h1 = s.t[c] - s.t[c - 1], h2 = s.t[c + 1] - s.t[c];
      s.a.push_back(h1 > 0.0 && h2 > 0.0
                        ? 2.0 * ((s.x[c + 1] - s.x[c]) / h2 - (s.x[c] - s.x[c - 1]) / h1) /
                              (h1 + h2)
                        : 0.0);
    }
    for (std::size_t i = first; i < s.x.size(); ++i) {
      const std::size_t lo = std::max(i, first + 1) - 1, hi = std::min(i + 1, s.x.size() - 1);
      const auto [mn, mx] = std::minmax_element(s.a.begin() + static_cast<std::ptrdiff_t>(lo),
                                                s.a.begin() + static_cast<std::ptrdiff_t>(hi) + 1);
      s.a_change.push_back(*mx - *mn);
    }
    const auto turns = TurningPoints(s.x, first, s.x.size());
    s.reversals.insert(s.reversals.end(), turns.begin(), turns.end());
    s.steady.resize(s.x.size(), false);
    MarkSteady(s, first, s.x.size(), turns, o);
    s.segment_end.push_back(s.x.size());
  }
  std::size_t forward = 0, backward = 0;
  for (std::size_t i = 0; i < s.x.size(); ++i)
    if (s.steady[i]) (s.v[i] > 0.0 ? forward : backward)++;
  if (forward < 10 || backward < 10) {
    throw InvalidInput(files.empty() ? "" : files.front()->file, 0, "pos_mm",
                       "the strokes need steady motion in both directions (found " +
                           std::to_string(forward) + " forward and " + std::to_string(backward) +
                           " backward samples at >= " +
                           std::to_string(static_cast<int>(100.0 * o.min_speed_fraction)) +
                           " % of their stroke's top speed, " + std::to_string(o.reversal_skip_mm) +
                           " mm after a reversal)");
  }
  return s;
}

}  // namespace km::servo::detail
