// Demo data for a fresh server: a serial machining centre "demo-vmc" with DBB tests in both
// directions, generated from a stated error model (squareness, servo mismatch, backlash,
// scale mismatch, noise) and written as contract-format files.
#pragma once

#include <string>
#include <vector>

namespace km::server {

struct DemoFile {
  std::string name;
  std::string bytes;
};

std::vector<DemoFile> DemoDbbFiles();

}  // namespace km::server
