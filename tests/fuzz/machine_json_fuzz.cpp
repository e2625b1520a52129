// Machine definition files (ingest/machine_json.h): what parses is written back and must parse
// again to the same machine.
#include "ingest/machine_json.h"
#include "tests/fuzz/fuzz_util.h"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  km::fuzz::Guarded([&] {
    const auto m = km::ingest::ParseMachineJson(km::fuzz::AsText(data, size), "fuzz.json");
    if (m.kind != "hexapod") return;
    const std::string written = km::ingest::WriteMachineJson(m);
    const auto again = km::ingest::ParseHexapodMachineJson(written, "fuzz-rewritten.json");
    km::fuzz::Check(again.machine_id == m.machine_id, "machine_id survives writing");
    for (std::size_t j = 0; j < 6; ++j) {
      km::fuzz::Check(
          again.geometry.base_joints_mm[j] == m.geometry.base_joints_mm[j] &&
              again.geometry.platform_joints_mm[j] == m.geometry.platform_joints_mm[j] &&
              again.geometry.strut_offset_mm[j] == m.geometry.strut_offset_mm[j],
          "geometry survives writing bit for bit");
    }
  });
  return 0;
}
