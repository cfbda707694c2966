// One-thread epoll loop: file descriptors with handlers, one absolute
// CLOCK_MONOTONIC timerfd (TFD_TIMER_ABSTIME, so periods never drift) and a
// signalfd. The owner arms the timer at its earliest deadline (the loop core's
// next_deadline() and its own housekeeping) after every wake-up. Failures
// are return values with error() saying why (io/failure.hpp).
#pragma once

#include <csignal>
#include <cstdint>
#include <initializer_list>
#include <string>

#include "core/can_frame.hpp"

namespace cansim::io {

// CLOCK_MONOTONIC in microseconds: the core's time base.
TimeUs monotonic_now();
// CPU time this thread has used (CLOCK_THREAD_CPUTIME_ID, µs).
TimeUs thread_cpu_now();

class FdHandler {
 public:
  virtual ~FdHandler() = default;
  virtual void on_events(std::uint32_t events) = 0;
};

class EventLoop {
 public:
  EventLoop() = default;
  ~EventLoop();
  EventLoop(const EventLoop&) = delete;
  EventLoop& operator=(const EventLoop&) = delete;

  // Creates the epoll sets and the timer; before anything else.
  bool open();
  // Why the last call that returned false (or -1) failed.
  const std::string& error() const { return error_; }

  // Watches fd for EPOLLIN / EPOLLOUT (... ) and calls handler->on_events().
  bool add(int fd, std::uint32_t events, FdHandler* handler);
  bool modify(int fd, std::uint32_t events, FdHandler* handler);
  void remove(int fd);

  // Deferred descriptors (the control connections): a second epoll set that
  // the owner services at its own passes (poll_deferred()). They wake the
  // loop only while allow_deferred_wakeup(true): the owner allows it when
  // its next pass is further away than it lets a deferred event wait, so a
  // busy loop serves them with the passes it makes anyway, not with extra
  // wake-ups (each costs a context switch and a timer re-arm).
  bool add_deferred(int fd, std::uint32_t events, FdHandler* handler);
  bool modify_deferred(int fd, std::uint32_t events, FdHandler* handler);
  void remove_deferred(int fd);
  bool allow_deferred_wakeup(bool allow);
  // Calls on_events() of the deferred descriptors that are ready (returns
  // their count, -1 on failure). Costs no system call when none can be: the
  // loop slept with them allowed to wake it and they did not.
  int poll_deferred();

  // Arms the one timer at an absolute monotonic time (kNever disarms).
  // Re-arming at the same time is a no-op.
  bool arm_timer(TimeUs at);
  TimeUs timer_at() const { return timer_at_; }
  // Blocks the given signals and delivers them through signalfd.
  bool watch_signals(std::initializer_list<int> signals);

  // Waits for events (at most timeout_ms, -1 forever) and dispatches them.
  // The timer and signals are reported through the two callbacks' flags:
  // returns the number of events handled (an interrupted wait: 0), -1 on failure.
  int wait(int timeout_ms, bool& timer_fired, int& signal);
  // When the last wait() woke (CLOCK_MONOTONIC µs), before it dispatched,
  // and the thread's CPU time then (thread_cpu_now()).
  TimeUs woke_at() const { return woke_at_; }
  TimeUs woke_cpu() const { return woke_cpu_; }

 private:
  bool fail(const char* what);  // false, error() = what: strerror(errno)

  int epoll_ = -1;
  int deferred_ = -1;  // the deferred descriptors' epoll set, itself in epoll_
  bool deferred_wakes_ = false;
  bool deferred_maybe_ready_ = true;
  int timer_ = -1;
  int signal_ = -1;
  TimeUs timer_at_ = kNever;
  std::string error_;
  TimeUs woke_at_ = 0;
  TimeUs woke_cpu_ = 0;
};

// The longest loop pass (a wake-up to the next wait: its wall-clock time, or
// the CPU time it used) over the last kWindows seconds: one maximum per
// second, the oldest forgotten.
class PassMeter {
 public:
  static constexpr int kWindows = 10;
  void pass(TimeUs now, TimeUs length);
  TimeUs longest(TimeUs now) const;

 private:
  TimeUs longest_[kWindows] = {};
  TimeUs second_[kWindows] = {};  // the second (µs / 1e6) each maximum is of
};

}  // namespace cansim::io
