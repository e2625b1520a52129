#include "analysis/dbb/column_dots.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <vector>

#include "analysis/core/cpu.h"

#if defined(__x86_64__) && defined(__GNUC__)
#include <immintrin.h>
#define KM_COLUMN_DOTS_AVX2 1
#endif

namespace km::dbb::diag {

namespace {

using ConstMap = Eigen::Map<const Eigen::VectorXd>;

void DotsEigen(const double* x, const double* const* ys, int count, Eigen::Index n, double* out) {
  for (int j = 0; j < count; ++j) out[j] = ConstMap(x, n).dot(ConstMap(ys[j], n));
}

#if KM_COLUMN_DOTS_AVX2

// Eigen's LinearVectorizedTraversal sum of the products with SSE2 packets of two: partial sums
// p0 (elements 4m, 4m+1) and p1 (4m+2, 4m+3) started from the first two packets, joined as
// p0 + p1, then the pair left over (if any), then lane 0 + lane 1, then the odd last element.
// One AVX2 register holds p0 and p1 side by side. Needs n ≥ 8.
__attribute__((target("avx2"))) double Finish(__m256d acc, const double* x, const double* y,
                                              Eigen::Index n) {
  const Eigen::Index end4 = n & ~Eigen::Index{3};
  __m128d p = _mm_add_pd(_mm256_castpd256_pd128(acc), _mm256_extractf128_pd(acc, 1));
  if ((n & ~Eigen::Index{1}) > end4)
    p = _mm_add_pd(p, _mm_mul_pd(_mm_load_pd(x + end4), _mm_load_pd(y + end4)));
  double r = _mm_cvtsd_f64(_mm_add_sd(p, _mm_unpackhi_pd(p, p)));
  if (n & 1) r = r + x[n - 1] * y[n - 1];
  return r;
}

template <int K>
__attribute__((target("avx2"))) void DotsAvx2(const double* x, const double* const* ys,
                                              Eigen::Index n, double* out) {
  __m256d acc[K];
  const __m256d x0 = _mm256_loadu_pd(x);
  for (int j = 0; j < K; ++j) acc[j] = _mm256_mul_pd(x0, _mm256_loadu_pd(ys[j]));
  const Eigen::Index end4 = n & ~Eigen::Index{3};
  for (Eigen::Index i = 4; i < end4; i += 4) {
    const __m256d xi = _mm256_loadu_pd(x + i);
    for (int j = 0; j < K; ++j)
      acc[j] = _mm256_add_pd(acc[j], _mm256_mul_pd(xi, _mm256_loadu_pd(ys[j] + i)));
  }
  for (int j = 0; j < K; ++j) out[j] = Finish(acc[j], x, ys[j], n);
}

// x against K ≤ 8 columns ys: K sums four rows wide with fused multiply-adds, joined as
// (l0 + l1) + (l2 + l3), then the rows left one by one.
template <int K>
__attribute__((target("avx2,fma"))) void FusedAvx2(const double* x, const double* const* ys,
                                                   Eigen::Index n, double* out) {
  __m256d acc[K];
  for (int k = 0; k < K; ++k) acc[k] = _mm256_setzero_pd();
  const Eigen::Index end4 = n & ~Eigen::Index{3};
  for (Eigen::Index i = 0; i < end4; i += 4) {
    const __m256d xi = _mm256_loadu_pd(x + i);
    for (int k = 0; k < K; ++k) acc[k] = _mm256_fmadd_pd(_mm256_loadu_pd(ys[k] + i), xi, acc[k]);
  }
  for (int k = 0; k < K; ++k) {
    alignas(32) double l[4];
    _mm256_store_pd(l, acc[k]);
    double s = (l[0] + l[1]) + (l[2] + l[3]);
    for (Eigen::Index i = end4; i < n; ++i) s = std::fma(ys[k][i], x[i], s);
    out[k] = s;
  }
}

// FusedAvx2 for any count ≤ kMaxFusedDots.
void FusedAvx2Any(const double* x, const double* const* ys, int count, Eigen::Index n,
                  double* out) {
  switch (count) {
    case 8:
      return FusedAvx2<8>(x, ys, n, out);
    case 7:
      return FusedAvx2<7>(x, ys, n, out);
    case 6:
      return FusedAvx2<6>(x, ys, n, out);
    case 5:
      return FusedAvx2<5>(x, ys, n, out);
    case 4:
      return FusedAvx2<4>(x, ys, n, out);
    case 3:
      return FusedAvx2<3>(x, ys, n, out);
    case 2:
      return FusedAvx2<2>(x, ys, n, out);
    case 1:
      return FusedAvx2<1>(x, ys, n, out);
    default:
      return;
  }
}

// coef[j]·cols[j] at the samples i … i + 3.
__attribute__((target("avx2"))) inline __m256d Term(const double* const* cols, const double* coef,
                                                    int j, Eigen::Index i) {
  return _mm256_mul_pd(_mm256_set1_pd(coef[j]), _mm256_loadu_pd(cols[j] + i));
}

__attribute__((target("avx2"))) void CombineAvx2(const double* const* cols, const double* coef,
                                                 int count, Eigen::Index n, double* out) {
  Eigen::Index i = 0;
  for (; i + 4 <= n; i += 4) {
    __m256d v = Term(cols, coef, 0, i);
    int m = 1;
    for (; m + 3 < count; m += 4) {
      __m256d s = _mm256_add_pd(Term(cols, coef, m, i), Term(cols, coef, m + 1, i));
      s = _mm256_add_pd(_mm256_add_pd(s, Term(cols, coef, m + 2, i)), Term(cols, coef, m + 3, i));
      v = _mm256_add_pd(v, s);
    }
    for (; m < count; ++m) v = _mm256_add_pd(v, Term(cols, coef, m, i));
    _mm256_storeu_pd(out + i, v);
  }
  for (; i < n; ++i) {
    double v = coef[0] * cols[0][i];
    int m = 1;
    for (; m + 3 < count; m += 4) {
      v = v +
          (((coef[m] * cols[m][i] + coef[m + 1] * cols[m + 1][i]) + coef[m + 2] * cols[m + 2][i]) +
           coef[m + 3] * cols[m + 3][i]);
    }
    for (; m < count; ++m) v = v + coef[m] * cols[m][i];
    out[i] = v;
  }
}

bool Aligned16(const double* p) {
  return (reinterpret_cast<std::uintptr_t>(p) & 15u) == 0;
}

// Lanes of the four sums of each order: 16 doubles per order, Σ cos, Σ sin, Σ r cos, Σ r sin.
constexpr int kOrderLanes = 16;

// acc ← v at the first group, acc + v after.
__attribute__((target("avx2"))) inline void Accumulate(double* acc, __m256d v, bool first) {
  _mm256_storeu_pd(acc, first ? v : _mm256_add_pd(_mm256_loadu_pd(acc), v));
}

// The sums' lanes over the full groups of four samples, order by order.
__attribute__((target("avx2"))) void HarmonicQuads(const double* c1, const double* s1,
                                                   const double* r, Eigen::Index end4, int top,
                                                   int rtop, double* acc) {
  for (Eigen::Index i = 0; i < end4; i += 4) {
    const __m256d cv = _mm256_loadu_pd(c1 + i), sv = _mm256_loadu_pd(s1 + i);
    const __m256d rv = _mm256_loadu_pd(r + i);
    __m256d ck = cv, sk = sv;
    for (int q = 0; q < top; ++q) {
      if (q > 0) {
        const __m256d next = _mm256_sub_pd(_mm256_mul_pd(ck, cv), _mm256_mul_pd(sk, sv));
        sk = _mm256_add_pd(_mm256_mul_pd(sk, cv), _mm256_mul_pd(ck, sv));
        ck = next;
      }
      double* a = acc + static_cast<std::ptrdiff_t>(kOrderLanes) * q;
      // 1·cos qθ is cos qθ exactly: the plain sums add the values themselves.
      Accumulate(a, ck, i == 0);
      Accumulate(a + 4, sk, i == 0);
      if (q < rtop) {
        Accumulate(a + 8, _mm256_mul_pd(rv, ck), i == 0);
        Accumulate(a + 12, _mm256_mul_pd(rv, sk), i == 0);
      }
    }
  }
}

// The samples after the last group of four (n & 3 of them), their cos qθ and sin qθ advanced
// one order at a time by the same recurrence.
struct HarmonicTail {
  const double *c1, *s1, *r;
  Eigen::Index n;
  int size;
  double ct[3] = {0, 0, 0}, st[3] = {0, 0, 0};

  HarmonicTail(const double* c, const double* s, const double* rr, Eigen::Index count)
      : c1(c + (count & ~Eigen::Index{3})),
        s1(s + (count & ~Eigen::Index{3})),
        r(rr + (count & ~Eigen::Index{3})),
        n(count),
        size(static_cast<int>(count & 3)) {
    for (int k = 0; k < size; ++k) {
      ct[k] = c1[k];
      st[k] = s1[k];
    }
  }
  void Advance() {
    for (int k = 0; k < size; ++k) {
      const double next = ct[k] * c1[k] - st[k] * s1[k];
      st[k] = st[k] * c1[k] + ct[k] * s1[k];
      ct[k] = next;
    }
  }
  // Finish of the lanes with the tail's products w·v (w = 1 for the plain sums, where the
  // product is v itself): the pair after the groups when two or more samples are left, then
  // the odd last sample when n is odd.
  __attribute__((target("avx2"))) double Sum(const double* lanes, const double* v,
                                             bool weighted) const {
    const __m256d acc = _mm256_loadu_pd(lanes);
    __m128d p = _mm_add_pd(_mm256_castpd256_pd128(acc), _mm256_extractf128_pd(acc, 1));
    auto prod = [&](int k) { return weighted ? r[k] * v[k] : v[k]; };
    if (size >= 2) p = _mm_add_pd(p, _mm_setr_pd(prod(0), prod(1)));
    double out = _mm_cvtsd_f64(_mm_add_sd(p, _mm_unpackhi_pd(p, p)));
    if (n & 1) out = out + prod(size - 1);
    return out;
  }
};

__attribute__((target("avx2"))) void HarmonicSumsAvx2(const double* c1, const double* s1,
                                                      const double* r, Eigen::Index n, int top,
                                                      int rtop, double* sc, double* ss, double* rc,
                                                      double* rs) {
  std::vector<double> acc(static_cast<std::size_t>(kOrderLanes) * static_cast<std::size_t>(top));
  HarmonicQuads(c1, s1, r, n & ~Eigen::Index{3}, top, rtop, acc.data());
  HarmonicTail tail(c1, s1, r, n);
  for (int q = 0; q < top; ++q) {
    if (q > 0) tail.Advance();
    const double* a = acc.data() + static_cast<std::ptrdiff_t>(kOrderLanes) * q;
    sc[q] = tail.Sum(a, tail.ct, false);
    ss[q] = tail.Sum(a + 4, tail.st, false);
    if (q < rtop) {
      rc[q] = tail.Sum(a + 8, tail.ct, true);
      rs[q] = tail.Sum(a + 12, tail.st, true);
    }
  }
}

#endif

}  // namespace

void ColumnDots(const double* x, const double* const* ys, int count, Eigen::Index n, double* out) {
#if KM_COLUMN_DOTS_AVX2
  bool fast = CpuHasAvx2() && n >= 8 && count >= 1 && count <= kMaxColumnDots && Aligned16(x);
  for (int j = 0; fast && j < count; ++j) fast = Aligned16(ys[j]);
  if (fast) {
    switch (count) {
      case 1:
        return DotsAvx2<1>(x, ys, n, out);
      case 2:
        return DotsAvx2<2>(x, ys, n, out);
      case 3:
        return DotsAvx2<3>(x, ys, n, out);
      default:
        return DotsAvx2<4>(x, ys, n, out);
    }
  }
#endif
  DotsEigen(x, ys, count, n, out);
}

bool HarmonicSums(const double* c1, const double* s1, const double* r, Eigen::Index n, int top,
                  int rtop, double* sc, double* ss, double* rc, double* rs) {
#if KM_COLUMN_DOTS_AVX2
  if (!CpuHasAvx2() || n < 8 || top < 1 || !Aligned16(c1) || !Aligned16(s1) || !Aligned16(r))
    return false;
  HarmonicSumsAvx2(c1, s1, r, n, top, std::min(rtop, top), sc, ss, rc, rs);
  return true;
#else
  return false;
#endif
}

void CombineColumns(const double* const* cols, const double* coef, int count, Eigen::Index n,
                    double* out) {
#if KM_COLUMN_DOTS_AVX2
  if (CpuHasAvx2()) return CombineAvx2(cols, coef, count, n, out);
#endif
  using Map = Eigen::Map<const Eigen::VectorXd>;
  Eigen::Map<Eigen::VectorXd> v(out, n);
  v = coef[0] * Map(cols[0], n);
  int m = 1;
  for (; m + 3 < count; m += 4) {
    v += coef[m] * Map(cols[m], n) + coef[m + 1] * Map(cols[m + 1], n) +
         coef[m + 2] * Map(cols[m + 2], n) + coef[m + 3] * Map(cols[m + 3], n);
  }
  for (; m < count; ++m) v += coef[m] * Map(cols[m], n);
}

void FusedDots(const double* x, const double* const* ys, int count, Eigen::Index n, double* out) {
#if KM_COLUMN_DOTS_AVX2
  if (CpuHasAvx2Fma()) return FusedAvx2Any(x, ys, count, n, out);
#endif
  DotsEigen(x, ys, count, n, out);
}

void FrameDots(const double* a, Eigen::Index ld, int cols, const double* v, Eigen::Index n,
               double* out) {
  std::array<const double*, kMaxFusedDots> ys{};
  for (int j = 0; j < cols; j += kMaxFusedDots) {
    const int count = std::min(kMaxFusedDots, cols - j);
    for (int k = 0; k < count; ++k) ys[static_cast<std::size_t>(k)] = a + (j + k) * ld;
    FusedDots(v, ys.data(), count, n, out + j);
  }
}

}  // namespace km::dbb::diag
