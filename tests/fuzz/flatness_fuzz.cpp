// kinemetric-flatness/1 parser (ingest/form_parsers.h).
#include "ingest/form_parsers.h"
#include "tests/fuzz/fuzz_util.h"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  km::fuzz::Guarded(
      [&] { km::ingest::ParseFlatnessFile(km::fuzz::AsText(data, size), "fuzz.txt"); });
  return 0;
}
