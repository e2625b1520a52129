#include "analysis/dbb/diagnosis_fit.h"

#include <algorithm>
#include <array>
#include <cmath>

#include <Eigen/Cholesky>
#include <Eigen/LU>

#include "analysis/core/errors.h"
#include "analysis/core/parallel.h"
#include "analysis/dbb/column_dots.h"

namespace km::dbb::diag {

using Eigen::MatrixXd;
using Eigen::VectorXd;
using serial_effects::EffectId;

bool IsSpike(EffectId id) {
  return id == EffectId::kReversalSpikeU || id == EffectId::kReversalSpikeV;
}

bool HasFittedShape(EffectId id) {
  return IsSpike(id) || id == EffectId::kStickSlip;
}

namespace {

// A candidate from its set-up-free columns; its column ids are taken from the problem.
Candidate FromColumns(const Problem& p, EffectId id, EffectColumns e) {
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

}  // namespace

Candidate MakeCandidate(const Problem& p, EffectId id, std::vector<double> shape) {
  return FromColumns(p, id, SetupFreeSignature(p, id, std::move(shape)));
}

std::vector<Candidate> MakeCandidates(const Problem& p, const std::vector<CandidateSpec>& specs,
                                      unsigned threads) {
  std::vector<EffectColumns> cols;
  for (const auto& s : specs) cols.push_back(SignatureShell(p, s.id, s.shape));
  // One job per candidate and trace: the rows of the traces are independent.
  const auto traces = static_cast<std::size_t>(p.traces);
  ParallelFor(
      specs.size() * traces,
      [&](std::size_t k) { SignatureOfTrace(p, static_cast<int>(k % traces), cols[k / traces]); },
      threads);
  std::vector<Candidate> out;
  for (std::size_t k = 0; k < specs.size(); ++k)
    out.push_back(FromColumns(p, specs[k].id, std::move(cols[k])));
  return out;
}

VectorXd FitResult::Combine(int off, int count, Eigen::Index n) const {
  if (count <= 0) return VectorXd::Zero(n);
  // One sweep over the samples for all the columns (column_dots.h).
  std::vector<const double*> cols(static_cast<std::size_t>(count));
  for (int m = 0; m < count; ++m)
    cols[static_cast<std::size_t>(m)] = a[static_cast<std::size_t>(off + m)]->data();
  VectorXd v(n);
  CombineColumns(cols.data(), x.data() + off, count, n, v.data());
  return v;
}

namespace {

// All candidate columns, their Gram matrix and right-hand side (one pass over the data).
struct Gram {
  std::vector<int> cand_first;  // first column of each candidate
  std::vector<const VectorXd*> all;
  std::vector<double> raw;  // squared norm of each column before the set-up removal
  MatrixXd g;
  VectorXd rhs;
};

// The missing inner products in groups sharing their first column (up to kMaxFusedDots each,
// one pass of FusedDots), summed over fixed chunks of rows: a chunk of every column involved
// stays in the second-level cache while its groups read it (the columns of a fit do not fit there
// whole), and the chunks are independent of the threads that sum them.
struct DotGroup {
  std::size_t first = 0;  // index into the missing products
  int count = 0;
  const double* x = nullptr;
  std::array<const double*, kMaxFusedDots> ys{};
};

std::vector<DotGroup> GroupsOf(const FitContext& ctx, const Gram& gr,
                               const std::vector<std::pair<int, int>>& missing) {
  std::vector<DotGroup> groups;
  for (std::size_t k = 0; k < missing.size(); ++k) {
    const auto [a, b] = missing[k];
    if (groups.empty() || groups.back().count == kMaxFusedDots ||
        missing[groups.back().first].first != a) {
      groups.push_back({k, 0, gr.all[static_cast<std::size_t>(a)]->data(), {}});
    }
    DotGroup& g = groups.back();
    g.ys[static_cast<std::size_t>(g.count++)] =
        b < 0 ? ctx.e0->data() : gr.all[static_cast<std::size_t>(b)]->data();
  }
  return groups;
}

std::vector<double> MissingProducts(const FitContext& ctx, const Gram& gr,
                                    const std::vector<std::pair<int, int>>& missing) {
  constexpr Eigen::Index kChunk = 1024;
  const Eigen::Index n = ctx.p->n;
  const std::vector<DotGroup> groups = GroupsOf(ctx, gr, missing);
  const auto chunks = static_cast<std::size_t>((n + kChunk - 1) / kChunk);
  std::vector<double> part(chunks * missing.size());
  ParallelFor(
      chunks,
      [&](std::size_t c) {
        const Eigen::Index from = static_cast<Eigen::Index>(c) * kChunk;
        const Eigen::Index len = std::min(kChunk, n - from);
        std::array<const double*, kMaxFusedDots> ys{};
        for (const DotGroup& g : groups) {
          for (int k = 0; k < g.count; ++k)
            ys[static_cast<std::size_t>(k)] = g.ys[static_cast<std::size_t>(k)] + from;
          FusedDots(g.x + from, ys.data(), g.count, len, &part[c * missing.size() + g.first]);
        }
      },
      missing.size() * chunks >= 64 ? ctx.threads : 1);
  std::vector<double> val(missing.size(), 0.0);
  for (std::size_t c = 0; c < chunks; ++c)
    for (std::size_t k = 0; k < missing.size(); ++k) val[k] += part[c * missing.size() + k];
  return val;
}

// The inner products of the columns and with the data, from the cache where known; the
// missing ones are computed (MissingProducts) and cached unless read-only.
void FillInnerProducts(const FitContext& ctx, const std::vector<int>& ids, Gram& gr) {
  GramCache& cache = *ctx.cache;
  const int total = static_cast<int>(gr.all.size());
  std::vector<std::pair<int, int>> missing;  // (a, b ≤ a), b = −1 for the data
  for (int a = 0; a < total; ++a) {
    const int ia = ids[static_cast<std::size_t>(a)];
    const auto r = cache.rhs.find(ia);
    if (r != cache.rhs.end())
      gr.rhs[a] = r->second;
    else
      missing.emplace_back(a, -1);
    for (int b = 0; b <= a; ++b) {
      const auto g = cache.gram.find({ia, ids[static_cast<std::size_t>(b)]});
      if (g != cache.gram.end())
        gr.g(a, b) = gr.g(b, a) = g->second;
      else
        missing.emplace_back(a, b);
    }
  }
  const std::vector<double> val = MissingProducts(ctx, gr, missing);
  for (std::size_t k = 0; k < missing.size(); ++k) {
    const auto [a, b] = missing[k];
    const int ia = ids[static_cast<std::size_t>(a)];
    if (b < 0) {
      gr.rhs[a] = val[k];
      if (!ctx.read_only_cache) cache.rhs.emplace(ia, val[k]);
    } else {
      gr.g(a, b) = gr.g(b, a) = val[k];
      if (!ctx.read_only_cache)
        cache.gram.emplace(std::make_pair(ia, ids[static_cast<std::size_t>(b)]), val[k]);
    }
  }
}

Gram GramOf(const FitContext& ctx, const std::vector<const Candidate*>& cands) {
  Gram gr;
  std::vector<int> ids;
  for (const Candidate* c : cands) {
    gr.cand_first.push_back(static_cast<int>(gr.all.size()));
    for (const auto& col : c->cols) gr.all.push_back(&col);
    ids.insert(ids.end(), c->ids.begin(), c->ids.end());
    gr.raw.insert(gr.raw.end(), c->raw_norm2.begin(), c->raw_norm2.end());
  }
  const int total = static_cast<int>(gr.all.size());
  gr.g.resize(total, total);
  gr.rhs.resize(total);
  FillInnerProducts(ctx, ids, gr);
  return gr;
}

// Part of column j not explained by the columns `kept`: the Schur complement
// g_jj − g_Kjᵀ G_KK⁻¹ g_Kj.
double Unexplained(const MatrixXd& g, const std::vector<int>& kept, int j) {
  if (kept.empty()) return g(j, j);
  const auto nk = static_cast<Eigen::Index>(kept.size());
  MatrixXd gkk(nk, nk);
  VectorXd gkj(nk);
  for (Eigen::Index a = 0; a < nk; ++a) {
    gkj[a] = g(kept[static_cast<std::size_t>(a)], j);
    for (Eigen::Index b = 0; b < nk; ++b)
      gkk(a, b) = g(kept[static_cast<std::size_t>(a)], kept[static_cast<std::size_t>(b)]);
  }
  return g(j, j) - gkj.dot(gkk.ldlt().solve(gkj));
}

// The kept column most correlated with column j.
int MostCorrelated(const MatrixXd& g, const std::vector<int>& kept, int j) {
  double best = 0.0;
  int culprit = -1;
  for (int i : kept) {
    const double corr = std::abs(g(i, j)) / std::sqrt(g(i, i) * g(j, j) + 1e-300);
    if (corr > best) {
      best = corr;
      culprit = i;
    }
  }
  return culprit;
}

// Why candidate k cannot join the columns `kcols` ("" when it can); on success its columns are
// appended to `trial`.
std::string Refusal(const FitContext& ctx, const std::vector<const Candidate*>& cands,
                    const Gram& gr, const std::vector<int>& kcols, std::size_t k,
                    std::vector<int>& trial) {
  const double r2 = ctx.confound_ratio * ctx.confound_ratio;
  trial = kcols;
  for (std::size_t m = 0; m < cands[k]->cols.size(); ++m) {
    const int j = gr.cand_first[k] + static_cast<int>(m);
    const double gjj = gr.g(j, j);
    // What the evaluated samples see of the effect is (almost) all centre and radius (e.g.
    // a partial arc that does not reach the axis reversal): not separable from the set-up.
    if (!(gjj > r2 * gr.raw[static_cast<std::size_t>(j)]) || !(gjj > 0.0)) {
      return " (indistinguishable from the centre offset and radius over the evaluated samples)";
    }
    if (Unexplained(gr.g, trial, j) < r2 * gjj) {
      const int culprit = MostCorrelated(gr.g, kcols, j);
      if (culprit < 0) return " ";
      std::size_t owner = 0;
      while (owner + 1 < cands.size() && gr.cand_first[owner + 1] <= culprit) ++owner;
      return " (confounded with " +
             serial_effects::EffectName(cands[owner]->id, ctx.first, ctx.second) + ")";
    }
    trial.push_back(j);
  }
  return "";
}

// Rank-revealing selection in list order; fills f.kept, f.first_col and f.dropped and returns
// the kept columns.
std::vector<int> SelectColumns(const FitContext& ctx, const std::vector<const Candidate*>& cands,
                               const Gram& gr, FitResult& f) {
  const Problem& p = *ctx.p;
  std::vector<int> kcols;
  // Keep at least max(5, N/10) degrees of freedom for the noise estimate.
  const int max_cols = p.n - 3 * p.traces - std::max(5, p.n / 10);
  for (std::size_t k = 0; k < cands.size(); ++k) {
    std::string name = serial_effects::EffectName(cands[k]->id, ctx.first, ctx.second);
    if (static_cast<int>(kcols.size() + cands[k]->cols.size()) > max_cols) {
      f.dropped.push_back(name + " (too few samples)");
      continue;
    }
    std::vector<int> trial;
    const std::string why = Refusal(ctx, cands, gr, kcols, k, trial);
    if (!why.empty()) {
      f.dropped.push_back(why == " " ? name : name + why);
      continue;
    }
    f.first_col.push_back(static_cast<int>(kcols.size()));
    kcols = trial;
    f.kept.push_back(static_cast<int>(k));
  }
  return kcols;
}

// Solves the normal equations of the kept columns.
void Solve(const FitContext& ctx, const Gram& gr, const std::vector<int>& kcols, FitResult& f) {
  const Problem& p = *ctx.p;
  const int ncol = static_cast<int>(kcols.size());
  const int dof = p.n - 3 * p.traces - ncol;
  if (dof <= 0) throw NotObservable("diagnosis: more parameters than samples");
  f.dof = dof;
  f.a.resize(static_cast<std::size_t>(ncol));
  MatrixXd m(ncol, ncol);
  VectorXd b(ncol);
  for (int a = 0; a < ncol; ++a) {
    const int ka = kcols[static_cast<std::size_t>(a)];
    f.a[static_cast<std::size_t>(a)] = gr.all[static_cast<std::size_t>(ka)];
    b[a] = gr.rhs[ka];
    for (int c = 0; c < ncol; ++c) m(a, c) = gr.g(ka, kcols[static_cast<std::size_t>(c)]);
  }
  if (ncol == 0) {
    f.x.resize(0);
    f.residual = *ctx.e0;
    f.sigma2 = f.residual.squaredNorm() / dof;
    return;
  }
  Eigen::LDLT<MatrixXd> ldlt(m);
  f.normal = std::move(m);
  f.x = ldlt.solve(b);
  f.residual = *ctx.e0 - f.Combine(0, ncol, p.n);
  f.sigma2 = f.residual.squaredNorm() / dof;
  f.normal_inv = ldlt.solve(MatrixXd::Identity(ncol, ncol));
  f.cov = f.sigma2 * f.normal_inv;
}

// Symmetric matrix of inner products of the columns `cols`, whose first `known` ones have the
// inner products `normal` (a fit's AᵀA: the same products, already computed); the rows of the
// others on up to `threads` threads.
MatrixXd InnerProducts(const std::vector<const VectorXd*>& cols, const MatrixXd& normal,
                       unsigned threads) {
  const auto n = static_cast<Eigen::Index>(cols.size());
  const Eigen::Index known = normal.rows();
  MatrixXd m(n, n);
  m.topLeftCorner(known, known) = normal;
  ParallelFor(
      static_cast<std::size_t>(n - known),
      [&](std::size_t k) {
        const Eigen::Index a = known + static_cast<Eigen::Index>(k);
        const VectorXd& x = *cols[static_cast<std::size_t>(a)];
        // Row a up to the diagonal, kMaxFusedDots products a pass (column_dots.h FusedDots).
        std::array<const double*, kMaxFusedDots> ys{};
        std::array<double, kMaxFusedDots> out{};
        for (Eigen::Index b0 = 0; b0 <= a; b0 += kMaxFusedDots) {
          const int count = static_cast<int>(std::min<Eigen::Index>(kMaxFusedDots, a + 1 - b0));
          for (int j = 0; j < count; ++j)
            ys[static_cast<std::size_t>(j)] = cols[static_cast<std::size_t>(b0 + j)]->data();
          FusedDots(x.data(), ys.data(), count, x.size(), out.data());
          for (int j = 0; j < count; ++j) m(a, b0 + j) = out[static_cast<std::size_t>(j)];
        }
      },
      threads);
  for (Eigen::Index a = known; a < n; ++a)
    for (Eigen::Index b = 0; b < a; ++b) m(b, a) = m(a, b);
  return m;
}

}  // namespace

FitResult Fit(const FitContext& ctx, const std::vector<const Candidate*>& cands) {
  FitResult f;
  const Gram gr = GramOf(ctx, cands);
  const std::vector<int> kcols = SelectColumns(ctx, cands, gr, f);
  Solve(ctx, gr, kcols, f);
  return f;
}

// The jacobian gains one column x_j ∂s_j/∂shape_j per kept candidate with a fitted shape,
// σ² = RSS / (N − 3T − p − q). Replaces f.cov and f.sigma2 and fills f.shape_sigma (left
// unchanged when the augmented normal matrix is singular, e.g. a shape the data do not
// determine).
void AugmentShapes(const Problem& p, const std::vector<Candidate>& cands, FitResult& f,
                   unsigned threads) {
  const int ncol = static_cast<int>(f.a.size());
  std::vector<std::size_t> shaped;  // indices into f.kept
  for (std::size_t j = 0; j < f.kept.size(); ++j) {
    const Candidate& c = cands[static_cast<std::size_t>(f.kept[j])];
    if (HasFittedShape(c.id) && c.cols.size() == 1) shaped.push_back(j);
  }
  std::vector<VectorXd> all(shaped.size());
  ParallelFor(
      shaped.size(),
      [&](std::size_t k) {
        const std::size_t j = shaped[k];
        all[k] =
            ShapeDerivative(p, cands[static_cast<std::size_t>(f.kept[j])]) * f.x[f.first_col[j]];
      },
      threads);
  std::vector<VectorXd> d;
  std::vector<int> which;
  for (std::size_t k = 0; k < shaped.size(); ++k) {
    if (!(all[k].squaredNorm() > 0.0)) continue;
    d.push_back(std::move(all[k]));
    which.push_back(static_cast<int>(shaped[k]));
  }
  const int nd = static_cast<int>(d.size());
  const int dof = f.dof - nd;
  if (d.empty() || dof <= 0) return;
  std::vector<const VectorXd*> cols = f.a;
  for (const auto& c : d) cols.push_back(&c);
  Eigen::LDLT<MatrixXd> ldlt(InnerProducts(cols, f.normal, threads));
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

Base MakeBase(const FitResult& f) {
  Base b;
  b.a = f.a;
  b.m = static_cast<int>(f.a.size());
  b.ninv = f.normal_inv;
  b.r = f.residual;
  return b;
}

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

std::vector<const Candidate*> Pointers(const std::vector<Candidate>& cands, std::size_t skip) {
  std::vector<const Candidate*> v;
  for (std::size_t i = 0; i < cands.size(); ++i)
    if (i != skip) v.push_back(&cands[i]);
  return v;
}

}  // namespace km::dbb::diag
