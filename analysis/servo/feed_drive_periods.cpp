// The periods of the position-dependent part of the feed-drive force (feed_drive.h, step 1):
// the periodogram of a sinusoid with a constant through the binned residual of the steady fit,
// over a geometric grid of periods (four periods at a time with AVX2 where the processor has
// it, bit for bit one at a time), refined by Brent's method.
#include <algorithm>
#include <array>
#include <cmath>
#include <numbers>

#include <Eigen/Cholesky>
#include <Eigen/Core>

#include "analysis/core/cpu.h"
#include "analysis/core/minimize_1d.h"
#include "analysis/servo/feed_drive_detail.h"

#if defined(__x86_64__) && defined(__GNUC__)
#include <immintrin.h>
#define KM_PERIODS_AVX2 1
#endif

namespace km::servo::detail {
namespace {

constexpr double kFullTurn = 2.0 * std::numbers::pi;

// The normal equations' sums of 1 and y, which do not depend on the period (Σ1, Σy, Σy²).
struct BinSums {
  double n = 0.0, y = 0.0, yy = 0.0;
};

BinSums FixedSums(const std::vector<double>& y) {
  BinSums f;
  for (double v : y) {
    f.n += 1.0;
    f.y += v;
    f.yy += v * v;
  }
  return f;
}

// The sums of one period: Σc, Σs, Σc², Σcs, Σs², Σyc, Σys (c, s the cosine and sine).
struct PeriodSums {
  double sc = 0.0, ss = 0.0, scc = 0.0, scs = 0.0, sss = 0.0, syc = 0.0, sys = 0.0;
};

// The bins lie on a grid (consecutive ones mostly one bin apart): the phase is rotated from bin
// to bin by the angle of that step, and taken afresh from sin and cos after any other gap and
// every 64 bins.
double GridStep(const std::vector<double>& xc) {
  return xc.size() > 1 ? xc[1] - xc[0] : 0.0;
}

bool Rotates(const std::vector<double>& xc, std::size_t i, double step) {
  return i > 0 && i % 64 != 0 && std::abs(xc[i] - xc[i - 1] - step) <= 1e-9 * step;
}

PeriodSums SumsOf(const std::vector<double>& xc, const std::vector<double>& y, double p) {
  PeriodSums t;
  const double step = GridStep(xc);
  const double turn_c = std::cos(kFullTurn * step / p), turn_s = std::sin(kFullTurn * step / p);
  double c = 0.0, sn = 0.0;
  for (std::size_t i = 0; i < y.size(); ++i) {
    if (Rotates(xc, i, step)) {
      const double c_next = c * turn_c - sn * turn_s;
      sn = sn * turn_c + c * turn_s;
      c = c_next;
    } else {
      c = std::cos(kFullTurn * xc[i] / p);
      sn = std::sin(kFullTurn * xc[i] / p);
    }
    t.sc += c;
    t.ss += sn;
    t.scc += c * c;
    t.scs += c * sn;
    t.sss += sn * sn;
    t.syc += c * y[i];
    t.sys += sn * y[i];
  }
  return t;
}

// RSS of the best sinusoid of period p (with a constant) through the bins, from its sums.
double RssOf(const PeriodSums& t, const BinSums& fixed, double p, RippleComponent* out) {
  Eigen::Matrix3d ata;
  ata << fixed.n, t.sc, t.ss, t.sc, t.scc, t.scs, t.ss, t.scs, t.sss;
  const Eigen::Vector3d atb(fixed.y, t.syc, t.sys);
  const Eigen::Vector3d x = ata.ldlt().solve(atb);
  if (out) *out = {p, x[1], x[2]};
  return fixed.yy - x.dot(atb);
}

double SinusoidRss(const std::vector<double>& xc, const std::vector<double>& y,
                   const BinSums& fixed, double p, RippleComponent* out) {
  return RssOf(SumsOf(xc, y, p), fixed, p, out);
}

#if KM_PERIODS_AVX2

bool PeriodsAvx2() {
  return CpuHasAvx2() && FeedDriveAvx2Allowed();
}

// SumsOf for the four periods p[0 … 3], one a lane: the same operations in the same order (no
// fused multiply-add), so bit for bit.
__attribute__((target("avx2"))) void SumsOf4(const std::vector<double>& xc,
                                             const std::vector<double>& y, const double* p,
                                             std::array<PeriodSums, 4>& out) {
  const double step = GridStep(xc);
  double lane_c[4], lane_s[4];
  for (int l = 0; l < 4; ++l) {
    lane_c[l] = std::cos(kFullTurn * step / p[l]);
    lane_s[l] = std::sin(kFullTurn * step / p[l]);
  }
  const __m256d turn_c = _mm256_loadu_pd(lane_c), turn_s = _mm256_loadu_pd(lane_s);
  __m256d c = _mm256_setzero_pd(), sn = c, sc = c, ss = c, scc = c, scs = c, sss = c, syc = c,
          sys = c;
  for (std::size_t i = 0; i < y.size(); ++i) {
    if (Rotates(xc, i, step)) {
      const __m256d c_next = _mm256_sub_pd(_mm256_mul_pd(c, turn_c), _mm256_mul_pd(sn, turn_s));
      sn = _mm256_add_pd(_mm256_mul_pd(sn, turn_c), _mm256_mul_pd(c, turn_s));
      c = c_next;
    } else {
      for (int l = 0; l < 4; ++l) {
        lane_c[l] = std::cos(kFullTurn * xc[i] / p[l]);
        lane_s[l] = std::sin(kFullTurn * xc[i] / p[l]);
      }
      c = _mm256_loadu_pd(lane_c);
      sn = _mm256_loadu_pd(lane_s);
    }
    const __m256d yi = _mm256_set1_pd(y[i]);
    sc = _mm256_add_pd(sc, c);
    ss = _mm256_add_pd(ss, sn);
    scc = _mm256_add_pd(scc, _mm256_mul_pd(c, c));
    scs = _mm256_add_pd(scs, _mm256_mul_pd(c, sn));
    sss = _mm256_add_pd(sss, _mm256_mul_pd(sn, sn));
    syc = _mm256_add_pd(syc, _mm256_mul_pd(c, yi));
    sys = _mm256_add_pd(sys, _mm256_mul_pd(sn, yi));
  }
  const __m256d sums[] = {sc, ss, scc, scs, sss, syc, sys};
  double lanes[7][4];
  for (int k = 0; k < 7; ++k) _mm256_storeu_pd(lanes[k], sums[k]);
  for (int l = 0; l < 4; ++l)
    out[l] = {lanes[0][l], lanes[1][l], lanes[2][l], lanes[3][l],
              lanes[4][l], lanes[5][l], lanes[6][l]};
}

#endif

// The RSS at every period of `periods` (in their order).
std::vector<double> Periodogram(const std::vector<double>& xc, const std::vector<double>& y,
                                const BinSums& fixed, const std::vector<double>& periods) {
  std::vector<double> rss(periods.size());
  std::size_t k = 0;
#if KM_PERIODS_AVX2
  if (PeriodsAvx2()) {
    std::array<PeriodSums, 4> sums;
    for (; k + 4 <= periods.size(); k += 4) {
      SumsOf4(xc, y, periods.data() + k, sums);
      for (std::size_t l = 0; l < 4; ++l)
        rss[k + l] = RssOf(sums[l], fixed, periods[k + l], nullptr);
    }
  }
#endif
  for (; k < periods.size(); ++k) rss[k] = SinusoidRss(xc, y, fixed, periods[k], nullptr);
  return rss;
}

}  // namespace

std::vector<double> PeriodogramOf(const std::vector<double>& xc, const std::vector<double>& y,
                                  const std::vector<double>& periods) {
  return Periodogram(xc, y, FixedSums(y), periods);
}

std::vector<RippleComponent> FindPeriods(const std::vector<double>& xc, std::vector<double> y,
                                         double pmin, double pmax, int max_components) {
  std::vector<RippleComponent> found;
  const std::size_t nb = y.size();
  if (nb < 8 || !(pmax > pmin)) return found;
  const int grid = 400;
  std::vector<double> periods;
  for (int k = 0; k <= grid; ++k)
    periods.push_back(pmin * std::pow(pmax / pmin, static_cast<double>(k) / grid));
  for (int c = 0; c < max_components; ++c) {
    const BinSums fixed = FixedSums(y);
    const std::vector<double> rss = Periodogram(xc, y, fixed, periods);
    double best_p = pmin, best_rss = INFINITY;
    for (std::size_t k = 0; k < periods.size(); ++k) {
      if (rss[k] < best_rss) {
        best_rss = rss[k];
        best_p = periods[k];
      }
    }
    // Refined between the grid's neighbours to 10⁻¹⁰ of the period (the joint fit refines it
    // further).
    const double step = std::pow(pmax / pmin, 1.0 / grid);
    const double period =
        BrentMinimize([&](double q) { return SinusoidRss(xc, y, fixed, q, nullptr); },
                      best_p / step, best_p * step, 1e-10 * best_p)
            .x;
    RippleComponent comp;
    const double rss_p = SinusoidRss(xc, y, fixed, period, &comp);
    const double sigma = std::sqrt(rss_p / static_cast<double>(nb - 3));
    const double amp = std::hypot(comp.a, comp.b);
    // Significant: the amplitude well above what noise of the bins' spread leaves.
    if (!(amp > 5.0 * sigma * std::sqrt(2.0 / static_cast<double>(nb)))) break;
    for (std::size_t i = 0; i < nb; ++i) {
      y[i] -= comp.a * std::cos(kFullTurn * xc[i] / comp.period) +
              comp.b * std::sin(kFullTurn * xc[i] / comp.period);
    }
    found.push_back(comp);
  }
  return found;
}

}  // namespace km::servo::detail
