// Replaces every form of global operator new/delete for this test binary (alloc_counter.h).
// Each block carries a 16-byte header (or one alignment's worth) holding its requested size.
#include "alloc_counter.h"

#include <atomic>
#include <cstdlib>
#include <new>

namespace {

std::atomic<int64_t> g_live{0};
std::atomic<int64_t> g_count{0};
std::atomic<int64_t> g_peak{0};
constexpr size_t kHeader = 16;  // keeps the default new alignment (16 on x86-64)

void* allocate(size_t n, size_t align) {
  const size_t header = align > kHeader ? align : kHeader;
  void* raw = align > kHeader ? std::aligned_alloc(align, (n + header + align - 1) / align * align) : std::malloc(n + header);
  if (!raw) return nullptr;
  auto* p = static_cast<unsigned char*>(raw) + header;
  reinterpret_cast<size_t*>(p)[-1] = n;
  const int64_t live = g_live.fetch_add(int64_t(n), std::memory_order_relaxed) + int64_t(n);
  int64_t peak = g_peak.load(std::memory_order_relaxed);
  while (live > peak && !g_peak.compare_exchange_weak(peak, live, std::memory_order_relaxed)) {
  }
  g_count.fetch_add(1, std::memory_order_relaxed);
  return p;
}

void release(void* p, size_t align) {
  if (!p) return;
  const size_t header = align > kHeader ? align : kHeader;
  g_live.fetch_sub(int64_t(static_cast<size_t*>(p)[-1]), std::memory_order_relaxed);
  std::free(static_cast<unsigned char*>(p) - header);
}

void* allocateOrThrow(size_t n, size_t align) {
  void* p = allocate(n, align);
  if (!p) throw std::bad_alloc();
  return p;
}

}  // namespace

namespace drtv::testing {
int64_t liveHeapBytes() { return g_live.load(); }
int64_t heapAllocations() { return g_count.load(); }
int64_t heapPeakBytes() { return g_peak.load(); }
void resetHeapPeak() { g_peak.store(g_live.load()); }
}  // namespace drtv::testing

void* operator new(size_t n) { return allocateOrThrow(n, 0); }
void* operator new[](size_t n) { return allocateOrThrow(n, 0); }
void* operator new(size_t n, const std::nothrow_t&) noexcept { return allocate(n, 0); }
void* operator new[](size_t n, const std::nothrow_t&) noexcept { return allocate(n, 0); }
void* operator new(size_t n, std::align_val_t a) { return allocateOrThrow(n, size_t(a)); }
void* operator new[](size_t n, std::align_val_t a) { return allocateOrThrow(n, size_t(a)); }
void* operator new(size_t n, std::align_val_t a, const std::nothrow_t&) noexcept { return allocate(n, size_t(a)); }
void* operator new[](size_t n, std::align_val_t a, const std::nothrow_t&) noexcept { return allocate(n, size_t(a)); }
void operator delete(void* p) noexcept { release(p, 0); }
void operator delete[](void* p) noexcept { release(p, 0); }
void operator delete(void* p, size_t) noexcept { release(p, 0); }
void operator delete[](void* p, size_t) noexcept { release(p, 0); }
void operator delete(void* p, const std::nothrow_t&) noexcept { release(p, 0); }
void operator delete[](void* p, const std::nothrow_t&) noexcept { release(p, 0); }
void operator delete(void* p, std::align_val_t a) noexcept { release(p, size_t(a)); }
void operator delete[](void* p, std::align_val_t a) noexcept { release(p, size_t(a)); }
void operator delete(void* p, size_t, std::align_val_t a) noexcept { release(p, size_t(a)); }
void operator delete[](void* p, size_t, std::align_val_t a) noexcept { release(p, size_t(a)); }
void operator delete(void* p, std::align_val_t a, const std::nothrow_t&) noexcept { release(p, size_t(a)); }
void operator delete[](void* p, std::align_val_t a, const std::nothrow_t&) noexcept { release(p, size_t(a)); }
