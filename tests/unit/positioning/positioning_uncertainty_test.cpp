// The uncertainty of the ISO 230-2 figures of a laser positioning test (docs/methods.md §16.3):
// first-order physics (a laser scale error moves E and M by u·span, a machine temperature by
// α·u_T·span, R not at all), the budget, the model at the estimates against the analysis, the
// file's rules, and every figure's U against an independent Monte Carlo written from the
// standard's definitions (tests/sim/positioning_uncertainty_truth.py) within 10 %.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "analysis/core/errors.h"
#include "analysis/positioning/air.h"
#include "analysis/positioning/figure_uncertainty.h"
#include "ingest/positioning_parser.h"
#include "tests/unit/expect_error.h"
#include "tests/unit/positioning/positioning_sim.h"
#include "usecases/positioning_report.h"

namespace km::positioning {
namespace {

using nlohmann::json;
using test::Truth;

std::vector<double> Evenly(double from, double to, int count) {
  std::vector<double> t;
  for (int i = 0; i < count; ++i) t.push_back(from + (to - from) * i / (count - 1));
  return t;
}

// The simulated file with header lines added before the column header.
std::string WithHeader(const Truth& t, const std::string& lines) {
  std::string text = test::SimulateFile(t);
  const auto at = text.find("run,direction");
  return text.insert(at, lines);
}

json Analyze(const std::string& text, const std::string& name = "u.txt") {
  return usecases::PositioningReportToJson(
      usecases::AnalyzePositioning(ingest::ParsePositioningFile(text, name)));
}

double FigureU(const json& j, const std::string& key) {
  return j["uncertainty"]["figures"][key]["u_um"].get<double>();
}

// |(d + x̄)_argmax − (d + x̄)_argmin| in µm over the given per-target means (both directions
// when `down` is given): what a relative scale error of 1 moves max − min by, to first order.
double ExtremeDistanceUm(const json& j, const std::vector<const char*>& keys, double datum_mm) {
  double hi = -1e300, lo = 1e300, d_hi = 0.0, d_lo = 0.0;
  const auto& tg = j["targets"];
  for (const char* key : keys) {
    for (std::size_t i = 0; i < tg["target_mm"].size(); ++i) {
      const double x = tg[key][i].get<double>();
      const double d = (tg["target_mm"][i].get<double>() - datum_mm) * 1000.0 + x;
      if (x > hi) hi = x, d_hi = d;
      if (x < lo) lo = x, d_lo = d;
    }
  }
  return std::abs(d_hi - d_lo);
}

Truth Axis1000() {
  Truth t;
  t.targets_mm = Evenly(0.0, 1000.0, 11);
  return t;
}

TEST(PositioningUncertainty, NothingStatedNothingPropagated) {
  const json j = Analyze(test::SimulateFile(Axis1000()));
  const json& u = j["uncertainty"];
  EXPECT_EQ(u["method"], "none: no input uncertainty stated");
  EXPECT_TRUE(u["figures"].empty());
  EXPECT_EQ(u["not_stated"].size(), 6u);
  EXPECT_FALSE(u.contains("draws"));
}

// u_laser_ppm alone: x̄' = x̄ + ε·(d + x̄), so u(E) = u_ε·|Δ(d + x̄)| between the targets of the
// largest and smallest mean, M alike over the bidirectional means; R scales by 1 + ε, so its u is
// R·u_ε ≈ 10⁻⁶ µm. Tolerance 2 %: more than 3 times the statistical error of u from 15 000 draws.
TEST(PositioningUncertainty, LaserScaleMovesTheSpan) {
  const double u_ppm = 0.5;
  const json j = Analyze(WithHeader(Axis1000(), "# u_laser_ppm: 0.5\n"));
  const json& u = j["uncertainty"];
  EXPECT_EQ(u["method"], "Monte Carlo (JCGM 101)");
  EXPECT_EQ(u["draws"], kPositioningDraws);
  EXPECT_EQ(u["seed"], kPositioningSeed);
  const double e_span = ExtremeDistanceUm(j, {"mean_up_um", "mean_down_um"}, 0.0);
  const double m_span = ExtremeDistanceUm(j, {"mean_bidirectional_um"}, 0.0);
  EXPECT_GT(e_span, 8e5);  // the extremes are far apart: the test means something
  EXPECT_NEAR(FigureU(j, "systematic_deviation_um"), u_ppm * 1e-6 * e_span,
              0.02 * u_ppm * 1e-6 * e_span);
  EXPECT_NEAR(FigureU(j, "mean_deviation_range_um"), u_ppm * 1e-6 * m_span,
              0.02 * u_ppm * 1e-6 * m_span);
  const double r = j["repeatability_um"].get<double>();
  EXPECT_NEAR(FigureU(j, "repeatability_um"), r * u_ppm * 1e-6, 0.05 * r * u_ppm * 1e-6);
  EXPECT_LT(FigureU(j, "repeatability_um"), 1e-5);
  const json& e = u["figures"]["systematic_deviation_um"];
  EXPECT_DOUBLE_EQ(e["U_um"].get<double>(), 2.0 * e["u_um"].get<double>());
  EXPECT_EQ(e["k"], 2.0);
  // The interval holds the figure; the GUM agrees for a figure linear in ε.
  EXPECT_LT(e["interval_um"][0].get<double>(), j["systematic_deviation_um"].get<double>());
  EXPECT_GT(e["interval_um"][1].get<double>(), j["systematic_deviation_um"].get<double>());
  EXPECT_NEAR(e["u_gum_um"].get<double>(), e["u_um"].get<double>(), 0.02 * e["u_um"].get<double>());
  ASSERT_EQ(e["budget"].size(), 1u);
  EXPECT_EQ(e["budget"][0]["input"], "u_laser_ppm");
  EXPECT_EQ(e["budget"][0]["unit"], "ppm");
  EXPECT_NEAR(e["budget"][0]["contribution_um"].get<double>(), e["u_um"].get<double>(),
              0.05 * e["u_um"].get<double>());
}

// u_material_temperature_c alone: the correction α·(T − 20)·d moves E by α·u_T·Δd; u_expansion
// alone by u_α·(T − 20)·Δd. Both together: the budget lists each, their quadrature sum is u.
TEST(PositioningUncertainty, MachineTemperatureMovesTheSpan) {
  Truth t = Axis1000();
  t.warm = true;  // 23 °C, α = 11.5 ppm/K
  const double alpha = t.expansion_ppm_per_k, dt = t.material_t_c - 20.0;
  const json jt = Analyze(WithHeader(t, "# u_material_temperature_c: 0.2\n"));
  const double span = std::abs(ExtremeDistanceUm(jt, {"mean_up_um", "mean_down_um"}, 0.0));
  const double want_t = alpha * 0.2 * span * 1e-6;  // about 2.3 µm over 1000 mm
  EXPECT_NEAR(FigureU(jt, "systematic_deviation_um"), want_t, 0.02 * want_t);
  // The scale of the readings is untouched: R and B do not move, u = 0 (not rounding), and the
  // GUM agrees everywhere.
  EXPECT_EQ(FigureU(jt, "repeatability_um"), 0.0);
  EXPECT_EQ(FigureU(jt, "reversal_value_um"), 0.0);
  EXPECT_TRUE(jt["uncertainty"]["warnings"].empty()) << jt["uncertainty"]["warnings"].dump();

  const json jb =
      Analyze(WithHeader(t, "# u_material_temperature_c: 0.2\n# u_expansion_ppm_per_k: 0.8\n"));
  const double want_a = 0.8 * dt * span * 1e-6;
  const json& e = jb["uncertainty"]["figures"]["systematic_deviation_um"];
  ASSERT_EQ(e["budget"].size(), 2u);
  EXPECT_EQ(e["budget"][0]["input"], "u_material_temperature_c");
  EXPECT_NEAR(e["budget"][0]["contribution_um"].get<double>(), want_t, 0.05 * want_t);
  EXPECT_EQ(e["budget"][1]["input"], "u_expansion_ppm_per_k");
  EXPECT_NEAR(e["budget"][1]["contribution_um"].get<double>(), want_a, 0.05 * want_a);
  EXPECT_NEAR(e["u_um"].get<double>(), std::hypot(want_t, want_a),
              0.02 * std::hypot(want_t, want_a));
  const auto& not_stated = jb["uncertainty"]["not_stated"];
  EXPECT_EQ(not_stated.size(), 4u);
}

// One draw at the inputs' estimates is the analysis itself: the model's figures equal the
// reported ones (raw readings, air and material corrected).
TEST(PositioningUncertainty, ModelAtTheEstimatesIsTheAnalysis) {
  Truth t = Axis1000();
  t.raw = true;
  t.warm = true;
  t.deviation_column = false;
  t.refractive_index = RefractiveIndexOfAir({t.air_t_c, t.air_p_pa, t.air_rh_pct, 632.991});
  const auto file = ingest::ParsePositioningFile(test::SimulateFile(t), "raw.txt");
  const auto report = usecases::AnalyzePositioning(file);
  const auto raw = EvaluatePositioning(file.readings);
  const auto inputs = PositioningMcInputs(file.corrections, {});
  std::vector<double> x, y(PositioningFigureKeys().size());
  for (const auto& in : inputs) x.push_back(in.estimate);
  PositioningModel(raw.targets, file.corrections)(x, y);
  const json j = usecases::PositioningReportToJson(report);
  for (std::size_t i = 0; i < 12; ++i) {
    EXPECT_NEAR(y[i], j[PositioningFigureKeys()[i]].get<double>(), 1e-8)
        << PositioningFigureKeys()[i];
  }
  EXPECT_NEAR(y[12], j["vdi3441"]["P_um"].get<double>(), 1e-8);
  EXPECT_NEAR(y[15], j["vdi3441"]["Pa_um"].get<double>(), 1e-8);
}

TEST(PositioningUncertainty, SameFileSameNumbers) {
  const std::string text = WithHeader(Axis1000(), "# u_laser_ppm: 0.3\n");
  EXPECT_EQ(Analyze(text)["uncertainty"], Analyze(text)["uncertainty"]);
}

// The air inputs act through the refractive index kinemetric applies to raw readings, the
// material ones through the correction to 20 °C: stated without them, the file is refused
// naming the key and its line.
TEST(PositioningUncertainty, InputsWithoutTheirCorrectionAreRefused) {
  const auto air = km::test::Expect<InvalidInput>([] {
    ingest::ParsePositioningFile(WithHeader(Axis1000(), "# u_air_temperature_c: 0.1\n"), "a.txt");
  });
  EXPECT_EQ(air.field(), "u_air_temperature_c");
  EXPECT_EQ(air.line(), 8u);
  EXPECT_TRUE(km::test::Contains(air.reason(), "u_laser_ppm"));
  const auto mat = km::test::Expect<InvalidInput>([] {
    ingest::ParsePositioningFile(WithHeader(Axis1000(), "# u_expansion_ppm_per_k: 0.5\n"), "m.txt");
  });
  EXPECT_EQ(mat.field(), "u_expansion_ppm_per_k");
  EXPECT_TRUE(km::test::Contains(mat.reason(), "material_temperature_c"));
  // Far beyond any instrument: a typing error, refused.
  const auto big = km::test::Expect<InvalidInput>([] {
    ingest::ParsePositioningFile(WithHeader(Axis1000(), "# u_laser_ppm: 5000\n"), "b.txt");
  });
  EXPECT_EQ(big.field(), "u_laser_ppm");
  EXPECT_EQ(big.line(), 8u);
}

// The file of the acceptance test: 21 targets over 700 mm, 5 runs, a pitch error, raw readings
// at 23.4 °C, 99 870 Pa, 41 %, a machine at 21.7 °C with α = 11.5 ppm/K, every input stated.
Truth AcceptanceTruth() {
  Truth t;
  t.targets_mm = Evenly(13.7, 713.7, 21);
  t.datum_mm = 5.3;
  t.slope_um_per_m = 11.3;
  t.amplitude_um = 2.7;
  t.period_mm = 127.3;
  t.reversal_um = 3.1;
  t.noise_um = 0.37;
  t.seed = 2311;
  t.raw = true;
  t.deviation_column = false;
  t.air_t_c = 23.4;
  t.air_p_pa = 99870.0;
  t.air_rh_pct = 41.0;
  t.wavelength_nm = 632.991;
  t.refractive_index = RefractiveIndexOfAir({23.4, 99870.0, 41.0, 632.991});
  t.warm = true;
  t.material_t_c = 21.7;
  t.expansion_ppm_per_k = 11.5;
  return t;
}

json IndependentMonteCarlo(const std::string& text) {
  const auto dir = std::filesystem::temp_directory_path() / "km_positioning_u_test";
  std::filesystem::create_directories(dir);
  const auto path = (dir / "acceptance.txt").string();
  std::ofstream(path) << text;
  const std::string cmd =
      "/usr/bin/python3 tests/sim/positioning_uncertainty_truth.py --draws 100000 '" + path + "'";
  FILE* p = popen(cmd.c_str(), "r");
  EXPECT_NE(p, nullptr);
  std::string out;
  char buf[4096];
  while (p && fgets(buf, sizeof buf, p)) out += buf;
  EXPECT_EQ(p ? pclose(p) : -1, 0) << out;
  return json::parse(out);
}

TEST(PositioningUncertainty, EveryFigureAgainstAnIndependentMonteCarlo) {
  const std::string text = WithHeader(AcceptanceTruth(),
                                      "# u_laser_ppm: 0.35\n# u_air_temperature_c: 0.12\n"
                                      "# u_air_pressure_pa: 35\n# u_air_humidity_pct: 6\n"
                                      "# u_material_temperature_c: 0.15\n"
                                      "# u_expansion_ppm_per_k: 0.6\n");
  const json got = Analyze(text, "acceptance.txt")["uncertainty"];
  const json want = IndependentMonteCarlo(text);
  EXPECT_TRUE(got["not_stated"].empty());
  for (const auto& key : PositioningFigureKeys()) {
    const json& g = got["figures"][key];
    const json& w = want[key];
    const double U = g["U_um"].get<double>(), U_ind = w["U_um"].get<double>();
    std::printf("%-30s U = %.6g µm, independent %.6g µm (%+.2f %%)\n", key.c_str(), U, U_ind,
                100.0 * (U - U_ind) / U_ind);
    EXPECT_NEAR(U, U_ind, 0.10 * U_ind) << key;
    EXPECT_NEAR(g["interval_um"][0].get<double>(), w["low_um"].get<double>(), 0.10 * U_ind) << key;
    EXPECT_NEAR(g["interval_um"][1].get<double>(), w["high_um"].get<double>(), 0.10 * U_ind) << key;
    EXPECT_EQ(g["budget"].size(), 6u) << key;
  }
  // The figures that scale with the span carry micrometres; the scatter-only ones nanometres
  // at most.
  EXPECT_GT(got["figures"]["systematic_deviation_um"]["U_um"].get<double>(), 0.1);
  EXPECT_LT(got["figures"]["repeatability_um"]["U_um"].get<double>(), 1e-4);
}

}  // namespace
}  // namespace km::positioning
