// The smallest and largest of n ≥ 1 values, as std::min / std::max (and std::minmax_element) give
// them from the first value on: a NaN after the first is passed over, a NaN first is the result.
// Four running extremes of two SSE2 lanes each, so the comparisons do not wait for one another;
// the values are the same (of two zeros, which one's sign is kept may differ).
#pragma once

#include <algorithm>
#include <cstddef>
#include <utility>

#if defined(__SSE2__)
#include <emmintrin.h>
#endif

namespace km {

inline std::pair<double, double> Extremes(const double* p, std::size_t n) {
  double mn = p[0], mx = mn;
  std::size_t i = 0;
#if defined(__SSE2__)
  __m128d lo0 = _mm_set1_pd(mn), lo1 = lo0, hi0 = lo0, hi1 = lo0;
  for (; i + 4 <= n; i += 4) {
    const __m128d x0 = _mm_loadu_pd(p + i), x1 = _mm_loadu_pd(p + i + 2);
    lo0 = _mm_min_pd(x0, lo0);  // x < lo ? x : lo, std::min(lo, x)
    lo1 = _mm_min_pd(x1, lo1);
    hi0 = _mm_max_pd(x0, hi0);
    hi1 = _mm_max_pd(x1, hi1);
  }
  alignas(16) double lo[4], hi[4];
  _mm_store_pd(lo, lo0);
  _mm_store_pd(lo + 2, lo1);
  _mm_store_pd(hi, hi0);
  _mm_store_pd(hi + 2, hi1);
  for (int k = 0; k < 4; ++k) {
    mn = std::min(mn, lo[k]);
    mx = std::max(mx, hi[k]);
  }
#endif
  for (; i < n; ++i) {
    mn = std::min(mn, p[i]);
    mx = std::max(mx, p[i]);
  }
  return {mn, mx};
}

}  // namespace km
