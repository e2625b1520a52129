// Demo data for a fresh server: a serial machining centre "demo-vmc" with DBB tests in both
// directions, generated from a stated error model (squareness, servo mismatch, backlash,
// scale mismatch, noise) and written as contract-format files.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "server/base/ids.h"

namespace km::server {

struct DemoFile {
  std::string name;
  std::string bytes;
};

std::vector<DemoFile> DemoDbbFiles();

// A laser positioning test of the X axis of "demo-vmc" (`kinemetric-positioning/1`): 5 runs of
// 11 targets over 500 mm, pendulum cycle, readings compensated for air by the laser, the machine
// at 21.0 °C (11.5 ppm/K); generated with a 12 µm/m pitch error, a 1.2 µm screw error of 100 mm
// period, 3 µm reversal and 0.3 µm noise.
DemoFile DemoPositioningFile();

class StreamService;
// A demo capacitance-sensor stream of "demo-vmc": a sensor against an optical flat while X
// travels 300 mm at 600 mm/min ([Fujita thesis] set-up: 55 mm guide waviness of 0.2 µm, 10 mm
// ball-screw lead of 0.05 µm, a set-up slope, 0.02 µm noise), with the X encoder on channel 2
// and one lost frame; then the straightness profile made from it. Returns the stream id.
StreamId LoadDemoStream(StreamService& streams);

}  // namespace km::server
