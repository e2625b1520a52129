#include "analysis/servo/identify.h"

#include <algorithm>
#include <cmath>

#include "analysis/core/errors.h"
#include "analysis/servo/linear_lsq.h"

namespace km::servo {
namespace {

struct Track {
  const ServoFile* file = nullptr;
  std::vector<MotionSample> motion;
  std::vector<RowUse> moving;
};

std::vector<Track> Tracks(const hexapod::HexapodGeometry& g, const std::vector<ServoFile>& files,
                          const IdentifyOptions& o) {
  std::vector<Track> tracks;
  for (const auto& f : files) {
    if (!f.hexapod) {
      throw InvalidInput(f.file, 0, "axis", "a feed-drive file is not a hexapod servo record");
    }
    Track t;
    t.file = &f;
    t.motion = TrackMotion(g, f.samples, f.tool_length_mm);
    t.moving = UsableRows(t.motion, o.min_rate_fraction, o.reversal_skip_mm);
    tracks.push_back(std::move(t));
  }
  return tracks;
}

std::array<double, 6> AbsGravity(const hexapod::MachinePhysics& m, const LoadVector& theta,
                                 const MotionSample& s, double tool_length_mm) {
  const hexapod::Vector6d g = StaticGravity(m, theta, s, tool_length_mm);
  std::array<double, 6> out{};
  for (int j = 0; j < 6; ++j) out[j] = std::abs(g[j]);
  return out;
}

// Normal equations over every usable row with ĝ from θ. A strut's row is used when it moves.
NormalEquations Accumulate(const hexapod::MachinePhysics& m, const std::vector<Track>& tracks,
                           const LoadVector& theta, bool inertia) {
  NormalEquations ne(kNumLoadParams);
  LoadRows a;
  hexapod::Vector6d c;
  for (const auto& t : tracks) {
    for (std::size_t i = 0; i < t.motion.size(); ++i) {
      const auto& row_use = t.moving[i];
      MotionSample s = t.motion[i];
      if (!inertia) s.accel_mm_s2.setZero();
      LoadRegressor(m, s, t.file->tool_length_mm, AbsGravity(m, theta, s, t.file->tool_length_mm),
                    row_use, a, c);
      for (int j = 0; j < 6; ++j) {
        if (!row_use.Row(j)) continue;
        ne.Add(a.row(j), Eigen::Matrix<double, 1, 1>(t.file->samples[i].force_N[j] - c[j]));
      }
    }
  }
  return ne;
}

void Residuals(const hexapod::MachinePhysics& m, const std::vector<Track>& tracks,
               const LoadVector& theta, bool inertia, IdentifyResult& r) {
  std::array<double, 6> ss{};
  LoadRows a;
  hexapod::Vector6d c;
  for (const auto& t : tracks) {
    for (std::size_t i = 0; i < t.motion.size(); ++i) {
      MotionSample s = t.motion[i];
      if (!inertia) s.accel_mm_s2.setZero();
      LoadRegressor(m, s, t.file->tool_length_mm, AbsGravity(m, theta, s, t.file->tool_length_mm),
                    t.moving[i], a, c);
      const hexapod::Vector6d model = a * theta + c;
      for (int j = 0; j < 6; ++j) {
        if (!t.moving[i].Row(j)) continue;
        const double e = t.file->samples[i].force_N[j] - model[j];
        ss[j] += e * e;
        ++r.rows_used[j];
      }
    }
  }
  for (int j = 0; j < 6; ++j) {
    r.residual_rms_N[j] = r.rows_used[j] ? std::sqrt(ss[j] / r.rows_used[j]) : NAN;
  }
}

// σ of the centre of gravity c = c0 + (m_PΔc)/m_P by the delta method.
void CogSigma(const LsqSolution& s, IdentifyResult& r) {
  const double mp = s.x[kPlatformMass];
  for (int k = 0; k < 3; ++k) {
    const int i = kCogDx + k;
    if (mp == 0.0) {
      r.platform_cog_sigma_mm[k] = NAN;
      continue;
    }
    const double d_i = 1.0 / mp, d_m = -s.x[i] / (mp * mp);
    const double v = d_i * d_i * s.covariance(i, i) + d_m * d_m * s.covariance(0, 0) +
                     2.0 * d_i * d_m * s.covariance(i, 0);
    r.platform_cog_sigma_mm[k] = std::sqrt(std::max(0.0, v));
  }
}

std::string HeldReason(int p) {
  if (p >= kCogDx && p <= kCogDz) {
    return "the motions do not separate this coordinate of the centre of gravity from the "
           "platform mass (e.g. no tilted tests); held at the machine's value";
  }
  return "the motions do not separate this parameter from the others; held at the machine's "
         "value";
}

}  // namespace

void IdentifyOptions::Check() const {
  if (!(min_rate_fraction >= 0.0 && min_rate_fraction < 1.0)) {
    throw InvalidInput("", 0, "min_rate_fraction", "must be in [0, 1)");
  }
  if (!(reversal_skip_mm >= 0.0 && reversal_skip_mm < 1e3)) {
    throw InvalidInput("", 0, "reversal_skip_mm", "must be in [0, 1000) mm");
  }
  if (!(max_iterations >= 1 && max_iterations <= 1000)) {
    throw InvalidInput("", 0, "max_iterations", "must be in 1 … 1000");
  }
  if (!(min_singular_ratio > 0.0 && min_singular_ratio < 1.0)) {
    throw InvalidInput("", 0, "min_singular_ratio", "must be in (0, 1)");
  }
}

IdentifyResult IdentifyLoads(const hexapod::HexapodGeometry& geometry,
                             const hexapod::MachinePhysics& machine,
                             const std::vector<ServoFile>& files, const IdentifyOptions& options) {
  options.Check();
  if (files.empty()) throw InvalidInput("", 0, "FILE", "no servo file given");
  const std::vector<Track> tracks = Tracks(geometry, files, options);
  IdentifyResult r;
  for (const auto& t : tracks) r.samples += t.motion.size();
  const LoadVector prior = ParametersOf(machine);
  LoadVector theta = prior;
  const std::vector<bool> hold(kNumLoadParams, false);
  LsqSolution sol;
  for (r.iterations = 1; r.iterations <= options.max_iterations; ++r.iterations) {
    const NormalEquations ne = Accumulate(machine, tracks, theta, options.inertia);
    sol = SolveLeastSquares(ne, prior, hold, options.min_singular_ratio);
    const LoadVector next = sol.x;
    const bool settled = ((next - theta).cwiseAbs().array() <=
                          1e-6 * (1.0 + theta.cwiseAbs().array()) + 1e-3 * sol.sigma.array())
                             .all();
    theta = next;
    if (settled) break;
  }
  r.iterations = std::min(r.iterations, options.max_iterations);
  r.theta = theta;
  r.sigma = sol.sigma;
  r.condition_number = sol.condition_number;
  r.residual_sigma_N = sol.sigma0;
  for (int p : sol.held) r.fixed.push_back({LoadParamName(p), HeldReason(p)});
  r.identified = WithParameters(machine, theta);
  CogSigma(sol, r);
  Residuals(machine, tracks, theta, options.inertia, r);
  if (options.estimate_ramp) {
    r.joint_ramp = EstimateJointRamp(geometry, r.identified, files, options.min_rate_fraction,
                                     options.reversal_skip_mm);
  }
  return r;
}

}  // namespace km::servo
