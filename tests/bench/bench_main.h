// The main of the benchmarks of analyses: the executables' allocator setting
// (analysis/core/allocator.h), as the command and the server run it, then Google Benchmark.
// Use KM_BENCHMARK_MAIN() in place of BENCHMARK_MAIN().
#pragma once

#include <benchmark/benchmark.h>

#include "analysis/core/allocator.h"

namespace km::bench {

inline int RunBenchmarks(int argc, char** argv) {
  km::RetainFreedMemory();
  benchmark::Initialize(&argc, argv);
  if (benchmark::ReportUnrecognizedArguments(argc, argv)) return 1;
  benchmark::RunSpecifiedBenchmarks();
  benchmark::Shutdown();
  return 0;
}

}  // namespace km::bench

// Ends in a declaration of main again, so that the use takes a semicolon (as BENCHMARK_MAIN).
#define KM_BENCHMARK_MAIN()                      \
  int main(int argc, char** argv) {              \
    return km::bench::RunBenchmarks(argc, argv); \
  }                                              \
  int main(int, char**)
