#include "analysis/servo/identify.h"

#include <algorithm>
#include <cmath>

#include "analysis/core/errors.h"
#include "analysis/core/parallel.h"
#include "analysis/servo/friction_states.h"
#include "analysis/servo/linear_lsq.h"

namespace km::servo {
namespace {

struct Track {
  const ServoFile* file = nullptr;
  std::vector<MotionSample> motion;
  std::vector<RowUse> moving;
  std::vector<SampleLoads> loads;  // the θ-free parts of the model at each sample
  FrictionPath path;
  std::vector<JointStates> states;  // the joints' ramp states; empty: unit(swing)
  const JointStates* StatesAt(std::size_t i) const { return states.empty() ? nullptr : &states[i]; }
};

// The joints' friction direction with the ramp λ (0: the swing's direction at once).
void SetRamp(std::vector<Track>& tracks, double ramp_mm) {
  ParallelFor(tracks.size(), [&](std::size_t k) {
    Track& t = tracks[k];
    t.states.clear();
    if (ramp_mm > 0.0) t.states = JointFrictionStates(t.path, ramp_mm);
  });
}

std::vector<Track> Tracks(const hexapod::HexapodGeometry& g, const hexapod::MachinePhysics& m,
                          const std::vector<ServoFile>& files, const IdentifyOptions& o) {
  for (const auto& f : files) {
    if (!f.hexapod) {
      throw InvalidInput(f.file, 0, "axis", "a feed-drive file is not a hexapod servo record");
    }
  }
  std::vector<Track> tracks(files.size());  // the files side by side
  ParallelFor(files.size(), [&](std::size_t k) {
    const ServoFile& f = files[k];
    Track& t = tracks[k];
    t.file = &f;
    t.motion = TrackMotion(g, f.samples, f.tool_length_mm);
    t.moving = UsableRows(t.motion, o.min_rate_fraction, o.reversal_skip_mm);
    t.path = PathOf(t.motion);
    t.loads.reserve(t.motion.size());
    for (const auto& s : t.motion) t.loads.push_back(PrepareSampleLoads(m, s, f.tool_length_mm));
  });
  return tracks;
}

// ĝ_j of eq. 3.12 (tension positive) with θ, and which joints carry friction with θ's t0, t1.
JointLoads Loads(const SampleLoads& p, const LoadVector& theta) {
  return JointLoadsOf(StaticGravity(p, theta), theta[kT0], theta[kT1]);
}

// The rows of sample i of t with the joints' loads `loads` (use.joints true): `a` and the force
// less the known part `b`, the rows not used zero. Returns how many rows are used.
int SampleRows(const Track& t, std::size_t i, const JointLoads& loads, bool inertia, LoadRows& a,
               hexapod::Vector6d& b, const JointStates* states) {
  const RowUse& use = t.moving[i];
  LoadRegressor(t.loads[i], t.motion[i], loads, use, inertia, a, b, states);
  int used = 0;
  for (int j = 0; j < 6; ++j) {
    if (use.Row(j)) {
      b[j] = t.file->samples[i].force_N[j] - b[j];
      ++used;
    } else {
      a.row(j).setZero();
      b[j] = 0.0;
    }
  }
  return used;
}

// The same with the loads at θ; none when the sample is not used.
int SampleRows(const Track& t, std::size_t i, const LoadVector& theta, bool inertia, LoadRows& a,
               hexapod::Vector6d& b, const JointStates* states) {
  const RowUse& use = t.moving[i];
  if (!use.joints) return 0;
  return SampleRows(t, i, Loads(t.loads[i], theta), inertia, a, b, states);
}

// The t0 and t1 columns of SampleRows alone with other joint states (the rows not used zero).
void JointRows(const Track& t, std::size_t i, const JointLoads& loads, LoadRows& a,
               const JointStates* states) {
  const RowUse& use = t.moving[i];
  JointColumns(t.loads[i], t.motion[i], loads, use, a, states);
  for (int j = 0; j < 6; ++j)
    if (!use.Row(j)) a.row(j).rightCols<2>().setZero();
}

// Sums of the products of the rows of many samples by blocks: a row j has the dense columns
// (masses, centre, strut mass, t0, t1) and one screw column, that of strut j.
class RowSums {
 public:
  static constexpr int kDense = kScrew1 + 2;
  void Add(const LoadRows& a, const hexapod::Vector6d& b) {
    Eigen::Matrix<double, 6, kDense> d;
    d << a.leftCols<kScrew1>(), a.rightCols<2>();
    dd_.noalias() += d.transpose().lazyProduct(d);
    db_.noalias() += d.transpose().lazyProduct(b);
    for (int j = 0; j < 6; ++j) {
      const double sj = a(j, kScrew1 + j);
      if (sj == 0.0) continue;
      ss_[j] += sj * sj;
      sd_.row(j) += sj * d.row(j);
      sb_[j] += sj * b[j];
    }
  }
  RowSums& operator+=(const RowSums& o) {
    dd_ += o.dd_;
    db_ += o.db_;
    sd_ += o.sd_;
    ss_ += o.ss_;
    sb_ += o.sb_;
    return *this;
  }
  void Into(NormalEquations& ne) const {
    const auto col = [](int k) { return k < kScrew1 ? k : kT0 + (k - kScrew1); };
    ne.ata.setZero();
    for (int k = 0; k < kDense; ++k) {
      ne.atb[col(k)] = db_[k];
      for (int l = 0; l < kDense; ++l) ne.ata(col(k), col(l)) = dd_(k, l);
    }
    for (int j = 0; j < 6; ++j) {
      ne.ata(kScrew1 + j, kScrew1 + j) = ss_[j];
      ne.atb[kScrew1 + j] = sb_[j];
      for (int k = 0; k < kDense; ++k)
        ne.ata(kScrew1 + j, col(k)) = ne.ata(col(k), kScrew1 + j) = sd_(j, k);
    }
  }

 private:
  Eigen::Matrix<double, kDense, kDense> dd_ = Eigen::Matrix<double, kDense, kDense>::Zero();
  Eigen::Matrix<double, kDense, 1> db_ = Eigen::Matrix<double, kDense, 1>::Zero();
  Eigen::Matrix<double, 6, kDense> sd_ = Eigen::Matrix<double, 6, kDense>::Zero();
  hexapod::Vector6d ss_ = hexapod::Vector6d::Zero(), sb_ = hexapod::Vector6d::Zero();
};

// Normal equations over every usable row with ĝ from θ. A strut's row is used when it moves.
// The tracks side by side, their sums added in order.
NormalEquations Accumulate(const std::vector<Track>& tracks, const LoadVector& theta,
                           bool inertia) {
  struct Part {
    RowSums sums;  // the rows of a sample at once; unused rows are zero
    double btb = 0.0;
    std::size_t rows = 0;
  };
  std::vector<Part> parts(tracks.size());
  ParallelFor(tracks.size(), [&](std::size_t k) {
    const Track& t = tracks[k];
    LoadRows a;
    hexapod::Vector6d b;
    for (std::size_t i = 0; i < t.motion.size(); ++i) {
      const int used = SampleRows(t, i, theta, inertia, a, b, t.StatesAt(i));
      if (used == 0) continue;
      parts[k].sums.Add(a, b);
      parts[k].btb += b.squaredNorm();
      parts[k].rows += static_cast<std::size_t>(used);
    }
  });
  RowSums sums;
  NormalEquations ne(kNumLoadParams);
  for (const Part& part : parts) {
    sums += part.sums;
    ne.btb += part.btb;
    ne.rows += part.rows;
  }
  sums.Into(ne);
  return ne;
}

void Residuals(const std::vector<Track>& tracks, const LoadVector& theta, bool inertia,
               IdentifyResult& r) {
  std::array<double, 6> ss{};
  LoadRows a;
  hexapod::Vector6d b;
  for (const auto& t : tracks) {
    for (std::size_t i = 0; i < t.motion.size(); ++i) {
      if (SampleRows(t, i, theta, inertia, a, b, t.StatesAt(i)) == 0) continue;
      const hexapod::Vector6d e_all = b - a * theta;
      for (int j = 0; j < 6; ++j) {
        if (!t.moving[i].Row(j)) continue;
        const double e = e_all[j];
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

// θ by least squares with the tracks' joint states, ĝ refreshed from the latest θ until θ
// settles (at most `iterations` passes, from `theta`).
struct Fit {
  LoadVector theta;
  LsqSolution sol;
  int iterations = 0;
};

Fit Solve(const hexapod::MachinePhysics& machine, const std::vector<Track>& tracks,
          const LoadVector& theta0, int iterations, const IdentifyOptions& options) {
  const LoadVector prior = ParametersOf(machine);
  const std::vector<bool> hold(kNumLoadParams, false);
  Fit f;
  f.theta = theta0;
  for (f.iterations = 1; f.iterations <= iterations; ++f.iterations) {
    const NormalEquations ne = Accumulate(tracks, f.theta, options.inertia);
    f.sol = SolveLeastSquares(ne, prior, hold, options.min_singular_ratio);
    const LoadVector next = f.sol.x;
    const bool settled = ((next - f.theta).cwiseAbs().array() <=
                          1e-6 * (1.0 + f.theta.cwiseAbs().array()) + 1e-3 * f.sol.sigma.array())
                             .all();
    f.theta = next;
    if (settled) break;
  }
  f.iterations = std::min(f.iterations, iterations);
  return f;
}

// The normal equations at θ with the joints' states of each ramp (0: unit(swing)), as
// Accumulate after SetRamp. Only the t0 and t1 columns depend on the ramp: the products of
// the other columns are summed once.
std::vector<NormalEquations> AccumulateRamps(const std::vector<Track>& tracks,
                                             const LoadVector& theta, bool inertia,
                                             const std::vector<double>& ramps) {
  static_assert(kT1 == kT0 + 1 && kNumLoadParams == kT1 + 1, "t0, t1 are the last columns");
  constexpr int kFixed = kT0;
  const std::size_t nr = ramps.size();
  Eigen::Matrix<double, kFixed, kFixed> ff = Eigen::Matrix<double, kFixed, kFixed>::Zero();
  Eigen::Matrix<double, kFixed, 1> fb = Eigen::Matrix<double, kFixed, 1>::Zero();
  std::vector<Eigen::Matrix<double, kFixed, 2>> fj(nr, Eigen::Matrix<double, kFixed, 2>::Zero());
  std::vector<Eigen::Matrix2d> jj(nr, Eigen::Matrix2d::Zero());
  std::vector<Eigen::Vector2d> jb(nr, Eigen::Vector2d::Zero());
  NormalEquations sums(kNumLoadParams);
  LoadRows a;
  hexapod::Vector6d b;
  std::vector<std::vector<JointStates>> states(nr);
  for (const auto& t : tracks) {
    for (std::size_t r = 0; r < nr; ++r) {
      states[r].clear();
      if (ramps[r] > 0.0) states[r] = JointFrictionStates(t.path, ramps[r]);
    }
    for (std::size_t i = 0; i < t.motion.size(); ++i) {
      if (!t.moving[i].joints) continue;
      // The ramp changes the joint columns only: the rest once.
      const JointLoads loads = Loads(t.loads[i], theta);
      for (std::size_t r = 0; r < nr; ++r) {
        const JointStates* st = states[r].empty() ? nullptr : &states[r][i];
        const auto fixed = a.leftCols<kFixed>();
        const auto joint = a.rightCols<2>();
        if (r == 0) {
          const int used = SampleRows(t, i, loads, inertia, a, b, st);
          if (used == 0) break;
          ff.noalias() += fixed.transpose().lazyProduct(fixed);
          fb.noalias() += fixed.transpose().lazyProduct(b);
          sums.btb += b.squaredNorm();
          sums.rows += static_cast<std::size_t>(used);
        } else {
          JointRows(t, i, loads, a, st);
        }
        fj[r].noalias() += fixed.transpose().lazyProduct(joint);
        jj[r].noalias() += joint.transpose().lazyProduct(joint);
        jb[r].noalias() += joint.transpose().lazyProduct(b);
      }
    }
  }
  std::vector<NormalEquations> out(nr, sums);
  for (std::size_t r = 0; r < nr; ++r) {
    out[r].ata << ff, fj[r], fj[r].transpose(), jj[r];
    out[r].atb << fb, jb[r];
  }
  return out;
}

// The joint ramp whose states, with θ refitted (ĝ held), leave the least residual over the
// identification's rows: a grid over log λ and the step. On circles no joint reverses, but the
// friction direction lags the turning swing by λ/(2 × the turn's radius); fitting θ with the
// swing's direction at once would bias the masses, and a ramp searched with θ held would then
// follow that bias.
double ProfileRamp(const hexapod::MachinePhysics& machine, const std::vector<Track>& tracks,
                   const LoadVector& theta0, const IdentifyOptions& options) {
  const std::vector<double> ramps{0.0, 0.02, 0.05, 0.1, 0.2, 0.3,  0.5, 0.7,
                                  1.0, 1.5,  2.0,  3.0, 5.0, 10.0, 20.0};
  const std::vector<NormalEquations> ne = AccumulateRamps(tracks, theta0, options.inertia, ramps);
  const LoadVector prior = ParametersOf(machine);
  const std::vector<bool> hold(kNumLoadParams, false);
  double best = 0.0, best_rss = INFINITY;
  for (std::size_t r = 0; r < ramps.size(); ++r) {
    const double rss = SolveLeastSquares(ne[r], prior, hold, options.min_singular_ratio).rss;
    if (rss < best_rss) {
      best_rss = rss;
      best = ramps[r];
    }
  }
  return best;
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
  std::vector<Track> tracks = Tracks(geometry, machine, files, options);
  IdentifyResult r;
  for (const auto& t : tracks) r.samples += t.motion.size();
  Fit fit = Solve(machine, tracks, ParametersOf(machine), options.max_iterations, options);
  if (options.estimate_ramp) {
    // λ from the profile, refined with θ held (joint_ramp.h); θ again with that λ.
    const double coarse = ProfileRamp(machine, tracks, fit.theta, options);
    SetRamp(tracks, coarse);
    const Fit at = Solve(machine, tracks, fit.theta, options.max_iterations, options);
    std::vector<RampRecord> records;
    for (const auto& t : tracks)
      records.push_back({t.file, &t.motion, &t.moving, &t.loads, &t.path});
    r.joint_ramp = EstimateJointRamp(at.theta, records);
    SetRamp(tracks, r.joint_ramp->ramp_mm);
    fit = Solve(machine, tracks, at.theta, options.max_iterations, options);
  }
  const LoadVector& theta = fit.theta;
  const LsqSolution& sol = fit.sol;
  r.iterations = fit.iterations;
  r.theta = theta;
  r.sigma = sol.sigma;
  r.condition_number = sol.condition_number;
  r.residual_sigma_N = sol.sigma0;
  for (int p : sol.held) r.fixed.push_back({LoadParamName(p), HeldReason(p)});
  r.identified = WithParameters(machine, theta);
  CogSigma(sol, r);
  Residuals(tracks, theta, options.inertia, r);
  return r;
}

}  // namespace km::servo
