// Writes the servo loads of the jig plan (CW and CCW circles at the 15 positions of
// [PM-600 report] ch. 2) of the pm600-like machine as `kinemetric-servo/1` files, simulated by
// the independent simulator (servo_truth.h), for scenarios that upload them to a real server
// (tests/browser/dashboard/servo.test.mjs).
//   km_servo_sim OUT_DIR [--samples N] [--stiff-leg K --factor F] [--noise-N S] [--noise-draw D]
// One file a circle: OUT_DIR/<test_id>_<ccw|cw>.txt; the names are printed, one a line.
//   km_servo_sim OUT_DIR --feed-drive SPEEDS [--stroke-mm L] [--accel-mm-s2 A] [--dwell-s D]
//                [--sample-s T] [--sigma0 S] [--sigma1 S] [--sigma2 S] [--vs V] [--fs F]
//                [--mass M] [--fc F] [--delta D] [--lorentzian 1] [--feed-noise-N S]
//                [--noise-draw D] [--cosine 1] [--one-way 1]
// writes instead one X feed-drive record of strokes out and back at each speed (mm/s,
// comma-separated) by the independent feed-drive simulator (feed_truth.h): OUT_DIR/x-strokes.txt.
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <random>
#include <string>
#include <vector>

#include "tests/unit/servo/feed_truth.h"
#include "tests/unit/servo/servo_truth.h"

namespace {

struct Args {
  std::string out;
  int samples = 240, stiff_leg = 0;
  double factor = 1.0, noise_N = 2.0;
  unsigned noise_draw = 7;  // which draw of the noise generator
  std::string feed_speeds;  // non-empty: a feed-drive record
  km::servo::feed_truth::Motion motion;
  km::servo::feed_truth::Drive drive;
  double stroke_mm = 200.0;
  bool one_way = false;  // one stroke a speed, alternating in direction
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
    } else if (k == "--feed-drive") {
      a.feed_speeds = v;
    } else if (k == "--stroke-mm") {
      a.stroke_mm = std::atof(v.c_str());
    } else if (k == "--accel-mm-s2") {
      a.motion.accel_mm_s2 = std::atof(v.c_str());
    } else if (k == "--dwell-s") {
      a.motion.dwell_s = std::atof(v.c_str());
    } else if (k == "--sample-s") {
      a.motion.sample_s = std::atof(v.c_str());
    } else if (k == "--sigma0") {
      a.drive.sigma0_N_per_um = std::atof(v.c_str());
    } else if (k == "--sigma1") {
      a.drive.sigma1_N_s_per_mm = std::atof(v.c_str());
    } else if (k == "--sigma2") {
      a.drive.sigma2_N_s_per_mm = std::atof(v.c_str());
    } else if (k == "--vs") {
      a.drive.vs_mm_s = std::atof(v.c_str());
    } else if (k == "--fc") {
      a.drive.fc_N = std::atof(v.c_str());
    } else if (k == "--delta") {
      a.drive.stribeck_exponent = std::atof(v.c_str());
    } else if (k == "--lorentzian") {
      a.drive.lorentzian = v == "1";
    } else if (k == "--feed-noise-N") {
      a.drive.noise_N = std::atof(v.c_str());
    } else if (k == "--fs") {
      a.drive.fs_N = std::atof(v.c_str());
    } else if (k == "--mass") {
      a.drive.mass_kg = std::atof(v.c_str());
    } else if (k == "--one-way") {
      a.one_way = v == "1";
    } else if (k == "--cosine") {
      a.motion.cosine_ramps = v == "1";
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
  if (!a.feed_speeds.empty()) {
    std::vector<double> speeds;
    for (const char* p = a.feed_speeds.c_str(); *p;) {
      char* end = nullptr;
      speeds.push_back(std::strtod(p, &end));
      p = *end == ',' ? end + 1 : end;
      if (end == p && *p) return 2;
    }
    namespace ft = km::servo::feed_truth;
    ft::Motion m = ft::BackAndForth(a.stroke_mm, speeds);
    if (a.one_way) {
      m.moves.clear();
      for (std::size_t k = 0; k < speeds.size(); ++k)
        m.moves.push_back({k % 2 == 0 ? a.stroke_mm : 0.0, speeds[k]});
    }
    m.accel_mm_s2 = a.motion.accel_mm_s2;
    m.dwell_s = a.motion.dwell_s;
    m.sample_s = a.motion.sample_s;
    m.cosine_ramps = a.motion.cosine_ramps;
    const auto tr = ft::Simulate(a.drive, m, a.noise_draw);
    std::ofstream(a.out + "/x-strokes.txt", std::ios::binary) << ft::ServoText(tr);
    std::printf("x-strokes.txt\n");
    return 0;
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
