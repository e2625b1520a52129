#include "analysis/dbb/signatures.h"

#include <algorithm>
#include <cmath>
#include <numbers>
#include <utility>

#include <Eigen/LU>
#include <opencv2/core.hpp>

#include "analysis/core/errors.h"
#include "analysis/core/sincos.h"
#include "analysis/dbb/column_dots.h"
#include "analysis/dbb/spike_decay.h"

namespace km::dbb {

using Eigen::VectorXd;

Eigen::Vector3d StackedTraces::RemoveSetupOfTrace(VectorXd& col, int t) const {
  const auto from = static_cast<Eigen::Index>(begin[static_cast<std::size_t>(t)]);
  const auto len = static_cast<Eigen::Index>(begin[static_cast<std::size_t>(t) + 1]) - from;
  auto seg = col.segment(from, len);
  const auto c_t = cos_a.segment(from, len);
  const auto s_t = sin_a.segment(from, len);
  Eigen::Vector3d sts;
  // The three sums in one pass (column_dots.h FusedDots; the sum as the product with ones).
  const double* with[3] = {c_t.data(), s_t.data(), ones.data()};
  diag::FusedDots(seg.data(), with, 3, len, sts.data());
  const Eigen::Vector3d c = setup_inv[static_cast<std::size_t>(t)] * sts;
  seg.array() -= c[0] * c_t.array() + c[1] * s_t.array() + c[2];
  return c;
}

void StackedTraces::RemoveSetup(VectorXd& col, std::vector<Eigen::Vector3d>* coef) const {
  if (coef) coef->assign(static_cast<std::size_t>(traces), Eigen::Vector3d::Zero());
  for (int t = 0; t < traces; ++t) {
    const Eigen::Vector3d c = RemoveSetupOfTrace(col, t);
    if (coef) (*coef)[static_cast<std::size_t>(t)] = c;
  }
}

StackedTraces StackTraces(const std::vector<DiagnosisTrace>& traces, bool leave_out_reversals) {
  StackedTraces p;
  p.traces = static_cast<int>(traces.size());
  p.begin.push_back(0);
  std::size_t total = 0;
  for (const auto& tr : traces) total += tr.angle_rad.size();
  // Sized for every sample, written in place, cut to the samples kept at the end.
  p.samples.resize(total);
  p.cos_a.resize(static_cast<Eigen::Index>(total));
  p.sin_a.resize(static_cast<Eigen::Index>(total));
  p.theta.resize(static_cast<Eigen::Index>(total));
  p.y.resize(static_cast<Eigen::Index>(total));
  std::size_t k = 0;
  for (const auto& tr : traces) {
    if (tr.angle_rad.size() != tr.dev_um.size() || tr.angle_rad.size() < 16) {
      throw InvalidInput("", 0, "dr_um", "diagnosis needs at least 16 samples per trace");
    }
    if (!(tr.radius_mm > 0.0)) throw InvalidInput("", 0, "radius_mm", "must be positive");
    serial_effects::EffectContext c;
    c.radius_mm = tr.radius_mm;
    c.feed_mm_min = tr.feed_mm_min;
    c.direction = tr.direction == Direction::kCcw ? 1 : -1;
    const int t = static_cast<int>(p.ctx.size());
    p.ctx.push_back(c);
    // SᵀS of the set-up columns {cos θ, sin θ, 1}, summed in sample order.
    double cc = 0.0, cs = 0.0, c1 = 0.0, ss = 0.0, s1 = 0.0, n1 = 0.0;
    const bool cached =
        tr.cos_angle.size() == tr.angle_rad.size() && tr.sin_angle.size() == tr.angle_rad.size();
    for (std::size_t i = 0; i < tr.angle_rad.size(); ++i) {
      const double th = tr.angle_rad[i];
      if (leave_out_reversals && serial_effects::internal::AtAxisReversal(th)) continue;
      const serial_effects::Angle<double> a =
          cached ? serial_effects::Angle<double>{th, tr.cos_angle[i], tr.sin_angle[i]}
                 : serial_effects::MakeAngle(th);
      cc += a.c * a.c;
      cs += a.c * a.s;
      c1 += a.c;
      ss += a.s * a.s;
      s1 += a.s;
      n1 += 1.0;
      const auto e = static_cast<Eigen::Index>(k);
      p.samples[k++] = {a, t};
      p.cos_a[e] = a.c;
      p.sin_a[e] = a.s;
      p.theta[e] = th;
      p.y[e] = tr.dev_um[i];
    }
    Eigen::Matrix3d g;
    g << cc, cs, c1, cs, ss, s1, c1, s1, n1;
    if (std::abs(g.determinant()) < 1e-9 * std::pow(static_cast<double>(tr.angle_rad.size()), 3)) {
      throw InvalidInput("", 0, "angle_deg", "the trace does not go around the circle");
    }
    p.setup_inv.push_back(g.inverse());
    p.begin.push_back(k);
  }
  p.n = static_cast<int>(k);
  p.samples.resize(k);
  p.cos_a.conservativeResize(p.n);
  p.sin_a.conservativeResize(p.n);
  p.theta.conservativeResize(p.n);
  p.y.conservativeResize(p.n);
  p.ones = VectorXd::Ones(p.n);
  return p;
}

EffectColumns SignatureShell(const StackedTraces& p, serial_effects::EffectId id,
                             std::vector<double> shape) {
  const auto& info = serial_effects::Info(id);
  EffectColumns c;
  c.id = id;
  // Shape parameters not given take the registry defaults (e.g. a spike width alone: the
  // exponential decay).
  if (shape.size() < info.default_shape.size()) {
    shape.insert(shape.end(), info.default_shape.begin() + static_cast<long>(shape.size()),
                 info.default_shape.end());
  }
  c.shape = std::move(shape);
  const auto nl = static_cast<std::size_t>(info.num_linear);
  c.cols.resize(nl);
  for (auto& col : c.cols) col.resize(p.n);
  c.setup_part.assign(nl, std::vector<Eigen::Vector3d>(static_cast<std::size_t>(p.traces)));
  return c;
}

namespace {

template <typename M>
constexpr bool kIsSpike = false;
template <int Axis>
constexpr bool kIsSpike<serial_effects::ReversalSpike<Axis>> = true;

// Rows [from, to) of a reversal spike's column for the exponents 1 and 2 (false otherwise): the
// phase of each sample as the model gives it, then the decays of the samples within the model's
// cut-off at once (spike_decay.h, the exponential of the width search: within an ulp of
// std::exp), zero beyond it. Side·n_a·decay rounds as the model's side·decay·n_a: the side is ±1.
template <int Axis>
bool SpikeRows(const StackedTraces& p, int from, int to, const std::vector<double>& shape,
               double* col) {
  using Spike = serial_effects::ReversalSpike<Axis>;
  const double k = Spike::Exponent(shape.size() > 1 ? shape[1] : 1.0);
  if (k != 1.0 && k != 2.0) return false;
  const double w = shape[0] * (std::numbers::pi / 180.0);
  const double cutoff = Spike::CutOff(k) * w;
  const auto& ctx =
      p.ctx[static_cast<std::size_t>(p.samples[static_cast<std::size_t>(from)].trace)];
  const auto len = static_cast<std::size_t>(to - from);
  std::vector<int> at(len);
  std::vector<double> phi(len), factor(len), decay(len);
  const auto& cached = p.reversal_phase[Axis];
  const bool have = cached.phi.size() == static_cast<std::size_t>(p.n);
  std::size_t m = 0;  // samples within the cut-off
  for (int i = from; i < to; ++i) {
    const auto u = static_cast<std::size_t>(i);
    const auto& a = p.samples[u].a;
    const auto ph =
        have ? serial_effects::internal::ReversalPhase<double>{cached.phi[u], cached.side[u]}
             : Spike::Phase(ctx, a);
    col[i] = 0.0;
    if (ph.phi > cutoff) continue;
    at[m] = i;
    phi[m] = ph.phi;
    factor[m] = ph.side * (Axis == 0 ? a.c : a.s);
    ++m;
  }
  diag::SpikeDecays(phi.data(), factor.data(), static_cast<Eigen::Index>(m), w, k == 2.0,
                    decay.data());
  for (std::size_t j = 0; j < m; ++j) col[at[j]] = decay[j];
  return true;
}

// Rows [from, to) of the signature columns of model M at the shape `shape`.
template <typename M>
void SignatureRows(const StackedTraces& p, serial_effects::EffectId id, int from, int to,
                   const std::vector<double>& shape, std::vector<VectorXd>& cols) {
  if constexpr (kIsSpike<M>) {
    if (SpikeRows<M::kAxis>(p, from, to, shape, cols[0].data())) return;
  }
  if constexpr (M::kNumLinear == 1) {
    // One linear parameter: the signature at p_0 = 1 is the column (plain doubles).
    double params[M::kNumParams];
    params[0] = 1.0;
    for (int k = 1; k < M::kNumParams; ++k) {
      const auto q = static_cast<std::size_t>(k - 1);
      params[k] = q < shape.size() ? shape[q] : 1.0;
    }
    // The rows are one trace's: its context is read once, the angles from contiguous arrays
    // (simple models then compile to vector instructions).
    const auto& ctx =
        p.ctx[static_cast<std::size_t>(p.samples[static_cast<std::size_t>(from)].trace)];
    const double* cs = p.cos_a.data();
    const double* sn = p.sin_a.data();
    const double* th = p.theta.data();
    double* col = cols[0].data();
    for (int i = from; i < to; ++i) {
      const serial_effects::Angle<double> a{th[i], cs[i], sn[i]};
      double e[2];
      M::template PositionError<double>(ctx, a, params, e);
      col[i] = e[0] * a.c + e[1] * a.s;
    }
  } else if constexpr (requires { &M::LinearBasisRows; }) {
    // The model's rows at once (cyclic errors: one vectorised sine and cosine for the lot).
    const auto& ctx =
        p.ctx[static_cast<std::size_t>(p.samples[static_cast<std::size_t>(from)].trace)];
    const int len = to - from;
    VectorXd work(3 * static_cast<Eigen::Index>(len));  // work space, not initialised
    M::LinearBasisRows(ctx, p.cos_a.data() + from, p.sin_a.data() + from, len, shape.data(),
                       work.data(), work.data() + len, work.data() + 2 * len, cols[0].data() + from,
                       cols[1].data() + from);
  } else {
    // Several linear parameters: all columns in one evaluation (serial_effects::RadialBasis, its
    // closed form inlined when the model has one).
    double basis[serial_effects::kMaxLinearParams];
    for (int i = from; i < to; ++i) {
      const auto& s = p.samples[static_cast<std::size_t>(i)];
      const auto& ctx = p.ctx[static_cast<std::size_t>(s.trace)];
      if constexpr (serial_effects::HasLinearBasis<M>) {
        serial_effects::ClosedFormBasis<M>(ctx, s.a, shape.data(), basis);
      } else {
        serial_effects::RadialBasis(id, ctx, s.a, shape.data(), basis);
      }
      for (int j = 0; j < M::kNumLinear; ++j) cols[static_cast<std::size_t>(j)][i] = basis[j];
    }
  }
}

}  // namespace

void SignatureOfTrace(const StackedTraces& p, int t, EffectColumns& c) {
  const auto ts = static_cast<std::size_t>(t);
  const int from = static_cast<int>(p.begin[ts]), to = static_cast<int>(p.begin[ts + 1]);
  // One dispatch for the rows: the model's loop is compiled for its own type.
  serial_effects::VisitEffect(
      c.id, [&]<typename M>() { SignatureRows<M>(p, c.id, from, to, c.shape, c.cols); });
  for (std::size_t j = 0; j < c.cols.size(); ++j)
    c.setup_part[j][ts] = p.RemoveSetupOfTrace(c.cols[j], t);
}

EffectColumns SetupFreeSignature(const StackedTraces& p, serial_effects::EffectId id,
                                 std::vector<double> shape) {
  EffectColumns c = SignatureShell(p, id, std::move(shape));
  for (int t = 0; t < p.traces; ++t) SignatureOfTrace(p, t, c);
  return c;
}

std::vector<double> RealPowerSpectrum(std::vector<double> x) {
  const int len = static_cast<int>(x.size());
  std::vector<double> out(x.size());
  const cv::Mat in(1, len, CV_64F, x.data());
  cv::Mat packed(1, len, CV_64F, out.data());
  cv::dft(in, packed);  // CCS: Re0, Re1, Im1, Re2, Im2, …
  std::vector<double> pw(static_cast<std::size_t>((len - 1) / 2 + 1));
  pw[0] = out[0] * out[0];
  for (std::size_t k = 1; k < pw.size(); ++k)
    pw[k] = out[2 * k - 1] * out[2 * k - 1] + out[2 * k] * out[2 * k];
  return pw;
}

double DiffNoiseUm(const StackedTraces& p, const VectorXd& r) {
  // Four running sums (the additions need not wait for one another), joined at the end.
  double ss[4] = {0.0, 0.0, 0.0, 0.0};
  int cnt = 0;
  const double* v = r.data();
  for (int t = 0; t < p.traces; ++t) {
    std::size_t i = p.begin[static_cast<std::size_t>(t)] + 1;
    const std::size_t end = p.begin[static_cast<std::size_t>(t) + 1];
    if (end > i) cnt += static_cast<int>(end - i);
    for (; i + 4 <= end; i += 4) {
      for (std::size_t k = 0; k < 4; ++k) {
        const double d = v[i + k] - v[i + k - 1];
        ss[k] += d * d;
      }
    }
    for (; i < end; ++i) ss[0] += (v[i] - v[i - 1]) * (v[i] - v[i - 1]);
  }
  const double sum = (ss[0] + ss[1]) + (ss[2] + ss[3]);
  return cnt > 0 ? std::sqrt(sum / (2.0 * cnt)) : 0.0;
}

// Periodogram of the residual against a cyclic error of axis `axis`: bins the numerator
// Σ r·n_a over the axis position and transforms it; returns the period of the strongest peak
// in the admissible band (0 if none).
double CyclicPeriodPeak(const StackedTraces& p, const VectorXd& r, int axis, double pmin,
                        double pmax) {
  double rmax = 0.0;
  for (const auto& c : p.ctx) rmax = std::max(rmax, c.radius_mm);
  const int m = kCyclicBins;
  const int l = kCyclicFft;
  const double dx = 2.0 * rmax / m;
  std::vector<double> b(static_cast<std::size_t>(l), 0.0);
  const double per_bin = 1.0 / dx;  // a product per sample, not a quotient
  const double* q = axis == 0 ? p.cos_a.data() : p.sin_a.data();
  for (int t = 0; t < p.traces; ++t) {
    const double rad = p.ctx[static_cast<std::size_t>(t)].radius_mm;
    for (auto i = static_cast<Eigen::Index>(p.begin[static_cast<std::size_t>(t)]);
         i < static_cast<Eigen::Index>(p.begin[static_cast<std::size_t>(t) + 1]); ++i) {
      const double bin = std::floor((rad * q[i] + rmax) * per_bin);
      const int k = bin >= m - 1.0 ? m - 1 : (bin > 0.0 ? static_cast<int>(bin) : 0);
      b[static_cast<std::size_t>(k)] += r[i] * q[i];
    }
  }
  const std::vector<double> pw = RealPowerSpectrum(std::move(b));
  const double df = 1.0 / (l * dx);
  const int kmin = std::max(1, static_cast<int>(std::ceil(1.0 / pmax / df)));
  const int kmax = std::min(l / 2 - 2, static_cast<int>(std::floor(1.0 / pmin / df)));
  if (kmin + 1 >= kmax) return 0.0;
  auto power = [&](int k) { return pw[static_cast<std::size_t>(k)]; };
  int best = -1;
  double bp = 0.0;
  for (int k = kmin; k <= kmax; ++k) {
    const double pw = power(k);
    if (pw > bp) {
      bp = pw;
      best = k;
    }
  }
  if (best < 0) return 0.0;
  double kk = best;
  if (best > kmin && best < kmax) {
    const double y0 = power(best - 1), y1 = power(best), y2 = power(best + 1);
    const double den = y0 - 2.0 * y1 + y2;
    if (den < 0.0) kk += 0.5 * (y0 - y2) / den;
  }
  return 1.0 / (kk * df);
}

namespace {

// What a cyclic energy reads of every `stride`-th sample, gathered once for all the periods a
// search tries: 2π times the axis position (mm), the radial factor n_a and the residual.
struct CyclicSamples {
  std::vector<double> arg0, w, r;
  mutable std::vector<double> work;  // arguments, sines, cosines of one period
};

CyclicSamples GatherCyclic(const StackedTraces& p, const VectorXd& r, int axis, int stride) {
  const std::size_t m = static_cast<std::size_t>((p.n + stride - 1) / stride);
  CyclicSamples c;
  c.arg0.resize(m);
  c.w.resize(m);
  c.r.resize(m);
  c.work.resize(3 * m);
  for (std::size_t k = 0; k < m; ++k) {
    const std::size_t i = k * static_cast<std::size_t>(stride);
    const auto& s = p.samples[i];
    const double rad = p.ctx[static_cast<std::size_t>(s.trace)].radius_mm;
    c.arg0[k] = 2.0 * std::numbers::pi * (axis == 0 ? rad * s.a.c : rad * s.a.s);
    c.w[k] = axis == 0 ? s.a.c : s.a.s;
    c.r[k] = r[static_cast<Eigen::Index>(i)];
  }
  return c;
}

// The sines and cosines of the period at once (SinCosArray), then the sums in sample order.
double CyclicEnergyOf(const CyclicSamples& c, double period) {
  const std::size_t m = c.arg0.size();
  double* arg = c.work.data();
  double* sa = arg + m;
  double* ca = sa + m;
  const double inv = 1.0 / period;  // a product per sample, not a quotient
  for (std::size_t k = 0; k < m; ++k) arg[k] = c.arg0[k] * inv;
  SinCosArray(arg, sa, ca, m);
  // The five sums of the 2 × 2 normal equations, each its own running sum.
  double g00 = 0.0, g01 = 0.0, g11 = 0.0, b0 = 0.0, b1 = 0.0;
  for (std::size_t k = 0; k < m; ++k) {
    const double v0 = c.w[k] * ca[k], v1 = c.w[k] * sa[k];
    g00 += v0 * v0;
    g01 += v0 * v1;
    g11 += v1 * v1;
    b0 += v0 * c.r[k];
    b1 += v1 * c.r[k];
  }
  Eigen::Matrix2d g;
  g << g00, g01, g01, g11;
  const Eigen::Vector2d b(b0, b1);
  if (!(std::abs(g.determinant()) > 0.0)) return 0.0;
  return b.dot(g.inverse() * b);
}

}  // namespace

// Energy of the residual's projection on a cyclic error of period `period` (axis `axis`),
// using every `stride`-th sample.
double CyclicEnergy(const StackedTraces& p, const VectorXd& r, int axis, double period,
                    int stride) {
  return CyclicEnergyOf(GatherCyclic(p, r, axis, stride), period);
}

// Golden-section refinement of the periodogram peak within ±rel of `period`; the samples'
// positions and factors are gathered once for the twelve periods tried.
double RefinePeriod(const StackedTraces& p, const VectorXd& r, int axis, double period, double rel,
                    double spacing_mm) {
  const int stride = std::max(1, static_cast<int>(period * (1.0 - rel) / (4.0 * spacing_mm)));
  const CyclicSamples c = GatherCyclic(p, r, axis, stride);
  double lo = period * (1.0 - rel), hi = period * (1.0 + rel);
  const double gr = (std::sqrt(5.0) - 1.0) / 2.0;
  double x1 = hi - gr * (hi - lo), x2 = lo + gr * (hi - lo);
  double f1 = CyclicEnergyOf(c, x1), f2 = CyclicEnergyOf(c, x2);
  for (int it = 0; it < 10; ++it) {
    if (f1 > f2) {
      hi = x2;
      x2 = x1;
      f2 = f1;
      x1 = hi - gr * (hi - lo);
      f1 = CyclicEnergyOf(c, x1);
    } else {
      lo = x1;
      x1 = x2;
      f1 = f2;
      x2 = lo + gr * (hi - lo);
      f2 = CyclicEnergyOf(c, x2);
    }
  }
  return 0.5 * (lo + hi);
}

EffectEstimate EstimateEffect(const StackedTraces& p, serial_effects::EffectId id,
                              const std::vector<double>& shape, const VectorXd& x,
                              const Eigen::MatrixXd& cov, int off) {
  const auto& info = serial_effects::Info(id);
  const int nl = info.num_linear;
  EffectEstimate v;
  v.params.assign(static_cast<std::size_t>(info.num_params), 0.0);
  for (int m = 0; m < nl; ++m) v.params[static_cast<std::size_t>(m)] = x[off + m];
  for (std::size_t k = 0; k < shape.size(); ++k)
    v.params[static_cast<std::size_t>(nl) + k] = shape[k];
  const auto& ctx = p.ctx[0];
  v.value = serial_effects::Value(id, ctx, v.params.data());
  const Eigen::MatrixXd jac = serial_effects::ValueJacobian(id, ctx, v.params.data()).leftCols(nl);
  const Eigen::MatrixXd cv = jac * cov.block(off, off, nl, nl) * jac.transpose();
  double vnorm = 0.0, snorm = 0.0;
  for (std::size_t m = 0; m < v.value.size(); ++m) {
    const auto mi = static_cast<Eigen::Index>(m);
    const double s = std::sqrt(std::max(0.0, cv(mi, mi)));
    v.sigma.push_back(s);
    vnorm += v.value[m] * v.value[m];
    snorm += s * s;
  }
  // Noise-free data (σ = 0): any non-zero value is significant; keep the figure finite (JSON).
  v.z = snorm > 0.0 ? std::sqrt(vnorm / (snorm / static_cast<double>(v.value.size())))
                    : (vnorm > 0.0 ? 1e9 : 0.0);
  v.z = std::min(v.z, 1e9);
  return v;
}

SetupMean MeanSetup(const StackedTraces& p, const std::vector<Eigen::Vector3d>& setup,
                    double sigma2) {
  SetupMean s;
  for (int t = 0; t < p.traces; ++t) {
    s.mean += setup[static_cast<std::size_t>(t)];
    s.var += sigma2 * p.setup_inv[static_cast<std::size_t>(t)].diagonal();
  }
  const double tt = p.traces;
  s.mean /= tt;
  s.var /= tt * tt;
  return s;
}

void NetSetup(std::vector<Eigen::Vector3d>& setup, double coefficient,
              const std::vector<Eigen::Vector3d>& part) {
  for (std::size_t t = 0; t < setup.size(); ++t) setup[t] -= coefficient * part[t];
}

}  // namespace km::dbb
