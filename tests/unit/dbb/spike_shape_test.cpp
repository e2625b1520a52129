// Reversal-spike heights, decay shapes and widths (in degrees and in seconds) recovered from DBB
// tests simulated HERE, from the physical description of the spike, with nothing of the analysis
// (no effect model, no signature, no simulation of analysis/):
//
//   the axis that reverses sticks for a moment: just after the reversal its position is off by
//   h·d(t) towards the side it came from, i.e. outward from the circle at that reversal (+x at
//   0°, −x at 180°, +y at 90°, −y at 270°), t the time since the reversal;
//   d(t) = exp(−t/τ) (exponential decay, τ the decay constant), or exp(−t²/2τ²) (Gaussian-like,
//   τ the standard width). The angle since the reversal is counted in degrees on the sample grid
//   along the motion, the time from it with the feed V and the radius R (t = φ·R/V).
//
// What a sample AT the reversal instant shows depends on how that instant was rounded: it is
// simulated both ways (the peak h, or nothing yet). The bar length is computed exactly from the
// displaced moving ball and a fixed ball set off the centre; Gaussian noise is added.
#include <cmath>
#include <numbers>
#include <random>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "analysis/core/angles.h"
#include "analysis/dbb/circular_test.h"
#include "analysis/dbb/diagnosis.h"
#include "analysis/dbb/full_analysis.h"
#include "tests/unit/dbb/dbb_test_util.h"
#include "usecases/dbb_json.h"

namespace km::dbb {
namespace {

using test::Describe;
using test::Named;
constexpr double kPi = std::numbers::pi;

enum class Decay { kExponential, kGaussian };
enum class AtReversal { kPeak, kNothing };

struct SpikeMachine {
  double radius_mm = 100.0;  // a flat test: bar length = radius
  double feed_mm_min = 1000.0;
  int axis = 1;  // 0 = x, 1 = y
  double height_um = 5.0;
  double width_s = 0.1;
  Decay decay = Decay::kExponential;
  AtReversal at_reversal = AtReversal::kPeak;
  double step_deg = 0.1;
  double offset_steps = 0.0;  // the first sample this many steps past 0° (along the motion)
  double noise_um = 0.1;
  double backlash_um = 0.0;          // of the spike's axis
  double squareness_um_per_m = 0.0;  // > 0: the angle between +x and +y above 90°
  unsigned seed = 1;

  double DegPerS() const { return feed_mm_min / 60.0 / radius_mm / kDeg; }
  double WidthDeg() const { return width_s * DegPerS(); }
};

// Degrees travelled since the axis last reversed (in [0, 180)), on the grid of the samples.
double SinceReversalDeg(int axis, int s, double deg) {
  const double first = axis == 0 ? 0.0 : 90.0;
  double d = std::fmod(s * (deg - first), 180.0);
  if (d < 0.0) d += 180.0;
  if (d > 180.0 - 1e-9 || d < 1e-9) d = 0.0;
  return d;
}

// Position error (µm) of the machine at the commanded angle `deg` for direction s.
std::array<double, 2> ErrorUm(const SpikeMachine& m, int s, double deg) {
  std::array<double, 2> e{0.0, 0.0};
  const double since = SinceReversalDeg(m.axis, s, deg);
  const double last = deg - s * since;  // the angle of the last reversal
  const double outward = m.axis == 0 ? (std::cos(last * kDeg) > 0.0 ? 1.0 : -1.0)
                                     : (std::sin(last * kDeg) > 0.0 ? 1.0 : -1.0);
  const double t = since / m.DegPerS();
  double d = m.decay == Decay::kExponential ? std::exp(-t / m.width_s)
                                            : std::exp(-t * t / (2.0 * m.width_s * m.width_s));
  if (since == 0.0 && m.at_reversal == AtReversal::kNothing) d = 0.0;
  e[static_cast<std::size_t>(m.axis)] += m.height_um * d * outward;
  // Backlash: the axis trails its command by b/2; after this reversal it moves inward, so it
  // is b/2 outward.
  e[static_cast<std::size_t>(m.axis)] += 0.5 * m.backlash_um * outward;
  // Squareness: +y leans towards −x.
  e[0] -= m.squareness_um_per_m * 1e-6 * m.radius_mm * std::sin(deg * kDeg) * 1e3;
  return e;
}

DbbTest Simulate(const SpikeMachine& m, Direction dir) {
  const int s = dir == Direction::kCcw ? 1 : -1;
  DbbTest t;
  t.machine_id = "spike";
  t.test_id = "T";
  t.direction = dir;
  t.bar_length_mm = m.radius_mm;
  t.radius_mm = m.radius_mm;
  t.feed_mm_min = m.feed_mm_min;
  const double fx = 2.5e-3, fy = -1.5e-3;  // fixed ball off the centre (mm)
  std::mt19937 rng(m.seed + (s > 0 ? 0u : 7919u));
  std::normal_distribution<double> noise(0.0, m.noise_um);
  const auto n = static_cast<long>(std::llround(360.0 / m.step_deg));
  for (long i = 0; i < n; ++i) {
    const double deg = s * (m.offset_steps + static_cast<double>(i)) * m.step_deg;
    const auto e = ErrorUm(m, s, deg);
    const double x = m.radius_mm * std::cos(deg * kDeg) + 1e-3 * e[0] - fx;
    const double y = m.radius_mm * std::sin(deg * kDeg) + 1e-3 * e[1] - fy;
    t.angle_deg.push_back(deg);
    t.dr_um.push_back((std::hypot(x, y) - m.radius_mm) * 1e3 + noise(rng));
  }
  return t;
}

enum class Runs { kPair, kCcw, kCw };

std::vector<DbbTest> Tests(const SpikeMachine& m, Runs runs) {
  std::vector<DbbTest> v;
  if (runs != Runs::kCw) v.push_back(Simulate(m, Direction::kCcw));
  if (runs != Runs::kCcw) v.push_back(Simulate(m, Direction::kCw));
  return v;
}

const char* ShapeName(Decay d) {
  return d == Decay::kExponential ? "exponential" : "gaussian";
}

// The height within 10 % and within `z_max` reported σ, the decay shape named right, the width
// in degrees and in seconds within 10 % or 3 σ. Returns the height's error in units of its σ.
double ExpectSpike(const DiagnosisResult& r, const SpikeMachine& m, const std::string& name,
                   double z_max = 3.0) {
  const DiagnosisEntry* e = Named(r, name);
  EXPECT_NE(e, nullptr) << Describe(r);
  if (!e) return 0.0;
  const double h = e->value[0], u = e->uncertainty[0];
  EXPECT_LT(std::abs(h - m.height_um), 0.1 * m.height_um) << Describe(r);
  EXPECT_LT(std::abs(h - m.height_um), z_max * u) << Describe(r);
  EXPECT_EQ(e->shape_kind, ShapeName(m.decay)) << Describe(r);
  const bool widths = e->shape.count("width_deg") && e->shape.count("width_s") &&
                      e->shape_uncertainty.count("width_deg") &&
                      e->shape_uncertainty.count("width_s");
  EXPECT_TRUE(widths) << Describe(r);
  if (widths) {
    const double w = e->shape.at("width_deg"), uw = e->shape_uncertainty.at("width_deg");
    EXPECT_LT(std::abs(w - m.WidthDeg()), std::max(0.1 * m.WidthDeg(), 3.0 * uw)) << Describe(r);
    const double ws = e->shape.at("width_s"), uws = e->shape_uncertainty.at("width_s");
    EXPECT_LT(std::abs(ws - m.width_s), std::max(0.1 * m.width_s, 3.0 * uws)) << Describe(r);
  }
  return (h - m.height_um) / u;
}

// The two machines of the issue: 6 µm with τ 0.10 s at 1 000 mm/min on a 100 mm bar, 5 µm with
// τ 0.15 s on a 150 mm bar, sampled every 0.1° (formerly 4.08 µm and 3.01 µm, "Gaussian", each
// ± 0.03 µm). Both conventions at the reversal instant; the JSON gives the shape and the decay
// in degrees and seconds.
TEST(SpikeShape, TheIssuesMachines) {
  for (const AtReversal at : {AtReversal::kPeak, AtReversal::kNothing}) {
    for (unsigned seed : {1u, 2u}) {
      SpikeMachine a;
      a.height_um = 6.0;
      a.width_s = 0.10;
      a.radius_mm = 100.0;
      SpikeMachine b;
      b.height_um = 5.0;
      b.width_s = 0.15;
      b.radius_mm = 150.0;
      for (SpikeMachine m : {a, b}) {
        m.at_reversal = at;
        m.seed = seed;
        const auto tests = Tests(m, Runs::kPair);
        SCOPED_TRACE("R " + std::to_string(m.radius_mm) + " seed " + std::to_string(seed));
        ExpectSpike(test::DiagnoseTests(tests), m, "reversal_spike_y");
        const auto j = usecases::DbbReportToJson(AnalyzeDbbSet(tests));
        bool found = false;
        for (const auto& d : j["tests"][0]["diagnosis"]) {
          if (d["effect"] != "reversal_spike_y") continue;
          found = true;
          EXPECT_EQ(d["spike_shape"], "exponential");
          EXPECT_NEAR(d["width_s"].get<double>(), m.width_s, 0.1 * m.width_s);
          EXPECT_GT(d["width_s_uncertainty"].get<double>(), 0.0);
          EXPECT_NEAR(d["width_deg"].get<double>(), m.WidthDeg(), 0.1 * m.WidthDeg());
        }
        EXPECT_TRUE(found) << j["tests"][0]["diagnosis"].dump();
      }
    }
  }
}

// Both decay shapes over widths from a couple of samples to several degrees, at 0.1°, 0.5° and
// 1° sampling, a pair or a single cw or ccw trace, the grid on the reversals or off them, either
// convention at the reversal instant (noise 0.1 µm): every height within 10 %; the reported σ
// honest over the 132 cases (rms of the errors in σ below 1.3, none beyond 4 σ).
TEST(SpikeShape, RecoveredOverWidthsAndSamplings) {
  int cases = 0;
  double z2 = 0.0;
  for (double step : {0.1, 0.5, 1.0}) {
    for (Decay decay : {Decay::kExponential, Decay::kGaussian}) {
      std::vector<double> widths = {2.3 * step, 4.7 * step};
      for (double w : {1.37, 4.1})
        if (w > 2.3 * step) widths.push_back(w);
      for (double w_deg : widths) {
        for (Runs runs : {Runs::kPair, Runs::kCcw, Runs::kCw}) {
          for (double offset : {0.0, 0.37}) {
            SpikeMachine m;
            m.decay = decay;
            m.height_um = decay == Decay::kExponential ? 4.6 : 3.7;
            m.step_deg = step;
            m.offset_steps = offset;
            m.width_s = w_deg / m.DegPerS();
            m.at_reversal = cases % 2 == 0 ? AtReversal::kPeak : AtReversal::kNothing;
            m.seed = static_cast<unsigned>(100 + cases++);
            SCOPED_TRACE("step " + std::to_string(step) + " " + ShapeName(decay) + " width " +
                         std::to_string(w_deg) + " runs " + std::to_string(static_cast<int>(runs)) +
                         " offset " + std::to_string(offset));
            const double z =
                ExpectSpike(test::DiagnoseTests(Tests(m, runs)), m, "reversal_spike_y", 4.0);
            z2 += z * z;
          }
        }
      }
    }
  }
  EXPECT_EQ(cases, 132);
  EXPECT_LT(std::sqrt(z2 / cases), 1.3);
}

// On the x axis beside a backlash of the same axis and a squareness: each recovered.
TEST(SpikeShape, BesideABacklashOfItsAxisAndASquareness) {
  for (unsigned seed : {3u, 4u}) {
    for (Decay decay : {Decay::kExponential, Decay::kGaussian}) {
      SpikeMachine m;
      m.axis = 0;
      m.decay = decay;
      m.height_um = 4.3;
      m.width_s = 0.06;
      m.radius_mm = 125.0;
      m.feed_mm_min = 1500.0;
      m.backlash_um = 2.2;
      m.squareness_um_per_m = 12.0;
      m.seed = seed;
      const auto r = test::DiagnoseTests(Tests(m, Runs::kPair));
      ExpectSpike(r, m, "reversal_spike_x");
      const auto* b = Named(r, "backlash_x");
      const auto* q = Named(r, "squareness");
      ASSERT_TRUE(b && q) << Describe(r);
      EXPECT_NEAR(b->value[0], 2.2, 0.22) << Describe(r);
      EXPECT_NEAR(q->value[0], 12.0, 0.6) << Describe(r);
    }
  }
}

// A spike narrower than the sampling resolves (0.6° at 1° steps: one sample after each reversal
// shows it) is not given a height; it is listed as such.
TEST(SpikeShape, NarrowerThanTheSamplesIsNotGivenAHeight) {
  for (AtReversal at : {AtReversal::kPeak, AtReversal::kNothing}) {
    SpikeMachine m;
    m.step_deg = 1.0;
    m.offset_steps = 0.29;
    m.at_reversal = at;
    m.width_s = 0.6 / m.DegPerS();
    const auto r = test::DiagnoseTests(Tests(m, Runs::kPair));
    EXPECT_EQ(Named(r, "reversal_spike_y"), nullptr) << Describe(r);
    bool listed = false;
    for (const auto& n : r.not_identifiable)
      listed = listed || n.rfind("reversal_spike_y (narrower than the samples resolve", 0) == 0;
    EXPECT_TRUE(listed) << Describe(r);
  }
}

// Where the decay shape is hard to tell (0.5° steps, a width of 2.3 steps, noise 0.4 µm), the
// reported σ of the height includes the doubt about the shape: over 16 noise realisations the
// errors in units of σ have an rms below 1.5 and none beyond 3.5.
TEST(SpikeShape, UncertaintyIncludesTheDoubtAboutTheShape) {
  double z2 = 0.0;
  int named = 0;
  for (unsigned seed = 0; seed < 16; ++seed) {
    SpikeMachine m;
    m.decay = seed % 2 == 0 ? Decay::kExponential : Decay::kGaussian;
    m.height_um = 3.7;
    m.step_deg = 0.5;
    m.noise_um = 0.4;
    m.width_s = 1.15 / m.DegPerS();
    m.seed = 300 + seed;
    const auto r = test::DiagnoseTests(Tests(m, Runs::kPair));
    const DiagnosisEntry* e = Named(r, "reversal_spike_y");
    if (!e) continue;
    ++named;
    const double z = (e->value[0] - m.height_um) / e->uncertainty[0];
    EXPECT_LT(std::abs(z), 3.5) << Describe(r);
    z2 += z * z;
  }
  ASSERT_GE(named, 8);
  EXPECT_LT(std::sqrt(z2 / named), 1.5);
}

}  // namespace
}  // namespace km::dbb
