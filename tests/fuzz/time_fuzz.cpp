// Time stamps (server/base/time_util.h): a normalised time is itself a normalised time, and any
// microsecond count has a text form.
#include <cstring>

#include "server/base/time_util.h"
#include "tests/fuzz/fuzz_util.h"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  km::fuzz::Guarded([&] {
    const std::string text(km::fuzz::AsText(data, size));
    if (const auto t = km::server::NormaliseIso8601(text)) {
      const auto again = km::server::NormaliseIso8601(*t);
      if (!again || *again != *t) {
        km::fuzz::Fail("'" + text + "' normalises to '" + *t + "', which normalises to '" +
                       (again ? *again : std::string("nothing")) + "'");
      }
    }
    if (size >= 8) {
      std::int64_t t_us = 0;
      std::memcpy(&t_us, data, sizeof t_us);
      km::server::UtcIso8601FromMicros(t_us);
    }
  });
  return 0;
}
