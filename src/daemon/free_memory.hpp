// Gives the memory of removed nodes back to the kernel without holding the
// loop. malloc_trim(0) releases the free pages inside the heap, but it
// takes as long as the kernel needs to drop them (20-170 ms after 4,000
// nodes left on this host), and it cannot reach the chunks glibc caches per
// thread (tcache: up to 7 of each size up to 1 KiB), which after a large
// removal lie scattered over the heap and keep a page each (measured: 4,096
// nodes shrunk to 10 kept 1.3 MB more than a 10-node daemon). So the loop
// thread takes its cached chunks out (a few hundred malloc calls) and a
// short-lived thread frees them and trims; the loop does not allocate while
// nodes run, so it does not wait for the trim's arena lock.
#pragma once

#include <atomic>
#include <thread>

namespace cansim::daemon {

class FreeMemory {
 public:
  FreeMemory() = default;
  FreeMemory(const FreeMemory&) = delete;
  FreeMemory& operator=(const FreeMemory&) = delete;
  ~FreeMemory();  // waits for a release under way

  // Starts a release; false (nothing done) while the last one still runs.
  bool release();

 private:
  std::thread worker_;
  std::atomic<bool> running_{false};
};

}  // namespace cansim::daemon
