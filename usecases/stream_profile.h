// A stretch of a capacitance-sensor stream turned into a straightness profile.
//
// Position of each sample: from an encoder channel (its value_um read as the position in µm,
// linearly interpolated in time onto the sensor's timestamps; samples outside the encoder's
// time span are dropped) or from feed × time: x = start_mm + feed_mm_min / 60 · (t − t_0).
// The samples are then averaged in `bins` equal position intervals over the travelled range
// (empty intervals are skipped), which gives strictly increasing positions whatever the travel
// direction and reduces the sensor noise by √(samples per bin).
#pragma once

#include <cstddef>
#include <cstdint>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include "analysis/form/profile.h"
#include "ingest/stream/stream_record.h"

namespace km::usecases {

// Positions at the sensor timestamps from an encoder (t sorted ascending). Entries outside the
// encoder's span are NaN.
std::vector<double> InterpolatePositionMm(const std::vector<std::int64_t>& encoder_t_us,
                                          const std::vector<double>& encoder_um,
                                          const std::vector<std::int64_t>& t_us);

// Positions from feed × time, t_0 = t_us.front().
std::vector<double> FeedPositionMm(const std::vector<std::int64_t>& t_us, double start_mm,
                                   double feed_mm_min);

// Bin means; NaN positions are ignored. Throws InvalidInput when fewer than 3 bins are filled.
form::Profile BinProfile(const std::vector<double>& position_mm,
                         const std::vector<double>& deviation_um, std::size_t bins);

// What turns a sensor channel into a straightness file.
struct ProfileSpec {
  std::string machine_id, axis, error_direction;
  std::string sensor = "capacitance", reference = "optical_flat", test_id;
  std::size_t points = 1000;
  double feed_mm_min = 0.0, start_mm = 0.0;                     // used when there is no encoder
  std::vector<std::pair<std::string, std::string>> provenance;  // extra header keys
};

// The kinemetric-straightness/1 file (docs/formats.md §1.3) of the sensor samples, positioned by
// the encoder run when given (its channel named in the header), else by feed × time. The header
// records where the profile came from (source_channel, source_time_us, source_samples,
// position_from and the spec's provenance keys). Throws InvalidInput (field names as in the
// API request) when the data cannot make a profile.
std::string StraightnessFileFromStream(const ProfileSpec& spec, const ingest::SampleRun& sensor,
                                       const ingest::SampleRun* encoder);

}  // namespace km::usecases
