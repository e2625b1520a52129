#include "analysis/geometry/circle_sums.h"

#include <cmath>

#include "analysis/core/cpu.h"

#if defined(__x86_64__) && defined(__GNUC__)
#include <immintrin.h>
#define KM_CIRCLE_SUMS_AVX2 1
#endif

namespace km::geometry::internal {

namespace {

#if KM_CIRCLE_SUMS_AVX2

// Horizontal sum of the four lanes, (l0 + l1) + (l2 + l3).
__attribute__((target("avx2,fma"))) double Lanes(__m256d v) {
  alignas(32) double l[4];
  _mm256_store_pd(l, v);
  return (l[0] + l[1]) + (l[2] + l[3]);
}

// One point as the lanes do it: the distance with a fused product, then the sums.
__attribute__((target("avx2,fma"))) double Distance(double vx, double vy) {
  return std::sqrt(std::fma(vx, vx, vy * vy));
}

__attribute__((target("avx2,fma"))) void Sums(const double* x, const double* y, Eigen::Index n,
                                              double cx, double cy, double r, CircleSums& o) {
  const __m256d vcx = _mm256_set1_pd(cx), vcy = _mm256_set1_pd(cy), vr = _mm256_set1_pd(r);
  const __m256d zero = _mm256_setzero_pd(), one = _mm256_set1_pd(1.0);
  __m256d sxx = zero, sxy = zero, syy = zero, sx = zero, sy = zero, cnt = zero, bx = zero,
          by = zero, b = zero, ss = zero;
  Eigen::Index i = 0;
  for (; i + 4 <= n; i += 4) {
    const __m256d vx = _mm256_sub_pd(_mm256_loadu_pd(x + i), vcx);
    const __m256d vy = _mm256_sub_pd(_mm256_loadu_pd(y + i), vcy);
    const __m256d dist = _mm256_sqrt_pd(_mm256_fmadd_pd(vx, vx, _mm256_mul_pd(vy, vy)));
    const __m256d pos = _mm256_cmp_pd(dist, zero, _CMP_GT_OQ);  // a point off the centre
    const __m256d inv = _mm256_and_pd(pos, _mm256_div_pd(one, dist));
    const __m256d ux = _mm256_mul_pd(vx, inv), uy = _mm256_mul_pd(vy, inv);
    const __m256d all = _mm256_sub_pd(dist, vr);
    const __m256d d = _mm256_and_pd(pos, all);
    sxx = _mm256_fmadd_pd(ux, ux, sxx);
    sxy = _mm256_fmadd_pd(ux, uy, sxy);
    syy = _mm256_fmadd_pd(uy, uy, syy);
    sx = _mm256_add_pd(sx, ux);
    sy = _mm256_add_pd(sy, uy);
    cnt = _mm256_add_pd(cnt, _mm256_and_pd(pos, one));
    bx = _mm256_fnmadd_pd(ux, d, bx);
    by = _mm256_fnmadd_pd(uy, d, by);
    b = _mm256_sub_pd(b, d);
    ss = _mm256_fmadd_pd(all, all, ss);
  }
  o = {Lanes(sxx), Lanes(sxy), Lanes(syy), Lanes(sx), Lanes(sy),
       Lanes(cnt), Lanes(bx),  Lanes(by),  Lanes(b),  Lanes(ss)};
  for (; i < n; ++i) {
    const double vx = x[i] - cx, vy = y[i] - cy;
    const double dist = Distance(vx, vy);
    const double all = dist - r;
    o.ss = std::fma(all, all, o.ss);
    if (!(dist > 0.0)) continue;
    const double ux = vx * (1.0 / dist), uy = vy * (1.0 / dist);
    o.sxx = std::fma(ux, ux, o.sxx);
    o.sxy = std::fma(ux, uy, o.sxy);
    o.syy = std::fma(uy, uy, o.syy);
    o.sx += ux;
    o.sy += uy;
    o.n += 1.0;
    o.bx = std::fma(-ux, all, o.bx);
    o.by = std::fma(-uy, all, o.by);
    o.b -= all;
  }
}

__attribute__((target("avx2,fma"))) double Cost(const double* x, const double* y, Eigen::Index n,
                                                double cx, double cy, double r) {
  const __m256d vcx = _mm256_set1_pd(cx), vcy = _mm256_set1_pd(cy), vr = _mm256_set1_pd(r);
  __m256d ss = _mm256_setzero_pd();
  Eigen::Index i = 0;
  for (; i + 4 <= n; i += 4) {
    const __m256d vx = _mm256_sub_pd(_mm256_loadu_pd(x + i), vcx);
    const __m256d vy = _mm256_sub_pd(_mm256_loadu_pd(y + i), vcy);
    const __m256d dist = _mm256_sqrt_pd(_mm256_fmadd_pd(vx, vx, _mm256_mul_pd(vy, vy)));
    const __m256d all = _mm256_sub_pd(dist, vr);
    ss = _mm256_fmadd_pd(all, all, ss);
  }
  double cost = Lanes(ss);
  for (; i < n; ++i) {
    const double all = Distance(x[i] - cx, y[i] - cy) - r;
    cost = std::fma(all, all, cost);
  }
  return cost;
}

#endif

}  // namespace

bool CircleSumsFused(const double* x, const double* y, Eigen::Index n, double cx, double cy,
                     double r, CircleSums& out) {
#if KM_CIRCLE_SUMS_AVX2
  if (CpuHasAvx2Fma()) {
    Sums(x, y, n, cx, cy, r, out);
    return true;
  }
#endif
  return false;
}

bool CircleCostFused(const double* x, const double* y, Eigen::Index n, double cx, double cy,
                     double r, double& cost) {
#if KM_CIRCLE_SUMS_AVX2
  if (CpuHasAvx2Fma()) {
    cost = Cost(x, y, n, cx, cy, r);
    return true;
  }
#endif
  return false;
}

}  // namespace km::geometry::internal
