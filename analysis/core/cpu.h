// What the processor offers beyond the x86-64 baseline the build targets, asked once: the
// vectorised paths (four lanes with AVX2) choose themselves at run time with these.
#pragma once

namespace km {

// AVX2 (false on other architectures).
bool CpuHasAvx2();
// AVX2 and fused multiply-add.
bool CpuHasAvx2Fma();

}  // namespace km
