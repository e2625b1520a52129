// Steps of the feed-drive analysis (feed_drive.h): strokes collected from the records, the
// steady-motion fit with the position-dependent ripple, the LuGre fit at reversals.
#pragma once

#include <cstddef>
#include <string>
#include <vector>

#include "analysis/servo/feed_drive.h"

namespace km::servo::detail {

struct Strokes {
  std::vector<double> t, x, v, a, f;     // every record, one after the other (a in mm/s²)
  std::vector<std::size_t> segment_end;  // one past the last sample of each record
  std::vector<bool> steady;              // used by the steady-motion fit
  std::vector<std::size_t> reversals;    // first sample after each change of direction
  std::vector<double> position_part;     // c0 + c1 x + ripple(x), after FitSteady
  std::size_t SegmentOf(std::size_t i) const;
};

Strokes CollectStrokes(const std::vector<const ServoFile*>& files, const std::string& axis,
                       const FeedDriveOptions& o);
void FitSteady(Strokes& s, const FeedDriveOptions& o, FeedDriveResult& r);
void FitLugre(const Strokes& s, const FeedDriveOptions& o, FeedDriveResult& r);

}  // namespace km::servo::detail
