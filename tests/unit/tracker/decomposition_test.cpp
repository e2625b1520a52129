// Recover-the-truth tests of the geometric decomposition of a volumetric error map.
#include <gtest/gtest.h>

#include <random>

#include "analysis/core/errors.h"
#include "analysis/tracker/tracker_selfcal.h"
#include "analysis/tracker/tracker_sim.h"
#include "analysis/tracker/volumetric_decomposition.h"
#include "tests/unit/tracker/tracker_test_util.h"

namespace km::tracker {
namespace {

const double* PolyTerm(const GeometricDecomposition& d, char axis, char dir, int order) {
  for (const auto& t : d.terms) {
    if (t.axis == axis && t.direction == dir && t.order == order) return &t.value_um;
  }
  return nullptr;
}

TEST(VolumetricDecomposition, RecoversComponentsOfAnErrorMap) {
  // The map itself with 0.2 µm noise and an arbitrary small rigid motion (which the
  // decomposition must absorb): scales, squareness and polynomial terms within 3σ and 10 %.
  for (unsigned seed : {1u, 2u, 3u}) {
    SCOPED_TRACE(seed);
    std::mt19937 rng(seed);
    std::normal_distribution<double> g(0.0, 1.0);
    std::uniform_real_distribution<double> u(-3.0, 3.0);
    const Eigen::Vector3d centre(300, 200, 250);
    const auto pts = GridPoints(centre, 400.0, 6);
    MachineErrorModel m = test::FewMicronMachine(centre, 400.0);
    m.scale_ppm = {12 + u(rng), -8 + u(rng), 10 + u(rng)};
    m.squareness_um_per_m = {15 + u(rng), -12 + u(rng), 9 + u(rng)};
    const Eigen::Vector3d w(3e-6 * g(rng), 3e-6 * g(rng), 3e-6 * g(rng));  // rad
    const Eigen::Vector3d t(2 * g(rng), 2 * g(rng), 2 * g(rng));           // µm
    std::vector<Eigen::Vector3d> err;
    for (const auto& p : pts) {
      err.push_back(m.ErrorUm(p) + t + 1e3 * w.cross(p - centre) +
                    0.2 * Eigen::Vector3d(g(rng), g(rng), g(rng)));
    }
    const auto d = DecomposeVolumetricError(pts, err);
    for (int a = 0; a < 3; ++a) {
      EXPECT_NEAR(d.scale_ppm(a), m.scale_ppm(a),
                  std::max(0.1 * std::abs(m.scale_ppm(a)), 3 * d.scale_sigma_ppm(a)));
      EXPECT_LT(std::abs(d.scale_ppm(a) - m.scale_ppm(a)), 0.1 * std::abs(m.scale_ppm(a)));
      EXPECT_LT(std::abs(d.squareness_um_per_m(a) - m.squareness_um_per_m(a)),
                0.1 * std::abs(m.squareness_um_per_m(a)));
      EXPECT_LT(std::abs(d.squareness_um_per_m(a) - m.squareness_um_per_m(a)),
                4 * d.squareness_sigma_um_per_m(a) + 1e-9);
    }
    // The simulated squareness tilts one axis only: half of it is a rotation.
    const Eigen::Vector3d rot_from_squareness(
        m.squareness_um_per_m(1) / 2, m.squareness_um_per_m(2) / 2, m.squareness_um_per_m(0) / 2);
    for (int a = 0; a < 3; ++a) {
      EXPECT_NEAR(d.rotation_urad(a), 1e6 * w(a) + rot_from_squareness(a), 0.35);
    }
    ASSERT_NE(PolyTerm(d, 'x', 'y', 2), nullptr);
    EXPECT_NEAR(*PolyTerm(d, 'x', 'y', 2), 1.5, 0.15);
    EXPECT_NEAR(*PolyTerm(d, 'y', 'y', 3), -0.8, 0.15);
    EXPECT_NEAR(*PolyTerm(d, 'z', 'x', 2), 1.0, 0.15);
    EXPECT_NEAR(*PolyTerm(d, 'z', 'z', 2), 0.0, 0.15);
    EXPECT_NEAR(d.sigma_um, 0.2, 0.03);
    // The model reproduces the map up to the rigid motion and noise.
    const auto rt = d.rotation_urad;
    double s = 0;
    for (std::size_t i = 0; i < pts.size(); ++i) {
      const Eigen::Vector3d model = EvaluateDecomposition(d, pts[i]) + d.translation_um +
                                    1e-3 * rt.cross(pts[i] - d.centre_mm);
      s += (model - err[i]).squaredNorm();
    }
    EXPECT_NEAR(std::sqrt(s / (3.0 * pts.size())), d.residual_rms_um, 1e-9);
  }
}

TEST(VolumetricDecomposition, EndToEndFromTrackerSurvey) {
  // [Tracker paper] set-up on a 400 mm volume: scale and squareness recovered within 10 %.
  for (unsigned seed : {1u, 2u, 3u}) {
    SCOPED_TRACE(seed);
    auto o = test::MakeSetup(400.0, 6, 4, seed);
    o.machine.scale_ppm = {25, -20, 30};
    o.machine.squareness_um_per_m = {30, -25, 20};
    const auto sim = SimulateTrackerSurvey(o);
    const auto r = SelfCalibrate(sim.readings);
    const auto d =
        DecomposeVolumetricError(o.commanded_mm, r.volumetric_error_um, {}, &r.error_covariance);
    const auto naive = DecomposeVolumetricError(o.commanded_mm, r.volumetric_error_um);
    EXPECT_TRUE(d.propagated);
    EXPECT_FALSE(naive.propagated);
    for (int a = 0; a < 3; ++a) {
      // The propagated σ accounts for the tracker-induced correlation of the point errors.
      EXPECT_LT(std::abs(d.scale_ppm(a) - o.machine.scale_ppm(a)), 4 * d.scale_sigma_ppm(a));
      EXPECT_LT(std::abs(d.squareness_um_per_m(a) - o.machine.squareness_um_per_m(a)),
                4 * d.squareness_sigma_um_per_m(a));
      EXPECT_NEAR(d.scale_ppm(a), naive.scale_ppm(a), 1e-9);
      EXPECT_LT(std::abs(d.scale_ppm(a) - o.machine.scale_ppm(a)),
                0.1 * std::abs(o.machine.scale_ppm(a)))
          << a << " " << d.scale_ppm.transpose();
      EXPECT_LT(std::abs(d.squareness_um_per_m(a) - o.machine.squareness_um_per_m(a)),
                0.1 * std::abs(o.machine.squareness_um_per_m(a)))
          << a << " " << d.squareness_um_per_m.transpose();
    }
  }
}

TEST(VolumetricDecomposition, PlanarMapFixesWhatItCannotSee) {
  const Eigen::Vector3d centre(0, 0, 0);
  std::vector<Eigen::Vector3d> pts, err;
  MachineErrorModel m;
  m.half_range_mm = {100, 100, 1};
  m.scale_ppm = {10, -5, 0};
  m.squareness_um_per_m = {20, 0, 0};
  for (int i = 0; i < 7; ++i) {
    for (int j = 0; j < 7; ++j) {
      pts.push_back({-100.0 + 200.0 * i / 6, -100.0 + 200.0 * j / 6, 0.0});
      err.push_back(m.ErrorUm(pts.back()));
    }
  }
  const auto d = DecomposeVolumetricError(pts, err);
  EXPECT_NEAR(d.scale_ppm.x(), 10, 1e-6);
  EXPECT_NEAR(d.scale_ppm.y(), -5, 1e-6);
  EXPECT_NEAR(d.squareness_um_per_m.x(), 20, 1e-6);
  EXPECT_EQ(d.scale_ppm.z(), 0.0);
  bool z_fixed = false;
  for (const auto& f : d.fixed) z_fixed |= f.rfind("scale_z", 0) == 0;
  EXPECT_TRUE(z_fixed);
}

TEST(VolumetricDecomposition, RefusesTooFewPoints) {
  std::vector<Eigen::Vector3d> pts{{0, 0, 0}, {1, 0, 0}, {0, 1, 0}};
  std::vector<Eigen::Vector3d> err(3, Eigen::Vector3d::Zero());
  EXPECT_THROW(DecomposeVolumetricError(pts, err), NotObservable);
  DecompositionOptions bad;
  bad.max_order = 0;
  EXPECT_THROW(bad.Check(), InvalidInput);
}

}  // namespace
}  // namespace km::tracker

namespace km::tracker {
namespace {

TEST(VolumetricDecomposition, PropagatedSigmaMatchesMonteCarlo) {
  // Same geometry, 40 noise draws: the scatter of the recovered scale and squareness matches
  // the propagated σ (within a factor 1.6; 40 draws give ±11 % on a standard deviation).
  auto o = test::MakeSetup(100.0, 5, 4, 2);
  const int draws = 40;
  Eigen::MatrixXd est(draws, 6);
  Eigen::VectorXd sig = Eigen::VectorXd::Zero(6);
  for (int k = 0; k < draws; ++k) {
    o.seed = 1000 + static_cast<unsigned>(k);
    const auto sim = SimulateTrackerSurvey(o);
    const auto r = SelfCalibrate(sim.readings);
    const auto d =
        DecomposeVolumetricError(o.commanded_mm, r.volumetric_error_um, {}, &r.error_covariance);
    est.row(k) << d.scale_ppm.transpose(), d.squareness_um_per_m.transpose();
    sig.head<3>() += d.scale_sigma_ppm / draws;
    sig.tail<3>() += d.squareness_sigma_um_per_m / draws;
  }
  for (int c = 0; c < 6; ++c) {
    const double mean = est.col(c).mean();
    const double sd = std::sqrt((est.col(c).array() - mean).square().sum() / (draws - 1));
    EXPECT_GT(sd, sig(c) / 1.6) << c;
    EXPECT_LT(sd, sig(c) * 1.6) << c;
  }
}

}  // namespace
}  // namespace km::tracker
