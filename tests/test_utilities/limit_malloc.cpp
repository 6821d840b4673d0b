#include "test_utilities/limit_malloc.hpp"

#include <cstdlib>
#include <new>

// Replaces the global allocation functions for every test binary that links the test utilities. Counting is
// per thread and only while an AllocationCounter is alive, so other threads' allocations do not interfere.

namespace {
thread_local std::uint64_t g_allocations = 0;
thread_local int g_active = 0;

void* CountedAlloc(std::size_t size) {
  if (g_active > 0) ++g_allocations;
  if (size == 0) size = 1;
  void* p = std::malloc(size);
  if (p == nullptr) throw std::bad_alloc();
  return p;
}

void* CountedAlignedAlloc(std::size_t size, std::align_val_t align) {
  if (g_active > 0) ++g_allocations;
  const std::size_t a = static_cast<std::size_t>(align);
  std::size_t rounded = (size + a - 1) / a * a;
  if (rounded == 0) rounded = a;
  void* p = std::aligned_alloc(a, rounded);
  if (p == nullptr) throw std::bad_alloc();
  return p;
}
}  // namespace

void* operator new(std::size_t size) { return CountedAlloc(size); }
void* operator new[](std::size_t size) { return CountedAlloc(size); }
void* operator new(std::size_t size, std::align_val_t align) { return CountedAlignedAlloc(size, align); }
void* operator new[](std::size_t size, std::align_val_t align) { return CountedAlignedAlloc(size, align); }
void operator delete(void* p) noexcept { std::free(p); }
void operator delete[](void* p) noexcept { std::free(p); }
void operator delete(void* p, std::size_t) noexcept { std::free(p); }
void operator delete[](void* p, std::size_t) noexcept { std::free(p); }
void operator delete(void* p, std::align_val_t) noexcept { std::free(p); }
void operator delete[](void* p, std::align_val_t) noexcept { std::free(p); }
void operator delete(void* p, std::size_t, std::align_val_t) noexcept { std::free(p); }
void operator delete[](void* p, std::size_t, std::align_val_t) noexcept { std::free(p); }

namespace teleop::test {

AllocationCounter::AllocationCounter() noexcept : start_(g_allocations) { ++g_active; }
AllocationCounter::~AllocationCounter() { --g_active; }
std::uint64_t AllocationCounter::count() const noexcept { return g_allocations - start_; }

}  // namespace teleop::test
