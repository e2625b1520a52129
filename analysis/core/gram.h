// The Gram matrix of a few columns (all their dot products) summed a block of rows at a time,
// for least-squares fits of many rows and few columns: the normal matrix AᵀA and Aᵀy of a
// design whose columns are formed a block at a time (so no design of the fit's whole length is
// stored) and added here while the block sits in the first-level cache.
#pragma once

#include <cstddef>

namespace km {

// g(j, k) += Σ_i cols[k][i]·cols[j][i] over i < n, for k ≤ j < m (the lower half of g, an m × m
// column-major matrix; the upper half is left as it is). Four rows at a time with fused
// multiply-adds where the processor has AVX2 and FMA; otherwise one row at a time. The sums
// are those of a dot product, rounded in a different order by the two paths.
void AddGram(const double* const* cols, int m, std::size_t n, double* g);

}  // namespace km
