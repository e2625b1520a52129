// kinemetric-tracker/1 parser and writer (ingest/tracker_parser.h): what parses is written
// back and must parse again.
#include "ingest/tracker_parser.h"
#include "tests/fuzz/fuzz_util.h"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  km::fuzz::Guarded([&] {
    const auto file = km::ingest::ParseTrackerFile(km::fuzz::AsText(data, size), "fuzz.txt");
    std::string written;
    if (!km::fuzz::Guarded([&] { written = km::ingest::WriteTrackerFile(file.readings); })) {
      return;  // readings the format cannot carry (documented refusal)
    }
    km::ingest::ParseTrackerFile(written, "fuzz-rewritten.txt");
  });
  return 0;
}
