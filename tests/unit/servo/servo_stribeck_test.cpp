// The shape of the Stribeck rise in the feed-drive analysis (analysis/servo/feed_drive.h). The
// thesis writes the LuGre model ([Fujita thesis] eqs. 4.1–4.2) with a Stribeck function g(v)
// whose form it leaves open; a drive whose rise is exponential, exp(−|v/v_s|), or steeper than
// a Gaussian, exp(−(v/v_s)⁴), read as a Gaussian gave v_s tens of σ off with a tiny σ. The
// independent simulator feed_truth integrates eqs. 4.1–4.2 with g(v) = F_c + (F_s − F_c)
// exp(−|v/v_s|^δ) by RK4 along an analytic motion; reversals at a gentle 20 mm/s² sampled at
// 1 kHz resolve the rise of a v_s of 0.5 mm/s. Every LuGre value must be within 3 σ of the
// truth or declared not identifiable, and here F_s and v_s must be determined.
#include <cmath>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "analysis/servo/feed_drive.h"
#include "ingest/servo_parser.h"
#include "tests/unit/servo/feed_truth.h"

namespace km::servo {
namespace {

namespace ft = feed_truth;

ft::Drive SlowRiseDrive(double exponent) {
  ft::Drive d;
  d.fc_N = 27.3;
  d.fs_N = 33.9;
  d.vs_mm_s = 0.5;
  d.stribeck_exponent = exponent;
  d.sigma0_N_per_um = 6.2;
  d.sigma1_N_s_per_mm = 4.1;
  d.sigma2_N_s_per_mm = 0.037;
  d.mass_kg = 37.0;
  d.offset_N = 9.0;
  d.slope_N_per_mm = 0.0;
  d.ripple_N = 2.2;
  d.ripple_mm = 41.0;
  d.ripple_phase_rad = 1.1;
  d.noise_N = 0.25;
  return d;
}

FeedDriveResult AnalyzeSlowReversals(const ft::Drive& d, unsigned seed,
                                     const std::vector<double>& speeds = {6.0, 15.0, 40.0}) {
  ft::Motion m = ft::BackAndForth(100.0, speeds);
  m.accel_mm_s2 = 20.0;
  m.sample_s = 1e-3;
  const ServoFile f = ingest::ParseServoFile(ft::ServoText(ft::Simulate(d, m, seed)), "x.txt");
  return AnalyzeFeedDrive({&f}, "X");
}

void ExpectWithinThreeSigma(const FeedDriveResult& r, const ft::Drive& d, const std::string& tag) {
  ASSERT_TRUE(r.lugre.has_value()) << tag << ": " << r.lugre_note;
  const auto& p = *r.lugre;
  const auto& e = *r.lugre_sigma;
  const auto& ok = r.lugre_identifiable;
  ASSERT_TRUE(ok.Fs_N && ok.vs_mm_s && ok.sigma0_N_per_um) << tag << ": " << r.lugre_note;
  EXPECT_NEAR(p.vs_mm_s, d.vs_mm_s, 3.0 * e.vs_mm_s) << tag;
  EXPECT_NEAR(p.Fs_N, d.fs_N, 3.0 * e.Fs_N) << tag;
  EXPECT_NEAR(p.sigma0_N_per_um, d.sigma0_N_per_um, 3.0 * e.sigma0_N_per_um) << tag;
  if (ok.sigma1_N_s_per_mm) {
    EXPECT_NEAR(p.sigma1_N_s_per_mm, d.sigma1_N_s_per_mm, 3.0 * e.sigma1_N_s_per_mm) << tag;
  }
  EXPECT_NEAR(r.coulomb_N, d.fc_N, 3.0 * r.coulomb_sigma_N) << tag;
  // Determined to better than a tenth: the σ is honest, not merely wide.
  EXPECT_LT(e.vs_mm_s, 0.1 * d.vs_mm_s) << tag;
}

// An exponential rise (δ = 1): read as a Gaussian, v_s came out 0.86 ± 0.005 mm/s (+70 σ).
TEST(ServoStribeck, ExponentialRiseRecoversItsSpeed) {
  const ft::Drive d = SlowRiseDrive(1.0);
  const FeedDriveResult r = AnalyzeSlowReversals(d, 31);
  ExpectWithinThreeSigma(r, d, "exponent 1");
  ASSERT_TRUE(r.lugre.has_value());
  EXPECT_NEAR(r.lugre->stribeck_exponent, 1.0, 3.0 * r.lugre_sigma->stribeck_exponent);
  EXPECT_NE(r.lugre_note.find("not Gaussian"), std::string::npos) << r.lugre_note;
}

// A rise steeper than a Gaussian (δ = 4): read as a Gaussian, v_s came out 0.39 mm/s, F_s high.
TEST(ServoStribeck, SteepRiseRecoversItsSpeed) {
  const ft::Drive d = SlowRiseDrive(4.0);
  const FeedDriveResult r = AnalyzeSlowReversals(d, 32);
  ExpectWithinThreeSigma(r, d, "exponent 4");
  ASSERT_TRUE(r.lugre.has_value());
  EXPECT_NEAR(r.lugre->stribeck_exponent, 4.0, 3.0 * r.lugre_sigma->stribeck_exponent);
}

// The Gaussian rise of the LuGre paper stays a Gaussian: δ = 2 reported, v_s right.
TEST(ServoStribeck, GaussianRiseStaysGaussian) {
  const ft::Drive d = SlowRiseDrive(2.0);
  const FeedDriveResult r = AnalyzeSlowReversals(d, 33);
  ExpectWithinThreeSigma(r, d, "exponent 2");
  ASSERT_TRUE(r.lugre.has_value());
  EXPECT_NEAR(r.lugre->stribeck_exponent, 2.0, 3.0 * r.lugre_sigma->stribeck_exponent);
}

// The Lorentzian rise of Hess and Soom, 1/(1 + (v/v_s)²), which no δ reproduces: fitted as
// exp(−|v/v_s|^δ) alone, v_s came out 0.27 ± 0.03 mm/s (−9 σ) and F_s 41.4 ± 1.0 N (+7 σ), its
// long tail in the slow strokes read as Coulomb friction. Both forms are fitted, each with its
// own tail taken out of the steady strokes; the Lorentzian fits clearly better and is named.
TEST(ServoStribeck, LorentzianRiseIsRecognised) {
  ft::Drive d = SlowRiseDrive(2.0);
  d.lorentzian = true;
  const FeedDriveResult r = AnalyzeSlowReversals(d, 5);
  ExpectWithinThreeSigma(r, d, "lorentzian");
  ASSERT_TRUE(r.lugre.has_value());
  EXPECT_EQ(r.lugre->stribeck_form, LugreParameters::Form::kLorentzian);
  EXPECT_LT(r.lugre_form_delta_chi2, -9.0);
  EXPECT_NE(r.lugre_note.find("Lorentzian"), std::string::npos) << r.lugre_note;
}

// Strokes at 4, 8 and 16 mm/s, slow enough to feel the rise's tail in their steady part: F_s and
// v_s determined (the rise passes over tens of samples at 20 mm/s²) and right for the Gaussian
// and the Lorentzian (before: v_s 0.35 ± 0.03 mm/s, −5 σ, for the Lorentzian).
TEST(ServoStribeck, SlowStrokesDetermineTheRise) {
  for (const bool lorentzian : {false, true}) {
    ft::Drive d = SlowRiseDrive(2.0);
    d.lorentzian = lorentzian;
    const FeedDriveResult r = AnalyzeSlowReversals(d, lorentzian ? 33 : 31, {4.0, 8.0, 16.0});
    ExpectWithinThreeSigma(r, d, lorentzian ? "slow lorentzian" : "slow gaussian");
  }
}

// Where the reversals cannot tell the forms apart (ramps of 100 mm/s², the rise within ten
// samples) the σ cover both forms' values: v_s within 3 σ, or declared not identifiable.
TEST(ServoStribeck, IndistinctFormsWidenTheSigma) {
  ft::Drive d = SlowRiseDrive(2.0);
  d.lorentzian = true;
  ft::Motion m = ft::BackAndForth(100.0, {4.0, 8.0, 16.0});
  m.accel_mm_s2 = 100.0;
  m.sample_s = 1e-3;
  const ServoFile f = ingest::ParseServoFile(ft::ServoText(ft::Simulate(d, m, 42)), "x.txt");
  const FeedDriveResult r = AnalyzeFeedDrive({&f}, "X");
  ASSERT_TRUE(r.lugre.has_value()) << r.lugre_note;
  EXPECT_TRUE(r.lugre_forms_comparable) << r.lugre_form_delta_chi2;
  EXPECT_NEAR(r.lugre->vs_mm_s, d.vs_mm_s, 3.0 * r.lugre_sigma->vs_mm_s);
  EXPECT_NEAR(r.lugre->Fs_N, d.fs_N, 3.0 * r.lugre_sigma->Fs_N);
  EXPECT_NE(r.lugre_note.find("comparably"), std::string::npos) << r.lugre_note;
}

}  // namespace
}  // namespace km::servo
