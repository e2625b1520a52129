// The bristle force of eqs. 4.1–4.2 along the measured motion at the reversals, and its
// derivatives in the LuGre parameters carried through the same exact steps (forward mode), for
// the Jacobian of the LuGre fit (feed_drive_lugre.cpp): one pass gives the force and all its
// derivatives, where differences would need a pass a parameter. The force is computed with the
// same arithmetic with and without the derivatives.
//
// Everything of a step of constant speed that does not depend on the bristle state z — the rise
// g(v), the decay rate, the steady deflection, the decay over the step and the coefficients of
// the derivatives — is computed for a block of steps at once, as array operations on fixed-size
// arrays that stay in the first-level cache (exponentials and divisions a SIMD packet at a
// time); the recursion in z and its derivatives is then a few multiply-adds a step.
#include <algorithm>
#include <atomic>
#include <cmath>
#include <memory>

#include <Eigen/Core>

#include "analysis/core/cpu.h"
#include "analysis/core/exp4.h"
#include "analysis/servo/feed_drive_detail.h"

#if KM_EXP4_AVX2
#define KM_BRISTLES_AVX2 1
#endif

namespace km::servo::detail {
namespace {

constexpr int kBlock = 256;  // steps a block
using Block = Eigen::Array<double, kBlock, 1>;
using Array = Eigen::ArrayXd;
constexpr int kSigma0 = 2;  // ln σ0 among the bristle parameters

// The derivatives carried: ln δ (the last) only when fitted; it is zero otherwise.
constexpr int Params(bool exponent) {
  return exponent ? kBristleParams : kBristleParams - 1;
}

// g(v) of the Stribeck curve at the speeds |v| = `speed` (mm/s) and, when asked, its
// derivatives in ln F_s, ln v_s and ln δ (σ0 does not enter g).
template <typename A>
struct Rise {
  A g, d[kBristleParams];
};

template <typename A>
void RiseOf(const LugreParameters& p, const A& speed, bool derivatives, bool exponent, Rise<A>& r) {
  // u at least 10⁻³⁰⁰: at rest u^δ ≈ 0 and its derivative in ln δ vanishes, without a branch.
  const A u = (speed / p.vs_mm_s).max(1e-300);
  A shape, by_vs;  // S and its derivative in ln v_s
  if (p.stribeck_form == LugreParameters::Form::kLorentzian) {
    shape = 1.0 / (1.0 + u.square());
    by_vs = 2.0 * u.square() * shape.square();
  } else {
    const double delta = p.stribeck_exponent;
    const bool by_exponent = derivatives && exponent;
    A log_u;
    if (delta != 2.0 || by_exponent) log_u = u.log();
    const A power = delta == 2.0 ? u.square().eval() : (delta * log_u).exp().eval();
    shape = (-power).exp();
    by_vs = delta * power * shape;
    if (derivatives)
      r.d[3] = by_exponent ? ((p.Fs_N - p.Fc_N) * -delta * power * log_u * shape).eval()
                           : A::Zero(u.size()).eval();
  }
  const double rise = p.Fs_N - p.Fc_N;
  r.g = p.Fc_N + rise * shape;
  if (!derivatives) return;
  r.d[0] = p.Fs_N * shape;
  r.d[1] = rise * by_vs;
  r.d[kSigma0] = A::Zero(u.size());
  if (p.stribeck_form == LugreParameters::Form::kLorentzian) r.d[3] = A::Zero(u.size());
}

#if KM_BRISTLES_AVX2

// Four lanes of what the Eigen expressions of RiseOf and StepTermsOf compute on SSE2 packets of
// two, operation for operation (no fused multiply-add: Eigen's SSE2 pmadd is a product then a
// sum; min and max with Eigen's order of arguments, which decides what a NaN gives; Eigen's
// exponential and logarithm as analysis/core/exp4.h reproduces them), so bit for bit the same.

bool HasAvx2() {
  return CpuHasAvx2() && FeedDriveAvx2Allowed();
}

using exp4::Set;

__attribute__((target("avx2"))) inline __m256d Negate(__m256d a) {
  return _mm256_xor_pd(a, Set(-0.0));
}

// RiseOf at the four speeds from `speed` + j into lane j of `r` (`exponent`: the derivative
// in ln δ too).
template <typename A>
__attribute__((target("avx2"))) void RiseOf4(const LugreParameters& p, const double* speed,
                                             Eigen::Index j, bool derivatives, bool exponent,
                                             Rise<A>& r) {
  const __m256d u =
      _mm256_max_pd(Set(1e-300), _mm256_div_pd(_mm256_loadu_pd(speed + j), Set(p.vs_mm_s)));
  __m256d shape, by_vs, by_exponent = _mm256_setzero_pd();
  if (p.stribeck_form == LugreParameters::Form::kLorentzian) {
    const __m256d u2 = _mm256_mul_pd(u, u);
    shape = _mm256_div_pd(Set(1.0), _mm256_add_pd(Set(1.0), u2));
    by_vs = _mm256_mul_pd(_mm256_mul_pd(Set(2.0), u2), _mm256_mul_pd(shape, shape));
  } else {
    const double delta = p.stribeck_exponent;
    const bool with_exponent = derivatives && exponent;
    const __m256d log_u = delta != 2.0 || with_exponent ? Log4(u) : _mm256_setzero_pd();
    const __m256d power =
        delta == 2.0 ? _mm256_mul_pd(u, u) : Exp4(_mm256_mul_pd(Set(delta), log_u));
    shape = Exp4(Negate(power));
    by_vs = _mm256_mul_pd(_mm256_mul_pd(Set(delta), power), shape);
    if (with_exponent) {
      const double c = (p.Fs_N - p.Fc_N) * -delta;
      by_exponent = _mm256_mul_pd(_mm256_mul_pd(_mm256_mul_pd(Set(c), power), log_u), shape);
    }
  }
  const double rise = p.Fs_N - p.Fc_N;
  _mm256_storeu_pd(r.g.data() + j, _mm256_add_pd(Set(p.Fc_N), _mm256_mul_pd(Set(rise), shape)));
  if (!derivatives) return;
  _mm256_storeu_pd(r.d[0].data() + j, _mm256_mul_pd(Set(p.Fs_N), shape));
  _mm256_storeu_pd(r.d[1].data() + j, _mm256_mul_pd(Set(rise), by_vs));
  _mm256_storeu_pd(r.d[kSigma0].data() + j, _mm256_setzero_pd());
  _mm256_storeu_pd(r.d[3].data() + j, by_exponent);
}

#endif

// The steps of constant speed of one window: speed |v| (mm/s), its sign and length (s) of each
// (a step standing is left out: z holds), for each sample the speed at which its force is
// read and the number of steps before it, and the speeds |v| of the samples read moving (the
// force of a sample read at rest does not depend on the rise).
}  // namespace

struct BristleMotion {
  std::vector<double> speed, sign, h, read, moving;
  std::vector<std::size_t> before;
  void Add(double v, double dt) {
    if (v == 0.0) return;
    speed.push_back(std::abs(v));
    sign.push_back(v > 0.0 ? 1.0 : -1.0);
    h.push_back(dt);
  }
};

namespace {

void MotionOf(const Strokes& s, const Window& w, Reading reading, BristleMotion& m) {
  m.speed.clear();
  m.sign.clear();
  m.h.clear();
  m.read.assign(1, s.v[w.first]);
  m.before.assign(1, 0);
  m.moving.clear();
  for (std::size_t i = w.first + 1; i <= w.last; ++i) {
    const double dt = s.t[i] - s.t[i - 1], mean = (s.x[i] - s.x[i - 1]) / dt;
    const bool standing = s.v[i - 1] == 0.0 && s.v[i] == 0.0 && mean == 0.0;
    if (standing) {
      m.read.push_back(0.0);  // every sub-interval stands: z holds
    } else if (reading == Reading::kLinear) {
      const double shift = mean - 0.5 * (s.v[i - 1] + s.v[i]);
      for (int k = 0; k < kSubsteps; ++k) {
        const double u = (k + 0.5) / kSubsteps;
        m.Add((1.0 - u) * s.v[i - 1] + u * s.v[i] + shift, dt / kSubsteps);
      }
      m.read.push_back(s.v[i]);
    } else {
      m.Add(mean, dt);
      m.read.push_back(mean);
    }
    m.before.push_back(m.speed.size());
  }
  for (double v : m.read)
    if (v != 0.0) m.moving.push_back(std::abs(v));
}

// The rise at the speeds m.moving[first … first + kBlock − 1] (the block padded with zero
// speeds past the window's last).
void ReadRiseOf(const LugreParameters& p, const BristleMotion& m, std::size_t first,
                bool derivatives, bool exponent, Rise<Block>& r) {
  Block speed = Block::Zero();
  const std::size_t n = std::min<std::size_t>(kBlock, m.moving.size() - first);
  for (std::size_t j = 0; j < n; ++j) speed[static_cast<Eigen::Index>(j)] = m.moving[first + j];
#if KM_BRISTLES_AVX2
  if (HasAvx2()) {
    for (Eigen::Index j = 0; j < static_cast<Eigen::Index>(n); j += 4)
      RiseOf4(p, speed.data(), j, derivatives, exponent, r);
    return;
  }
#endif
  RiseOf(p, speed, derivatives, exponent, r);
}

// The z-independent part of the exact solution of eq. 4.1 at constant speed v over h seconds
// for a block of steps: z → z_ss + (z − z_ss) e and dz/dθ → a_θ + e dz/dθ − (z − z_ss) b_θ.
struct StepTerms {
  Block z_ss, e, a[kBristleParams], b[kBristleParams];
};

#if KM_BRISTLES_AVX2

// StepTermsOf's Eigen expressions on four lanes, bit for bit (see RiseOf4), for the `len`
// steps of the block from `speed`, `sign` and `h` (rounded up to whole lanes).
__attribute__((target("avx2"))) void StepTermsOf4(const LugreParameters& p, const Block& speed,
                                                  const Block& sign, const Block& h, int len,
                                                  bool derivatives, bool exponent, StepTerms& t) {
  Rise<Block> rise;
  const double side = 1.0 / p.sigma0_N_per_um, stiff = p.sigma0_N_per_um * 1e3;
  for (Eigen::Index j = 0; j < len; j += 4) {
    RiseOf4(p, speed.data(), j, derivatives, exponent, rise);
    const __m256d g = _mm256_loadu_pd(rise.g.data() + j), hj = _mm256_loadu_pd(h.data() + j);
    const __m256d inv_g = _mm256_div_pd(Set(1.0), g);
    const __m256d rate =
        _mm256_mul_pd(_mm256_mul_pd(Set(stiff), _mm256_loadu_pd(speed.data() + j)), inv_g);
    const __m256d by_s0 = _mm256_mul_pd(Set(side), _mm256_loadu_pd(sign.data() + j));
    const __m256d z_ss = _mm256_mul_pd(by_s0, g);
    const __m256d e = Exp4(_mm256_mul_pd(Negate(rate), hj));
    _mm256_storeu_pd(t.z_ss.data() + j, z_ss);
    _mm256_storeu_pd(t.e.data() + j, e);
    if (!derivatives) continue;
    const __m256d by_g = _mm256_mul_pd(rate, inv_g), he = _mm256_mul_pd(hj, e);
    const __m256d decay = _mm256_sub_pd(Set(1.0), e);
    for (int k = 0; k < Params(exponent); ++k) {
      const __m256d d = _mm256_loadu_pd(rise.d[k].data() + j);
      __m256d a, b;
      if (k == kSigma0) {
        a = _mm256_mul_pd(_mm256_sub_pd(_mm256_mul_pd(by_s0, d), z_ss), decay);
        b = _mm256_mul_pd(he, _mm256_sub_pd(rate, _mm256_mul_pd(by_g, d)));
      } else {
        a = _mm256_mul_pd(_mm256_mul_pd(by_s0, d), decay);
        b = _mm256_mul_pd(Negate(he), _mm256_mul_pd(by_g, d));
      }
      _mm256_storeu_pd(t.a[k].data() + j, a);
      _mm256_storeu_pd(t.b[k].data() + j, b);
    }
  }
}

#endif

// Steps first … first + len − 1 of `m` (the rest of the block repeats the last step, unused).
void StepTermsOf(const LugreParameters& p, const BristleMotion& m, std::size_t first, int len,
                 bool derivatives, bool exponent, StepTerms& t) {
  Block speed, sign, h;
  for (int j = 0; j < kBlock; ++j) {
    const std::size_t i = first + static_cast<std::size_t>(std::min(j, len - 1));
    speed[j] = m.speed[i];
    sign[j] = m.sign[i];
    h[j] = m.h[i];
  }
#if KM_BRISTLES_AVX2
  if (HasAvx2()) {
    StepTermsOf4(p, speed, sign, h, len, derivatives, exponent, t);
    return;
  }
#endif
  Rise<Block> rise;
  RiseOf(p, speed, derivatives, exponent, rise);
  const Block inv_g = 1.0 / rise.g;
  const Block rate = (p.sigma0_N_per_um * 1e3) * speed * inv_g;  // 1/s
  const double side = 1.0 / p.sigma0_N_per_um;
  t.z_ss = (side * sign) * rise.g;
  t.e = (-rate * h).exp();
  if (!derivatives) return;
  // d rate/dθ = rate (own − dg/g), d z_ss/dθ = sign(v) dg/σ0 − own z_ss.
  const Block by_g = rate * inv_g, by_s0 = side * sign, he = h * t.e, decay = 1.0 - t.e;
  for (int k = 0; k < Params(exponent); ++k) {
    if (k == kSigma0) {
      t.a[k] = (by_s0 * rise.d[k] - t.z_ss) * decay;
      t.b[k] = he * (rate - by_g * rise.d[k]);
    } else {
      t.a[k] = (by_s0 * rise.d[k]) * decay;
      t.b[k] = -he * (by_g * rise.d[k]);
    }
  }
}

struct State {
  double z = 0.0;                           // µm
  std::array<double, kBristleParams> dz{};  // dz/dθ
};

// The state in steady sliding at the window's first speed v0.
State SlidingState(const LugreParameters& p, double v0, bool derivatives, bool exponent) {
  Rise<Array> rise;
  const Array speed = Array::Constant(1, std::abs(v0));
  RiseOf(p, speed, derivatives, exponent, rise);
  const double side = v0 > 0.0 ? 1.0 : -1.0;
  State st;
  st.z = side * rise.g[0] / p.sigma0_N_per_um;
  if (!derivatives) return st;
  for (int k = 0; k < kBristleParams; ++k)
    st.dz[k] = side * rise.d[k][0] / p.sigma0_N_per_um - (k == kSigma0 ? st.z : 0.0);
  return st;
}

// Step j of the block applied to `st` (and to the first `params` derivatives).
inline void Advance(const StepTerms& t, int j, int params, State& st) {
  const double lag = st.z - t.z_ss[j], e = t.e[j];
  for (int k = 0; k < params; ++k) st.dz[k] = t.a[k][j] + e * st.dz[k] - lag * t.b[k][j];
  st.z = t.z_ss[j] + lag * e;
}

// The force σ0 z + σ1 dz/dt at a sample read at speed v, with the rise `rise` at index i when
// moving (at rest dz/dt = 0 and the rise is not read).
void Emit(const LugreParameters& p, const State& st, double v, const Rise<Block>& rise,
          Eigen::Index i, std::vector<double>& out, std::vector<double>* damping,
          std::vector<BristleDerivatives>* derivatives) {
  const double vu = 1e3 * v, g = v == 0.0 ? 1.0 : rise.g[i];
  const double zdot = v == 0.0 ? 0.0 : vu - p.sigma0_N_per_um * std::abs(vu) * st.z / g;  // µm/s
  out.push_back(p.sigma0_N_per_um * st.z + p.sigma1_N_s_per_mm * 1e-3 * zdot);
  if (damping) damping->push_back(1e-3 * zdot);
  if (!derivatives) return;
  const double rate = v == 0.0 ? 0.0 : p.sigma0_N_per_um * std::abs(vu) / g;
  BristleDerivatives d{};
  for (int k = 0; k < kBristleParams; ++k) {
    const double own = k == kSigma0 ? 1.0 : 0.0;
    const double d_rate = v == 0.0 ? 0.0 : rate * (own - rise.d[k][i] / g);
    const double d_zdot = v == 0.0 ? 0.0 : -(d_rate * st.z + rate * st.dz[k]);
    d[k] = own * p.sigma0_N_per_um * st.z + p.sigma0_N_per_um * st.dz[k] +
           p.sigma1_N_s_per_mm * 1e-3 * d_zdot;
  }
  derivatives->push_back(d);
}

// The last sample's force (and damping and derivatives) once more.
void Repeat(std::vector<double>& out, std::vector<double>* damping,
            std::vector<BristleDerivatives>* derivatives) {
  out.push_back(out.back());
  if (damping) damping->push_back(damping->back());
  if (derivatives) derivatives->push_back(derivatives->back());
}

}  // namespace

namespace {
std::atomic<bool> avx2_allowed{true};
}  // namespace

void UseFeedDriveAvx2(bool on) {
  avx2_allowed.store(on, std::memory_order_relaxed);
}

bool FeedDriveAvx2Allowed() {
  return avx2_allowed.load(std::memory_order_relaxed);
}

struct BristlePath::Motions {
  std::vector<BristleMotion> windows;
};

BristlePath::BristlePath(const Strokes& s, const std::vector<Window>& ws, Reading reading)
    : motions_(std::make_unique<Motions>()) {
  motions_->windows.resize(ws.size());
  for (std::size_t k = 0; k < ws.size(); ++k) MotionOf(s, ws[k], reading, motions_->windows[k]);
}

BristlePath::~BristlePath() = default;

namespace {

// Scratch of one evaluation: a block of step terms and of rises at the samples' speeds.
struct Scratch {
  StepTerms terms;
  Rise<Block> read_rise;
};

// The force of window w along its motion m, appended to the outputs: sample k is read once the
// steps before it (m.before[k]) have been taken, the step terms formed a block at a time.
void WindowForce(const Strokes& s, const Window& w, const BristleMotion& m,
                 const LugreParameters& p, bool exponent, Scratch& scratch,
                 std::vector<double>& out, std::vector<double>* damping,
                 std::vector<BristleDerivatives>* derivatives) {
  const bool with = derivatives != nullptr;
  const int params = with ? Params(exponent) : 0;
  StepTerms& terms = scratch.terms;
  Rise<Block>& read_rise = scratch.read_rise;
  // The rise at the speeds of the samples read moving, a block at a time: `slot` counts them,
  // the block holds those from `read_first` on.
  std::size_t read_first = 0, slot = 0;
  if (!m.moving.empty()) ReadRiseOf(p, m, read_first, with, exponent, read_rise);
  State st = SlidingState(p, s.v[w.first], with, exponent);
  std::size_t step = 0, block_first = 0, block_end = 0;
  for (std::size_t k = 0; k < m.read.size(); ++k) {
    for (; step < m.before[k]; ++step) {
      if (step == block_end) {
        const int len = static_cast<int>(std::min<std::size_t>(kBlock, m.speed.size() - step));
        StepTermsOf(p, m, step, len, with, exponent, terms);
        block_first = step;
        block_end = step + static_cast<std::size_t>(len);
      }
      Advance(terms, static_cast<int>(step - block_first), params, st);
    }
    // A sample of a standstill after one: the same state read at rest, the same force.
    if (k > 0 && m.read[k] == 0.0 && m.read[k - 1] == 0.0 && m.before[k] == m.before[k - 1]) {
      Repeat(out, damping, derivatives);
      continue;
    }
    if (m.read[k] == 0.0) {
      Emit(p, st, 0.0, read_rise, 0, out, damping, derivatives);
      continue;
    }
    if (slot >= read_first + kBlock) {  // the rise at the next block of speeds
      read_first = slot;
      ReadRiseOf(p, m, read_first, with, exponent, read_rise);
    }
    Emit(p, st, m.read[k], read_rise, static_cast<Eigen::Index>(slot - read_first), out, damping,
         derivatives);
    ++slot;
  }
}

}  // namespace

void BristleForce(const Strokes& s, const std::vector<Window>& ws, const BristlePath& path,
                  const LugreParameters& p, std::vector<double>& out, std::vector<double>* damping,
                  std::vector<BristleDerivatives>* derivatives, bool exponent) {
  out.clear();
  if (damping) damping->clear();
  if (derivatives) derivatives->clear();
  Scratch scratch;
  for (std::size_t k = 0; k < ws.size(); ++k) {
    WindowForce(s, ws[k], path.motions().windows[k], p, exponent, scratch, out, damping,
                derivatives);
  }
}

void BristleForce(const Strokes& s, const std::vector<Window>& ws, const LugreParameters& p,
                  Reading reading, std::vector<double>& out, std::vector<double>* damping,
                  std::vector<BristleDerivatives>* derivatives, bool exponent) {
  BristleForce(s, ws, BristlePath(s, ws, reading), p, out, damping, derivatives, exponent);
}

}  // namespace km::servo::detail
