// Counting global operator new: the number of heap allocations so far, for
// checks that a hot path does not allocate. It REPLACES the program's
// operator new / delete, so include it in exactly one source file of a test
// (or benchmark) executable. AddressSanitizer owns operator new / delete:
// there nothing is replaced and kCountingNew is false (skip the check).
// (tests/unit/no_alloc_test.cpp has its own, switchable counter that also
// works under ASan through its allocator hooks.)
#pragma once

#include <atomic>
#include <cstdlib>
#include <new>

#include "support/sanitizer.hpp"

#if defined(__GNUC__) && !defined(__clang__)
#pragma GCC diagnostic ignored "-Wmismatched-new-delete"
#endif

namespace cansim::test {
inline std::atomic<long> g_allocations{0};  // operator new calls so far
}  // namespace cansim::test

#ifdef CANSIM_ASAN
namespace cansim::test {
constexpr bool kCountingNew = false;
}
#else
namespace cansim::test {
constexpr bool kCountingNew = true;
}
void* operator new(std::size_t n) {
  cansim::test::g_allocations.fetch_add(1, std::memory_order_relaxed);
  if (void* p = std::malloc(n ? n : 1)) return p;
  throw std::bad_alloc();
}
void* operator new[](std::size_t n) { return operator new(n); }
void operator delete(void* p) noexcept { std::free(p); }
void operator delete[](void* p) noexcept { std::free(p); }
void operator delete(void* p, std::size_t) noexcept { std::free(p); }
void operator delete[](void* p, std::size_t) noexcept { std::free(p); }
#endif
