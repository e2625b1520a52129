// Counts the bytes allocated through the global operator new of the binary that includes this
// header (include it in exactly one source file of a test or benchmark binary): PeakOf(f) is the
// most allocated at once while f runs, above what was allocated when it started.
#pragma once

#include <malloc.h>

#include <atomic>
#include <cstdlib>
#include <new>

namespace km::test {

inline std::atomic<std::size_t> g_allocated{0};
inline std::atomic<std::size_t> g_peak_allocated{0};

// Not inlined: the compiler must not pair the replaced operators with malloc / free.
[[gnu::noinline]] inline void* CountedAllocate(std::size_t n, std::size_t align = 0) {
  void* p =
      align ? std::aligned_alloc(align, (n + align - 1) / align * align) : std::malloc(n ? n : 1);
  if (!p) return nullptr;
  const std::size_t now = g_allocated += malloc_usable_size(p);
  std::size_t peak = g_peak_allocated.load();
  while (now > peak && !g_peak_allocated.compare_exchange_weak(peak, now)) {
  }
  return p;
}

[[gnu::noinline]] inline void CountedFree(void* p) {
  if (!p) return;
  g_allocated -= malloc_usable_size(p);
  std::free(p);
}

template <typename F>
std::size_t PeakOf(F&& f) {
  const std::size_t base = g_allocated.load();
  g_peak_allocated = base;
  f();
  return g_peak_allocated.load() - base;
}

}  // namespace km::test

void* operator new(std::size_t n) {
  if (void* p = km::test::CountedAllocate(n)) return p;
  throw std::bad_alloc();
}
void* operator new[](std::size_t n) {
  if (void* p = km::test::CountedAllocate(n)) return p;
  throw std::bad_alloc();
}
void* operator new(std::size_t n, const std::nothrow_t&) noexcept {
  return km::test::CountedAllocate(n);
}
void* operator new[](std::size_t n, const std::nothrow_t&) noexcept {
  return km::test::CountedAllocate(n);
}
void* operator new(std::size_t n, std::align_val_t a) {
  if (void* p = km::test::CountedAllocate(n, static_cast<std::size_t>(a))) return p;
  throw std::bad_alloc();
}
void* operator new[](std::size_t n, std::align_val_t a) {
  if (void* p = km::test::CountedAllocate(n, static_cast<std::size_t>(a))) return p;
  throw std::bad_alloc();
}
void* operator new(std::size_t n, std::align_val_t a, const std::nothrow_t&) noexcept {
  return km::test::CountedAllocate(n, static_cast<std::size_t>(a));
}
void* operator new[](std::size_t n, std::align_val_t a, const std::nothrow_t&) noexcept {
  return km::test::CountedAllocate(n, static_cast<std::size_t>(a));
}
void operator delete(void* p) noexcept {
  km::test::CountedFree(p);
}
void operator delete[](void* p) noexcept {
  km::test::CountedFree(p);
}
void operator delete(void* p, std::size_t) noexcept {
  km::test::CountedFree(p);
}
void operator delete[](void* p, std::size_t) noexcept {
  km::test::CountedFree(p);
}
void operator delete(void* p, const std::nothrow_t&) noexcept {
  km::test::CountedFree(p);
}
void operator delete[](void* p, const std::nothrow_t&) noexcept {
  km::test::CountedFree(p);
}
void operator delete(void* p, std::align_val_t) noexcept {
  km::test::CountedFree(p);
}
void operator delete[](void* p, std::align_val_t) noexcept {
  km::test::CountedFree(p);
}
void operator delete(void* p, std::size_t, std::align_val_t) noexcept {
  km::test::CountedFree(p);
}
void operator delete[](void* p, std::size_t, std::align_val_t) noexcept {
  km::test::CountedFree(p);
}
void operator delete(void* p, std::align_val_t, const std::nothrow_t&) noexcept {
  km::test::CountedFree(p);
}
void operator delete[](void* p, std::align_val_t, const std::nothrow_t&) noexcept {
  km::test::CountedFree(p);
}
