// kinemetric-parallelism/1 parser (ingest/form_parsers.h).
#include "ingest/form_parsers.h"
#include "tests/fuzz/fuzz_util.h"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  km::fuzz::Guarded([&] {
    const auto f = km::ingest::ParseParallelismFile(km::fuzz::AsText(data, size), "fuzz.txt");
    km::fuzz::Check(f.profile.position_mm.size() == f.profile.deviation_um.size(),
                    "one deviation per position");
    km::fuzz::Check(f.profile.position_mm.size() >= km::ingest::kMinParallelismPoints,
                    "minimum number of points");
  });
  return 0;
}
