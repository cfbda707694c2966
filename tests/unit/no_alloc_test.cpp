// Proof that the frame and tick paths do not touch the heap: global operator
// new/delete are replaced by counting versions; a generic-404 node on a tiny
// fixed-size sink (SimBus logs into a vector, so it is not used here) is
// powered on, then driven through minutes of mixed traffic — NMT, SYNC,
// heartbeats, TPDO timers and events, RPDO, SDO expedited / segmented / block
// up- and download, aborts and timeouts — while allocations are counted.
#include <gtest/gtest.h>

#include <atomic>
#include <cstdio>
#include <cstdlib>
#include <new>

#include "config/profile.hpp"
#include "core/node.hpp"
#include "personalities/registry.hpp"
#include "support/sanitizer.hpp"
#include "sdo_support.hpp"
#include "support/sim.hpp"

namespace {
std::atomic<bool> g_counting{false};
std::atomic<long> g_allocations{0};
void count_one() {
  if (g_counting.load(std::memory_order_relaxed)) g_allocations.fetch_add(1, std::memory_order_relaxed);
}
}  // namespace

#ifdef CANSIM_ASAN
// AddressSanitizer owns operator new/delete (replacing them does not link);
// its allocator hook sees every heap allocation instead (malloc included).
// (declared here: GCC installs no sanitizer/allocator_interface.h)
extern "C" int __sanitizer_install_malloc_and_free_hooks(void (*)(const volatile void*, std::size_t),
                                                         void (*)(const volatile void*));
namespace {
void on_malloc(const volatile void*, std::size_t) { count_one(); }
void on_free(const volatile void*) {}
const int g_hooks_installed = __sanitizer_install_malloc_and_free_hooks(on_malloc, on_free);
}  // namespace
#else
namespace {
void* counted_alloc(std::size_t n) {
  count_one();
  void* p = std::malloc(n ? n : 1);
  if (!p) throw std::bad_alloc();
  return p;
}
void* counted_alloc_aligned(std::size_t n, std::align_val_t al) {
  count_one();
  std::size_t a = static_cast<std::size_t>(al);
  void* p = std::aligned_alloc(a, ((n ? n : 1) + a - 1) / a * a);
  if (!p) throw std::bad_alloc();
  return p;
}
}  // namespace

void* operator new(std::size_t n) { return counted_alloc(n); }
void* operator new[](std::size_t n) { return counted_alloc(n); }
void* operator new(std::size_t n, const std::nothrow_t&) noexcept {
  try {
    return counted_alloc(n);
  } catch (...) {
    return nullptr;
  }
}
void* operator new[](std::size_t n, const std::nothrow_t&) noexcept {
  try {
    return counted_alloc(n);
  } catch (...) {
    return nullptr;
  }
}
void* operator new(std::size_t n, std::align_val_t a) { return counted_alloc_aligned(n, a); }
void* operator new[](std::size_t n, std::align_val_t a) { return counted_alloc_aligned(n, a); }
void operator delete(void* p) noexcept { std::free(p); }
void operator delete[](void* p) noexcept { std::free(p); }
void operator delete(void* p, std::size_t) noexcept { std::free(p); }
void operator delete[](void* p, std::size_t) noexcept { std::free(p); }
void operator delete(void* p, std::align_val_t) noexcept { std::free(p); }
void operator delete[](void* p, std::align_val_t) noexcept { std::free(p); }
void operator delete(void* p, std::size_t, std::align_val_t) noexcept { std::free(p); }
void operator delete[](void* p, std::size_t, std::align_val_t) noexcept { std::free(p); }
#endif

namespace cansim {
namespace {

// Keeps the last frames in a ring; counts per COB-ID class. No allocation.
class RingSink : public FrameSink {
 public:
  void send(const CanFrame& f) override {
    ring_[count_ % kSize] = f;
    ++count_;
    if (f.id >= 0x580 && f.id < 0x600) ++sdo_;
    if (f.id >= 0x180 && f.id < 0x500) ++pdo_;
    if (f.id >= 0x700 && f.id < 0x780) ++heartbeat_;
  }
  const CanFrame& last() const { return ring_[(count_ - 1) % kSize]; }
  long count() const { return count_; }
  long sdo() const { return sdo_; }
  long pdo() const { return pdo_; }
  long heartbeat() const { return heartbeat_; }

 private:
  static constexpr long kSize = 256;
  CanFrame ring_[kSize];
  long count_ = 0;
  long sdo_ = 0;
  long pdo_ = 0;
  long heartbeat_ = 0;
};

constexpr std::uint32_t kRx = 0x610;

// Drives one node: time advances through every deadline; the "master" frames
// come from a fixed script. Counts allocations per phase.
class Driver {
 public:
  Driver(Node& node, RingSink& sink) : node_(node), sink_(sink) {}

  void run_until(TimeUs t) {
    for (TimeUs next = node_.next_deadline(); next <= t; next = node_.next_deadline()) {
      now_ = std::max(now_, next);
      node_.advance(now_);
    }
    now_ = std::max(now_, t);
  }
  void frame(std::uint32_t id, std::initializer_list<std::uint8_t> bytes) {
    node_.on_frame(CanFrame::make(id, bytes), now_);
  }
  void sdo(std::initializer_list<std::uint8_t> bytes) { frame(kRx, bytes); }
  TimeUs now() const { return now_; }

  // One round of SDO traffic of every kind.
  void sdo_round() {
    sdo({0x40, 0x00, 0x10, 0x00, 0, 0, 0, 0});        // expedited upload
    sdo({0x2B, 0x17, 0x10, 0x00, 0xE8, 0x03, 0, 0});  // expedited download (heartbeat 1000 ms)
    sdo({0x22, 0x12, 0x61, 0x01, 0x01, 0, 0, 0});     // without size
    sdo({0x40, 0x08, 0x10, 0x00, 0, 0, 0, 0});        // segmented upload of 0x1008
    for (int i = 0; i < 6; ++i) sdo({std::uint8_t(i % 2 ? 0x70 : 0x60), 0, 0, 0, 0, 0, 0, 0});
    sdo({0x21, 0x00, 0x20, 0x00, 10, 0, 0, 0});  // segmented download
    sdo({0x00, 'a', 'b', 'c', 'd', 'e', 'f', 'g'});
    sdo({0x19, 'h', 'i', 'j', 0, 0, 0, 0});
    // Block download of 20 bytes to 0x2001 without CRC, with a lost segment.
    sdo({0xC2, 0x01, 0x20, 0x00, 20, 0, 0, 0});
    sdo({0x01, 1, 2, 3, 4, 5, 6, 7});
    sdo({0x03, 15, 16, 17, 18, 19, 20, 0});  // gap: ack 1
    sdo({0x01, 8, 9, 10, 11, 12, 13, 14});
    sdo({0x82, 15, 16, 17, 18, 19, 20, 0});
    sdo({0xC5, 0, 0, 0, 0, 0, 0, 0});
    // Block upload of 0x2001 (20 bytes) with CRC, blksize 2, one resend.
    sdo({0xA4, 0x01, 0x20, 0x00, 2, 0, 0, 0});
    sdo({0xA3, 0, 0, 0, 0, 0, 0, 0});
    sdo({0xA2, 1, 2, 0, 0, 0, 0, 0});
    sdo({0xA2, 2, 2, 0, 0, 0, 0, 0});
    sdo({0xA1, 0, 0, 0, 0, 0, 0, 0});
    // Aborts of several kinds, then a stalled transfer left to time out.
    sdo({0x40, 0x34, 0x12, 0x00, 0, 0, 0, 0});
    sdo({0x23, 0x00, 0x10, 0x00, 1, 2, 3, 4});
    sdo({0xE0, 0, 0, 0, 0, 0, 0, 0});
    sdo({0x40, 0x00, 0x20, 0x00, 0, 0, 0, 0});
  }

 private:
  Node& node_;
  RingSink& sink_;
  TimeUs now_ = 0;
};

long count_allocations(void (*body)(Driver&), Driver& d) {
  g_allocations = 0;
  g_counting = true;
  body(d);
  g_counting = false;
  return g_allocations.load();
}

void mixed_traffic(Driver& d) {
  d.frame(0x000, {0x01, 0x10});  // NMT start
  for (int second = 0; second < 180; ++second) {
    TimeUs base = d.now();
    for (int k = 0; k < 10; ++k) {  // SYNC every 100 ms
      d.run_until(base + ms(100) * k);
      d.frame(0x080, {});
    }
    d.frame(0x210, {0x01, 0x02, 0x03, 0x04, 0x05, 0x06});  // RPDO1
    if (second % 10 == 0) d.sdo_round();
    if (second == 90) {
      d.frame(0x000, {0x80, 0x10});  // pre-operational and back
      d.frame(0x000, {0x01, 0x10});
    }
    d.run_until(base + ms(1000));
  }
}

void check_no_allocations(const config::Profile& profile, Application* app) {
  RingSink sink;
  test::MemoryStorage storage;
  Node node(config::node_setup(profile, 0x10), sink, app, &storage);
  Driver d(node, sink);
  node.power_on(0);
  d.run_until(ms(10));  // boot-up done: start-up allocations end here
  long before = sink.count();

  long allocations = count_allocations(mixed_traffic, d);

  EXPECT_EQ(allocations, 0) << "heap allocations on the frame/tick paths";
  EXPECT_GT(sink.count() - before, 1000) << "the scenario must actually produce traffic";
  EXPECT_GT(sink.sdo(), 50);
  // Once NMT, heartbeat and PDO have landed they are part of the proof too.
  std::printf("no_alloc: %ld frames, %ld SDO, %ld PDO, %ld heartbeat\n", sink.count() - before, sink.sdo(), sink.pdo(),
              sink.heartbeat());
}

TEST(NoAlloc, PlainNodeFramesAndTicks) {
  auto profile = test::load_repo_profile("generic-404");
  check_no_allocations(profile, nullptr);
}

TEST(NoAlloc, NodeWithItsPersonality) {
  auto profile = test::load_repo_profile("generic-404");
  auto app = personalities::make_application(profile, personalities::NodeContext{});
  check_no_allocations(profile, app.get());
}

// Response times hold SDO answers and synchronous TPDOs (TPDO2, type 1) in
// buffers sized at reset.
TEST(NoAlloc, NodeWithResponseTimes) {
  const config::Profile profile = test::parse_generic_with_options(
      "sdo_turnaround_us: 1500, sdo_turnaround_jitter_us: 500, sync_tpdo_delay_us: 300, sync_tpdo_jitter_us: 200");
  check_no_allocations(profile, nullptr);
}

// The counter itself works (else a zero above would prove nothing).
TEST(NoAlloc, CounterSeesAllocations) {
#ifdef CANSIM_ASAN
  ASSERT_NE(g_hooks_installed, 0);
#endif
  g_allocations = 0;
  g_counting = true;
  int* volatile p = new int(3);  // volatile: the allocation cannot be elided
  g_counting = false;
  delete p;
  EXPECT_EQ(g_allocations.load(), 1);
}

}  // namespace
}  // namespace cansim
