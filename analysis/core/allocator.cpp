#include "analysis/core/allocator.h"

// <cstdlib> first: it defines __GLIBC__ on glibc, which the test below needs.
#include <cstdlib>
#if defined(__GLIBC__)
#include <malloc.h>
#endif

namespace km {

void RetainFreedMemory() {
#if defined(__GLIBC__)
  // Give the heap back only when 64 MiB at its top are free, and take blocks of up to 32 MiB
  // (a long trace's columns) from the heap rather than from fresh mappings, which the system
  // zero-fills on first touch and unmaps on every free.
  mallopt(M_TRIM_THRESHOLD, 64 << 20);
  mallopt(M_MMAP_THRESHOLD, 32 << 20);
#endif
}

}  // namespace km
