// The forward model of the rotary-axis R-test (analysis/rotary/rotary_model.h) against
// displacements derived by hand from the definitions (docs/methods.md §17.1), and its exact
// Jacobian against central differences.
#include <gtest/gtest.h>

#include <cmath>
#include <random>

#include "analysis/core/angles.h"
#include "analysis/rotary/rotary_model.h"

namespace km::rotary {
namespace {

using Eigen::Vector3d;

RotarySetup AcSetup(std::array<double, 3> sphere) {
  RotarySetup s;
  s.kinematics = Kinematics::kAcTrunnion;
  s.tilt_axis_mm = {{0.0, 0.0}};
  s.c_axis_mm = {{0.0, 0.0}};
  s.sphere_mm = sphere;
  return s;
}

void ExpectNear(const Vector3d& got, const Vector3d& want, double tol) {
  for (int k = 0; k < 3; ++k) EXPECT_NEAR(got(k), want(k), tol) << "component " << k;
}

TEST(RotaryModel, YocMovesTheSphereWhenCTurns) {
  // AC, only YOC = +10 µm: the actual C line passes through q = (0, 0.010, 0) mm, direction +Z.
  // Sphere s = (100, 0, 50) mm, C = +90° at A = 0 turns the table right-handed about +Z:
  // R (x, y, z) = (−y, x, z). Actual: q + R (s − q) = (0, 0.01, 0) + R (100, −0.01, 50)
  // = (0, 0.01, 0) + (0.01, 100, 50) = (0.01, 100.01, 50). Nominal: R s = (0, 100, 50).
  // Displacement (0.01, 0.01, 0) mm = (+10, +10, 0) µm.
  LocationErrors e{};
  e[5] = 10.0;  // YOC
  const auto d = PredictedDisplacement(AcSetup({{100.0, 0.0, 50.0}}), e, 0.0, 90.0 * kDeg);
  ExpectNear(d, Vector3d(10.0, 10.0, 0.0), 1e-9);
  // At C = 180°: R (x, y, z) = (−x, −y, z): (0, 0.01, 0) + (−100, 0.01, 50) − (−100, 0, 50)
  // = (0, 0.02, 0) mm: +20 µm in Y.
  ExpectNear(PredictedDisplacement(AcSetup({{100.0, 0.0, 50.0}}), e, 0.0, 180.0 * kDeg),
             Vector3d(0.0, 20.0, 0.0), 1e-9);
}

TEST(RotaryModel, PositiveAngleTurnsTheTableRightHanded) {
  // A sphere 100 mm above the A line (through the origin) at A = +90°: right-handed about +X
  // takes +Z to −Y, so the sphere goes to (0, −100, 0).
  const AxisLines nominal = ActualLines(AcSetup({{0.0, 0.0, 100.0}}), LocationErrors{});
  ExpectNear(SpherePosition(nominal, Vector3d(0.0, 0.0, 100.0), 90.0 * kDeg, 0.0),
             Vector3d(0.0, -100.0, 0.0), 1e-12);
  // C = +90° takes +X to +Y.
  ExpectNear(SpherePosition(nominal, Vector3d(100.0, 0.0, 0.0), 0.0, 90.0 * kDeg),
             Vector3d(0.0, 100.0, 0.0), 1e-12);
  // BC: B = +90° right-handed about +Y takes +Z to +X.
  RotarySetup bc = AcSetup({{0.0, 0.0, 100.0}});
  bc.kinematics = Kinematics::kBcTrunnion;
  ExpectNear(SpherePosition(ActualLines(bc, LocationErrors{}), Vector3d(0.0, 0.0, 100.0),
                            90.0 * kDeg, 0.0),
             Vector3d(100.0, 0.0, 0.0), 1e-12);
}

TEST(RotaryModel, BoaTiltsTheALine) {
  // AC, only BOA = β = 10 µrad: the A direction is (1, 0, −β) = R_y(β) X, so the actual turn is
  // R_y(β) R_x(θ) R_y(−β). Sphere r = (200, 0, 100) mm (A line through the origin), θ = +90°:
  // R_y(−β) r ≈ (200 − 100β, 0, 100 + 200β); R_x(90°) (x, y, z) = (x, −z, y) gives
  // (200 − 100β, −100 − 200β, 0); R_y(β) (x, y, z) ≈ (x + βz, y, z − βx) gives
  // (200 − 100β, −100 − 200β, −200β). Nominal (200, −100, 0): displacement
  // (−100β, −200β, −200β) mm = (−1, −2, −2) µm (to first order; the rest is of order β²·200 mm =
  // 2e-5 µm).
  LocationErrors e{};
  e[2] = 10.0;  // BOA
  ExpectNear(PredictedDisplacement(AcSetup({{200.0, 0.0, 100.0}}), e, 90.0 * kDeg, 0.0),
             Vector3d(-1.0, -2.0, -2.0), 1e-4);
}

TEST(RotaryModel, CLineIsCarriedByTheTilt) {
  // AC, only XOC = +10 µm, C = 180° then A = 90°. At zero tilt C moves the sphere by
  // (I − R_z(180°)) (0.01, 0, 0) mm = (0.02, 0, 0) mm; the A turn about X leaves an X
  // displacement as it is: +20 µm in X at any A.
  LocationErrors e{};
  e[4] = 10.0;  // XOC
  ExpectNear(PredictedDisplacement(AcSetup({{50.0, 30.0, 80.0}}), e, 90.0 * kDeg, 180.0 * kDeg),
             Vector3d(20.0, 0.0, 0.0), 1e-9);
  // YOC = +10 µm instead: (0, 0.02, 0) mm at zero tilt, which A = +90° turns to (0, 0, 0.02).
  LocationErrors f{};
  f[5] = 10.0;
  ExpectNear(PredictedDisplacement(AcSetup({{50.0, 30.0, 80.0}}), f, 90.0 * kDeg, 180.0 * kDeg),
             Vector3d(0.0, 0.0, 20.0), 1e-9);
}

TEST(RotaryModel, JacobianMatchesCentralDifferences) {
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> err(-40.0, 40.0), angle(-3.0, 3.0);
  for (const auto k : {Kinematics::kAcTrunnion, Kinematics::kBcTrunnion}) {
    RotarySetup s;
    s.kinematics = k;
    s.tilt_axis_mm = {{12.0, -40.0}};
    s.c_axis_mm = {{3.0, -7.0}};
    s.sphere_mm = {{120.0, -60.0, 90.0}};
    LocationErrors e{};
    for (double& v : e) v = err(rng);
    const Vector3d sphere(120.0, -60.0, 90.0);
    for (int trial = 0; trial < 10; ++trial) {
      const double t = angle(rng), c = angle(rng);
      const Vector3d nominal = SpherePosition(ActualLines(s, LocationErrors{}), sphere, t, c);
      const auto lin = LinearisePose(k, ActualLines(s, e), sphere, nominal, t, c);
      ExpectNear(lin.displacement_um, PredictedDisplacement(s, e, t, c), 1e-9);
      for (std::size_t j = 0; j < kLocationErrorCount; ++j) {
        LocationErrors up = e, down = e;
        up[j] += 0.5;
        down[j] -= 0.5;
        const Vector3d fd =
            (PredictedDisplacement(s, up, t, c) - PredictedDisplacement(s, down, t, c)) / 1.0;
        ExpectNear(lin.jacobian.col(Eigen::Index(j)), fd, 1e-7);
      }
    }
  }
}

}  // namespace
}  // namespace km::rotary
