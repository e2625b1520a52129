#include "analysis/servo/joint_ramp.h"

#include <algorithm>
#include <cmath>

#include <Eigen/Geometry>

#include "analysis/core/errors.h"
#include "analysis/core/minimize_1d.h"
#include "analysis/core/parallel.h"
#include "analysis/hexapod/joint_swing.h"

namespace km::servo {
namespace {

// One record prepared for the search: per sample the residual without joint friction, and
// the force per unit of each joint's direction state r_j (3 components), f_t,j / L_j at the
// identified torque f_t,j = t0 + t1·ĝ_j; its wrench reaches the struts through Γ⁻¹.
struct Prepared {
  std::vector<hexapod::Vector6d> residual;
  std::vector<std::array<bool, 6>> row;
  std::vector<std::array<double, 6>> per_state;
  RampRecord record;
};

Prepared Prepare(const LoadVector& theta, const RampRecord& rec) {
  const auto& motion = *rec.motion;
  const std::size_t n = motion.size();
  Prepared p;
  p.record = rec;
  p.residual.resize(n);
  p.row.resize(n);
  p.per_state.resize(n);
  LoadRows a;
  hexapod::Vector6d c;
  for (std::size_t i = 0; i < n; ++i) {
    const MotionSample& s = motion[i];
    const SampleLoads& sl = (*rec.loads)[i];
    const JointLoads loads = JointLoadsOf(StaticGravity(sl, theta), theta[kT0], theta[kT1]);
    RowUse u = (*rec.use)[i];
    u.joints = false;  // joint friction modelled here
    LoadRegressor(sl, s, loads, u, true, a, c);
    const hexapod::Vector6d model = a * theta + c;
    for (int j = 0; j < 6; ++j) {
      p.residual[i][j] = rec.file->samples[i].force_N[j] - model[j];
      // Settled screw friction and a moving tool tip (the joints' own ramps are the subject).
      p.row[i][j] = (*rec.use)[i].screw[j] && s.tip_speed_mm_s > 0.0;
      const double torque =
          hexapod::JointFrictionTorque(theta[kT0], theta[kT1], loads.gravity_N[j]);
      p.per_state[i][j] = torque * (1e3 / s.frame.length_mm[j]);
    }
  }
  return p;
}

// The strut forces of the joints' friction with the states r at sample i of p.
hexapod::Vector6d JointForces(const Prepared& p, std::size_t i, const JointStates& r) {
  const auto& frame = (*p.record.motion)[i].frame;
  Eigen::Vector3d force = Eigen::Vector3d::Zero(), moment = Eigen::Vector3d::Zero();
  for (int j = 0; j < 6; ++j) {
    const Eigen::Vector3d fj = -p.per_state[i][j] * r[j];
    force += fj;
    moment += frame.lever_mm[j].cross(fj);
  }
  hexapod::Vector6d w;
  w << force, moment;
  return (*p.record.loads)[i].gamma_inv * w;
}

// The joint states of one pass over a closed path from rest (InitialJointStates: its last
// ones are the states before the first sample), with each ramp of `lambdas`, the ramps stepped
// together; pass[i * lambdas.size() + k] after sample i with ramp k.
void FirstPass(const FrictionPath& path, const std::vector<double>& lambdas,
               std::vector<JointStates>& pass) {
  const std::size_t nl = lambdas.size(), n = path.swing_mm.size();
  pass.resize(n * nl);
  std::vector<JointStates> r(nl);
  for (auto& q : r) q.fill(Eigen::Vector3d::Zero());
  for (std::size_t i = 0; i < n; ++i) {
    for (std::size_t k = 0; k < nl; ++k) {
      StepJointStates(path, i, lambdas[k], r[k]);
      pass[i * nl + k] = r[k];
    }
  }
}

// The joint states at each sample with each ramp, stepped from the states before the first
// sample. On a closed path a joint whose state equals (to the last bit) the first pass's at the
// same sample follows that pass from there on (the same steps from the same state): its states
// are read from `pass` instead of stepped again.
class RampStates {
 public:
  RampStates(const FrictionPath& path, const std::vector<double>& lambdas,
             std::vector<JointStates>& pass)
      : path_(path), lambdas_(lambdas), pass_(pass), states_(lambdas.size()) {
    const std::size_t nl = lambdas.size();
    followed_.assign(nl, {});
    if (!path.closed) {
      for (std::size_t k = 0; k < nl; ++k) states_[k] = InitialJointStates(path, lambdas[k]);
      return;
    }
    FirstPass(path, lambdas, pass);
    const std::size_t n = path.swing_mm.size();
    for (std::size_t k = 0; k < nl && n > 0; ++k) states_[k] = pass[(n - 1) * nl + k];
  }
  // Steps every ramp's states over sample i.
  void Step(std::size_t i) {
    const std::size_t nl = lambdas_.size();
    for (std::size_t k = 0; k < nl; ++k) {
      for (int j = 0; j < 6; ++j) {
        Eigen::Vector3d& r = states_[k][j];
        if (followed_[k][j]) {
          r = pass_[i * nl + k][j];
          continue;
        }
        r = hexapod::StepSwingState(r, path_.unit[i][j], path_.swing_mm[i][j], lambdas_[k]);
        followed_[k][j] = path_.closed && r == pass_[i * nl + k][j];
      }
    }
  }
  const JointStates& Of(std::size_t k) const { return states_[k]; }

 private:
  const FrictionPath& path_;
  const std::vector<double>& lambdas_;
  const std::vector<JointStates>& pass_;
  std::vector<JointStates> states_;
  std::vector<std::array<bool, 6>> followed_;
};

// The residual sum of squares of one record with each ramp of `lambdas` (added to `ss`) and its
// rows (added to `count`).
void RecordRss(const Prepared& p, const std::vector<double>& lambdas, std::vector<double>& ss,
               std::size_t& count) {
  const std::size_t nl = lambdas.size();
  std::vector<JointStates> pass;
  RampStates states(*p.record.path, lambdas, pass);
  for (std::size_t i = 0; i < p.residual.size(); ++i) {
    states.Step(i);
    const auto& row = p.row[i];
    if (std::none_of(row.begin(), row.end(), [](bool b) { return b; })) continue;
    for (std::size_t k = 0; k < nl; ++k) {
      const hexapod::Vector6d e = p.residual[i] - JointForces(p, i, states.Of(k));
      for (int j = 0; j < 6; ++j)
        if (row[j]) ss[k] += e[j] * e[j];
    }
    for (int j = 0; j < 6; ++j) count += row[j] ? 1 : 0;
  }
}

// Residual sum of squares with each ramp λ of `lambdas` (λ ≤ 0: the direction of the swing at
// once), all in one pass over the samples: the records side by side, their sums added in order.
std::vector<double> Rss(const std::vector<Prepared>& recs, const std::vector<double>& lambdas,
                        std::size_t* rows = nullptr) {
  const std::size_t nl = lambdas.size();
  std::vector<std::vector<double>> parts(recs.size(), std::vector<double>(nl, 0.0));
  std::vector<std::size_t> counts(recs.size(), 0);
  ParallelFor(recs.size(),
              [&](std::size_t r) { RecordRss(recs[r], lambdas, parts[r], counts[r]); });
  std::vector<double> ss(nl, 0.0);
  std::size_t count = 0;
  for (std::size_t r = 0; r < recs.size(); ++r) {
    for (std::size_t k = 0; k < nl; ++k) ss[k] += parts[r][k];
    count += counts[r];
  }
  if (rows) *rows = count;
  return ss;
}

double Rss(const std::vector<Prepared>& recs, double lambda) {
  return Rss(recs, std::vector<double>{lambda})[0];
}

// The minimum of the RSS over log λ in the grid's best bracket, to `tol`. When the grid's best is
// an end of the range and the RSS rises from it over `tol`, the minimum (unimodal in the bracket,
// as Brent's search takes it) is at that end to within `tol`: the end is returned after one pass,
// where Brent's search would creep to the end by golden-section steps (about 30 passes).
double RampMinimum(const std::vector<Prepared>& recs, const std::vector<double>& grid_rss, int best,
                   int grid, double lo, double hi, double tol) {
  auto rss = [&](double log_lambda) { return Rss(recs, std::exp(log_lambda)); };
  if (best == 0 && rss(lo + tol) >= grid_rss[1]) return lo;
  if (best == grid && rss(hi - tol) >= grid_rss[static_cast<std::size_t>(grid) + 1]) return hi;
  return BrentMinimize(rss, lo + (hi - lo) * std::max(best - 1, 0) / grid,
                       lo + (hi - lo) * std::min(best + 1, grid) / grid, tol)
      .x;
}

}  // namespace

RampEstimate EstimateJointRamp(const hexapod::HexapodGeometry& geometry,
                               const hexapod::MachinePhysics& physics,
                               const std::vector<ServoFile>& files, double min_rate_fraction,
                               double reversal_skip_mm) {
  const std::size_t n = files.size();
  std::vector<std::vector<MotionSample>> motion(n);
  std::vector<std::vector<RowUse>> use(n);
  std::vector<std::vector<SampleLoads>> loads(n);
  std::vector<FrictionPath> paths(n);
  std::vector<RampRecord> records(n);
  for (std::size_t k = 0; k < n; ++k) {
    const ServoFile& f = files[k];
    motion[k] = TrackMotion(geometry, f.samples, f.tool_length_mm);
    use[k] = UsableRows(motion[k], min_rate_fraction, reversal_skip_mm);
    for (const auto& s : motion[k])
      loads[k].push_back(PrepareSampleLoads(physics, s, f.tool_length_mm));
    paths[k] = PathOf(motion[k]);
    records[k] = {&f, &motion[k], &use[k], &loads[k], &paths[k]};
  }
  return EstimateJointRamp(ParametersOf(physics), records);
}

RampEstimate EstimateJointRamp(const LoadVector& theta, const std::vector<RampRecord>& records) {
  std::vector<Prepared> recs;
  for (const auto& r : records) recs.push_back(Prepare(theta, r));
  RampEstimate out;
  // Grid over log λ (and no ramp), then Brent's search in the best bracket.
  const double lo = std::log(0.01), hi = std::log(20.0);
  const int grid = 24;
  std::vector<double> lambdas{0.0};
  for (int k = 0; k <= grid; ++k) lambdas.push_back(std::exp(lo + (hi - lo) * k / grid));
  const std::vector<double> grid_rss = Rss(recs, lambdas, &out.rows);
  if (out.rows == 0) throw NotObservable("servo loads: no moving sample for the joint ramp");
  const double step = grid_rss[0];
  int best = 0;
  double best_rss = INFINITY;
  for (int k = 0; k <= grid; ++k) {
    const double rss = grid_rss[static_cast<std::size_t>(k) + 1];
    if (rss < best_rss) {
      best_rss = rss;
      best = k;
    }
  }
  // The minimum in the best bracket to 10⁻⁷ in log λ (Brent: a pass over every sample each).
  const double x = RampMinimum(recs, grid_rss, best, grid, lo, hi, 1e-7);
  out.ramp_mm = std::exp(x);
  // σ of λ from the curvature of the RSS in λ: var = 2 σ̂² / RSS''.
  const double h = 0.05 * out.ramp_mm;
  const std::vector<double> at =
      Rss(recs, {out.ramp_mm, out.ramp_mm + h, std::max(out.ramp_mm - h, 1e-6)});
  const double rss = at[0];
  const double rows = static_cast<double>(out.rows);
  out.residual_rms_N = std::sqrt(rss / rows);
  out.step_residual_rms_N = std::sqrt(step / rows);
  const double d2 = (at[1] - 2.0 * rss + at[2]) / (h * h);
  const double s2 = rss / std::max(rows - 1.0, 1.0);
  out.sigma_mm = d2 > 0.0 ? std::sqrt(2.0 * s2 / d2) : NAN;
  return out;
}

}  // namespace km::servo
