#include "analysis/dbb/diagnosis_search.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <iterator>
#include <numbers>
#include <utility>

#include <opencv2/core.hpp>

#include "analysis/core/angles.h"
#include "analysis/dbb/column_dots.h"
#include "analysis/dbb/spike_decay.h"

namespace km::dbb::diag {

using Eigen::VectorXd;
using serial_effects::EffectId;

namespace {}  // namespace

int ReversalOrder::Bucket(double phi) {
  return std::clamp(static_cast<int>(phi / std::numbers::pi * kBuckets), 0, kBuckets - 1);
}

namespace {

// Angle since the reversal and radial factor Side·n_a of the samples within max_phi of the
// reversal (reversal_spike.h).
template <int Axis>
std::vector<ReversalOrder::Entry> SpikeFactors(const Problem& p, double max_phi) {
  using Spike = serial_effects::ReversalSpike<Axis>;
  std::vector<ReversalOrder::Entry> e;
  e.reserve(static_cast<std::size_t>(p.n));
  const auto& cached = p.reversal_phase[Axis];
  const bool have = cached.phi.size() == static_cast<std::size_t>(p.n);
  for (int i = 0; i < p.n; ++i) {
    const auto u = static_cast<std::size_t>(i);
    const auto& s = p.samples[u];
    const auto ph =
        have ? serial_effects::internal::ReversalPhase<double>{cached.phi[u], cached.side[u]}
             : Spike::Phase(p.ctx[static_cast<std::size_t>(s.trace)], s.a);
    if (ph.phi <= max_phi) e.push_back({ph.phi, i, ph.side * (Axis == 0 ? s.a.c : s.a.s)});
  }
  return e;
}

}  // namespace

ReversalOrder MakeReversalOrder(const Problem& p, EffectId id, double max_phi) {
  const std::vector<ReversalOrder::Entry> e =
      id == EffectId::kReversalSpikeU ? SpikeFactors<0>(p, max_phi) : SpikeFactors<1>(p, max_phi);
  std::vector<int> count(ReversalOrder::kBuckets + 1, 0);
  std::vector<int> bucket(e.size());
  for (std::size_t i = 0; i < e.size(); ++i) {
    bucket[i] = ReversalOrder::Bucket(e[i].phi);
    ++count[static_cast<std::size_t>(bucket[i]) + 1];
  }
  for (int k = 0; k < ReversalOrder::kBuckets; ++k)
    count[static_cast<std::size_t>(k) + 1] += count[static_cast<std::size_t>(k)];
  ReversalOrder o;
  o.by_phi.resize(e.size());
  for (std::size_t i = 0; i < e.size(); ++i)
    o.by_phi[static_cast<std::size_t>(count[static_cast<std::size_t>(bucket[i])]++)] = e[i];
  return o;
}

namespace {

// The base columns, the set-up columns {cos θ, sin θ, 1} of each trace and the residual at the
// samples a spike of width up to the search's largest can reach, sorted by the angle since the
// reversal: each width's gain is then one dense product over a prefix of the rows.
struct SpikeFrame {
  Eigen::MatrixXd a;  // [base columns | 3 set-up columns per trace | residual]
  VectorXd factor, phi;
};

SpikeFrame MakeSpikeFrame(const Problem& p, const ReversalOrder& o, const Base& b, double phimax) {
  std::vector<const ReversalOrder::Entry*> rows;
  const int last = ReversalOrder::Bucket(phimax);
  for (const auto& e : o.by_phi) {
    if (ReversalOrder::Bucket(e.phi) > last) break;
    if (e.phi <= phimax) rows.push_back(&e);
  }
  // Within a bucket only: insertion sort, stable (what std::stable_sort gives) and linear for
  // rows already in bucket order.
  for (std::size_t k = 1; k < rows.size(); ++k) {
    const ReversalOrder::Entry* e = rows[k];
    std::size_t m = k;
    for (; m > 0 && e->phi < rows[m - 1]->phi; --m) rows[m] = rows[m - 1];
    rows[m] = e;
  }
  SpikeFrame f;
  const auto n = static_cast<Eigen::Index>(rows.size());
  f.a.resize(n, b.m + 3 * p.traces + 1);
  f.a.middleCols(b.m, 3 * p.traces).setZero();
  f.factor.resize(n);
  f.phi.resize(n);
  std::vector<int> sample(static_cast<std::size_t>(n));
  for (Eigen::Index k = 0; k < n; ++k) {
    const auto& e = *rows[static_cast<std::size_t>(k)];
    sample[static_cast<std::size_t>(k)] = e.sample;
    const auto& smp = p.samples[static_cast<std::size_t>(e.sample)];
    const Eigen::Index setup = b.m + 3 * smp.trace;
    f.a(k, setup) = smp.a.c;
    f.a(k, setup + 1) = smp.a.s;
    f.a(k, setup + 2) = 1.0;
    f.factor[k] = e.factor;
    f.phi[k] = e.phi;
  }
  // Column by column: the frame is column-major (the stores are then contiguous).
  auto gather = [&](Eigen::Index j, const VectorXd& col) {
    double* out = f.a.col(j).data();
    for (Eigen::Index k = 0; k < n; ++k) out[k] = col[sample[static_cast<std::size_t>(k)]];
  };
  for (int j = 0; j < b.m; ++j) gather(j, *b.a[static_cast<std::size_t>(j)]);
  gather(b.m + 3 * p.traces, b.r);
  return f;
}

// Largest angle since the reversal where a decay of width w (rad) and exponent k is above e^−7
// (the search only; the fit uses the registry signature in full).
double SpikeReach(double w, double exponent) {
  return std::pow(7.0 * exponent, 1.0 / exponent) * w;
}

}  // namespace

double SpikeMaxReach(double hi_deg) {
  return std::max(SpikeReach(hi_deg * kDeg, 1.0), SpikeReach(hi_deg * kDeg, 2.0));
}

namespace {

// Gain (diagnosis_fit.h Gain) of the unit-height spike of width w (rad) and exponent k, and
// the spike's height in the fit of base + spike (when wanted).
// Work space of the gains of one search, sized once for its frame: the decays, Aᵀs and
// (AᵀA)⁻¹g (no allocation per width tried).
struct GainWork {
  VectorXd v, h, ng;
  explicit GainWork(const SpikeFrame& f, int m)
      : v(f.a.rows()), h(f.a.cols()), ng(std::max(m, 1)) {}
};

double SpikeGain(const Problem& p, const Base& b, const SpikeFrame& f, double w, double exponent,
                 GainWork& work, double* height = nullptr) {
  const double phimax = SpikeReach(w, exponent);
  const Eigen::Index len =
      std::upper_bound(f.phi.data(), f.phi.data() + f.phi.size(), phimax) - f.phi.data();
  // The decay of reversal_spike.h, vectorised for its two shapes (spike_decay.h).
  auto v = work.v.head(len);
  if (exponent == 1.0 || exponent == 2.0) {
    SpikeDecays(f.phi.data(), f.factor.data(), len, w, exponent == 2.0, v.data());
  } else {
    for (Eigen::Index k = 0; k < len; ++k)
      v[k] = f.factor[k] * serial_effects::ReversalSpike<0>::Decay(f.phi[k], w, exponent);
  }
  VectorXd& h = work.h;  // Aᵀs, S_tᵀs, rᵀs
  FrameDots(f.a.data(), f.a.rows(), static_cast<int>(f.a.cols()), v.data(), len, h.data());
  const double raw = v.squaredNorm();
  const double rs = h[b.m + 3 * p.traces];
  double den = raw;
  for (int t = 0; t < p.traces; ++t) {
    const Eigen::Vector3d sts = h.segment<3>(b.m + 3 * t);
    den -= sts.dot(p.setup_inv[static_cast<std::size_t>(t)] * sts);
  }
  if (b.m > 0) {
    auto ng = work.ng.head(b.m);
    ng.noalias() = b.ninv * h.head(b.m);
    den -= h.head(b.m).dot(ng);
  }
  if (!(den > 1e-9 * raw)) return 0.0;
  // The residual is orthogonal to the base and the set-up: rs is the projection on the part of
  // the spike they leave, whose squared norm is den.
  if (height) *height = rs / den;
  return rs * rs / den;
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

}  // namespace

// Width (and decay shape) of the spike that most reduces the residual of the base:
// log-spaced scan of `grid` widths over [lo, hi] for each decay shape, then golden section
// between the neighbours of the best.
SpikeFit SearchSpike(const Problem& p, const ReversalOrder& o, const Base& b, double lo, double hi,
                     int grid) {
  std::array<SpikeShape, 2> best;
  const int kGrid = std::max(grid, 3);
  const double llo = std::log(lo), lhi = std::log(hi);
  const SpikeFrame frame = MakeSpikeFrame(p, o, b, SpikeMaxReach(hi));
  GainWork work(frame, b.m);
  for (std::size_t shape = 0; shape < 2; ++shape) {
    const double k = shape == 0 ? 1.0 : 2.0;
    // Every evaluation keeps its height; the best one's is reported.
    std::vector<std::pair<double, double>> height;  // (log width, height)
    auto gain = [&](double lw) {
      double h = 0.0;
      const double g = SpikeGain(p, b, frame, std::exp(lw) * kDeg, k, work, &h);
      height.emplace_back(lw, h);
      return g;
    };
    std::vector<double> lw(kGrid), g(kGrid);
    int jb = 0;
    for (int j = 0; j < kGrid; ++j) {
      lw[static_cast<std::size_t>(j)] = llo + (lhi - llo) * j / (kGrid - 1);
      g[static_cast<std::size_t>(j)] = gain(lw[static_cast<std::size_t>(j)]);
      if (g[static_cast<std::size_t>(j)] > g[static_cast<std::size_t>(jb)]) jb = j;
    }
    double xb = lw[static_cast<std::size_t>(jb)], gb = g[static_cast<std::size_t>(jb)];
    const auto [x, val] = GoldenMax(gain, lw[static_cast<std::size_t>(std::max(jb - 1, 0))],
                                    lw[static_cast<std::size_t>(std::min(jb + 1, kGrid - 1))], 10);
    if (val > gb) {
      xb = x;
      gb = val;
    }
    best[shape] = {std::exp(xb), k, gb, 0.0};
    for (const auto& [l, h] : height)
      if (l == xb) best[shape].height = h;
  }
  // The exponential decay wins a tie (the former model).
  return best[1].gain > best[0].gain ? SpikeFit{best[1], best[0]} : SpikeFit{best[0], best[1]};
}

SpikeFit RefineSpike(const Problem& p, const ReversalOrder& o, const Base& b,
                     const std::array<double, 2>& widths, double lo, double hi) {
  std::array<SpikeShape, 2> best;
  const double lf = std::log(kSpikeRefineFactor);
  const double llo = std::log(lo), lhi = std::log(hi);
  std::array<std::pair<double, double>, 2> range;  // log width bracket of each shape
  double reach = 0.0;
  for (std::size_t shape = 0; shape < 2; ++shape) {
    const double lw = std::clamp(std::log(widths[shape]), llo, lhi);
    range[shape] = {std::max(llo, lw - lf), std::min(lhi, lw + lf)};
    reach = std::max(reach, SpikeReach(std::exp(range[shape].second) * kDeg, shape + 1.0));
  }
  const SpikeFrame frame = MakeSpikeFrame(p, o, b, reach);
  GainWork work(frame, b.m);
  for (std::size_t shape = 0; shape < 2; ++shape) {
    const double k = shape == 0 ? 1.0 : 2.0;
    std::vector<std::pair<double, double>> height;  // (log width, height)
    auto gain = [&](double lw) {
      double h = 0.0;
      const double g = SpikeGain(p, b, frame, std::exp(lw) * kDeg, k, work, &h);
      height.emplace_back(lw, h);
      return g;
    };
    const double start = std::clamp(std::log(widths[shape]), llo, lhi);
    double xb = start, gb = gain(start);
    const auto [x, val] = GoldenMax(gain, range[shape].first, range[shape].second, 12);
    if (val > gb) {
      xb = x;
      gb = val;
    }
    best[shape] = {std::exp(xb), k, gb, 0.0};
    for (const auto& [l, h] : height)
      if (l == xb) best[shape].height = h;
  }
  return best[1].gain > best[0].gain ? SpikeFit{best[1], best[0]} : SpikeFit{best[0], best[1]};
}

double ShapeDoubtVariance(const SpikeFit& f, double s2) {
  if (!(s2 > 0.0) || !(f.other.gain > 0.0)) return 0.0;
  const double x = (f.best.gain - f.other.gain) / (2.0 * s2);
  const double p_other = x > 700.0 ? 0.0 : 1.0 / (1.0 + std::exp(x));
  const double d = f.best.height - f.other.height;
  return p_other * d * d;
}

StickZones MakeStickZones(const Problem& p) {
  StickZones z;
  for (int i = 0; i < p.n; ++i) {
    const auto& s = p.samples[static_cast<std::size_t>(i)];
    const int dir = p.ctx[static_cast<std::size_t>(s.trace)].direction;
    for (int ax = 0; ax < 2; ++ax) {
      const double va = serial_effects::internal::AxisUnitVelocity(ax, dir, s.a);
      if (std::abs(va) >= serial_effects::StickSlip::kZone) continue;
      z.idx.push_back(i);
      z.phi_deg.push_back(serial_effects::internal::AngleSinceReversal(
                              s.a.theta, serial_effects::internal::AxisReversalAngle(ax), dir) /
                          kDeg);
      z.weight.push_back(-serial_effects::internal::SignOf(va) * (ax == 0 ? s.a.c : s.a.s));
    }
  }
  return z;
}

namespace {

// Stick-slip signature at unit amplitude (registry model) on the zone samples.
void StickColumn(const Problem& p, const StickZones& z, double period_deg, Sparse& out) {
  const double params[2] = {1.0, period_deg};
  out.Clear();
  int last = -1;
  for (int i : z.idx) {
    if (i == last) continue;
    last = i;
    const auto& s = p.samples[static_cast<std::size_t>(i)];
    const double v = serial_effects::RadialSignature(
        EffectId::kStickSlip, p.ctx[static_cast<std::size_t>(s.trace)], s.a, params);
    if (v != 0.0) {
      out.idx.push_back(i);
      out.val.push_back(v);
    }
  }
}

}  // namespace

namespace {

// std::round of x without the call for 0 ≤ x < 2⁵² (x − ⌊x⌋ is exact there): ties away from 0.
double RoundHalfUp(double x) {
  if (!(x >= 0.0 && x < 0x1p52)) return std::round(x);
  const double t = std::floor(x);
  return x - t >= 0.5 ? t + 1.0 : t;
}

}  // namespace

// Period (degrees) of the strongest sawtooth fundamental in the residual over the angle since
// the reversal: binned (δ = pmin/4), zero-padded DFT, parabolic peak interpolation; 0 if none.
// `chi2` receives the peak's projection energy over s2 Σ w² (≈ χ² with 2 degrees of freedom
// per frequency for white noise of variance s2).
double StickPeriodPeak(const StickZones& z, const VectorXd& r, double pmin, double pmax, double s2,
                       double* chi2) {
  const double delta = pmin / 4.0;
  const int nb = static_cast<int>(std::ceil(180.0 / delta)) + 1;
  const int len = cv::getOptimalDFTSize(4 * nb);
  std::vector<double> b(static_cast<std::size_t>(len), 0.0);
  double ww = 0.0;
  for (std::size_t k = 0; k < z.idx.size(); ++k) {
    // The nearest bin (std::lround's), within [0, nb).
    const double q = RoundHalfUp(z.phi_deg[k] / delta);
    const int bin = q >= 0.0 ? static_cast<int>(std::min(q, nb - 1.0)) : 0;
    b[static_cast<std::size_t>(bin)] += z.weight[k] * r[z.idx[k]];
    ww += z.weight[k] * z.weight[k];
  }
  *chi2 = 0.0;
  const double df = 1.0 / (len * delta);  // cycles per degree per bin
  const int kmin = std::max(1, static_cast<int>(std::ceil(1.0 / pmax / df)));
  const int kmax = std::min(len / 2 - 2, static_cast<int>(std::floor(1.0 / pmin / df)));
  if (kmin + 1 >= kmax || !(ww > 0.0) || !(s2 > 0.0)) return 0.0;
  const std::vector<double> pw = RealPowerSpectrum(std::move(b));
  auto power = [&](int k) { return pw[static_cast<std::size_t>(k)]; };
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

namespace {

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

}  // namespace

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

namespace {

// Gain of the stick-slip signature of period `per` against the base.
double StickGain(const Problem& p, const StickZones& z, const Base& b, double per, Sparse& buf) {
  StickColumn(p, z, per, buf);
  return Gain(p, b, buf);
}

}  // namespace

namespace {

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

}  // namespace

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

}  // namespace km::dbb::diag
