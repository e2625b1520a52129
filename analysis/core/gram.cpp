#include "analysis/core/gram.h"

#include "analysis/core/cpu.h"

#if defined(__x86_64__) && defined(__GNUC__)
#include <immintrin.h>
#define KM_GRAM_AVX2 1
#endif

namespace km {
namespace {

void AddGramScalar(const double* const* cols, int m, std::size_t n, double* g) {
  const auto um = static_cast<std::size_t>(m);
  for (std::size_t k = 0; k < um; ++k) {
    for (std::size_t j = k; j < um; ++j) {
      double sum = 0.0;
      for (std::size_t i = 0; i < n; ++i) sum += cols[k][i] * cols[j][i];
      g[k * um + j] += sum;
    }
  }
}

#if KM_GRAM_AVX2

__attribute__((target("avx2,fma"))) double Lanes(__m256d v) {
  const __m128d p = _mm_add_pd(_mm256_castpd256_pd128(v), _mm256_extractf128_pd(v, 1));
  return _mm_cvtsd_f64(_mm_add_sd(p, _mm_unpackhi_pd(p, p)));
}

// The dot products of column x with the K columns ys over n rows (n a multiple of 4).
template <int K>
__attribute__((target("avx2,fma"))) void Dots(const double* x, const double* const* ys,
                                              std::size_t n, double* out) {
  __m256d acc[K];
  for (int q = 0; q < K; ++q) acc[q] = _mm256_setzero_pd();
  for (std::size_t i = 0; i < n; i += 4) {
    const __m256d xi = _mm256_loadu_pd(x + i);
    for (int q = 0; q < K; ++q) acc[q] = _mm256_fmadd_pd(xi, _mm256_loadu_pd(ys[q] + i), acc[q]);
  }
  for (int q = 0; q < K; ++q) out[q] = Lanes(acc[q]);
}

__attribute__((target("avx2,fma"))) void AddGramAvx2(const double* const* cols, int m,
                                                     std::size_t n, double* g) {
  const auto um = static_cast<std::size_t>(m);
  const std::size_t n4 = n & ~std::size_t{3};
  double dots[4];
  for (std::size_t k = 0; k < um; ++k) {
    std::size_t j = k;
    for (; j + 4 <= um; j += 4) {
      Dots<4>(cols[k], cols + j, n4, dots);
      for (std::size_t q = 0; q < 4; ++q) g[k * um + j + q] += dots[q];
    }
    for (; j < um; ++j) {
      Dots<1>(cols[k], cols + j, n4, dots);
      g[k * um + j] += dots[0];
    }
  }
  if (n4 == n) return;
  const double* tail[64];
  for (std::size_t k = 0; k < um; ++k) tail[k] = cols[k] + n4;
  AddGramScalar(tail, m, n - n4, g);
}

#endif

}  // namespace

void AddGram(const double* const* cols, int m, std::size_t n, double* g) {
#if KM_GRAM_AVX2
  if (m <= 64 && CpuHasAvx2Fma()) {
    AddGramAvx2(cols, m, n, g);
    return;
  }
#endif
  AddGramScalar(cols, m, n, g);
}

}  // namespace km
