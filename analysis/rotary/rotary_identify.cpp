#include "analysis/rotary/rotary_identify.h"

#include <cmath>
#include <memory>
#include <utility>

#include <Eigen/Dense>

#include "analysis/core/angles.h"
#include "analysis/core/errors.h"
#include "analysis/core/option_check.h"
#include "analysis/rotary/rotary_model.h"

namespace km::rotary {
// Named rather than anonymous: Reidentification::Impl holds these types.
namespace identify_detail {

using Eigen::Index;
using Eigen::MatrixXd;
using Eigen::Vector3d;
using Eigen::VectorXd;

constexpr Index kN = static_cast<Index>(kLocationErrorCount);

// The poses as the solver uses them: angles in radians, the nominal sphere positions, the
// measured displacements stacked (x, y, z per pose).
struct PreparedTest {
  Kinematics kinematics = Kinematics::kAcTrunnion;
  Vector3d sphere_mm = Vector3d::Zero();
  std::vector<double> tilt_rad, c_rad;
  std::vector<Vector3d> nominal_mm;
  VectorXd measured_um;
};

PreparedTest Prepare(const RotaryTest& test) {
  if (test.poses.size() < 4) {
    throw InvalidInput("", 0, "poses",
                       "at least 4 poses are needed (the zero pose and three more), found " +
                           std::to_string(test.poses.size()));
  }
  PreparedTest p;
  p.kinematics = test.setup.kinematics;
  const auto& s = test.setup.sphere_mm;
  p.sphere_mm = Vector3d(s[0], s[1], s[2]);
  const AxisLines nominal = ActualLines(test.setup, LocationErrors{});
  p.measured_um.resize(Index(3 * test.poses.size()));
  for (std::size_t i = 0; i < test.poses.size(); ++i) {
    const auto& pose = test.poses[i];
    p.tilt_rad.push_back(pose.tilt_deg * kDeg);
    p.c_rad.push_back(pose.c_deg * kDeg);
    p.nominal_mm.push_back(SpherePosition(nominal, p.sphere_mm, p.tilt_rad[i], p.c_rad[i]));
    for (int k = 0; k < 3; ++k) p.measured_um(Index(3 * i) + k) = pose.d_um[std::size_t(k)];
  }
  if (!p.measured_um.allFinite() || !p.sphere_mm.allFinite()) {
    throw InvalidInput("", 0, "poses", "every value must be a finite number");
  }
  return p;
}

struct Linearisation {
  VectorXd model_um;
  MatrixXd jacobian;
};

Linearisation Linearise(const PreparedTest& p, const RotarySetup& setup, const VectorXd& x) {
  LocationErrors e{};
  for (Index j = 0; j < kN; ++j) e[std::size_t(j)] = x(j);
  const AxisLines lines = ActualLines(setup, e);
  const Index m = p.measured_um.size();
  Linearisation out{VectorXd(m), MatrixXd(m, kN)};
  for (std::size_t i = 0; i < p.nominal_mm.size(); ++i) {
    const PoseLinearisation l =
        LinearisePose(p.kinematics, lines, p.sphere_mm, p.nominal_mm[i], p.tilt_rad[i], p.c_rad[i]);
    out.model_um.segment<3>(Index(3 * i)) = l.displacement_um;
    out.jacobian.middleRows<3>(Index(3 * i)) = l.jacobian;
  }
  return out;
}

// What the first-order model determines: the column scales, the singular values and the
// directions kept (V_r) and not (V_n), in scaled coordinates.
struct Identifiability {
  VectorXd scale;
  VectorXd singular_values;
  MatrixXd kept, null;
  std::size_t rank = 0;
};

Identifiability Analyze(const MatrixXd& j0, double rank_tolerance) {
  Identifiability id;
  id.scale = j0.colwise().norm().transpose();
  for (Index j = 0; j < kN; ++j) {
    if (!(id.scale(j) > 1e-12)) id.scale(j) = 1.0;  // a column of zeros stays zero
  }
  const MatrixXd scaled = j0 * id.scale.cwiseInverse().asDiagonal();
  const Eigen::JacobiSVD<MatrixXd> svd(scaled, Eigen::ComputeThinV);
  id.singular_values = svd.singularValues();
  const double largest = id.singular_values(0);
  for (Index k = 0; k < id.singular_values.size(); ++k) {
    if (largest > 0.0 && id.singular_values(k) > rank_tolerance * largest) ++id.rank;
  }
  const Index r = Index(id.rank);
  id.kept = svd.matrixV().leftCols(r);
  id.null = svd.matrixV().rightCols(kN - r);
  return id;
}

struct Solution {
  VectorXd x = VectorXd::Zero(kN);
  Linearisation at;
  int iterations = 0;
  bool converged = false;
};

// Gauss–Newton over the determined directions from `start` (x and the model there): each step
// the least-squares solution of (J D⁻¹ V_r) z = measured − model, x += D⁻¹ V_r z.
Solution GaussNewton(const PreparedTest& p, const RotarySetup& setup, const Identifiability& id,
                     const IdentifyOptions& o, const VectorXd& measured_um, Solution s) {
  s.iterations = 0;
  s.converged = false;
  const MatrixXd to_x = id.scale.cwiseInverse().asDiagonal() * id.kept;  // z → x
  if (id.rank == 0) {
    s.converged = true;
    return s;
  }
  for (s.iterations = 1; s.iterations <= o.max_iterations; ++s.iterations) {
    const MatrixXd jr = s.at.jacobian * to_x;
    const VectorXd z = jr.colPivHouseholderQr().solve(measured_um - s.at.model_um);
    s.x += to_x * z;
    s.at = Linearise(p, setup, s.x);
    const double size = (id.scale.asDiagonal() * s.x).norm();
    if (z.norm() <= o.step_tolerance * (1.0 + size)) {
      s.converged = true;
      break;
    }
  }
  s.iterations = std::min(s.iterations, o.max_iterations);
  return s;
}

// D⁻¹ V_r (J_rᵀ J_r)⁻¹ V_rᵀ D⁻¹ at the solution: the covariance of the determined errors for
// readings of unit variance.
MatrixXd UnitCovariance(const Identifiability& id, const Solution& s) {
  if (id.rank == 0) return MatrixXd::Zero(kN, kN);
  const MatrixXd to_x = id.scale.cwiseInverse().asDiagonal() * id.kept;
  const MatrixXd jr = s.at.jacobian * to_x;
  const MatrixXd inv = (jr.transpose() * jr).ldlt().solve(MatrixXd::Identity(jr.cols(), jr.cols()));
  return to_x * inv * to_x.transpose();
}

double Rms(const VectorXd& v) {
  return v.size() ? std::sqrt(v.squaredNorm() / double(v.size())) : 0.0;
}

// s, the values and σ of the determined errors, the residuals.
void Report(const PreparedTest& p, const Identifiability& id, const Solution& s,
            const IdentifyOptions& o, RotaryIdentification& out) {
  const VectorXd residual = p.measured_um - s.at.model_um;
  const std::size_t dof = out.observations - id.rank;
  out.sigma_um = std::sqrt(residual.squaredNorm() / double(dof));
  out.measured_rms_um = Rms(p.measured_um);
  out.residual_rms_um = Rms(residual);
  const MatrixXd cov = out.sigma_um * out.sigma_um * UnitCovariance(id, s);
  for (Index j = 0; j < kN; ++j) {
    auto& e = out.errors[std::size_t(j)];
    // Every error is determined when no direction is undetermined (a row of an empty matrix
    // would point into no storage).
    e.identifiable = id.null.cols() == 0 || id.null.row(j).squaredNorm() <= o.null_share_tolerance;
    if (!e.identifiable) continue;
    e.value = s.x(j);
    e.sigma = std::sqrt(std::max(0.0, cov(j, j)));
  }
  for (std::size_t i = 0; i < out.poses; ++i) {
    const auto r = residual.segment<3>(Index(3 * i));
    out.residuals_um.push_back({{r(0), r(1), r(2)}});
  }
}

}  // namespace identify_detail

using namespace identify_detail;

void IdentifyOptions::Check() const {
  KM_OPTION_GE(max_iterations, 1);
  KM_OPTION_GT(step_tolerance, 0.0);
  KM_OPTION_IN_OPEN(rank_tolerance, 0.0, 1.0);
  KM_OPTION_IN_OPEN(null_share_tolerance, 0.0, 1.0);
}

RotaryIdentification IdentifyLocationErrors(const RotaryTest& test, const IdentifyOptions& o) {
  o.Check();
  const PreparedTest p = Prepare(test);
  Solution start;
  start.at = Linearise(p, test.setup, start.x);
  const Identifiability id = Analyze(start.at.jacobian, o.rank_tolerance);
  const Solution s = GaussNewton(p, test.setup, id, o, p.measured_um, std::move(start));
  RotaryIdentification out;
  out.kinematics = test.setup.kinematics;
  out.poses = test.poses.size();
  out.observations = 3 * out.poses;
  out.rank = id.rank;
  for (Index k = 0; k < id.singular_values.size(); ++k) {
    out.singular_values.push_back(id.singular_values(k));
  }
  if (id.rank > 0) out.condition = id.singular_values(0) / id.singular_values(Index(id.rank) - 1);
  out.not_separable = DescribeNullSpace(out.kinematics, id.null, id.scale, o.null_share_tolerance);
  out.iterations = s.iterations;
  out.converged = s.converged;
  Report(p, id, s, o, out);
  return out;
}

struct Reidentification::Impl {
  RotarySetup setup;
  IdentifyOptions options;
  PreparedTest prepared;
  Identifiability id;
  Solution base;
};

Reidentification::Reidentification(const RotaryTest& test, const IdentifyOptions& o)
    : impl_(std::make_unique<Impl>()) {
  o.Check();
  Impl& m = *impl_;
  m.setup = test.setup;
  m.options = o;
  m.prepared = Prepare(test);
  Solution start;
  start.at = Linearise(m.prepared, m.setup, start.x);
  m.id = Analyze(start.at.jacobian, o.rank_tolerance);
  m.base = GaussNewton(m.prepared, m.setup, m.id, o, m.prepared.measured_um, std::move(start));
}

Reidentification::~Reidentification() = default;

std::size_t Reidentification::Readings() const {
  return std::size_t(impl_->prepared.measured_um.size());
}

std::vector<double> Reidentification::MeasuredUm() const {
  const VectorXd& v = impl_->prepared.measured_um;
  return {v.data(), v.data() + v.size()};
}

std::array<bool, kLocationErrorCount> Reidentification::Identifiable() const {
  std::array<bool, kLocationErrorCount> out{};
  for (Index j = 0; j < kN; ++j) {
    out[std::size_t(j)] = impl_->id.null.cols() == 0 || impl_->id.null.row(j).squaredNorm() <=
                                                            impl_->options.null_share_tolerance;
  }
  return out;
}

LocationErrors Reidentification::Solve(std::span<const double> measured_um, bool* converged) const {
  const Impl& m = *impl_;
  if (measured_um.size() != Readings()) {
    throw InvalidInput("", 0, "readings", "3 readings per pose are needed");
  }
  const VectorXd measured = Eigen::Map<const VectorXd>(measured_um.data(), Index(Readings()));
  const Solution s = GaussNewton(m.prepared, m.setup, m.id, m.options, measured, m.base);
  if (converged) *converged = s.converged;
  LocationErrors out{};
  for (Index j = 0; j < kN; ++j) out[std::size_t(j)] = s.x(j);
  return out;
}

LocationErrors Reidentification::SigmaPerUnitReading() const {
  const MatrixXd cov = UnitCovariance(impl_->id, impl_->base);
  LocationErrors out{};
  for (Index j = 0; j < kN; ++j) out[std::size_t(j)] = std::sqrt(std::max(0.0, cov(j, j)));
  return out;
}

std::vector<std::array<double, 3>> ModelDisplacements(const RotaryTest& test,
                                                      const LocationErrors& errors) {
  std::vector<std::array<double, 3>> out;
  for (const auto& pose : test.poses) {
    const Vector3d d =
        PredictedDisplacement(test.setup, errors, pose.tilt_deg * kDeg, pose.c_deg * kDeg);
    out.push_back({{d(0), d(1), d(2)}});
  }
  return out;
}

}  // namespace km::rotary
