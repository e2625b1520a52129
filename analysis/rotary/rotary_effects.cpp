#include "analysis/rotary/rotary_effects.h"

#include <cmath>

#include <Eigen/Dense>

#include "analysis/core/angles.h"
#include "analysis/core/errors.h"
#include "analysis/rotary/rotary_model.h"

namespace km::rotary {
namespace {

using Eigen::Index;
using Eigen::MatrixXd;
using Eigen::Vector3d;
using Eigen::VectorXd;

constexpr std::size_t kCAngle = 8, kTiltAngle = 13, kRadial = 18, kDriftFirst = 26;

// ε(θ) = a1 cos θ + b1 sin θ + a2 cos 2θ + b2 sin 2θ + s·θ, µrad, from 5 parameters at `p`.
double AngleError(const EffectParameters& x, std::size_t p, double angle) {
  return x[p] * std::cos(angle) + x[p + 1] * std::sin(angle) + x[p + 2] * std::cos(2 * angle) +
         x[p + 3] * std::sin(2 * angle) + x[p + 4] * angle;
}

// The C line's point moved in its plane, µm: harmonics 2 and 3 of c.
Vector3d RadialMotion(const EffectParameters& x, double c) {
  Vector3d d = Vector3d::Zero();
  for (int k = 2; k <= 3; ++k) {
    const std::size_t p = kRadial + std::size_t(4 * (k - 2));
    d(0) += x[p] * std::cos(k * c) + x[p + 1] * std::sin(k * c);
    d(1) += x[p + 2] * std::cos(k * c) + x[p + 3] * std::sin(k * c);
  }
  return d;
}

Vector3d Displacement(const EffectPoses& p, const EffectParameters& x, std::size_t i) {
  LocationErrors loc{};
  for (std::size_t j = 0; j < kLocationErrorCount; ++j) loc[j] = x[j];
  const double h = p.hours[i];
  loc[4] += x[kDriftFirst] * h;
  loc[5] += x[kDriftFirst + 1] * h;
  loc[0] += x[kDriftFirst + 2] * h;
  loc[1] += x[kDriftFirst + 3] * h;
  AxisLines lines = ActualLines(p.setup, loc);
  lines.c.point_mm += 1e-3 * RadialMotion(x, p.c_rad[i]);
  const double c = p.c_rad[i] + 1e-6 * AngleError(x, kCAngle, p.c_rad[i]);
  const double t = p.tilt_rad[i] + 1e-6 * AngleError(x, kTiltAngle, p.tilt_rad[i]);
  const auto& s = p.setup.sphere_mm;
  const Vector3d sphere(s[0], s[1], s[2]);
  const Vector3d nominal =
      SpherePosition(ActualLines(p.setup, LocationErrors{}), sphere, p.tilt_rad[i], p.c_rad[i]);
  return 1e3 * (SpherePosition(lines, sphere, t, c) - nominal);
}

MatrixXd Jacobian(const EffectPoses& p, const EffectParameters& x,
                  const std::vector<std::size_t>& free) {
  MatrixXd j(p.measured_um.size(), Index(free.size()));
  for (std::size_t k = 0; k < free.size(); ++k) {
    EffectParameters plus = x, minus = x;
    plus[free[k]] += 1.0;
    minus[free[k]] -= 1.0;
    j.col(Index(k)) = 0.5 * (EffectReadings(p, plus) - EffectReadings(p, minus));
  }
  return j;
}

struct Directions {
  VectorXd scale;
  MatrixXd kept, null;
  std::size_t rank = 0;
};

Directions Analyze(const MatrixXd& j0) {
  Directions d;
  d.scale = j0.colwise().norm().transpose();
  for (Index k = 0; k < d.scale.size(); ++k) {
    if (!(d.scale(k) > 1e-12)) d.scale(k) = 1.0;
  }
  const Eigen::JacobiSVD<MatrixXd> svd(j0 * d.scale.cwiseInverse().asDiagonal(),
                                       Eigen::ComputeThinV);
  const VectorXd sv = svd.singularValues();
  for (Index k = 0; k < sv.size(); ++k) {
    if (sv(0) > 0.0 && sv(k) > 1e-8 * sv(0)) ++d.rank;
  }
  d.kept = svd.matrixV().leftCols(Index(d.rank));
  d.null = svd.matrixV().rightCols(sv.size() - Index(d.rank));
  return d;
}

void Uncertainty(const EffectPoses& p, const Directions& d, EffectFit& f) {
  const MatrixXd to_x = d.scale.cwiseInverse().asDiagonal() * d.kept;
  const MatrixXd jr = Jacobian(p, f.value, f.free) * to_x;
  const MatrixXd inv = (jr.transpose() * jr).ldlt().solve(MatrixXd::Identity(jr.cols(), jr.cols()));
  const MatrixXd cov = f.s_um * f.s_um * to_x * inv * to_x.transpose();
  for (std::size_t k = 0; k < f.free.size(); ++k) {
    const std::size_t j = f.free[k];
    f.determined[j] = d.null.cols() == 0 || d.null.row(Index(k)).squaredNorm() <= 1e-6;
    f.sigma[j] = f.determined[j] ? std::sqrt(std::max(0.0, cov(Index(k), Index(k)))) : 0.0;
  }
}

}  // namespace

ParameterRange EffectRange(RotaryEffect e) {
  switch (e) {
    case RotaryEffect::kCAngular:
      return {kCAngle, 5};
    case RotaryEffect::kTiltAngular:
      return {kTiltAngle, 5};
    case RotaryEffect::kCRadial:
      return {kRadial, 8};
    case RotaryEffect::kDrift:
      return {kDriftFirst, 4};
  }
  return {};
}

std::string EffectName(Kinematics k, RotaryEffect e) {
  switch (e) {
    case RotaryEffect::kCAngular:
      return "angular positioning error of C";
    case RotaryEffect::kTiltAngular:
      return std::string("angular positioning error of ") + TiltLetter(k);
    case RotaryEffect::kCRadial:
      return "radial error motion of C";
    case RotaryEffect::kDrift:
      return "thermal drift of the axis lines";
  }
  return {};
}

std::string ParameterKey(Kinematics k, std::size_t i) {
  const auto& names = LocationErrorNames(k);
  if (i < kLocationErrorCount) return std::string(names[i]) + (IsAngularError(i) ? "_urad" : "_um");
  static const char* kAngle[] = {"cos1_urad", "sin1_urad", "cos2_urad", "sin2_urad",
                                 "scale_urad_per_rad"};
  if (i < kTiltAngle) return "C_angle_" + std::string(kAngle[i - kCAngle]);
  if (i < kRadial) return std::string(1, TiltLetter(k)) + "_angle_" + kAngle[i - kTiltAngle];
  if (i < kDriftFirst) {
    static const char* kRad[] = {"x_cos", "x_sin", "y_cos", "y_sin"};
    const std::size_t r = i - kRadial;
    return "C_radial_" + std::string(kRad[r % 4]) + std::to_string(2 + r / 4) + "_um";
  }
  static const std::size_t kDriftOf[] = {4, 5, 0, 1};
  return "drift_" + std::string(names[kDriftOf[i - kDriftFirst]]) + "_um_per_h";
}

EffectPoses PrepareEffectPoses(const RotaryTest& test, const std::vector<double>& time_s) {
  const std::size_t n = test.poses.size();
  if (n < 4) throw InvalidInput("", 0, "poses", "at least 4 poses are needed");
  if (!time_s.empty() && time_s.size() != n) {
    throw InvalidInput("", 0, "time_s", "one time per pose is needed");
  }
  EffectPoses p;
  p.setup = test.setup;
  p.measured_um.resize(Index(3 * n));
  for (std::size_t i = 0; i < n; ++i) {
    p.tilt_rad.push_back(test.poses[i].tilt_deg * kDeg);
    p.c_rad.push_back(test.poses[i].c_deg * kDeg);
    p.hours.push_back(time_s.empty() ? 0.0 : (time_s[i] - time_s[0]) / 3600.0);
    for (int k = 0; k < 3; ++k)
      p.measured_um(Index(3 * i) + k) = test.poses[i].d_um[std::size_t(k)];
  }
  if (!p.measured_um.allFinite()) throw InvalidInput("", 0, "poses", "every value must be finite");
  return p;
}

VectorXd EffectReadings(const EffectPoses& p, const EffectParameters& x) {
  VectorXd out(p.measured_um.size());
  const Vector3d zero = Displacement(p, x, 0);
  for (std::size_t i = 0; i < p.tilt_rad.size(); ++i) {
    out.segment<3>(Index(3 * i)) = Displacement(p, x, i) - zero;
  }
  return out;
}

EffectFit FitEffects(const EffectPoses& p, const std::vector<std::size_t>& free) {
  EffectFit f;
  f.free = free;
  const Directions d = Analyze(Jacobian(p, f.value, free));
  const MatrixXd to_x = d.scale.cwiseInverse().asDiagonal() * d.kept;
  VectorXd r = p.measured_um - EffectReadings(p, f.value);
  for (int it = 0; it < 20 && d.rank > 0; ++it) {
    const MatrixXd jr = Jacobian(p, f.value, free) * to_x;
    const VectorXd step = to_x * jr.colPivHouseholderQr().solve(r);
    for (std::size_t k = 0; k < free.size(); ++k) f.value[free[k]] += step(Index(k));
    r = p.measured_um - EffectReadings(p, f.value);
    if ((d.scale.asDiagonal() * step).norm() <= 1e-10 * (1.0 + r.norm())) break;
  }
  const double m = double(r.size());
  f.rank = d.rank;
  f.rss = r.squaredNorm();
  f.s_um = std::sqrt(f.rss / std::max(1.0, m - double(d.rank)));
  f.rms_um = std::sqrt(f.rss / m);
  f.residual_um = r;
  if (d.rank > 0) Uncertainty(p, d, f);
  return f;
}

}  // namespace km::rotary
