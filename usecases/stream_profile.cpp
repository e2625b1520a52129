#include "usecases/stream_profile.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>

#include "analysis/core/errors.h"
#include "ingest/iso8601.h"

namespace km::usecases {

std::vector<double> InterpolatePositionMm(const std::vector<std::int64_t>& encoder_t_us,
                                          const std::vector<double>& encoder_um,
                                          const std::vector<std::int64_t>& t_us) {
  std::vector<double> out(t_us.size(), std::numeric_limits<double>::quiet_NaN());
  if (encoder_t_us.empty()) return out;
  for (std::size_t i = 0; i < t_us.size(); ++i) {
    const std::int64_t t = t_us[i];
    auto it = std::lower_bound(encoder_t_us.begin(), encoder_t_us.end(), t);
    if (it == encoder_t_us.end()) continue;
    auto k = static_cast<std::size_t>(it - encoder_t_us.begin());
    if (encoder_t_us[k] == t) {
      out[i] = encoder_um[k] / 1000.0;
      continue;
    }
    if (k == 0) continue;
    const double t0 = static_cast<double>(encoder_t_us[k - 1]);
    const double t1 = static_cast<double>(encoder_t_us[k]);
    const double w = (static_cast<double>(t) - t0) / (t1 - t0);
    out[i] = ((1.0 - w) * encoder_um[k - 1] + w * encoder_um[k]) / 1000.0;
  }
  return out;
}

std::vector<double> FeedPositionMm(const std::vector<std::int64_t>& t_us, double start_mm,
                                   double feed_mm_min) {
  std::vector<double> out(t_us.size());
  if (t_us.empty()) return out;
  const double mm_per_us = feed_mm_min / 60.0 / 1e6;
  for (std::size_t i = 0; i < t_us.size(); ++i) {
    // t − t_0 in int64 when it fits (exact), else in double (time stamps at both ends of int64).
    std::int64_t dt = 0;
    const double dt_us = __builtin_sub_overflow(t_us[i], t_us.front(), &dt)
                             ? static_cast<double>(t_us[i]) - static_cast<double>(t_us.front())
                             : static_cast<double>(dt);
    out[i] = start_mm + mm_per_us * dt_us;
  }
  return out;
}

form::Profile BinProfile(const std::vector<double>& position_mm,
                         const std::vector<double>& deviation_um, std::size_t bins) {
  double lo = std::numeric_limits<double>::infinity();
  double hi = -lo;
  for (double x : position_mm) {
    if (!std::isfinite(x)) continue;
    lo = std::min(lo, x);
    hi = std::max(hi, x);
  }
  if (!(hi > lo) || bins < 3) {
    throw InvalidInput("", 0, "position",
                       "the samples do not travel along the axis (no position range to bin)");
  }
  std::vector<double> sx(bins, 0.0), sy(bins, 0.0);
  std::vector<std::size_t> n(bins, 0);
  const double width = (hi - lo) / static_cast<double>(bins);
  for (std::size_t i = 0; i < position_mm.size(); ++i) {
    const double x = position_mm[i];
    if (!std::isfinite(x)) continue;
    auto b = static_cast<std::size_t>((x - lo) / width);
    b = std::min(b, bins - 1);
    sx[b] += x;
    sy[b] += deviation_um[i];
    ++n[b];
  }
  form::Profile p;
  for (std::size_t b = 0; b < bins; ++b) {
    if (n[b] == 0) continue;
    const double x = sx[b] / static_cast<double>(n[b]);
    // Means of disjoint intervals increase; guard the rounding of equal means anyway.
    if (!p.position_mm.empty() && !(x > p.position_mm.back())) continue;
    p.position_mm.push_back(x);
    p.deviation_um.push_back(sy[b] / static_cast<double>(n[b]));
  }
  if (p.position_mm.size() < 3) {
    throw InvalidInput("", 0, "bins", "fewer than 3 position intervals hold samples");
  }
  return p;
}

namespace {
std::string Num(double v) {
  char buf[40];
  std::snprintf(buf, sizeof buf, "%.12g", v);
  return buf;
}
}  // namespace

std::string StraightnessFileFromStream(const ProfileSpec& spec, const ingest::SampleRun& sensor,
                                       const ingest::SampleRun* encoder) {
  if (sensor.size() < 3) {
    throw InvalidInput("request", 0, "channel",
                       "channel " + std::to_string(sensor.channel) + " has " +
                           std::to_string(sensor.size()) + " samples in the chosen time range");
  }
  std::vector<double> x;
  std::string position_from;
  if (encoder) {
    if (encoder->size() < 2) {
      throw InvalidInput("request", 0, "position.encoder_channel",
                         "encoder channel " + std::to_string(encoder->channel) +
                             " has fewer than 2 samples in the chosen time range");
    }
    x = InterpolatePositionMm(encoder->t_us, encoder->value_um, sensor.t_us);
    position_from = "encoder channel " + std::to_string(encoder->channel);
  } else {
    if (!std::isfinite(spec.feed_mm_min) || spec.feed_mm_min == 0.0) {
      throw InvalidInput("request", 0, "position.feed_mm_min", "must be a non-zero number");
    }
    x = FeedPositionMm(sensor.t_us, spec.start_mm, spec.feed_mm_min);
    position_from = "feed " + Num(spec.feed_mm_min) + " mm/min from " + Num(spec.start_mm) + " mm";
  }
  const auto profile = BinProfile(x, sensor.value_um, spec.points);
  std::string text = "# format: kinemetric-straightness/1\n";
  text += "# machine_id: " + spec.machine_id + "\n";
  text += "# axis: " + spec.axis + "\n";
  text += "# error_direction: " + spec.error_direction + "\n";
  text += "# sensor: " + spec.sensor + "\n";
  text += "# reference: " + spec.reference + "\n";
  if (!spec.test_id.empty()) text += "# test_id: " + spec.test_id + "\n";
  text += "# timestamp: " + ingest::UtcIso8601FromMicros(sensor.t_us.front()) + "\n";
  for (const auto& [k, v] : spec.provenance) text += "# " + k + ": " + v + "\n";
  text += "# source_channel: " + std::to_string(sensor.channel) + "\n";
  text += "# source_time_us: " + std::to_string(sensor.t_us.front()) + ", " +
          std::to_string(sensor.t_us.back()) + "\n";
  text += "# source_samples: " + std::to_string(sensor.size()) + "\n";
  text += "# position_from: " + position_from + "\n";
  text += "position_mm,deviation_um\n";
  for (std::size_t i = 0; i < profile.position_mm.size(); ++i) {
    text += Num(profile.position_mm[i]) + "," + Num(profile.deviation_um[i]) + "\n";
  }
  return text;
}

}  // namespace km::usecases
