// EventLoop's deferred descriptors (the control connections): they wake the
// loop only while allowed to, and poll_deferred() finds them ready either way.
#include <gtest/gtest.h>
#include <sys/epoll.h>
#include <unistd.h>

#include "io/event_loop.hpp"

namespace cansim::io {
namespace {

struct CountingHandler : FdHandler {
  int calls = 0;
  void on_events(std::uint32_t) override { ++calls; }
};

class DeferredTest : public ::testing::Test {
 protected:
  void SetUp() override {
    ASSERT_TRUE(loop.open()) << loop.error();
    ASSERT_EQ(::pipe(fds), 0);
    ASSERT_TRUE(loop.add_deferred(fds[0], EPOLLIN, &handler)) << loop.error();
  }
  void TearDown() override {
    loop.remove_deferred(fds[0]);
    ::close(fds[0]);
    ::close(fds[1]);
  }
  void make_readable() { ASSERT_EQ(::write(fds[1], "x", 1), 1); }
  int wait(int timeout_ms) {
    bool timer = false;
    int signal = 0;
    return loop.wait(timeout_ms, timer, signal);
  }

  EventLoop loop;
  CountingHandler handler;
  int fds[2] = {-1, -1};
};

TEST_F(DeferredTest, DoesNotWakeTheLoopUnlessAllowed) {
  make_readable();
  EXPECT_EQ(wait(20), 0);  // slept the whole timeout
  EXPECT_EQ(handler.calls, 0);
  EXPECT_EQ(loop.poll_deferred(), 1);
  EXPECT_EQ(handler.calls, 1);
}

TEST_F(DeferredTest, WakesTheLoopWhenAllowed) {
  loop.allow_deferred_wakeup(true);
  make_readable();
  EXPECT_EQ(wait(5000), 1);
  EXPECT_EQ(handler.calls, 0);  // served by the owner's pass, not by wait()
  EXPECT_EQ(loop.poll_deferred(), 1);
  EXPECT_EQ(handler.calls, 1);
}

TEST_F(DeferredTest, PollFindsInputThatArrivedWhileWakingWasForbidden) {
  loop.allow_deferred_wakeup(false);
  EXPECT_EQ(loop.poll_deferred(), 0);
  make_readable();
  EXPECT_EQ(wait(0), 0);
  loop.allow_deferred_wakeup(true);
  EXPECT_EQ(loop.poll_deferred(), 1);
}

TEST_F(DeferredTest, InputLeftUnreadWakesAgainOnceAllowed) {
  loop.allow_deferred_wakeup(true);
  make_readable();
  EXPECT_EQ(wait(5000), 1);
  EXPECT_EQ(loop.poll_deferred(), 1);
  // The handler did not read: level-triggered, it is reported again.
  EXPECT_EQ(wait(5000), 1);
  EXPECT_EQ(loop.poll_deferred(), 1);
  EXPECT_EQ(handler.calls, 2);
}

TEST_F(DeferredTest, NothingReadyCostsNoDispatch) {
  loop.allow_deferred_wakeup(true);
  EXPECT_EQ(wait(0), 0);
  EXPECT_EQ(loop.poll_deferred(), 0);
  EXPECT_EQ(handler.calls, 0);
}

// io's failures are return values with the reason (io/failure.hpp), never exceptions.
TEST(EventLoopFailures, AreReturnedWithTheirReason) {
  EventLoop loop;
  CountingHandler handler;
  EXPECT_FALSE(loop.add(0, EPOLLIN, &handler));  // not open yet: no epoll set
  EXPECT_EQ(loop.error(), "epoll_ctl(ADD): Bad file descriptor");
  ASSERT_TRUE(loop.open()) << loop.error();
  EXPECT_FALSE(loop.add(-1, EPOLLIN, &handler));
  EXPECT_EQ(loop.error(), "epoll_ctl(ADD): Bad file descriptor");
  EXPECT_FALSE(loop.modify_deferred(12345, EPOLLIN, &handler));
  EXPECT_EQ(loop.error(), "epoll_ctl(MOD): Bad file descriptor");
  EXPECT_TRUE(loop.arm_timer(kNever));
}

// The longest pass of the last 10 s: a long pass counts until its second is
// 10 s old, then only what came after.
TEST(PassMeter, TheLongestPassOfTheLastTenSeconds) {
  PassMeter m;
  EXPECT_EQ(m.longest(0), 0);
  m.pass(1'400'000, 400'000);  // 400 ms in second 1
  m.pass(2'003'000, 3'000);
  EXPECT_EQ(m.longest(2'500'000), 400'000);
  EXPECT_EQ(m.longest(10'900'000), 400'000);
  EXPECT_EQ(m.longest(11'000'000), 3'000);  // second 1 is out of the window
  m.pass(21'000'500, 500);                  // the same bin as second 1 and 11, reused
  EXPECT_EQ(m.longest(21'000'600), 500);
}

}  // namespace
}  // namespace cansim::io
