// The whole upload path (Service::Upload): format dispatch, parsing, analysis at upload (DBB
// figures, tracker self-calibration, form evaluation) and storage, on an in-memory database.
#include "tests/fuzz/fuzz_service.h"
#include "tests/fuzz/fuzz_util.h"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  static km::fuzz::RecycledService service(1000, nullptr);
  auto& svc = service.Get();
  km::fuzz::Guarded([&] {
    const auto out = svc.measurements().Upload(km::fuzz::AsText(data, size), "fuzz.txt");
    km::fuzz::Check(out.id.value() > 0 && !out.kind.empty() && out.sha256.size() == 64,
                    "an accepted upload has an id, a kind and a SHA-256");
    svc.measurements().Results(out.id);
  });
  return 0;
}
