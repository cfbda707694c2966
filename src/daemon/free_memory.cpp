#include "daemon/free_memory.hpp"

#include <malloc.h>

#include <cstdlib>
#include <vector>

namespace cansim::daemon {

namespace {
// glibc's per-thread cache (malloc/malloc.c: TCACHE_FILL_COUNT, tidx2usize).
constexpr std::size_t kCachedPerSize = 7;
constexpr std::size_t kSizeStep = 16;
constexpr std::size_t kLargestCached = 1032;
}  // namespace

FreeMemory::~FreeMemory() {
  if (worker_.joinable()) worker_.join();
}

bool FreeMemory::release() {
  if (running_) return false;
  if (worker_.joinable()) worker_.join();
  // A malloc of a cached size takes a cached chunk first: these are the
  // loop thread's cached chunks (and fresh ones where the cache was short).
  std::vector<void*> cached;
  cached.reserve(kLargestCached / kSizeStep * kCachedPerSize);
  for (std::size_t size = kSizeStep; size <= kLargestCached; size += kSizeStep)
    for (std::size_t i = 0; i < kCachedPerSize; ++i) cached.push_back(std::malloc(size));
  running_ = true;
  worker_ = std::thread([this, cached = std::move(cached)] {
    // Freed by a thread of their own, they go into its cache, and back to
    // the heap when it ends: then the trim reaches their pages.
    std::thread([&cached] {
      for (void* p : cached) std::free(p);
    }).join();
    malloc_trim(0);
    running_ = false;
  });
  return true;
}

}  // namespace cansim::daemon
