#include "analysis/dbb/diagnosis.h"

#include <algorithm>
#include <cmath>
#include <iterator>
#include <map>
#include <numbers>
#include <tuple>
#include <utility>

#include <ceres/jet.h>
#include <Eigen/Cholesky>
#include <Eigen/Core>
#include <Eigen/LU>
#include <opencv2/core.hpp>

#include "analysis/core/errors.h"
#include "analysis/dbb/iso230.h"
#include "analysis/dbb/signatures.h"

namespace km::dbb {

namespace {

using effects::EffectId;
using Eigen::MatrixXd;
using Eigen::VectorXd;

constexpr double kDeg = std::numbers::pi / 180.0;

bool IsSpike(EffectId id) {
  return id == EffectId::kReversalSpikeU || id == EffectId::kReversalSpikeV;
}

// Effects whose (first) shape parameter the diagnosis fits: spike width, stick-slip period.
bool HasFittedShape(EffectId id) {
  return IsSpike(id) || id == EffectId::kStickSlip;
}

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
  std::vector<double> raw_norm2;  // squared norm of each signature before the set-up removal
};

Candidate MakeCandidate(const Problem& p, EffectId id, std::vector<double> shape) {
  EffectColumns e = SetupFreeSignature(p, id, std::move(shape));
  Candidate c;
  c.id = id;
  c.shape = std::move(e.shape);
  c.cols = std::move(e.cols);
  c.setup_part = std::move(e.setup_part);
  for (std::size_t m = 0; m < c.cols.size(); ++m) {
    c.ids.push_back(p.next_column_id++);
    // raw = free + S c per trace, free ⟂ S: |raw|² = |free|² + Σ_t cᵀ (SᵀS) c.
    double raw = c.cols[m].squaredNorm();
    for (int t = 0; t < p.traces; ++t) {
      const Eigen::Vector3d& k = c.setup_part[m][static_cast<std::size_t>(t)];
      raw += k.dot(p.setup_inv[static_cast<std::size_t>(t)].inverse() * k);
    }
    c.raw_norm2.push_back(raw);
  }
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
  MatrixXd normal_inv;  // (AᵀA)⁻¹
  double sigma2 = 0.0;
  int dof = 0;
  VectorXd residual;
  // Standard uncertainty of the fitted shape parameter of kept candidate j (index into kept),
  // when the model's jacobian with respect to it was included (AugmentShapes).
  std::map<int, double> shape_sigma;
};

// Inner products already computed, keyed by column ids; valid for one data vector.
struct GramCache {
  std::map<std::pair<int, int>, double> gram;
  std::map<int, double> rhs;
};

FitResult Fit(const Problem& p, const std::vector<const Candidate*>& cands, const VectorXd& e0,
              double confound_ratio, char first, char second, GramCache& cache) {
  FitResult f;
  // All candidate columns, their Gram matrix and right-hand side (one pass over the data).
  int total = 0;
  std::vector<int> cand_first;
  for (const Candidate* c : cands) {
    cand_first.push_back(total);
    total += static_cast<int>(c->cols.size());
  }
  std::vector<const VectorXd*> all;
  std::vector<int> ids;
  std::vector<double> raw;
  for (const Candidate* c : cands) {
    for (const auto& col : c->cols) all.push_back(&col);
    ids.insert(ids.end(), c->ids.begin(), c->ids.end());
    raw.insert(raw.end(), c->raw_norm2.begin(), c->raw_norm2.end());
  }
  MatrixXd gram(total, total);
  VectorXd rhs(total);
  for (int a = 0; a < total; ++a) {
    const VectorXd& ca = *all[static_cast<std::size_t>(a)];
    const int ia = ids[static_cast<std::size_t>(a)];
    auto r = cache.rhs.find(ia);
    if (r == cache.rhs.end()) r = cache.rhs.emplace(ia, ca.dot(e0)).first;
    rhs[a] = r->second;
    for (int b = 0; b <= a; ++b) {
      const VectorXd& cb = *all[static_cast<std::size_t>(b)];
      const auto key = std::make_pair(ia, ids[static_cast<std::size_t>(b)]);
      auto g = cache.gram.find(key);
      if (g == cache.gram.end()) g = cache.gram.emplace(key, ca.dot(cb)).first;
      gram(a, b) = gram(b, a) = g->second;
    }
  }

  // Rank-revealing selection in list order: the part of a column not explained by the columns
  // already kept is the Schur complement g_jj − g_Kjᵀ G_KK⁻¹ g_Kj.
  std::vector<int> kcols;
  // Keep at least max(5, N/10) degrees of freedom for the noise estimate.
  const int max_cols = p.n - 3 * p.traces - std::max(5, p.n / 10);
  const double r2 = confound_ratio * confound_ratio;
  for (std::size_t k = 0; k < cands.size(); ++k) {
    const std::string name = effects::EffectName(cands[k]->id, first, second);
    if (static_cast<int>(kcols.size() + cands[k]->cols.size()) > max_cols) {
      f.dropped.push_back(name + " (too few samples)");
      continue;
    }
    std::vector<int> trial = kcols;
    bool ok = true;
    bool setup_only = false;
    int culprit_col = -1;
    for (std::size_t m = 0; m < cands[k]->cols.size(); ++m) {
      const int j = cand_first[k] + static_cast<int>(m);
      const double gjj = gram(j, j);
      // What the evaluated samples see of the effect is (almost) all centre and radius (e.g.
      // a partial arc that does not reach the axis reversal): not separable from the set-up.
      if (!(gjj > r2 * raw[static_cast<std::size_t>(j)]) || !(gjj > 0.0)) {
        ok = false;
        setup_only = true;
        break;
      }
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
      if (left < r2 * gjj) {
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
      std::string s = name;
      if (setup_only) {
        s += " (indistinguishable from the centre offset and radius over the evaluated samples)";
      } else if (culprit_col >= 0) {
        std::size_t owner = 0;
        while (owner + 1 < cands.size() && cand_first[owner + 1] <= culprit_col) ++owner;
        s += " (confounded with " + effects::EffectName(cands[owner]->id, first, second) + ")";
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
      off += static_cast<int>(cands[static_cast<std::size_t>(k)]->cols.size());
    }
  }
  const int dof = p.n - 3 * p.traces - ncol;
  if (dof <= 0) throw NotObservable("diagnosis: more parameters than samples");
  f.dof = dof;
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
    f.sigma2 = f.residual.squaredNorm() / dof;
    f.normal_inv = ldlt.solve(MatrixXd::Identity(ncol, ncol));
    f.cov = f.sigma2 * f.normal_inv;
  } else {
    f.x.resize(0);
    f.residual = e0;
    f.sigma2 = e0.squaredNorm() / dof;
    f.cov.resize(0, 0);
    f.normal_inv.resize(0, 0);
  }
  return f;
}

// d s / d (first shape parameter) of a one-linear-parameter effect at unit value, set-up free,
// by automatic differentiation of the registry model.
VectorXd ShapeDerivative(const Problem& p, const Candidate& c) {
  using J = ceres::Jet<double, 1>;
  VectorXd d(p.n);
  J params[8];
  params[0] = J(1.0);
  for (std::size_t k = 0; k < c.shape.size() && k + 1 < 8; ++k) params[k + 1] = J(c.shape[k]);
  params[1].v[0] = 1.0;
  for (int i = 0; i < p.n; ++i) {
    const auto& s = p.samples[static_cast<std::size_t>(i)];
    const effects::Angle<J> a{J(s.a.theta), J(s.a.c), J(s.a.s)};
    J e[2];
    effects::PositionErrorT<J>(c.id, p.ctx[static_cast<std::size_t>(s.trace)], a, params, e);
    d[i] = e[0].v[0] * s.a.c + e[1].v[0] * s.a.s;
  }
  p.RemoveSetup(d);
  return d;
}

// Covariance of the full model, the fitted shape parameters included: the jacobian gains one
// column x_j ∂s_j/∂shape_j per kept candidate with a fitted shape, σ² = RSS / (N − 3T − p − q).
// Replaces f.cov and f.sigma2 and fills f.shape_sigma (left unchanged when the augmented normal
// matrix is singular, e.g. a shape the data do not determine).
void AugmentShapes(const Problem& p, const std::vector<Candidate>& cands, FitResult& f) {
  const int ncol = static_cast<int>(f.a.size());
  std::vector<VectorXd> d;
  std::vector<int> which;
  for (std::size_t j = 0; j < f.kept.size(); ++j) {
    const Candidate& c = cands[static_cast<std::size_t>(f.kept[j])];
    if (!HasFittedShape(c.id) || c.cols.size() != 1) continue;
    VectorXd col = ShapeDerivative(p, c) * f.x[f.first_col[j]];
    if (!(col.squaredNorm() > 0.0)) continue;
    d.push_back(std::move(col));
    which.push_back(static_cast<int>(j));
  }
  if (d.empty()) return;
  const int nd = static_cast<int>(d.size());
  const int dof = f.dof - nd;
  if (dof <= 0) return;
  MatrixXd m(ncol + nd, ncol + nd);
  for (int a = 0; a < ncol + nd; ++a) {
    const VectorXd& ca =
        a < ncol ? *f.a[static_cast<std::size_t>(a)] : d[static_cast<std::size_t>(a - ncol)];
    for (int b = 0; b <= a; ++b) {
      const VectorXd& cb =
          b < ncol ? *f.a[static_cast<std::size_t>(b)] : d[static_cast<std::size_t>(b - ncol)];
      m(a, b) = m(b, a) = ca.dot(cb);
    }
  }
  Eigen::LDLT<MatrixXd> ldlt(m);
  if (ldlt.info() != Eigen::Success || !ldlt.isPositive()) return;
  const MatrixXd inv = ldlt.solve(MatrixXd::Identity(ncol + nd, ncol + nd));
  for (int a = 0; a < ncol + nd; ++a)
    if (!(inv(a, a) > 0.0) || !std::isfinite(inv(a, a))) return;
  const double sigma2 = f.residual.squaredNorm() / dof;
  f.sigma2 = sigma2;
  f.cov = sigma2 * inv.topLeftCorner(ncol, ncol);
  for (int q = 0; q < nd; ++q)
    f.shape_sigma[which[static_cast<std::size_t>(q)]] = std::sqrt(sigma2 * inv(ncol + q, ncol + q));
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
  if (IsSpike(c.id)) {
    en.shape_kind = c.shape.size() > 1 && c.shape[1] == 2.0 ? "gaussian" : "exponential";
  }
  const auto sh = f.shape_sigma.find(static_cast<int>(j));
  if (sh != f.shape_sigma.end()) {
    en.shape_uncertainty[info.param_names[static_cast<std::size_t>(nl)]] = sh->second;
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
  en.significance = std::min(en.significance, 1e9);
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

// z + 1 for two-value effects and for effects whose shape was searched (one more fitted
// value, and a search that would otherwise make features out of noise).
// A stick-slip sawtooth is a slow ramp against the motion and a sudden slip: fitted reversed
// (amplitude < 0) it is not that shape, and it is not named.
bool Significant(const DiagnosisEntry& e, const DiagnosisOptions& o) {
  const bool strict =
      e.value.size() > 1 || e.params.size() > 1 + e.shape.size() || HasFittedShape(e.id);
  if (e.id == EffectId::kStickSlip && !(e.value[0] > 0.0)) return false;
  return e.significance > (strict ? o.significance + 1.0 : o.significance);
}

// ---- Shape searches: conditional fits of one sparse column against a fixed base ------------

// Base of a conditional fit: the kept columns of a fit (owned by the candidates), their
// (AᵀA)⁻¹ and the residual.
struct Base {
  std::vector<const VectorXd*> a;
  MatrixXd ninv;
  VectorXd r;
  int m = 0;
};

Base MakeBase(const FitResult& f) {
  Base b;
  b.a = f.a;
  b.m = static_cast<int>(f.a.size());
  b.ninv = f.normal_inv;
  b.r = f.residual;
  return b;
}

// A signature given by its non-zero values BEFORE the set-up is removed.
struct Sparse {
  std::vector<int> idx;
  std::vector<double> val;
  void Clear() {
    idx.clear();
    val.clear();
  }
};

// Residual-sum-of-squares reduction when the set-up-free version of `s` joins the base:
// (sᵀr)² / (sᵀs − gᵀ(AᵀA)⁻¹g), g = Aᵀs. The set-up removal is done implicitly: the base
// columns and the residual are set-up free, so only sᵀs needs the correction Σ_t kᵀ(SᵀS)⁻¹k,
// k = S_tᵀ s.
double Gain(const Problem& p, const Base& b, const Sparse& s) {
  std::vector<Eigen::Vector3d> sts(static_cast<std::size_t>(p.traces), Eigen::Vector3d::Zero());
  double ss = 0.0, rs = 0.0;
  VectorXd g = VectorXd::Zero(b.m);
  for (std::size_t k = 0; k < s.idx.size(); ++k) {
    const int i = s.idx[k];
    const double v = s.val[k];
    const auto& smp = p.samples[static_cast<std::size_t>(i)];
    sts[static_cast<std::size_t>(smp.trace)] += v * Eigen::Vector3d(smp.a.c, smp.a.s, 1.0);
    ss += v * v;
    rs += b.r[i] * v;
  }
  for (int j = 0; j < b.m; ++j) {
    const double* col = b.a[static_cast<std::size_t>(j)]->data();
    double acc = 0.0;
    for (std::size_t k = 0; k < s.idx.size(); ++k) acc += s.val[k] * col[s.idx[k]];
    g[j] = acc;
  }
  const double raw = ss;
  for (int t = 0; t < p.traces; ++t) {
    ss -= sts[static_cast<std::size_t>(t)].dot(p.setup_inv[static_cast<std::size_t>(t)] *
                                               sts[static_cast<std::size_t>(t)]);
  }
  double den = ss;
  if (b.m > 0) den -= g.dot(b.ninv * g);
  if (!(den > 1e-9 * raw)) return 0.0;
  return rs * rs / den;
}

// Samples ordered (in buckets of π/kBuckets) by the angle φ travelled since the last reversal
// of one axis, with the spike signature's factor c = signature / decay (the sign of the axis
// velocity and the radial projection), taken from the registry model at a very wide width, so
// a spike of any width and decay is c·Decay(φ) (reversal_spike.h) over the samples where the
// decay is not negligible.
struct ReversalOrder {
  static constexpr int kBuckets = 2048;
  struct Entry {
    double phi;
    int sample;
    double factor;
  };
  std::vector<Entry> by_phi;
  static int Bucket(double phi) {
    return std::clamp(static_cast<int>(phi / std::numbers::pi * kBuckets), 0, kBuckets - 1);
  }
};

ReversalOrder MakeReversalOrder(const Problem& p, EffectId id) {
  const int axis = id == EffectId::kReversalSpikeU ? 0 : 1;
  const double theta0 = effects::internal::AxisReversalAngle(axis);
  constexpr double kWideDeg = 1e4;
  const double params[3] = {1.0, kWideDeg, 1.0};
  std::vector<int> count(ReversalOrder::kBuckets + 1, 0);
  std::vector<ReversalOrder::Entry> e(static_cast<std::size_t>(p.n));
  for (int i = 0; i < p.n; ++i) {
    const auto& s = p.samples[static_cast<std::size_t>(i)];
    const auto& ctx = p.ctx[static_cast<std::size_t>(s.trace)];
    const double phi = effects::internal::AngleSinceReversal(s.a.theta, theta0, ctx.direction);
    const double decay = effects::ReversalSpike<0>::Decay(phi, kWideDeg * kDeg, 1.0);
    e[static_cast<std::size_t>(i)] = {phi, i,
                                      effects::RadialSignature(id, ctx, s.a, params) / decay};
    ++count[static_cast<std::size_t>(ReversalOrder::Bucket(phi)) + 1];
  }
  for (int k = 0; k < ReversalOrder::kBuckets; ++k)
    count[static_cast<std::size_t>(k) + 1] += count[static_cast<std::size_t>(k)];
  ReversalOrder o;
  o.by_phi.resize(e.size());
  for (const auto& x : e) {
    o.by_phi[static_cast<std::size_t>(
        count[static_cast<std::size_t>(ReversalOrder::Bucket(x.phi))]++)] = x;
  }
  return o;
}

// Spike signature at unit height where its decay is above e^−7 (the search only; the fit uses
// the registry signature in full).
void SpikeColumn(const ReversalOrder& o, double width_deg, double exponent, Sparse& out) {
  const double xmax = std::pow(7.0 * exponent, 1.0 / exponent);
  const double w = width_deg * kDeg;
  const double phimax = xmax * w;
  const int last = ReversalOrder::Bucket(phimax);
  out.Clear();
  for (const auto& e : o.by_phi) {
    if (e.phi > phimax) {
      if (ReversalOrder::Bucket(e.phi) > last) break;
      continue;
    }
    const double v = e.factor * effects::ReversalSpike<0>::Decay(e.phi, w, exponent);
    if (v != 0.0) {
      out.idx.push_back(e.sample);
      out.val.push_back(v);
    }
  }
}

// Golden-section maximisation of f on [lo, hi]; returns the best abscissa and value seen.
template <typename F>
std::pair<double, double> GoldenMax(F&& f, double lo, double hi, int iterations) {
  const double gr = (std::sqrt(5.0) - 1.0) / 2.0;
  double x1 = hi - gr * (hi - lo), x2 = lo + gr * (hi - lo);
  double f1 = f(x1), f2 = f(x2);
  for (int it = 0; it < iterations; ++it) {
    if (f1 > f2) {
      hi = x2;
      x2 = x1;
      f2 = f1;
      x1 = hi - gr * (hi - lo);
      f1 = f(x1);
    } else {
      lo = x1;
      x1 = x2;
      f1 = f2;
      x2 = lo + gr * (hi - lo);
      f2 = f(x2);
    }
  }
  return f1 > f2 ? std::make_pair(x1, f1) : std::make_pair(x2, f2);
}

struct SpikeShape {
  double width = 0.0;
  double exponent = 1.0;
  double gain = -1.0;
};

// Width (and decay shape) of the spike that most reduces the residual of the base:
// log-spaced scan of `grid` widths over [lo, hi] for each decay shape, then golden section
// between the neighbours of the best.
SpikeShape SearchSpike(const Problem& p, const ReversalOrder& o, const Base& b, double lo,
                       double hi, int grid, Sparse& buf) {
  SpikeShape best;
  const int kGrid = std::max(grid, 3);
  const double llo = std::log(lo), lhi = std::log(hi);
  for (double k : {1.0, 2.0}) {
    auto gain = [&](double lw) {
      SpikeColumn(o, std::exp(lw), k, buf);
      return Gain(p, b, buf);
    };
    std::vector<double> lw(kGrid), g(kGrid);
    int jb = 0;
    for (int j = 0; j < kGrid; ++j) {
      lw[static_cast<std::size_t>(j)] = llo + (lhi - llo) * j / (kGrid - 1);
      g[static_cast<std::size_t>(j)] = gain(lw[static_cast<std::size_t>(j)]);
      if (g[static_cast<std::size_t>(j)] > g[static_cast<std::size_t>(jb)]) jb = j;
    }
    double xb = lw[static_cast<std::size_t>(jb)], gb = g[static_cast<std::size_t>(jb)];
    const auto [x, v] = GoldenMax(gain, lw[static_cast<std::size_t>(std::max(jb - 1, 0))],
                                  lw[static_cast<std::size_t>(std::min(jb + 1, kGrid - 1))], 10);
    if (v > gb) {
      xb = x;
      gb = v;
    }
    if (gb > best.gain) best = {std::exp(xb), k, gb};
  }
  return best;
}

// Samples in the low-speed zones of stick_slip.h with the angle since their axis reversed
// (degrees) and the sign and radial factor of the sawtooth there, −sign(v_a)·n_a.
struct StickZones {
  std::vector<int> idx;
  std::vector<double> phi_deg;
  std::vector<double> weight;
};

StickZones MakeStickZones(const Problem& p) {
  StickZones z;
  for (int i = 0; i < p.n; ++i) {
    const auto& s = p.samples[static_cast<std::size_t>(i)];
    const int dir = p.ctx[static_cast<std::size_t>(s.trace)].direction;
    for (int ax = 0; ax < 2; ++ax) {
      const double va = effects::internal::AxisUnitVelocity(ax, dir, s.a);
      if (std::abs(va) >= effects::StickSlip::kZone) continue;
      z.idx.push_back(i);
      z.phi_deg.push_back(effects::internal::AngleSinceReversal(
                              s.a.theta, effects::internal::AxisReversalAngle(ax), dir) /
                          kDeg);
      z.weight.push_back(-effects::internal::SignOf(va) * (ax == 0 ? s.a.c : s.a.s));
    }
  }
  return z;
}

// Stick-slip signature at unit amplitude (registry model) on the zone samples.
void StickColumn(const Problem& p, const StickZones& z, double period_deg, Sparse& out) {
  const double params[2] = {1.0, period_deg};
  out.Clear();
  int last = -1;
  for (int i : z.idx) {
    if (i == last) continue;
    last = i;
    const auto& s = p.samples[static_cast<std::size_t>(i)];
    const double v = effects::RadialSignature(
        EffectId::kStickSlip, p.ctx[static_cast<std::size_t>(s.trace)], s.a, params);
    if (v != 0.0) {
      out.idx.push_back(i);
      out.val.push_back(v);
    }
  }
}

// Period (degrees) of the strongest sawtooth fundamental in the residual over the angle since
// the reversal: binned (δ = pmin/4), zero-padded DFT, parabolic peak interpolation; 0 if none.
// `chi2` receives the peak's projection energy over s2 Σ w² (≈ χ² with 2 degrees of freedom
// per frequency for white noise of variance s2).
double StickPeriodPeak(const StickZones& z, const VectorXd& r, double pmin, double pmax, double s2,
                       double* chi2) {
  const double delta = pmin / 4.0;
  const int nb = static_cast<int>(std::ceil(180.0 / delta)) + 1;
  const int len = cv::getOptimalDFTSize(4 * nb);
  cv::Mat buf = cv::Mat::zeros(1, len, CV_64F);
  auto* b = buf.ptr<double>();
  double ww = 0.0;
  for (std::size_t k = 0; k < z.idx.size(); ++k) {
    const int bin = std::clamp(static_cast<int>(std::lround(z.phi_deg[k] / delta)), 0, nb - 1);
    b[bin] += z.weight[k] * r[z.idx[k]];
    ww += z.weight[k] * z.weight[k];
  }
  *chi2 = 0.0;
  cv::Mat spec;
  cv::dft(buf, spec, cv::DFT_COMPLEX_OUTPUT);
  const auto* c = spec.ptr<cv::Vec2d>();
  const double df = 1.0 / (len * delta);  // cycles per degree per bin
  const int kmin = std::max(1, static_cast<int>(std::ceil(1.0 / pmax / df)));
  const int kmax = std::min(len / 2 - 2, static_cast<int>(std::floor(1.0 / pmin / df)));
  if (kmin + 1 >= kmax || !(ww > 0.0) || !(s2 > 0.0)) return 0.0;
  auto power = [&](int k) { return c[k][0] * c[k][0] + c[k][1] * c[k][1]; };
  int best = kmin;
  for (int k = kmin; k <= kmax; ++k)
    if (power(k) > power(best)) best = k;
  double kk = best;
  if (best > kmin && best < kmax) {
    const double y0 = power(best - 1), y1 = power(best), y2 = power(best + 1);
    const double den = y0 - 2.0 * y1 + y2;
    if (den < 0.0) kk += 0.5 * (y0 - y2) / den;
  }
  *chi2 = power(best) / (s2 * ww);
  return 1.0 / (kk * df);
}

// Projection energy of the residual on the sawtooth of period P at the zone samples, against
// the residual alone (no set-up, no other effect): (Σ s r)² / Σ s², s = w (2 frac(φ/P) − 1),
// the shape of stick_slip.h. Cheap enough to scan the period finely.
double SawtoothScore(const StickZones& z, const VectorXd& r, double period) {
  double sr = 0.0, ss = 0.0;
  const double inv = 1.0 / period;
  for (std::size_t k = 0; k < z.idx.size(); ++k) {
    const double x = z.phi_deg[k] * inv;
    const double v = z.weight[k] * (2.0 * (x - std::floor(x)) - 1.0);
    sr += v * r[z.idx[k]];
    ss += v * v;
  }
  return ss > 0.0 ? sr * sr / ss : 0.0;
}

// The teeth of a sawtooth locked to the reversal line up over the whole half turn only at the
// right period: the projection peaks are P·step/180 wide and lie P²/180 apart (the zones just
// after a reversal and just before the next one), and neighbouring peaks differ by a few per
// cent only. From the transform's estimate, scan ±4 such fringes in 1/16 steps of one and
// return the best few local maxima (for an exact comparison on the registry signature).
std::vector<double> FineStickPeriods(const StickZones& z, const VectorXd& r, double period) {
  const double fringe = period * period / 180.0;
  constexpr int kHalf = 64;
  std::vector<double> q(2 * kHalf + 1), sc(2 * kHalf + 1);
  for (int k = -kHalf; k <= kHalf; ++k) {
    q[static_cast<std::size_t>(k + kHalf)] = period + fringe * k / 16.0;
    sc[static_cast<std::size_t>(k + kHalf)] =
        SawtoothScore(z, r, q[static_cast<std::size_t>(k + kHalf)]);
  }
  std::vector<std::pair<double, double>> peaks;
  for (std::size_t i = 0; i < q.size(); ++i) {
    const bool left = i == 0 || sc[i] >= sc[i - 1];
    const bool right = i + 1 == q.size() || sc[i] > sc[i + 1];
    if (left && right) peaks.emplace_back(sc[i], q[i]);
  }
  std::sort(peaks.begin(), peaks.end(), [](const auto& a, const auto& b) { return a > b; });
  std::vector<double> out;
  for (std::size_t i = 0; i < peaks.size() && i < 3; ++i) out.push_back(peaks[i].second);
  return out;
}

// Periods commensurate with the sample step, P = step·n/m (m ≤ 4), within [lo, hi].
std::vector<double> CommensuratePeriods(double lo, double hi, double step) {
  std::vector<double> out;
  if (!(step > 0.0)) return out;
  for (int m = 1; m <= 4; ++m) {
    for (double n = std::ceil(lo * m / step); n <= std::floor(hi * m / step); n += 1.0) {
      const double q = step * n / m;
      if (n > 0.0 && std::find(out.begin(), out.end(), q) == out.end()) out.push_back(q);
    }
  }
  return out;
}

// Gain of the stick-slip signature of period `per` against the base.
double StickGain(const Problem& p, const StickZones& z, const Base& b, double per, Sparse& buf) {
  StickColumn(p, z, per, buf);
  return Gain(p, b, buf);
}

// When the teeth fall on samples (a period q commensurate with the sample step), every period
// within half a sample step of phase over the half turn gives the same sampled sawtooth except
// AT those samples, where the side of the jump is decided by rounding, not by the machine. The
// model there is the jump's midpoint (exactly q, stick_slip.h), so those samples do not bias
// the amplitude whichever way the data were rounded. Returns q when `per` is that close to it.
double SnapStickPeriod(double per, double step) {
  const double tol = per * step / (2.0 * 180.0);
  const auto comm = CommensuratePeriods(per - tol, per + tol, step);
  return comm.empty() ? per : comm.front();
}

// Exact refinement of a stick-slip period: golden section of the gain within ±half (degrees),
// then SnapStickPeriod.
std::pair<double, double> RefineStickPeriod(const Problem& p, const StickZones& z, const Base& b,
                                            double period, double half, double step, Sparse& buf) {
  auto gain = [&](double per) { return StickGain(p, z, b, per, buf); };
  auto best = GoldenMax(gain, period - half, period + half, 14);
  const double g0 = gain(period);
  if (g0 > best.second) best = {period, g0};
  const double q = SnapStickPeriod(best.first, step);
  return q == best.first ? best : std::make_pair(q, gain(q));
}

// A commensurate period q near the best one found: q's signature leaves out the samples on its
// jumps (midpoint), so the comparison is made without those samples for both. Neighbouring
// fringes of a sawtooth whose teeth fall on samples differ from q mostly there, and the data's
// rounding at the jumps must not decide the period (it would bias the amplitude). q is kept
// when it explains at least 90 % of what the best one explains on the same samples.
std::pair<double, double> PreferCommensurate(const Problem& p, const StickZones& z, const Base& b,
                                             std::pair<double, double> best, double window,
                                             double step, Sparse& buf) {
  Sparse qcol, side;
  for (double q : CommensuratePeriods(best.first - window, best.first + window, step)) {
    if (q == best.first) continue;
    StickColumn(p, z, q, qcol);
    StickColumn(p, z, q * (1.0 - 1e-7), side);
    std::vector<int> jumps;
    std::set_difference(side.idx.begin(), side.idx.end(), qcol.idx.begin(), qcol.idx.end(),
                        std::back_inserter(jumps));
    const double gq = Gain(p, b, qcol);
    StickColumn(p, z, best.first, buf);
    Sparse restricted;
    for (std::size_t k = 0; k < buf.idx.size(); ++k) {
      if (std::binary_search(jumps.begin(), jumps.end(), buf.idx[k])) continue;
      restricted.idx.push_back(buf.idx[k]);
      restricted.val.push_back(buf.val[k]);
    }
    // A few samples besides the jumps (those at the reversals themselves, where the angle since
    // the reversal is 0 or 180° by rounding) move the restricted gains by a few per cent.
    if (gq >= 0.9 * Gain(p, b, restricted)) best = {q, gq};
  }
  return best;
}

double MedianStepDeg(const std::vector<DiagnosisTrace>& traces) {
  std::vector<double> steps;
  for (const auto& t : traces)
    for (std::size_t i = 1; i < t.angle_rad.size(); ++i)
      steps.push_back(std::abs(t.angle_rad[i] - t.angle_rad[i - 1]) / kDeg);
  if (steps.empty()) return 0.0;
  auto mid = steps.begin() + static_cast<long>(steps.size() / 2);
  std::nth_element(steps.begin(), mid, steps.end());
  // Files write round steps (0.1°); undo the rounding of the degree → radian conversion.
  const double scale = std::pow(10.0, 6 - std::ceil(std::log10(*mid)));
  return std::round(*mid * scale) / scale;
}

std::vector<const Candidate*> Pointers(const std::vector<Candidate>& cands,
                                       std::size_t skip = static_cast<std::size_t>(-1)) {
  std::vector<const Candidate*> v;
  for (std::size_t i = 0; i < cands.size(); ++i)
    if (i != skip) v.push_back(&cands[i]);
  return v;
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
  if (!(spike_min_width_deg > 0.0 && spike_max_width_deg > spike_min_width_deg)) {
    throw InvalidInput("", 0, "spike_min_width_deg", "need 0 < min < max width");
  }
  if (!(cyclic_min_period_mm > 0.0)) throw InvalidInput("", 0, "cyclic_min_period_mm", "> 0");
  if (!(stick_slip_min_period_deg > 0.0 && stick_slip_max_period_deg > stick_slip_min_period_deg)) {
    throw InvalidInput("", 0, "stick_slip_min_period_deg", "need 0 < min < max period");
  }
  if (!(stick_slip_max_step_deg > 0.0)) {
    throw InvalidInput("", 0, "stick_slip_max_step_deg", "must be positive");
  }
  if (!(stick_slip_detection_chi2 > 0.0)) {
    throw InvalidInput("", 0, "stick_slip_detection_chi2", "must be positive");
  }
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
  const auto axes = AxisLetters(plane);
  const char first = axes.first;
  const char second = axes.second;
  Problem p;
  static_cast<StackedTraces&>(p) = StackTraces(traces);
  // Set-up fit (centre, radius per trace) and the residual about it.
  VectorXd e0 = p.y;
  std::vector<Eigen::Vector3d> setup;
  p.Orthogonalise(e0, &setup);
  std::vector<std::string> not_assessed;
  const double median_step = MedianStepDeg(traces);

  // Stage 1: base form effects (everything linear with a fixed shape).
  const std::vector<EffectId> base_ids = {
      EffectId::kSquareness,   EffectId::kScaleMismatch, EffectId::kServoMismatch,
      EffectId::kBacklashU,    EffectId::kBacklashV,     EffectId::kLateralPlayU,
      EffectId::kLateralPlayV, EffectId::kStraightnessU, EffectId::kStraightnessV};
  std::vector<Candidate> cands;
  for (EffectId id : base_ids) cands.push_back(MakeCandidate(p, id, {}));
  GramCache cache;
  auto fit = [&](const std::vector<Candidate>& c) {
    return Fit(p, Pointers(c), e0, opt.confound_ratio, first, second, cache);
  };
  const FitResult f1 = fit(cands);

  // Stage 2: reversal spikes, width and decay shape fitted against the stage-1 model.
  const double spike_lo = std::max(opt.spike_min_width_deg, 0.5 * median_step);
  const double spike_hi = opt.spike_max_width_deg;
  const ReversalOrder order[2] = {MakeReversalOrder(p, EffectId::kReversalSpikeU),
                                  MakeReversalOrder(p, EffectId::kReversalSpikeV)};
  Sparse buf;
  if (spike_hi > spike_lo) {
    const Base b1 = MakeBase(f1);
    for (int axis = 0; axis < 2; ++axis) {
      const EffectId id = axis == 0 ? EffectId::kReversalSpikeU : EffectId::kReversalSpikeV;
      const SpikeShape s = SearchSpike(p, order[axis], b1, spike_lo, spike_hi, 10, buf);
      if (s.gain > 0.0) cands.push_back(MakeCandidate(p, id, {s.width, s.exponent}));
    }
  } else {
    for (EffectId id : {EffectId::kReversalSpikeU, EffectId::kReversalSpikeV}) {
      not_assessed.push_back(effects::EffectName(id, first, second) +
                             " (samples too far apart to resolve a spike)");
    }
  }
  FitResult f2 = fit(cands);

  // Stage 2b: stick-slip, a sawtooth in the low-speed zones; period from a periodogram over the
  // angle since the reversal, refined on the exact signature, tried when it stands out.
  // Stick-slip teeth shorter than three samples alias into longer, reversed ones: with steps
  // above stick_slip_max_step_deg the sawtooth is not assessed at all.
  const double stick_lo = std::max(opt.stick_slip_min_period_deg, 3.0 * median_step);
  const double stick_hi = opt.stick_slip_max_period_deg;
  const bool stick_assessed = stick_hi > stick_lo && median_step <= opt.stick_slip_max_step_deg;
  const StickZones zones = MakeStickZones(p);
  if (stick_assessed && zones.idx.size() > 10) {
    const double s2 =
        std::max(std::pow(DiffNoiseUm(p, f2.residual), 2), f2.residual.squaredNorm() / f2.dof);
    double chi2 = 0.0;
    const double peak = StickPeriodPeak(zones, f2.residual, stick_lo, stick_hi, s2, &chi2);
    // The transform's peak must stand out before the fine scan is worth its cost: ~500
    // independent frequencies of exponentially distributed power (mean 1) exceed 15 by chance
    // with probability ~1e-4.
    if (peak > 0.0 && chi2 > 15.0) {
      const Base b2 = MakeBase(f2);
      double period = 0.0, gain = -1.0;
      const double fringe = peak * peak / 180.0;
      for (double fine : FineStickPeriods(zones, f2.residual, peak)) {
        const auto [q, g] = RefineStickPeriod(p, zones, b2, fine, fringe / 16.0, median_step, buf);
        if (g > gain) {
          period = q;
          gain = g;
        }
      }
      std::tie(period, gain) =
          PreferCommensurate(p, zones, b2, {period, gain}, 4.0 * fringe, median_step, buf);
      if (gain / s2 > opt.stick_slip_detection_chi2) {
        cands.push_back(MakeCandidate(p, EffectId::kStickSlip, {period}));
        f2 = fit(cands);
      }
    }
  } else if (!stick_assessed) {
    not_assessed.push_back(effects::EffectName(EffectId::kStickSlip, first, second) +
                           " (samples too far apart to resolve its teeth)");
  }

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
  FitResult f3 = fit(cands);
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
    if (changed) f3 = fit(cands);
  }
  // Fitted shapes, jointly: each spike's width and decay shape and the stick-slip period again,
  // against the model of every other effect (one backfitting pass).
  {
    bool changed = false;
    std::vector<double> z(cands.size(), 0.0);  // |value| / σ of the kept candidates in f3
    for (std::size_t j = 0; j < f3.kept.size(); ++j) {
      const int c = f3.first_col[j];
      if (f3.cov(c, c) > 0.0) {
        z[static_cast<std::size_t>(f3.kept[j])] = std::abs(f3.x[c]) / std::sqrt(f3.cov(c, c));
      }
    }
    for (std::size_t q = 0; q < cands.size(); ++q) {
      const EffectId id = cands[q].id;
      // Not worth refining what is clearly not there (z < 2): it will not be named.
      if (!HasFittedShape(id) || z[q] < 2.0) continue;
      const FitResult fo = Fit(p, Pointers(cands, q), e0, opt.confound_ratio, first, second, cache);
      const Base b = MakeBase(fo);
      if (IsSpike(id)) {
        const int axis = id == EffectId::kReversalSpikeU ? 0 : 1;
        const SpikeShape s = SearchSpike(p, order[axis], b, spike_lo, spike_hi, 8, buf);
        if (s.gain > 0.0) cands[q] = MakeCandidate(p, id, {s.width, s.exponent});
      } else {
        const double period = cands[q].shape[0];
        const double tol = period * 1e-6;
        const bool on_samples =
            !CommensuratePeriods(period - tol, period + tol, median_step).empty();
        if (on_samples) continue;  // the teeth fall on the samples: the period is exact
        const auto [refined, gain] = RefineStickPeriod(
            p, zones, b, period, period * period / 180.0 / 32.0, median_step, buf);
        if (gain > 0.0) cands[q] = MakeCandidate(p, id, {refined});
      }
      changed = true;
    }
    if (changed) f3 = fit(cands);
  }

  DiagnosisResult res;
  res.not_identifiable = f3.dropped;
  res.not_identifiable.insert(res.not_identifiable.end(), not_assessed.begin(), not_assessed.end());
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
  // Stage 4: refit with the named form effects only; uncertainties with the fitted shapes.
  FitResult f4 = fit(chosen);
  AugmentShapes(p, chosen, f4);
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

  // Final contributions: named form effects against what is left unexplained.
  {
    std::vector<DiagnosisEntry*> ptrs;
    for (auto& e : res.named)
      if (effects::Info(e.id).in_form) ptrs.push_back(&e);
    Normalise(p, ptrs, final_res);
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
