#include "analysis/servo/joint_resistance.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <map>

#include <Eigen/Geometry>
#include <Eigen/LU>

#include "analysis/core/errors.h"
#include "analysis/hexapod/joint_swing.h"
#include "analysis/servo/hexapod_motion.h"
#include "analysis/servo/linear_lsq.h"
#include "analysis/servo/load_model.h"

namespace km::servo {
namespace {

constexpr int kParams = 18;  // f0_j, τb_j, τp_j
using FrictionRows = Eigen::Matrix<double, 6, kParams>;

struct ResistanceTrack {
  const ServoFile* file = nullptr;
  std::vector<MotionSample> motion;
  std::vector<RowUse> use;
};

// The direction of the strut's rotation that the platform joint resists: l_j × unit(swing).
Eigen::Vector3d TurnAxis(const MotionSample& s, int k) {
  const Eigen::Vector3d& v = s.swing_mm_s[k];
  const double speed = v.norm();
  if (!(speed > 0.0)) return Eigen::Vector3d::Zero();
  return s.frame.unit[k].cross(v / speed);
}

// `shape[k]`: the resistance of leg k at this pose relative to its mean (the load dependence
// t0 + t1·ĝ_k of the machine's friction model, [PM-600 report] eq. 3.12).
FrictionRows FrictionRegressor(const MotionSample& s, const std::array<double, 6>& shape) {
  FrictionRows a = FrictionRows::Zero();
  Eigen::Matrix<double, 6, 12> w;
  for (int k = 0; k < 6; ++k) {
    const hexapod::Vector6d base = JointFrictionWrench(s, k);
    const Eigen::Vector3d turn = TurnAxis(s, k);
    w.col(k) = shape[k] * base;
    w.col(6 + k) = shape[k] * base;
    w.block<3, 1>(3, 6 + k) += shape[k] * 1e3 * turn;  // N·m → N·mm
  }
  a.rightCols<12>() = Eigen::PartialPivLU<hexapod::Matrix6d>(s.frame.gamma).solve(w);
  for (int j = 0; j < 6; ++j) {
    const double r = s.strut_rate_mm_s[j];
    a(j, j) = r > 0.0 ? -1.0 : (r < 0.0 ? 1.0 : 0.0);
  }
  return a;
}

double PoseDistance(const HexapodSample& a, const HexapodSample& b) {
  double d = 0.0;
  for (int k = 0; k < 3; ++k) {
    d += (a.tip_mm[k] - b.tip_mm[k]) * (a.tip_mm[k] - b.tip_mm[k]);
    const double ang = 10.0 * (a.abc_deg[k] - b.abc_deg[k]);  // 0.1° counts as 1 mm
    d += ang * ang;
  }
  return std::sqrt(d);
}

// CW/CCW pairs of tracks by test id (and tool length).
std::vector<std::pair<const ResistanceTrack*, const ResistanceTrack*>> Pairs(
    const std::vector<ResistanceTrack>& tracks) {
  std::map<std::string, std::pair<const ResistanceTrack*, const ResistanceTrack*>> by_id;
  for (const auto& t : tracks) {
    auto& p = by_id[t.file->test_id];
    if (t.file->direction == "cw" && !p.first) p.first = &t;
    if (t.file->direction == "ccw" && !p.second) p.second = &t;
  }
  std::vector<std::pair<const ResistanceTrack*, const ResistanceTrack*>> out;
  for (const auto& [id, p] : by_id) {
    if (p.first && p.second && p.first->file->tool_length_mm == p.second->file->tool_length_mm) {
      out.push_back(p);
    }
  }
  return out;
}

std::string Fixed(double v, int digits = 2) {
  char buf[48];
  std::snprintf(buf, sizeof buf, "%.*f", digits, v);
  return buf;
}

struct Accumulated {
  NormalEquations ne{kParams};
  std::array<double, 6> gravity_sum{};  // ĝ_j, tension positive
  std::size_t gravity_samples = 0;
};

// The CCW sample at the pose of each usable CW sample (or -1).
// The CCW pose matching a CW sample: between samples k and k2 of the CCW record, weight w on
// k2 (the point of that segment nearest to the CW pose); k < 0 when none is within match_mm.
struct Match {
  long k = -1, k2 = -1;
  double w = 0.0;
};

double Distance(const HexapodSample& a, const HexapodSample& b, const HexapodSample& c, double w) {
  HexapodSample m = b;
  for (int q = 0; q < 3; ++q) {
    m.tip_mm[q] = (1 - w) * b.tip_mm[q] + w * c.tip_mm[q];
    m.abc_deg[q] = (1 - w) * b.abc_deg[q] + w * c.abc_deg[q];
  }
  return PoseDistance(a, m);
}

std::vector<Match> Matches(const ResistanceTrack& cw, const ResistanceTrack& ccw, double match_mm) {
  std::vector<Match> out(cw.motion.size());
  const auto& cs = ccw.file->samples;
  const std::size_t n = cs.size();
  if (n == 0) return out;
  // CCW samples by x: a match lies within match_mm plus one sample step of the CW pose.
  std::vector<std::size_t> by_x(n);
  double step = 0.0;
  for (std::size_t k = 0; k < n; ++k) {
    by_x[k] = k;
    if (k > 0) step = std::max(step, PoseDistance(cs[k], cs[k - 1]));
  }
  std::sort(by_x.begin(), by_x.end(),
            [&](std::size_t a, std::size_t b) { return cs[a].tip_mm[0] < cs[b].tip_mm[0]; });
  const double window = match_mm + step;
  for (std::size_t i = 0; i < cw.motion.size(); ++i) {
    if (!cw.use[i].joints) continue;
    const HexapodSample& p = cw.file->samples[i];
    std::size_t best = 0;
    double best_d = INFINITY;
    auto it = std::lower_bound(by_x.begin(), by_x.end(), p.tip_mm[0] - window,
                               [&](std::size_t k, double x) { return cs[k].tip_mm[0] < x; });
    for (; it != by_x.end() && cs[*it].tip_mm[0] <= p.tip_mm[0] + window; ++it) {
      const double d = PoseDistance(p, cs[*it]);
      if (d < best_d) {
        best_d = d;
        best = *it;
      }
    }
    if (!(best_d <= window)) continue;
    Match m{static_cast<long>(best), static_cast<long>(best), 0.0};
    // The nearer neighbour, and the point between them nearest to the CW pose.
    for (const std::size_t k2 : {best > 0 ? best - 1 : best, best + 1 < n ? best + 1 : best}) {
      if (k2 == best) continue;
      Eigen::Vector3d a(cs[best].tip_mm.data()), b(cs[k2].tip_mm.data()), x(p.tip_mm.data());
      const double len2 = (b - a).squaredNorm();
      const double w = len2 > 0.0 ? std::clamp((x - a).dot(b - a) / len2, 0.0, 1.0) : 0.0;
      const double d = Distance(p, cs[best], cs[k2], w);
      if (d < best_d) {
        best_d = d;
        m = {static_cast<long>(best), static_cast<long>(k2), w};
      }
    }
    const auto k = static_cast<std::size_t>(m.k), k2 = static_cast<std::size_t>(m.k2);
    if (best_d <= match_mm && ccw.use[k].joints && ccw.use[k2].joints) out[i] = m;
  }
  return out;
}

bool LoadDependent(const hexapod::MachinePhysics& m) {
  return m.has_friction && m.base_joint_torque_Nm > 0.0 && m.base_joint_torque_per_N_m > 0.0;
}

std::array<double, 6> Gravity(const hexapod::MachinePhysics& m, const ResistanceTrack& t,
                              std::size_t i) {
  const hexapod::Vector6d g =
      StaticGravity(m, ParametersOf(m), t.motion[i], t.file->tool_length_mm);
  std::array<double, 6> out{};
  for (int j = 0; j < 6; ++j) out[j] = g[j];
  return out;
}

// The machine's joint friction torque at the axial gravity ĝ (eq. 3.12).
double ModelTorque(const hexapod::MachinePhysics& m, double gravity_N) {
  return hexapod::JointFrictionTorque(m.base_joint_torque_Nm, m.base_joint_torque_per_N_m,
                                      gravity_N);
}

// First pass: the mean axial gravity of each strut over the matched poses.
void AddGravity(const hexapod::MachinePhysics& m, const ResistanceTrack& cw,
                const std::vector<Match>& match, Accumulated& acc) {
  for (std::size_t i = 0; i < cw.motion.size(); ++i) {
    if (match[i].k < 0) continue;
    const auto g = Gravity(m, cw, i);
    for (int j = 0; j < 6; ++j) acc.gravity_sum[j] += g[j];
    ++acc.gravity_samples;
  }
}

void AddPair(const hexapod::MachinePhysics& m, const ResistanceTrack& cw,
             const ResistanceTrack& ccw, const std::vector<Match>& match, Accumulated& acc) {
  const bool load = LoadDependent(m) && acc.gravity_samples > 0;
  for (std::size_t i = 0; i < cw.motion.size(); ++i) {
    if (match[i].k < 0) continue;
    const auto k = static_cast<std::size_t>(match[i].k), k2 = static_cast<std::size_t>(match[i].k2);
    const double w = match[i].w;
    std::array<double, 6> shape{};
    shape.fill(1.0);
    if (load) {
      const auto g = Gravity(m, cw, i);
      for (int j = 0; j < 6; ++j) {
        const double mean = acc.gravity_sum[j] / static_cast<double>(acc.gravity_samples);
        const double at_mean = ModelTorque(m, mean);
        shape[j] = at_mean > 0.0 ? ModelTorque(m, g[j]) / at_mean : 1.0;
      }
    }
    const FrictionRows a = FrictionRegressor(cw.motion[i], shape) -
                           (1 - w) * FrictionRegressor(ccw.motion[k], shape) -
                           w * FrictionRegressor(ccw.motion[k2], shape);
    for (int j = 0; j < 6; ++j) {
      if (!cw.use[i].screw[j] || !ccw.use[k].screw[j] || !ccw.use[k2].screw[j]) continue;
      const double ccw_force =
          (1 - w) * ccw.file->samples[k].force_N[j] + w * ccw.file->samples[k2].force_N[j];
      const double df = cw.file->samples[i].force_N[j] - ccw_force;
      acc.ne.Add(a.row(j), Eigen::Matrix<double, 1, 1>(df));
    }
  }
}

std::array<double, 6> References(const hexapod::MachinePhysics& m, const Accumulated& acc,
                                 const JointOptions& o, const std::array<double, 6>& estimate,
                                 std::string& source) {
  std::array<double, 6> ref{};
  if (o.reference_Nm) {
    source = "given";
    return *o.reference_Nm;
  }
  if (m.has_friction && m.base_joint_torque_Nm + m.base_joint_torque_per_N_m > 0.0 &&
      acc.gravity_samples > 0) {
    source = "machine model";
    for (int j = 0; j < 6; ++j) {
      ref[j] = ModelTorque(m, acc.gravity_sum[j] / static_cast<double>(acc.gravity_samples));
    }
    return ref;
  }
  source = "median of the legs";
  std::array<double, 6> sorted = estimate;
  std::sort(sorted.begin(), sorted.end());
  ref.fill(0.5 * (sorted[2] + sorted[3]));
  return ref;
}

}  // namespace

void JointOptions::Check() const {
  if (!(min_rate_fraction >= 0.0 && min_rate_fraction < 1.0)) {
    throw InvalidInput("", 0, "min_rate_fraction", "must be in [0, 1)");
  }
  if (!(reversal_skip_mm >= 0.0 && reversal_skip_mm < 1e3)) {
    throw InvalidInput("", 0, "reversal_skip_mm", "must be in [0, 1000) mm");
  }
  if (!(match_mm > 0.0 && match_mm < 1e3)) {
    throw InvalidInput("", 0, "match_mm", "must be in (0, 1000) mm");
  }
  if (!(min_singular_ratio > 0.0 && min_singular_ratio < 1.0)) {
    throw InvalidInput("", 0, "min_singular_ratio", "must be in (0, 1)");
  }
  if (!(level2_ratio > 0.0 && level3_ratio > level2_ratio && level3_ratio < 1e6)) {
    throw InvalidInput("", 0, "level3_ratio", "limits must satisfy 0 < level 2 < level 3");
  }
  if (!(increase_warn > 0.0 && increase_stop > increase_warn && increase_stop < 1e6)) {
    throw InvalidInput("", 0, "increase_stop", "limits must satisfy 0 < warn < stop");
  }
  for (const auto* v : {&reference_Nm, &previous_Nm}) {
    if (!*v) continue;
    for (double x : **v) {
      if (!(x > 0.0 && x < 1e6)) {
        throw InvalidInput("", 0, v == &reference_Nm ? "reference_Nm" : "previous_Nm",
                           "resistances must be positive and below 1e6 N·m");
      }
    }
  }
}

void GradeLeg(LegHealth& leg, const JointOptions& o) {
  leg.ratio = leg.reference_Nm > 0.0 ? leg.resistance_Nm / leg.reference_Nm : 0.0;
  leg.level = leg.ratio > o.level3_ratio ? 3 : (leg.ratio > o.level2_ratio ? 2 : 1);
  const std::string who = "leg " + std::to_string(leg.leg);
  leg.evidence = who + ": " + Fixed(leg.resistance_Nm) + " ± " + Fixed(leg.sigma_Nm) +
                 " N·m = " + Fixed(leg.ratio) + " × the reference " + Fixed(leg.reference_Nm) +
                 " N·m (level 2 above " + Fixed(o.level2_ratio) + " ×, level 3 above " +
                 Fixed(o.level3_ratio) + " ×)";
  if (leg.previous_Nm) {
    const double prev = *leg.previous_Nm;
    const double growth = leg.resistance_Nm - prev;
    const bool significant = growth > 3.0 * leg.sigma_Nm;
    int inc_level = 1;
    if (significant && growth > o.increase_stop * prev) {
      inc_level = 3;
    } else if (significant && growth > o.increase_warn * prev) {
      inc_level = 2;
    }
    leg.evidence += "; since the previous estimate " + Fixed(prev) + " N·m it changed by " +
                    Fixed(100.0 * growth / prev, 0) + " % (level 2 above +" +
                    Fixed(100.0 * o.increase_warn, 0) + " %, level 3 above +" +
                    Fixed(100.0 * o.increase_stop, 0) + " %, when above 3 σ)";
    leg.level = std::max(leg.level, inc_level);
  }
  const auto& b = leg.joints[0];
  const auto& p = leg.joints[1];
  if (p.identified && b.identified) {
    leg.evidence += "; base joint " + Fixed(b.resistance_Nm) + " ± " + Fixed(b.sigma_Nm) +
                    ", platform joint " + Fixed(p.resistance_Nm) + " ± " + Fixed(p.sigma_Nm) +
                    " N·m";
  } else if (leg.split_requested) {
    leg.evidence += "; base and platform joints not separable by these motions";
  } else {
    leg.evidence += "; base and platform joints taken together";
  }
}

JointsResult EstimateJointResistance(const hexapod::HexapodGeometry& geometry,
                                     const hexapod::MachinePhysics& machine,
                                     const std::vector<ServoFile>& files,
                                     const JointOptions& options) {
  options.Check();
  std::vector<ResistanceTrack> tracks;
  for (const auto& f : files) {
    if (!f.hexapod) throw InvalidInput(f.file, 0, "axis", "not a hexapod servo record");
    ResistanceTrack t;
    t.file = &f;
    t.motion = TrackMotion(geometry, f.samples, f.tool_length_mm);
    t.use = UsableRows(t.motion, options.min_rate_fraction, options.reversal_skip_mm);
    tracks.push_back(std::move(t));
  }
  const auto pairs = Pairs(tracks);
  if (pairs.empty()) {
    throw InvalidInput(files.empty() ? "" : files.front().file, 0, "direction",
                       "no CW and CCW circle with the same test_id and tool length");
  }
  JointsResult r;
  Accumulated acc;
  std::vector<std::vector<Match>> matches;
  for (const auto& [cw, ccw] : pairs) {
    matches.push_back(Matches(*cw, *ccw, options.match_mm));
    AddGravity(machine, *cw, matches.back(), acc);
    r.pairs.push_back(cw->file->test_id);
  }
  for (std::size_t p = 0; p < pairs.size(); ++p) {
    AddPair(machine, *pairs[p].first, *pairs[p].second, matches[p], acc);
  }
  std::vector<bool> hold(kParams, false);
  for (int j = 12; j < 18 && !options.separate_platform_joints; ++j) hold[j] = true;
  const LsqSolution sol =
      SolveLeastSquares(acc.ne, Eigen::VectorXd::Zero(kParams), hold, options.min_singular_ratio);
  r.rows = acc.ne.rows;
  r.residual_rms_N = std::sqrt(sol.rss / static_cast<double>(acc.ne.rows));
  r.condition_number = sol.condition_number;
  std::vector<bool> held = hold;
  for (int p : sol.held) held[static_cast<std::size_t>(p)] = true;
  std::array<double, 6> total{};
  for (int j = 0; j < 6; ++j) {
    LegHealth& leg = r.legs[j];
    leg.leg = j + 1;
    leg.screw_friction_N = sol.x[j];
    leg.screw_friction_sigma_N = sol.sigma[j];
    const int b = 6 + j, p = 12 + j;
    leg.joints[0] = {"base", sol.x[b], sol.sigma[b], !held[b]};
    leg.joints[1] = {"platform", sol.x[p], sol.sigma[p], !held[p]};
    leg.resistance_Nm = sol.x[b] + sol.x[p];
    leg.sigma_Nm = std::sqrt(
        std::max(0.0, sol.covariance(b, b) + sol.covariance(p, p) + 2.0 * sol.covariance(b, p)));
    total[j] = leg.resistance_Nm;
    if (options.previous_Nm) leg.previous_Nm = (*options.previous_Nm)[j];
    leg.split_requested = options.separate_platform_joints;
  }
  for (int p : sol.held) {
    const int leg = p % 6 + 1;
    r.not_identifiable.push_back(p < 6    ? "screw_friction_N of leg " + std::to_string(leg)
                                 : p < 12 ? "base joint of leg " + std::to_string(leg)
                                          : "platform joint of leg " + std::to_string(leg));
  }
  const auto ref = References(machine, acc, options, total, r.reference_source);
  for (int j = 0; j < 6; ++j) {
    r.legs[j].reference_Nm = ref[j];
    GradeLeg(r.legs[j], options);
    r.level = std::max(r.level, r.legs[j].level);
  }
  return r;
}

}  // namespace km::servo
