// Several dot products of one column with others at once, for the Gram matrices of the
// diagnosis fits (diagnosis_fit.cpp) and the sums of the harmonics (harmonics.cpp):
// out[j] = x·ys[j], j < count.
// Bit for bit what Eigen's x.dot(y) gives for 16-byte aligned columns (VectorXd): the same
// products summed in the same order (four interleaved partial sums, joined as Eigen joins them).
// A single dot is bound by the latency of its additions; several at once fill the pipeline, four
// lanes wide with AVX2 where the processor has it. Otherwise (or for unaligned or short
// columns) Eigen's dot, one at a time.
#pragma once

#include <Eigen/Core>

namespace km::dbb::diag {

inline constexpr int kMaxColumnDots = 4;

void ColumnDots(const double* x, const double* const* ys, int count, Eigen::Index n, double* out);

// The combination out = Σ_j coef[j]·cols[j] (count ≥ 1) in one pass over the samples, bit for
// bit what FitResult::Combine's Eigen expressions give: coef[0]·cols[0], then four columns a
// step, ((c₁ + c₂) + c₃) + c₄ added to the sum, then the columns left one by one.
void CombineColumns(const double* const* cols, const double* coef, int count, Eigen::Index n,
                    double* out);

// The sums of the harmonic fit (harmonics.cpp) in one sweep over the samples: with cos qθ and
// sin qθ from the angle-addition recurrence on c1 = cos θ, s1 = sin θ (cos (q+1)θ = cos qθ·c1 −
// sin qθ·s1, sin (q+1)θ = sin qθ·c1 + cos qθ·s1, element by element), for q = 1 … top
//   sc[q−1] = Σ cos qθ,  ss[q−1] = Σ sin qθ,  and for q ≤ rtop  rc[q−1] = Σ r cos qθ,
//   rs[q−1] = Σ r sin qθ,
// each bit for bit ColumnDots' of the recurrence's arrays (with a column of ones for the plain
// sums). The recurrence of four samples stays in registers across the orders, so no array of
// the samples' length is written. Returns false, having computed nothing, where the processor
// has no AVX2 or for n < 8 or arrays not 16-byte aligned (ColumnDots would then use Eigen).
bool HarmonicSums(const double* c1, const double* s1, const double* r, Eigen::Index n, int top,
                  int rtop, double* sc, double* ss, double* rc, double* rs);

// out[j] = x·ys[j], j < count ≤ kMaxFusedDots, summed four rows wide with fused multiply-adds
// where the processor has AVX2 and FMA (one pass over x for all of them); otherwise Eigen's dot.
// The sums round otherwise than Eigen's (an ulp or so of a product): for the inner products of
// the diagnosis' fits and set-up removal, whose figures may move by rounding.
inline constexpr int kMaxFusedDots = 8;
void FusedDots(const double* x, const double* const* ys, int count, Eigen::Index n, double* out);

// The products of v with every column of a column-major matrix over its first n rows:
// out[j] = Σ_{i<n} a[j·ld + i]·v[i], j < cols (the spike search's Aᵀs), by FusedDots.
void FrameDots(const double* a, Eigen::Index ld, int cols, const double* v, Eigen::Index n,
               double* out);

}  // namespace km::dbb::diag
