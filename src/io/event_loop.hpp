// One-thread epoll loop: file descriptors with handlers, one absolute
// CLOCK_MONOTONIC timerfd (TFD_TIMER_ABSTIME, so periods never drift) and a
// signalfd. The owner arms the timer at its earliest deadline (the loop core's
// next_deadline() and its own housekeeping) after every wake-up.
#pragma once

#include <csignal>
#include <cstdint>
#include <initializer_list>

#include "core/can_frame.hpp"

namespace cansim::io {

// CLOCK_MONOTONIC in microseconds: the core's time base.
TimeUs monotonic_now();

class FdHandler {
 public:
  virtual ~FdHandler() = default;
  virtual void on_events(std::uint32_t events) = 0;
};

class EventLoop {
 public:
  EventLoop();
  ~EventLoop();
  EventLoop(const EventLoop&) = delete;
  EventLoop& operator=(const EventLoop&) = delete;

  // Watches fd for EPOLLIN / EPOLLOUT (... ) and calls handler->on_events().
  void add(int fd, std::uint32_t events, FdHandler* handler);
  void modify(int fd, std::uint32_t events, FdHandler* handler);
  void remove(int fd);

  // Deferred descriptors (the control connections): a second epoll set that
  // the owner services at its own passes (poll_deferred()). They wake the
  // loop only while allow_deferred_wakeup(true): the owner allows it when
  // its next pass is further away than it lets a deferred event wait, so a
  // busy loop serves them with the passes it makes anyway, not with extra
  // wake-ups (each costs a context switch and a timer re-arm).
  void add_deferred(int fd, std::uint32_t events, FdHandler* handler);
  void modify_deferred(int fd, std::uint32_t events, FdHandler* handler);
  void remove_deferred(int fd);
  void allow_deferred_wakeup(bool allow);
  // Calls on_events() of the deferred descriptors that are ready. Costs no
  // system call when none can be: the loop slept with them allowed to wake
  // it and they did not.
  int poll_deferred();

  // Arms the one timer at an absolute monotonic time (kNever disarms).
  // Re-arming at the same time is a no-op.
  void arm_timer(TimeUs at);
  TimeUs timer_at() const { return timer_at_; }
  // Blocks the given signals and delivers them through signalfd.
  void watch_signals(std::initializer_list<int> signals);

  // Waits for events (at most timeout_ms, -1 forever) and dispatches them.
  // The timer and signals are reported through the two callbacks' flags:
  // returns the number of events handled.
  int wait(int timeout_ms, bool& timer_fired, int& signal);

 private:
  int epoll_ = -1;
  int deferred_ = -1;  // the deferred descriptors' epoll set, itself in epoll_
  bool deferred_wakes_ = false;
  bool deferred_maybe_ready_ = true;
  int timer_ = -1;
  int signal_ = -1;
  TimeUs timer_at_ = kNever;
};

}  // namespace cansim::io
