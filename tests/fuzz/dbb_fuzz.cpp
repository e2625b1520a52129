// The DBB reader (ingest/file_formats.h ReadDbb): every DBB format recognised from its bytes
// (kinemetric-dbb/1, dbb-csv) and parsed.
#include <cmath>

#include "ingest/file_formats.h"
#include "tests/fuzz/fuzz_util.h"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  km::fuzz::Guarded([&] {
    const auto test = km::ingest::ReadDbb(km::fuzz::AsText(data, size), "fuzz.txt");
    km::fuzz::Check(test.angle_deg.size() == test.dr_um.size(), "one deviation per angle");
    km::fuzz::Check(test.angle_deg.size() >= 16, "a parsed test has a full turn of samples");
    km::fuzz::Check(test.bar_length_mm > 0 && test.feed_mm_min > 0, "positive bar length, feed");
    for (std::size_t i = 0; i < test.angle_deg.size(); ++i) {
      km::fuzz::Check(std::isfinite(test.angle_deg[i]) && std::isfinite(test.dr_um[i]),
                      "finite samples");
    }
  });
  return 0;
}
