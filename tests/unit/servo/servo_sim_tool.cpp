// Writes the servo loads of the jig plan (CW and CCW circles at the 15 positions of
// [PM-600 report] ch. 2) of the pm600-like machine as `kinemetric-servo/1` files, simulated by
// the independent simulator (servo_truth.h), for scenarios that upload them to a real server
// (tests/browser/dashboard/servo.test.mjs).
//   km_servo_sim OUT_DIR [--samples N] [--stiff-leg K --factor F] [--noise-N S] [--noise-draw D]
// One file a circle: OUT_DIR/<test_id>_<ccw|cw>.txt; the names are printed, one a line.
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <random>
#include <string>

#include "tests/unit/servo/servo_truth.h"

namespace {

struct Args {
  std::string out;
  int samples = 240, stiff_leg = 0;
  double factor = 1.0, noise_N = 2.0;
  unsigned noise_draw = 7;  // which draw of the noise generator
};

bool Parse(int argc, char** argv, Args& a) {
  if (argc < 2) return false;
  a.out = argv[1];
  for (int i = 2; i + 1 < argc; i += 2) {
    const std::string k = argv[i], v = argv[i + 1];
    if (k == "--samples") {
      a.samples = std::atoi(v.c_str());
    } else if (k == "--stiff-leg") {
      a.stiff_leg = std::atoi(v.c_str());
    } else if (k == "--factor") {
      a.factor = std::atof(v.c_str());
    } else if (k == "--noise-N") {
      a.noise_N = std::atof(v.c_str());
    } else if (k == "--noise-draw") {
      a.noise_draw = static_cast<unsigned>(std::atoi(v.c_str()));
    } else {
      return false;
    }
  }
  return a.samples >= 5 && a.stiff_leg >= 0 && a.stiff_leg <= 6 && a.factor > 0.0;
}

}  // namespace

int main(int argc, char** argv) {
  Args a;
  if (!Parse(argc, argv, a)) {
    std::fprintf(stderr,
                 "usage: km_servo_sim OUT_DIR [--samples N] [--stiff-leg K --factor F] "
                 "[--noise-N S] [--noise-draw D]\n");
    return 2;
  }
  auto m = km::servo::truth::Pm600Truth();
  if (a.stiff_leg > 0) m.leg_factor[static_cast<std::size_t>(a.stiff_leg - 1)] = a.factor;
  std::mt19937 rng(a.noise_draw);
  for (auto c : km::servo::truth::JigPlan(a.samples)) {
    for (bool ccw : {true, false}) {
      c.ccw = ccw;
      const auto text =
          km::servo::truth::ServoText(c, km::servo::truth::Simulate(m, c, a.noise_N, rng));
      const std::string name = c.test_id + (ccw ? "_ccw" : "_cw") + ".txt";
      std::ofstream(a.out + "/" + name, std::ios::binary) << text;
      std::printf("%s\n", name.c_str());
    }
  }
  return 0;
}
