#include "analysis/dbb/diagnosis.h"

#include <algorithm>
#include <cmath>
#include <complex>
#include <map>
#include <numbers>
#include <utility>

#include <Eigen/Cholesky>
#include <Eigen/Core>
#include <Eigen/LU>

#include "analysis/core/errors.h"
#include "analysis/dbb/iso230.h"
#include "analysis/dbb/signatures.h"

namespace km::dbb {

namespace {

using effects::EffectId;
using Eigen::MatrixXd;
using Eigen::VectorXd;

constexpr double kDeg = std::numbers::pi / 180.0;

// Stacked traces (signatures.h) plus the ids handed out to candidate columns (Gram cache keys).
struct Problem : StackedTraces {
  mutable int next_column_id = 0;
  void Orthogonalise(VectorXd& col, std::vector<Eigen::Vector3d>* coef = nullptr) const {
    RemoveSetup(col, coef);
  }
};

struct Candidate {
  EffectId id;
  std::vector<double> shape;
  std::vector<VectorXd> cols;  // orthogonalised signatures of the linear parameters
  std::vector<int> ids;        // column ids (copies of a candidate share them)
  // Set-up part (cos θ, sin θ, 1 coefficients per trace) removed from each signature.
  std::vector<std::vector<Eigen::Vector3d>> setup_part;
};

Candidate MakeCandidate(const Problem& p, EffectId id, std::vector<double> shape) {
  EffectColumns e = SetupFreeSignature(p, id, std::move(shape));
  Candidate c;
  c.id = id;
  c.shape = std::move(e.shape);
  c.cols = std::move(e.cols);
  c.setup_part = std::move(e.setup_part);
  for (std::size_t m = 0; m < c.cols.size(); ++m) c.ids.push_back(p.next_column_id++);
  return c;
}

struct FitResult {
  std::vector<int> kept;             // candidate indices
  std::vector<int> first_col;        // column offset of each kept candidate
  std::vector<std::string> dropped;  // "name (confounded with other)"
  std::vector<const VectorXd*> a;    // kept columns (owned by the candidates)
  // Σ_m x_m a_m over the kept columns [off, off + count).
  VectorXd Combine(int off, int count, Eigen::Index n) const {
    VectorXd v = VectorXd::Zero(n);
    for (int m = off; m < off + count; ++m) v += x[m] * *a[static_cast<std::size_t>(m)];
    return v;
  }
  VectorXd x;
  MatrixXd cov;
  MatrixXd normal_inv;  // (AᵀWA)⁻¹
  double sigma2 = 0.0;
  VectorXd residual;
};

// Inner products already computed, keyed by column ids; valid for one data vector and one set
// of weights.
struct GramCache {
  std::map<std::pair<int, int>, double> gram;
  std::map<int, double> rhs;
};

// Weighted by the square-root weights `sw` (empty: unweighted); the returned columns and
// residual are unweighted, σ² is the weighted residual variance (unit weight = outside the
// reversal zones).
FitResult Fit(const Problem& p, const std::vector<Candidate>& cands, const VectorXd& e0,
              const VectorXd& sw, double confound_ratio, char first, char second,
              GramCache& cache) {
  FitResult f;
  // All candidate columns, their Gram matrix and right-hand side (one pass over the data).
  int total = 0;
  std::vector<int> cand_first;
  for (const auto& c : cands) {
    cand_first.push_back(total);
    total += static_cast<int>(c.cols.size());
  }
  std::vector<const VectorXd*> all;
  std::vector<int> ids;
  for (const auto& c : cands) {
    for (const auto& col : c.cols) all.push_back(&col);
    ids.insert(ids.end(), c.ids.begin(), c.ids.end());
  }
  const bool weighted = sw.size() == p.n;
  const VectorXd w = weighted ? VectorXd(sw.cwiseProduct(sw)) : VectorXd();
  MatrixXd gram(total, total);
  VectorXd rhs(total);
  for (int a = 0; a < total; ++a) {
    const VectorXd& ca = *all[static_cast<std::size_t>(a)];
    VectorXd wa;
    auto weighted_a = [&]() -> const VectorXd& {
      if (!weighted) return ca;
      if (wa.size() == 0) wa = ca.cwiseProduct(w);
      return wa;
    };
    const int ia = ids[static_cast<std::size_t>(a)];
    auto r = cache.rhs.find(ia);
    if (r == cache.rhs.end()) r = cache.rhs.emplace(ia, weighted_a().dot(e0)).first;
    rhs[a] = r->second;
    for (int b = 0; b <= a; ++b) {
      const VectorXd& cb = *all[static_cast<std::size_t>(b)];
      const auto key = std::make_pair(ia, ids[static_cast<std::size_t>(b)]);
      auto g = cache.gram.find(key);
      if (g == cache.gram.end()) g = cache.gram.emplace(key, weighted_a().dot(cb)).first;
      gram(a, b) = gram(b, a) = g->second;
    }
  }

  // Rank-revealing selection in list order: the part of a column not explained by the columns
  // already kept is the Schur complement g_jj − g_Kjᵀ G_KK⁻¹ g_Kj.
  std::vector<int> kcols;
  // Keep at least max(5, N/10) degrees of freedom for the noise estimate.
  const int max_cols = p.n - 3 * p.traces - std::max(5, p.n / 10);
  for (std::size_t k = 0; k < cands.size(); ++k) {
    if (static_cast<int>(kcols.size() + cands[k].cols.size()) > max_cols) {
      f.dropped.push_back(effects::EffectName(cands[k].id, first, second) + " (too few samples)");
      continue;
    }
    std::vector<int> trial = kcols;
    bool ok = true;
    int culprit_col = -1;
    for (std::size_t m = 0; m < cands[k].cols.size(); ++m) {
      const int j = cand_first[k] + static_cast<int>(m);
      const double gjj = gram(j, j);
      double left = gjj;
      if (!trial.empty()) {
        const auto nk = static_cast<Eigen::Index>(trial.size());
        MatrixXd gkk(nk, nk);
        VectorXd gkj(nk);
        for (Eigen::Index a = 0; a < nk; ++a) {
          gkj[a] = gram(trial[static_cast<std::size_t>(a)], j);
          for (Eigen::Index b = 0; b < nk; ++b) {
            gkk(a, b) =
                gram(trial[static_cast<std::size_t>(a)], trial[static_cast<std::size_t>(b)]);
          }
        }
        left = gjj - gkj.dot(gkk.ldlt().solve(gkj));
      }
      if (!(gjj > 0.0) || left < confound_ratio * confound_ratio * gjj) {
        ok = false;
        double best = 0.0;
        for (int i : kcols) {
          const double corr = std::abs(gram(i, j)) / std::sqrt(gram(i, i) * gjj + 1e-300);
          if (corr > best) {
            best = corr;
            culprit_col = i;
          }
        }
        break;
      }
      trial.push_back(j);
    }
    if (!ok) {
      std::string s = effects::EffectName(cands[k].id, first, second);
      if (culprit_col >= 0) {
        std::size_t owner = 0;
        while (owner + 1 < cands.size() && cand_first[owner + 1] <= culprit_col) ++owner;
        s += " (confounded with " + effects::EffectName(cands[owner].id, first, second) + ")";
      }
      f.dropped.push_back(s);
      continue;
    }
    kcols = trial;
    f.kept.push_back(static_cast<int>(k));
  }
  const int ncol = static_cast<int>(kcols.size());
  {
    int off = 0;
    for (int k : f.kept) {
      f.first_col.push_back(off);
      off += static_cast<int>(cands[static_cast<std::size_t>(k)].cols.size());
    }
  }
  const int dof = p.n - 3 * p.traces - ncol;
  if (dof <= 0) throw NotObservable("diagnosis: more parameters than samples");
  f.a.resize(static_cast<std::size_t>(ncol));
  MatrixXd m(ncol, ncol);
  VectorXd b(ncol);
  for (int a = 0; a < ncol; ++a) {
    f.a[static_cast<std::size_t>(a)] =
        all[static_cast<std::size_t>(kcols[static_cast<std::size_t>(a)])];
    b[a] = rhs[kcols[static_cast<std::size_t>(a)]];
    for (int c = 0; c < ncol; ++c) {
      m(a, c) = gram(kcols[static_cast<std::size_t>(a)], kcols[static_cast<std::size_t>(c)]);
    }
  }
  if (ncol > 0) {
    Eigen::LDLT<MatrixXd> ldlt(m);
    f.x = ldlt.solve(b);
    f.residual = e0 - f.Combine(0, ncol, p.n);
    f.sigma2 = (weighted ? sw.cwiseProduct(f.residual) : f.residual).squaredNorm() / dof;
    f.normal_inv = ldlt.solve(MatrixXd::Identity(ncol, ncol));
    f.cov = f.sigma2 * f.normal_inv;
  } else {
    f.x.resize(0);
    f.residual = e0;
    f.sigma2 = (weighted ? sw.cwiseProduct(e0) : e0).squaredNorm() / dof;
    f.cov.resize(0, 0);
  }
  return f;
}

// |value| / σ, finite also for noise-free data (σ = 0).
double ZScore(double value, double sigma) {
  if (sigma > 0.0) return std::min(std::abs(value) / sigma, 1e9);
  return value != 0.0 ? 1e9 : 0.0;
}

double Range(const VectorXd& v, std::size_t b, std::size_t e) {
  double mn = v[static_cast<Eigen::Index>(b)], mx = mn;
  for (std::size_t i = b; i < e; ++i) {
    mn = std::min(mn, v[static_cast<Eigen::Index>(i)]);
    mx = std::max(mx, v[static_cast<Eigen::Index>(i)]);
  }
  return mx - mn;
}

// Entry of a fitted candidate: value, uncertainty, contributions.
DiagnosisEntry MakeEntry(const Problem& p, const Candidate& c, const FitResult& f, std::size_t j,
                         char first, char second) {
  const auto& info = effects::Info(c.id);
  DiagnosisEntry en;
  en.id = c.id;
  en.effect = effects::EffectName(c.id, first, second);
  en.unit = info.unit;
  const int nl = info.num_linear;
  const int off = f.first_col[j];
  en.params.assign(static_cast<std::size_t>(info.num_params), 0.0);
  for (int m = 0; m < nl; ++m) en.params[static_cast<std::size_t>(m)] = f.x[off + m];
  for (std::size_t k = 0; k < c.shape.size(); ++k) {
    en.params[static_cast<std::size_t>(nl) + k] = c.shape[k];
    en.shape[info.param_names[static_cast<std::size_t>(nl) + k]] = c.shape[k];
  }
  const auto& ctx = p.ctx[0];
  en.value = effects::Value(c.id, ctx, en.params.data());
  const MatrixXd jac = effects::ValueJacobian(c.id, ctx, en.params.data()).leftCols(nl);
  const MatrixXd cv = jac * f.cov.block(off, off, nl, nl) * jac.transpose();
  double vnorm = 0.0, snorm = 0.0;
  for (std::size_t m = 0; m < en.value.size(); ++m) {
    const double s =
        std::sqrt(std::max(0.0, cv(static_cast<Eigen::Index>(m), static_cast<Eigen::Index>(m))));
    en.uncertainty.push_back(s);
    vnorm += en.value[m] * en.value[m];
    snorm += s * s;
  }
  // Noise-free data (σ = 0): any non-zero value is significant; keep the figure finite (JSON).
  en.significance = snorm > 0.0 ? std::sqrt(vnorm / (snorm / static_cast<double>(en.value.size())))
                                : (vnorm > 0.0 ? 1e9 : 0.0);
  const VectorXd sig = f.Combine(off, nl, p.n);
  for (int t = 0; t < p.traces; ++t)
    en.peak_to_valley_um.push_back(Range(sig, p.begin[t], p.begin[t + 1]));
  return en;
}

// contribution_pct of each entry on trace t: its own peak-to-valley over the sum of all the
// entries' peak-to-valley values plus the range of what is left unexplained.
void Normalise(const Problem& p, std::vector<DiagnosisEntry*> entries, const VectorXd& residual) {
  for (int t = 0; t < p.traces; ++t) {
    double total = Range(residual, p.begin[t], p.begin[t + 1]);
    for (const auto* e : entries) total += e->peak_to_valley_um[static_cast<std::size_t>(t)];
    for (auto* e : entries) {
      e->contribution_pct.resize(static_cast<std::size_t>(p.traces), 0.0);
      e->contribution_pct[static_cast<std::size_t>(t)] =
          total > 0.0 ? 100.0 * e->peak_to_valley_um[static_cast<std::size_t>(t)] / total : 0.0;
    }
  }
}

bool Significant(const DiagnosisEntry& e, const DiagnosisOptions& o) {
  const double z = e.value.size() > 1 || e.params.size() > 1 + e.shape.size() ? o.significance + 1.0
                                                                              : o.significance;
  return e.significance > z;
}

struct ZoneStats {
  VectorXd hp;             // high-passed residual
  std::vector<char> zone;  // sample in a low-speed zone near an axis reversal
  double sz = 0.0, so = 0.0;
  int nz = 0, no = 0;
  // z-score of the excess zone variance and the zone/outside variance ratio.
  double Z() const {
    if (nz <= 10 || no <= 10) return 0.0;
    const double vz = sz / nz, vo = so / no;
    const double sd = std::sqrt(2.0 * vz * vz / nz + 2.0 * vo * vo / no);
    return sd > 0.0 ? (vz - vo) / sd : 0.0;
  }
};

ZoneStats StickSlipStats(const Problem& p, const std::vector<DiagnosisTrace>& traces,
                         const VectorXd& final_res, double window_deg) {
  ZoneStats zs;
  zs.hp = VectorXd::Zero(p.n);
  zs.zone.assign(static_cast<std::size_t>(p.n), 0);
  for (int t = 0; t < p.traces; ++t) {
    const std::size_t b = p.begin[t], e = p.begin[t + 1];
    const double step = std::abs(traces[static_cast<std::size_t>(t)].angle_rad.back() -
                                 traces[static_cast<std::size_t>(t)].angle_rad.front()) /
                        static_cast<double>(e - b - 1);
    const int k = std::max(1, static_cast<int>(std::lround(window_deg * kDeg / step)));
    // Moving average by a running sum (window clipped at the ends).
    std::vector<double> cs(e - b + 1, 0.0);
    for (std::size_t i = b; i < e; ++i) {
      cs[i - b + 1] = cs[i - b] + final_res[static_cast<Eigen::Index>(i)];
    }
    for (std::size_t i = b; i < e; ++i) {
      const std::size_t lo = i - b >= static_cast<std::size_t>(k) ? i - b - k : 0;
      const std::size_t hi = std::min(e - b, i - b + k + 1);
      const double avg = (cs[hi] - cs[lo]) / static_cast<double>(hi - lo);
      const double h = final_res[static_cast<Eigen::Index>(i)] - avg;
      zs.hp[static_cast<Eigen::Index>(i)] = h;
      const auto& a = p.samples[i].a;
      const bool z =
          std::abs(a.s) < effects::StickSlip::kZone || std::abs(a.c) < effects::StickSlip::kZone;
      zs.zone[i] = z ? 1 : 0;
      if (z) {
        zs.sz += h * h;
        ++zs.nz;
      } else {
        zs.so += h * h;
        ++zs.no;
      }
    }
  }
  return zs;
}

}  // namespace

void DiagnosisOptions::Check() const {
  if (!(significance > 0.0)) throw InvalidInput("", 0, "significance", "must be positive");
  if (min_contribution_pct < 0.0 || min_contribution_pct > 100.0) {
    throw InvalidInput("", 0, "min_contribution_pct", "must be within 0…100");
  }
  if (!(confound_ratio > 0.0 && confound_ratio < 1.0)) {
    throw InvalidInput("", 0, "confound_ratio", "must be within (0, 1)");
  }
  if (spike_widths_deg.empty()) throw InvalidInput("", 0, "spike_widths_deg", "empty");
  for (double w : spike_widths_deg) {
    if (!(w > 0.0)) throw InvalidInput("", 0, "spike_widths_deg", "must be positive");
  }
  if (!(cyclic_min_period_mm > 0.0)) throw InvalidInput("", 0, "cyclic_min_period_mm", "> 0");
  if (!(stick_slip_window_deg > 0.0)) throw InvalidInput("", 0, "stick_slip_window_deg", "> 0");
}

double DiagnosisEntry::MaxContribution() const {
  double m = 0.0;
  for (double c : contribution_pct) m = std::max(m, c);
  return m;
}

std::pair<char, char> AxisLetters(Plane plane) {
  switch (plane) {
    case Plane::kYZ:
      return {'y', 'z'};
    case Plane::kZX:
      return {'z', 'x'};
    case Plane::kXY:
    default:
      return {'x', 'y'};
  }
}

DiagnosisTrace MakeDiagnosisTrace(const DbbTest& test, const CircularTestResult& result) {
  return MakeDiagnosisTrace(test, result, DeviationAboutNominalCentre(result));
}

DiagnosisTrace MakeDiagnosisTrace(const DbbTest& test, const CircularTestResult& result,
                                  const std::vector<double>& dev) {
  if (dev.size() != result.angle_deg.size()) {
    throw InvalidInput("", 0, "dr_um", "deviation and angle sizes differ");
  }
  DiagnosisTrace t;
  t.direction = test.direction;
  t.radius_mm = test.radius_mm;
  t.feed_mm_min = test.feed_mm_min;
  const double k = test.bar_length_mm / test.radius_mm;  // bar → in-plane radial (cone tests)
  t.dev_um = dev;
  for (double& d : t.dev_um) d *= k;
  t.angle_rad.resize(result.angle_deg.size());
  for (std::size_t i = 0; i < t.angle_rad.size(); ++i) t.angle_rad[i] = result.angle_deg[i] * kDeg;
  return t;
}

DiagnosisResult DiagnoseSerialDbb(const std::vector<DiagnosisTrace>& traces, Plane plane,
                                  const DiagnosisOptions& opt) {
  opt.Check();
  if (traces.empty()) throw InvalidInput("", 0, "tests", "no trace to diagnose");
  const auto [first, second] = AxisLetters(plane);
  Problem p;
  static_cast<StackedTraces&>(p) = StackTraces(traces);
  // Set-up fit (centre, radius per trace) and the residual about it.
  VectorXd e0 = p.y;
  std::vector<Eigen::Vector3d> setup;
  p.Orthogonalise(e0, &setup);

  // Stage 1: base form effects (everything linear with a fixed shape).
  const std::vector<EffectId> base_ids = {
      EffectId::kSquareness,   EffectId::kScaleMismatch, EffectId::kServoMismatch,
      EffectId::kBacklashU,    EffectId::kBacklashV,     EffectId::kLateralPlayU,
      EffectId::kLateralPlayV, EffectId::kStraightnessU, EffectId::kStraightnessV};
  std::vector<Candidate> cands;
  for (EffectId id : base_ids) cands.push_back(MakeCandidate(p, id, {}));
  VectorXd sw;  // square-root weights (empty: unweighted)
  GramCache cache;
  const FitResult f1 = Fit(p, cands, e0, sw, opt.confound_ratio, first, second, cache);

  // Stage 2: reversal spikes, width chosen by the largest projection of the stage-1 residual.
  for (EffectId id : {EffectId::kReversalSpikeU, EffectId::kReversalSpikeV}) {
    Candidate best_c;
    double best_e = -1.0;
    for (double w : opt.spike_widths_deg) {
      Candidate c = MakeCandidate(p, id, {w});
      // Residual-sum-of-squares reduction when the spike joins the stage-1 model: (cᵀr)² over
      // the part of c not explained by the stage-1 columns (Schur complement).
      const VectorXd& col = c.cols[0];
      VectorXd g(static_cast<Eigen::Index>(f1.a.size()));
      for (std::size_t k = 0; k < f1.a.size(); ++k)
        g[static_cast<Eigen::Index>(k)] = f1.a[k]->dot(col);
      const double nn = col.squaredNorm() - (g.size() > 0 ? g.dot(f1.normal_inv * g) : 0.0);
      if (!(nn > 1e-12 * col.squaredNorm())) continue;
      const double d = col.dot(f1.residual);
      const double e = d * d / nn;
      if (e > best_e) {
        best_e = e;
        best_c = std::move(c);
      }
    }
    if (best_e >= 0.0) cands.push_back(std::move(best_c));
  }
  const FitResult f2 = Fit(p, cands, e0, sw, opt.confound_ratio, first, second, cache);

  // Stage 3: cyclic errors (period search on the stage-2 residual).
  if (opt.search_cyclic) {
    double rmin = 1e300;
    double max_step = 0.0;
    for (std::size_t t = 0; t < traces.size(); ++t) {
      rmin = std::min(rmin, traces[t].radius_mm);
      const auto& a = traces[t].angle_rad;
      for (std::size_t i = 1; i < a.size(); ++i)
        max_step = std::max(max_step, std::abs(a[i] - a[i - 1]));
    }
    const double pmin = std::max(opt.cyclic_min_period_mm, 4.0 * rmin * max_step);
    const double pmax = opt.cyclic_max_period_fraction * rmin;
    const double s2 = std::pow(DiffNoiseUm(p, f2.residual), 2);
    // Search only when the residual is not white: a smooth periodic error raises its variance
    // above the successive-difference estimate of the noise variance.
    const double var = f2.residual.squaredNorm() / p.n;
    const bool structured = var > s2 * (1.0 + 4.0 * std::sqrt(2.0 / p.n));
    if (structured && pmax > pmin && s2 > 0.0) {
      for (int axis = 0; axis < 2; ++axis) {
        const double period = CyclicPeriodPeak(p, f2.residual, axis, pmin, pmax);
        if (!(period > 0.0)) continue;

        // Projection energy of the residual (on a subsample that keeps ≥ 4 samples a period),
        // scaled to the full sample count, against the noise variance.
        const int stride = std::max(1, static_cast<int>(period / (4.0 * rmin * max_step)));
        const double energy = stride * CyclicEnergy(p, f2.residual, axis, period, stride);
        if (energy / s2 > opt.cyclic_detection_chi2) {
          cands.push_back(MakeCandidate(
              p, axis == 0 ? EffectId::kCyclicErrorU : EffectId::kCyclicErrorV, {period}));
        }
      }
    }
  }
  FitResult f3 = Fit(p, cands, e0, sw, opt.confound_ratio, first, second, cache);
  // Refine the periods by one backfitting step: maximise the projection energy of the partial
  // residual (data minus every other jointly fitted effect) within ±2 periodogram bins.
  {
    bool changed = false;
    for (std::size_t j = 0; j < f3.kept.size(); ++j) {
      Candidate& c = cands[static_cast<std::size_t>(f3.kept[j])];
      if (c.id != EffectId::kCyclicErrorU && c.id != EffectId::kCyclicErrorV) continue;
      const int axis = c.id == EffectId::kCyclicErrorU ? 0 : 1;
      const VectorXd partial = f3.residual + f3.Combine(f3.first_col[j], 2, p.n);
      double rmin = 1e300, max_step = 0.0;
      for (const auto& tr : traces) {
        rmin = std::min(rmin, tr.radius_mm);
        for (std::size_t i = 1; i < tr.angle_rad.size(); ++i)
          max_step = std::max(max_step, std::abs(tr.angle_rad[i] - tr.angle_rad[i - 1]));
      }
      const double period = c.shape[0];
      const double bin_rel = 2.0 * period * kCyclicBins / (2.0 * kCyclicFft * rmin);
      const double refined =
          RefinePeriod(p, partial, axis, period, std::min(0.2, bin_rel), rmin * max_step);
      c = MakeCandidate(p, c.id, {refined});
      changed = true;
    }
    if (changed) f3 = Fit(p, cands, e0, sw, opt.confound_ratio, first, second, cache);
  }

  // Heteroscedastic weights: when the high-frequency scatter in the low-speed zones near the
  // reversals clearly exceeds the rest (stick-slip) after every other effect is fitted, those
  // samples are weighted by the ratio of the variances and the model is refitted, so that
  // local structure there is not mistaken for spikes or backlash.
  {
    const ZoneStats zs = StickSlipStats(p, traces, f3.residual, opt.stick_slip_window_deg);
    if (zs.Z() > opt.significance + 1.0) {
      const double ratio = std::sqrt((zs.so / zs.no) / (zs.sz / zs.nz));
      sw = VectorXd::Ones(p.n);
      for (int i = 0; i < p.n; ++i)
        if (zs.zone[static_cast<std::size_t>(i)]) sw[i] = ratio;
      cache = GramCache{};
      f3 = Fit(p, cands, e0, sw, opt.confound_ratio, first, second, cache);
    }
  }

  DiagnosisResult res;
  res.not_identifiable = f3.dropped;
  std::vector<Candidate> chosen;
  {
    std::vector<DiagnosisEntry> stage3;
    for (std::size_t j = 0; j < f3.kept.size(); ++j) {
      stage3.push_back(
          MakeEntry(p, cands[static_cast<std::size_t>(f3.kept[j])], f3, j, first, second));
    }
    std::vector<DiagnosisEntry*> ptrs;
    for (auto& e : stage3) ptrs.push_back(&e);
    Normalise(p, ptrs, f3.residual);
    for (std::size_t j = 0; j < stage3.size(); ++j) {
      if (Significant(stage3[j], opt) && stage3[j].MaxContribution() >= opt.min_contribution_pct) {
        chosen.push_back(cands[static_cast<std::size_t>(f3.kept[j])]);
      }
      res.candidates.push_back(std::move(stage3[j]));
    }
  }
  // Stage 4: refit with the named form effects only.
  FitResult f4 = Fit(p, chosen, e0, sw, opt.confound_ratio, first, second, cache);
  res.form_model_um.assign(traces.size(), {});
  VectorXd model = VectorXd::Zero(p.n);
  for (std::size_t j = 0; j < f4.kept.size(); ++j) {
    const auto& c = chosen[static_cast<std::size_t>(f4.kept[j])];
    DiagnosisEntry en = MakeEntry(p, c, f4, j, first, second);
    if (!Significant(en, opt)) continue;
    const int nl = static_cast<int>(c.cols.size());
    model += f4.Combine(f4.first_col[j], nl, p.n);
    // The set-up fit absorbed this effect's own mean and first harmonic: give them back.
    for (int m = 0; m < nl; ++m) {
      for (std::size_t t = 0; t < setup.size(); ++t) {
        setup[t] -= f4.x[f4.first_col[j] + m] * c.setup_part[static_cast<std::size_t>(m)][t];
      }
    }
    en.named = true;
    res.named.push_back(std::move(en));
  }
  const VectorXd final_res = e0 - model;
  VectorXd left = final_res;  // unexplained part (stick-slip removed below when named)
  res.residual_rms_um = std::sqrt(final_res.squaredNorm() / p.n);
  res.noise_um = DiffNoiseUm(p, final_res);
  for (int t = 0; t < p.traces; ++t) {
    res.form_model_um[static_cast<std::size_t>(t)].assign(model.data() + p.begin[t],
                                                          model.data() + p.begin[t + 1]);
  }

  // Set-up terms: centre offset and radius change (mean over the traces).
  {
    Eigen::Vector3d mean = Eigen::Vector3d::Zero();
    Eigen::Vector3d var = Eigen::Vector3d::Zero();
    for (int t = 0; t < p.traces; ++t) {
      mean += setup[static_cast<std::size_t>(t)];
      var += f4.sigma2 * p.setup_inv[t].diagonal();
    }
    const double tt = p.traces;
    mean /= tt;
    var /= tt * tt;
    DiagnosisEntry c;
    c.id = EffectId::kCentreOffset;
    c.effect = effects::EffectName(c.id, first, second);
    c.unit = effects::Info(c.id).unit;
    c.value = {mean[0], mean[1]};
    c.params = c.value;
    c.uncertainty = {std::sqrt(var[0]), std::sqrt(var[1])};
    c.contribution_pct.assign(traces.size(), 0.0);
    c.peak_to_valley_um.assign(traces.size(), 0.0);
    c.significance = ZScore(std::hypot(mean[0], mean[1]), std::sqrt(0.5 * (var[0] + var[1])));
    DiagnosisEntry r;
    r.id = EffectId::kRadiusError;
    r.effect = effects::EffectName(r.id, first, second);
    r.unit = effects::Info(r.id).unit;
    r.value = {mean[2]};
    r.params = r.value;
    r.uncertainty = {std::sqrt(var[2])};
    r.contribution_pct.assign(traces.size(), 0.0);
    r.peak_to_valley_um.assign(traces.size(), 0.0);
    r.significance = ZScore(mean[2], std::sqrt(var[2]));
    for (DiagnosisEntry* e : {&c, &r}) {
      e->named = Significant(*e, opt);
      res.candidates.push_back(*e);
      if (e->named) res.named.push_back(*e);
    }
  }

  // stick_slip: excess high-frequency power near the axis reversals.
  {
    const ZoneStats zs = StickSlipStats(p, traces, final_res, opt.stick_slip_window_deg);
    const auto& hp = zs.hp;
    const auto& zone = zs.zone;
    const int nz = zs.nz, no = zs.no;
    const double sz = zs.sz, so = zs.so;
    if (nz > 10 && no > 10) {
      const double vz = sz / nz, vo = so / no;
      const double d = vz - vo;
      const double sd = std::sqrt(2.0 * vz * vz / nz + 2.0 * vo * vo / no);
      DiagnosisEntry s;
      s.id = EffectId::kStickSlip;
      s.effect = effects::EffectName(s.id, first, second);
      s.unit = effects::Info(s.id).unit;
      const double amp = std::sqrt(3.0 * std::max(0.0, d));
      s.value = {amp};
      s.params = {amp};
      s.uncertainty = {amp > 0.0 ? 1.5 * sd / amp : std::sqrt(3.0 * sd)};
      s.significance = sd > 0.0 ? d / sd : 0.0;
      s.peak_to_valley_um.assign(traces.size(), 2.0 * amp);
      s.contribution_pct.assign(traces.size(), 0.0);
      s.named = s.significance > opt.significance + 1.0;
      if (s.named) {
        for (int i = 0; i < p.n; ++i)
          if (zone[static_cast<std::size_t>(i)]) left[i] -= hp[i];
      }
      res.candidates.push_back(s);
      if (s.named) res.named.push_back(s);
    }
  }
  // Final contributions: named form effects against what is left unexplained.
  {
    std::vector<DiagnosisEntry*> ptrs;
    for (auto& e : res.named)
      if (effects::Info(e.id).in_form) ptrs.push_back(&e);
    Normalise(p, ptrs, left);
    res.named.erase(std::remove_if(res.named.begin(), res.named.end(),
                                   [&](const DiagnosisEntry& e) {
                                     return effects::Info(e.id).in_form &&
                                            e.MaxContribution() < opt.min_contribution_pct;
                                   }),
                    res.named.end());
  }
  std::stable_sort(res.named.begin(), res.named.end(),
                   [](const DiagnosisEntry& a, const DiagnosisEntry& b) {
                     const double ca = a.MaxContribution(), cb = b.MaxContribution();
                     if (ca != cb) return ca > cb;
                     return a.significance > b.significance;
                   });
  return res;
}

}  // namespace km::dbb
