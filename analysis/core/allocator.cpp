#include "analysis/core/allocator.h"

#if defined(__GLIBC__)
#include <malloc.h>
#endif

namespace km {

void RetainFreedMemory() {
#if defined(__GLIBC__)
  // Give the heap back only when 64 MiB at its top are free.
  mallopt(M_TRIM_THRESHOLD, 64 << 20);
#endif
}

}  // namespace km
