// Servo loads (docs/formats.md §1.7, `kinemetric-servo/1`): the motor force of every hexapod
// strut or serial feed drive against time and commanded position. Plain data, filled by
// ingest/servo_parser and read by the analyses of analysis/servo.
#pragma once

#include <array>
#include <cstddef>
#include <map>
#include <string>
#include <vector>

namespace km::servo {

// One row of a hexapod file: the commanded tool-tip pose and the axial motor force of each
// strut, tension positive, in N (already multiplied by the force constant for `current_A`).
struct HexapodSample {
  double t_s = 0.0;
  std::array<double, 3> tip_mm{};
  std::array<double, 3> abc_deg{};
  std::array<double, 6> force_N{};
};

// One feed-drive axis of a serial machine: position and motor force (N) against time.
struct AxisTrace {
  std::string axis;  // upper case, e.g. "X"
  std::vector<double> pos_mm;
  std::vector<double> force_N;
};

struct ServoFile {
  std::string file;  // name used in messages
  std::string machine_id;
  std::string test_id;
  std::string motion;     // "circle" or "path"
  std::string direction;  // "cw", "ccw" or "" (paths)
  bool hexapod = true;    // false: serial feed drive (`# axis:` present)
  double tool_length_mm = 0.0;
  std::string force_unit;                       // "N" or "current_A" as written
  std::map<std::string, std::string> metadata;  // every header key
  std::vector<double> t_s;
  std::vector<HexapodSample> samples;  // hexapod
  std::vector<AxisTrace> axes;         // serial
  std::vector<std::size_t> lines;      // file line of each row
};

}  // namespace km::servo
