#include "analysis/discovery/engine.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <map>
#include <numbers>

#include <Eigen/Cholesky>
#include <Eigen/QR>

#include "analysis/core/errors.h"
#include "analysis/core/option_check.h"
#include "analysis/core/statistics.h"
#include "analysis/discovery/serial_family_util.h"

namespace km::discovery {
namespace {

using Eigen::MatrixXd;
using Eigen::VectorXd;
using util::Rms;

// Eliminates the local columns of a fit group by group: every vector handed to Project() loses
// its component in the span of its group's local columns.
class LocalProjector {
 public:
  explicit LocalProjector(const FitState& fit) : row_begin_(fit.row_begin) {
    const int groups = static_cast<int>(row_begin_.size()) - 1;
    basis_.resize(static_cast<std::size_t>(groups));
    for (int g = 0; g < groups; ++g) {
      std::vector<int> cols;
      for (int c = 0; c < static_cast<int>(fit.column_group.size()); ++c)
        if (fit.column_group[static_cast<std::size_t>(c)] == g) cols.push_back(c);
      if (cols.empty()) continue;
      const int r0 = row_begin_[g], m = row_begin_[g + 1] - r0;
      MatrixXd local(m, static_cast<int>(cols.size()));
      for (std::size_t k = 0; k < cols.size(); ++k)
        local.col(static_cast<int>(k)) = fit.jacobian.block(r0, cols[k], m, 1);
      const Eigen::HouseholderQR<MatrixXd> qr(local);
      basis_[static_cast<std::size_t>(g)] =
          qr.householderQ() * MatrixXd::Identity(m, static_cast<int>(cols.size()));
    }
  }
  void Project(VectorXd& v) const {
    for (std::size_t g = 0; g < basis_.size(); ++g) {
      const auto& q = basis_[g];
      if (q.size() == 0) continue;
      const int r0 = row_begin_[g], m = static_cast<int>(q.rows());
      auto seg = v.segment(r0, m);
      seg -= q * (q.transpose() * seg);
    }
  }

 private:
  std::vector<int> row_begin_;
  std::vector<MatrixXd> basis_;
};

// Normal equations of a global-only linear problem, accumulated per cross-validation fold.
struct FoldSystem {
  std::vector<MatrixXd> gram;
  std::vector<VectorXd> rhs;
  std::vector<double> yy;
  MatrixXd gram_all;
  VectorXd rhs_all;
  double yy_all = 0.0;
};

VectorXd SolveSym(const MatrixXd& g, const VectorXd& b) {
  if (g.rows() == 0) return VectorXd();
  // Scaled, with a tiny ridge so that a parameter absent from the training rows stays at 0.
  VectorXd d = g.diagonal().cwiseMax(1e-300).cwiseSqrt().cwiseInverse();
  MatrixXd gs = d.asDiagonal() * g * d.asDiagonal();
  gs.diagonal().array() += 1e-12;
  return d.asDiagonal() * gs.ldlt().solve(d.asDiagonal() * b);
}

FoldSystem Accumulate(const MatrixXd& x, const VectorXd& y, const std::vector<int>& row_fold,
                      int folds) {
  FoldSystem s;
  const int p = static_cast<int>(x.cols());
  s.gram.assign(static_cast<std::size_t>(folds), MatrixXd::Zero(p, p));
  s.rhs.assign(static_cast<std::size_t>(folds), VectorXd::Zero(p));
  s.yy.assign(static_cast<std::size_t>(folds), 0.0);
  int r = 0;
  while (r < x.rows()) {
    const int f = row_fold[static_cast<std::size_t>(r)];
    int e = r;
    while (e < x.rows() && row_fold[static_cast<std::size_t>(e)] == f) ++e;
    const auto yb = y.segment(r, e - r);
    if (p > 0) {  // a block of a matrix without columns would offset a null data pointer
      const auto xb = x.middleRows(r, e - r);
      s.gram[static_cast<std::size_t>(f)].noalias() += xb.transpose() * xb;
      s.rhs[static_cast<std::size_t>(f)].noalias() += xb.transpose() * yb;
    }
    s.yy[static_cast<std::size_t>(f)] += yb.squaredNorm();
    r = e;
  }
  s.gram_all = MatrixXd::Zero(p, p);
  s.rhs_all = VectorXd::Zero(p);
  for (int f = 0; f < folds; ++f) {
    s.gram_all += s.gram[static_cast<std::size_t>(f)];
    s.rhs_all += s.rhs[static_cast<std::size_t>(f)];
    s.yy_all += s.yy[static_cast<std::size_t>(f)];
  }
  return s;
}

double Rss(const FoldSystem& s, VectorXd* beta) {
  const VectorXd b = SolveSym(s.gram_all, s.rhs_all);
  if (beta) *beta = b;
  return std::max(0.0, s.yy_all - (b.size() ? s.rhs_all.dot(b) : 0.0));
}

double Press(const FoldSystem& s) {
  double press = 0.0;
  for (std::size_t f = 0; f < s.gram.size(); ++f) {
    const VectorXd b = SolveSym(s.gram_all - s.gram[f], s.rhs_all - s.rhs[f]);
    double sse = s.yy[f];
    if (b.size()) sse += -2.0 * b.dot(s.rhs[f]) + b.dot(s.gram[f] * b);
    press += std::max(0.0, sse);
  }
  return press;
}

// The step's linear workspace: the model's global columns and the gap, local parts removed.
struct Workspace {
  MatrixXd model;        // n × p_global
  VectorXd gap;          // −(residual), projected
  VectorXd gap_partial;  // the gap without its fit by the model's global columns
  std::vector<int> row_fold;
  int folds = 0;
  int total_columns = 0;
  FoldSystem base;
  std::vector<int> row_cluster;  // cluster (fold key rank) of every row
  int clusters = 0;
};

std::vector<int> RowFolds(const FitState& fit, const std::vector<int>& keys, int folds, int* used) {
  std::vector<int> distinct = keys;
  std::sort(distinct.begin(), distinct.end());
  distinct.erase(std::unique(distinct.begin(), distinct.end()), distinct.end());
  *used = std::max(1, std::min(folds, static_cast<int>(distinct.size())));
  std::vector<int> row_fold(static_cast<std::size_t>(fit.residual.size()), 0);
  for (std::size_t g = 0; g + 1 < fit.row_begin.size(); ++g) {
    const auto pos = std::lower_bound(distinct.begin(), distinct.end(), keys[g]) - distinct.begin();
    const int f = static_cast<int>(pos) % *used;
    for (int r = fit.row_begin[g]; r < fit.row_begin[g + 1]; ++r)
      row_fold[static_cast<std::size_t>(r)] = f;
  }
  return row_fold;
}

Workspace MakeWorkspace(const FitState& fit, const LocalProjector& proj,
                        const std::vector<int>& keys, int folds) {
  Workspace w;
  std::vector<int> global;
  for (int c = 0; c < static_cast<int>(fit.column_group.size()); ++c)
    if (fit.column_group[static_cast<std::size_t>(c)] < 0) global.push_back(c);
  w.model.resize(fit.residual.size(), static_cast<int>(global.size()));
  for (std::size_t k = 0; k < global.size(); ++k) {
    VectorXd col = fit.jacobian.col(global[k]);
    proj.Project(col);
    w.model.col(static_cast<int>(k)) = col;
  }
  w.gap = -fit.residual;
  proj.Project(w.gap);
  w.total_columns = static_cast<int>(fit.jacobian.cols());
  w.row_fold = RowFolds(fit, keys, folds, &w.folds);
  w.row_cluster = RowFolds(fit, keys, std::numeric_limits<int>::max(), &w.clusters);
  w.base = Accumulate(w.model, w.gap, w.row_fold, w.folds);
  w.gap_partial = w.gap;
  if (w.model.cols() > 0)
    w.gap_partial -= w.model * SolveSym(w.base.gram_all, w.model.transpose() * w.gap);
  return w;
}

struct Scored {
  CandidateScore score;
  double rss_before = 0.0;
  double press_before = 0.0;
  double f = 0.0;
  int q = 0;
  int dof = 0;
  VectorXd contribution;
  VectorXd own;  // the candidate's own part of the contribution (offset and columns)
};

// Cluster-robust Wald test that the candidate's fitted contribution is present, with the
// model's parameters partialled out (Frisch–Waugh–Lovell): `c` is the contribution (offset
// and columns at the fitted values) and `y` the gap, both without their fit by the model;
// θ = cᵀy/cᵀc (≈ 1) and its sandwich variance Σ_g (c_gᵀe_g)²/(cᵀc)²·G/(G − 1), e = y − θc,
// over the clusters g. θ²/var/q is referred to F(q, G − 1), q the candidate's free parameters
// (the shape of the contribution was itself fitted). Returns log10 of the p-value.
double ClusteredLog10P(const Workspace& w, const VectorXd& c, const VectorXd& y, int q) {
  const int n = static_cast<int>(c.size()), g = w.clusters;
  const double cc = c.squaredNorm();
  if (!(cc > 0.0)) return 0.0;
  const double theta = c.dot(y) / cc;
  std::vector<double> score(static_cast<std::size_t>(g), 0.0);
  for (int r = 0; r < n; ++r)
    score[static_cast<std::size_t>(w.row_cluster[static_cast<std::size_t>(r)])] +=
        c[r] * (y[r] - theta * c[r]);
  double meat = 0.0;
  for (double sc : score) meat += sc * sc;
  const double var = (static_cast<double>(g) / (g - 1)) * meat / (cc * cc);
  const double wald = var > 0.0 ? theta * theta / var / q : HUGE_VAL;
  if (!(wald > 0.0)) return 0.0;
  if (!std::isfinite(wald)) return -300.0;
  return LogFUpperTail(wald, q, g - 1) / std::log(10.0);
}

// `v` without its least-squares fit by the model's global columns.
VectorXd Partial(const Workspace& w, const VectorXd& v) {
  if (w.model.cols() == 0) return v;
  return v - w.model * SolveSym(w.base.gram_all, w.model.transpose() * v);
}

Scored ScoreCandidate(const Workspace& w, const LocalProjector& proj, const Candidate& c,
                      ModelFamily& family, const EngineOptions& opt) {
  Scored s;
  s.score.effect = c.effect;
  s.score.variant = c.variant;
  const int n = static_cast<int>(w.gap.size()), p = static_cast<int>(w.model.cols());
  s.q = static_cast<int>(c.columns.cols());
  MatrixXd x(n, p + s.q);
  x.leftCols(p) = w.model;
  // Identifiability: each candidate column must keep part of its norm outside the model.
  const MatrixXd gm = w.base.gram_all;
  std::vector<int> absorbed;  // candidate columns mostly inside the model's span
  for (int k = 0; k < s.q; ++k) {
    VectorXd a = c.columns.col(k);
    const double full = a.squaredNorm();
    proj.Project(a);
    x.col(p + k) = a;
    const VectorXd beta = SolveSym(gm, w.model.transpose() * a);
    const double left = a.squaredNorm() - (beta.size() ? (w.model.transpose() * a).dot(beta) : 0.0);
    if (!(full > 0.0) || left < opt.confound_ratio * opt.confound_ratio * full)
      absorbed.push_back(k);
  }
  VectorXd y = w.gap;
  if (c.offset.size() == n) {
    VectorXd o = c.offset;
    proj.Project(o);
    y -= o;
  }
  const FoldSystem sys = Accumulate(x, y, w.row_fold, w.folds);
  VectorXd beta;
  s.rss_before = Rss(w.base, nullptr);
  s.score.rss_after_um2 = Rss(sys, &beta);
  s.score.estimate = beta.tail(s.q);
  s.press_before = Press(w.base);
  s.score.press_um2 = Press(sys);
  s.dof = std::max(1, n - w.total_columns - s.q);
  // A column mostly absorbed by the model is still identified when the data determine its
  // parameter sharply (|estimate| ≥ determined_t σ, e.g. a large centre-of-gravity offset).
  for (int k : absorbed) {
    VectorXd unit = VectorXd::Zero(p + s.q);
    unit[p + k] = 1.0;
    const double var = SolveSym(sys.gram_all, unit)[p + k] * s.score.rss_after_um2 / s.dof;
    const double t = var > 0.0 ? std::abs(beta[p + k]) / std::sqrt(var) : 0.0;
    if (opt.determined_t > 0.0 && t >= opt.determined_t) continue;
    s.score.identifiable = false;
    s.score.rejected_because = "not identifiable: the model's parameters absorb it";
  }
  const double drop = s.rss_before - s.score.rss_after_um2;
  s.f = drop > 0.0 ? (drop / s.q) / (s.score.rss_after_um2 / s.dof + 1e-300) : 0.0;
  s.score.log10_p_white = LogFUpperTail(s.f, s.q, s.dof) / std::log(10.0);
  s.score.log10_p_value = s.score.log10_p_white;

  // The fitted change of the model (the candidate with the model's readjustment), in the same
  // terms as the gap: gap − contribution is what remains.
  s.contribution = x * beta + (w.gap - y);
  s.own = x.rightCols(s.q) * s.score.estimate + (w.gap - y);
  if (opt.cluster_inference && w.clusters >= opt.min_clusters && s.q > 0) {
    s.score.log10_p_clustered = ClusteredLog10P(w, Partial(w, s.own), w.gap_partial, s.q);
    s.score.log10_p_value = std::max(s.score.log10_p_value, s.score.log10_p_clustered);
  }
  std::string why;
  if (s.score.identifiable && !family.Physical(c, s.score.estimate, &why)) {
    s.score.physical = false;
    s.score.rejected_because = "not physical: " + why;
  }
  return s;
}

// Whether the richer of two forms of one effect (more free parameters) is worth its extra
// parameters: it predicts held-out tests better, and what it adds to the simpler form passes
// the F-test (and the test-level Wald test when used) at max_p_value.
bool RicherIsBetter(const Workspace& w, const Scored& simple, const Scored& rich,
                    const EngineOptions& opt) {
  if (!(rich.score.press_um2 < simple.score.press_um2)) return false;
  const int dq = std::max(1, rich.q - simple.q);
  const double drop = simple.score.rss_after_um2 - rich.score.rss_after_um2;
  if (!(drop > 0.0)) return false;
  const double f = (drop / dq) / (rich.score.rss_after_um2 / rich.dof + 1e-300);
  double log_p = LogFUpperTail(f, dq, rich.dof) / std::log(10.0);
  if (opt.cluster_inference && w.clusters >= opt.min_clusters) {
    const VectorXd extra = Partial(w, rich.own - simple.own);
    log_p = std::max(log_p, ClusteredLog10P(w, extra, w.gap_partial - Partial(w, simple.own), dq));
  }
  return log_p < std::log10(opt.max_p_value);
}

// The qualifying candidate that predicts held-out tests best; between forms of one effect, a
// form with more free parameters only when RicherIsBetter.
const Scored* ChooseBest(const Workspace& w, const std::vector<Scored>& scored,
                         const EngineOptions& opt) {
  std::map<std::string, const Scored*> per_effect;
  for (const auto& s : scored) {
    if (!s.score.rejected_because.empty()) continue;
    const Scored*& b = per_effect[s.score.effect];
    if (!b) {
      b = &s;
    } else if (s.q == b->q) {
      if (s.score.press_um2 < b->score.press_um2) b = &s;
    } else {
      const Scored* simple = s.q < b->q ? &s : b;
      const Scored* rich = s.q < b->q ? b : &s;
      b = RicherIsBetter(w, *simple, *rich, opt) ? rich : simple;
    }
  }
  const Scored* best = nullptr;
  for (const auto& [name, s] : per_effect)
    if (!best || s->score.press_um2 < best->score.press_um2) best = s;
  return best;
}

std::vector<GroupGap> GroupGaps(const FitState& before, const FitState& after) {
  std::vector<GroupGap> out;
  for (std::size_t g = 0; g + 1 < before.row_begin.size(); ++g) {
    const int r0 = before.row_begin[g], m = before.row_begin[g + 1] - r0;
    GroupGap gg;
    gg.group = static_cast<int>(g);
    gg.rms_before_um = Rms(before.residual.segment(r0, m));
    gg.rms_after_um = Rms(after.residual.segment(r0, m));
    out.push_back(gg);
  }
  return out;
}

}  // namespace

void EngineOptions::Check() const {
  KM_OPTION_IN_OPEN(max_p_value, 0.0, 1.0);
  KM_OPTION_GE(folds, 2);
  KM_OPTION_IN_HALF_OPEN(min_cv_gain, 0.0, 1.0);
  KM_OPTION_GE(misfit_ratio, 1.0);
  KM_OPTION_GE(max_steps, 0);
  KM_OPTION_GE(min_clusters, 2);
}

double NoiseFloor(const VectorXd& residual, const std::vector<int>& row_begin) {
  std::vector<std::vector<double>> per;
  for (std::size_t g = 0; g + 1 < row_begin.size(); ++g)
    per.emplace_back(residual.data() + row_begin[g], residual.data() + row_begin[g + 1]);
  return RobustDiffNoiseUm(per);
}

const char* ToString(Verdict v) {
  return v == Verdict::kComplete ? "complete" : "model misfit";
}

const char* ToString(StopReason r) {
  switch (r) {
    case StopReason::kAtNoiseFloor:
      return "the gap is at the noise floor";
    case StopReason::kMaxSteps:
      return "maximum number of steps";
    case StopReason::kNoCandidateLeft:
      return "no candidate left";
    case StopReason::kNoCandidateQualifies:
      return "no candidate qualifies";
  }
  return "";
}

std::optional<Verdict> ParseVerdict(std::string_view text) {
  for (Verdict v : {Verdict::kComplete, Verdict::kModelMisfit}) {
    if (text == ToString(v)) return v;
  }
  return std::nullopt;
}

const char* StopCode(StopReason r) {
  switch (r) {
    case StopReason::kAtNoiseFloor:
      return "noise_floor";
    case StopReason::kMaxSteps:
      return "max_steps";
    case StopReason::kNoCandidateLeft:
      return "no_candidate_left";
    case StopReason::kNoCandidateQualifies:
      return "no_candidate_qualifies";
  }
  return "";
}

EngineResult RunDiscovery(ModelFamily& family, const EngineOptions& opt,
                          const ProgressFn& progress) {
  opt.Check();
  auto tell = [&](int step, const std::string& what) {
    if (progress) progress(std::min(0.95, step / static_cast<double>(opt.max_steps + 1)), what);
  };
  EngineResult res;
  tell(0, "fitting the base model");
  res.base = family.FitBase();
  FitState fit = res.base;
  const std::vector<int> keys = family.FoldKeys();
  res.verdict = Verdict::kComplete;
  while (true) {
    const int step_no = static_cast<int>(res.steps.size()) + 1;
    const double gap_rms = Rms(fit.residual);
    const double floor = std::max(NoiseFloor(fit.residual, fit.row_begin), opt.resolution_um);
    // What no model can explain, coloured noise included: the verdict and the practical gain
    // are judged against it.
    const double repeat_floor = std::max(floor, family.RepeatabilityFloor(fit));
    if (gap_rms <= opt.noise_stop_ratio * floor) {
      res.stop_reason = StopReason::kAtNoiseFloor;
      break;
    }
    if (static_cast<int>(res.steps.size()) >= opt.max_steps) {
      res.stop_reason = StopReason::kMaxSteps;
      break;
    }
    const LocalProjector proj(fit);
    const Workspace w = MakeWorkspace(fit, proj, keys, opt.folds);
    const auto candidates = family.Candidates(fit);
    std::vector<Scored> scored;
    for (const auto& c : candidates) {
      tell(step_no, "trying " + c.effect + (c.variant.empty() ? "" : " (" + c.variant + ")"));
      scored.push_back(ScoreCandidate(w, proj, c, family, opt));
    }
    // Qualification of every candidate.
    const double excess =
        std::max(0.0, scored.empty()
                          ? 0.0
                          : scored.front().rss_before - repeat_floor * repeat_floor * w.gap.size());
    for (auto& s : scored) {
      auto& sc = s.score;
      if (!sc.rejected_because.empty()) continue;
      if (sc.log10_p_value > std::log10(opt.max_p_value)) {
        sc.rejected_because = "not significant (F-test)";
      } else if (!(sc.press_um2 < (1.0 - opt.min_cv_gain) * s.press_before)) {
        sc.rejected_because = "does not predict held-out tests better";
      } else if (s.rss_before - sc.rss_after_um2 < opt.min_practical_fraction * excess) {
        sc.rejected_because = "improvement too small to matter";
      }
    }
    const Scored* best = ChooseBest(w, scored, opt);
    std::vector<CandidateScore> all;
    for (const auto& s : scored) all.push_back(s.score);
    if (!best) {
      res.last_candidates = all;
      res.stop_reason =
          candidates.empty() ? StopReason::kNoCandidateLeft : StopReason::kNoCandidateQualifies;
      if (gap_rms > opt.misfit_ratio * repeat_floor) {
        res.verdict = Verdict::kModelMisfit;
        res.misfit = family.DescribeGap(fit);
      }
      break;
    }
    const Candidate& chosen = candidates[static_cast<std::size_t>(best - scored.data())];
    tell(step_no, "adding " + chosen.effect);
    Step st;
    st.added_effect = chosen.effect;
    st.variant = chosen.variant;
    st.before = fit;
    st.gap_rms_before_um = gap_rms;
    st.rss_before_um2 = best->rss_before;
    st.press_before_um2 = best->press_before;
    st.press_after_um2 = best->score.press_um2;
    st.f_statistic = best->f;
    st.log10_p_value = best->score.log10_p_value;
    st.df_numerator = best->q;
    st.df_denominator = best->dof;
    st.evidence = family.Describe(fit, chosen, best->contribution);
    st.candidates = all;
    fit = family.Accept(chosen, best->score.estimate);
    st.after = fit;
    st.rss_after_um2 = fit.residual.squaredNorm();
    st.gap_rms_after_um = Rms(fit.residual);
    st.groups = GroupGaps(st.before, st.after);
    res.steps.push_back(std::move(st));
  }
  res.final_fit = fit;
  res.unexplained_rms_um = Rms(fit.residual);
  res.noise_floor_um = NoiseFloor(fit.residual, fit.row_begin);
  res.repeatability_floor_um = family.RepeatabilityFloor(fit);
  return res;
}

}  // namespace km::discovery
