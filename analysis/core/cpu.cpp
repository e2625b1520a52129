#include "analysis/core/cpu.h"

namespace km {

bool CpuHasAvx2() {
#if defined(__x86_64__) && defined(__GNUC__)
  static const bool has = __builtin_cpu_supports("avx2");
  return has;
#else
  return false;
#endif
}

bool CpuHasAvx2Fma() {
#if defined(__x86_64__) && defined(__GNUC__)
  static const bool has = CpuHasAvx2() && __builtin_cpu_supports("fma");
  return has;
#else
  return false;
#endif
}

}  // namespace km
