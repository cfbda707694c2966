#include "io/event_loop.hpp"

#include <sys/epoll.h>
#include <sys/signalfd.h>
#include <sys/timerfd.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <ctime>
#include <string>

#include "io/failure.hpp"

namespace cansim::io {

namespace {
// Marker pointers for the loop's own descriptors.
FdHandler* const kTimerTag = reinterpret_cast<FdHandler*>(std::uintptr_t(1));
FdHandler* const kSignalTag = reinterpret_cast<FdHandler*>(std::uintptr_t(2));
FdHandler* const kDeferredTag = reinterpret_cast<FdHandler*>(std::uintptr_t(3));

bool epoll_control(int epoll, int op, int fd, std::uint32_t events, void* ptr, std::string& error) {
  epoll_event ev{};
  ev.events = events;
  ev.data.ptr = ptr;
  if (epoll_ctl(epoll, op, fd, &ev) == 0) return true;
  error = failure(op == EPOLL_CTL_ADD ? "epoll_ctl(ADD)" : "epoll_ctl(MOD)", errno);
  return false;
}
}  // namespace

TimeUs monotonic_now() {
  timespec ts;
  clock_gettime(CLOCK_MONOTONIC, &ts);
  return TimeUs(ts.tv_sec) * 1000000 + ts.tv_nsec / 1000;
}

TimeUs thread_cpu_now() {
  timespec ts;
  clock_gettime(CLOCK_THREAD_CPUTIME_ID, &ts);
  return TimeUs(ts.tv_sec) * 1000000 + ts.tv_nsec / 1000;
}

bool EventLoop::fail(const char* what) {
  error_ = failure(what, errno);
  return false;
}

bool EventLoop::open() {
  if ((epoll_ = epoll_create1(EPOLL_CLOEXEC)) < 0) return fail("epoll_create1");
  if ((timer_ = timerfd_create(CLOCK_MONOTONIC, TFD_NONBLOCK | TFD_CLOEXEC)) < 0) return fail("timerfd_create");
  if ((deferred_ = epoll_create1(EPOLL_CLOEXEC)) < 0) return fail("epoll_create1");
  return add(timer_, EPOLLIN, kTimerTag) && add(deferred_, 0, kDeferredTag);
}

EventLoop::~EventLoop() {
  if (signal_ >= 0) ::close(signal_);
  if (timer_ >= 0) ::close(timer_);
  if (deferred_ >= 0) ::close(deferred_);
  if (epoll_ >= 0) ::close(epoll_);
}

bool EventLoop::add(int fd, std::uint32_t events, FdHandler* handler) {
  return epoll_control(epoll_, EPOLL_CTL_ADD, fd, events, handler, error_);
}

bool EventLoop::modify(int fd, std::uint32_t events, FdHandler* handler) {
  return epoll_control(epoll_, EPOLL_CTL_MOD, fd, events, handler, error_);
}

void EventLoop::remove(int fd) { epoll_ctl(epoll_, EPOLL_CTL_DEL, fd, nullptr); }

bool EventLoop::add_deferred(int fd, std::uint32_t events, FdHandler* handler) {
  deferred_maybe_ready_ = true;
  return epoll_control(deferred_, EPOLL_CTL_ADD, fd, events, handler, error_);
}

bool EventLoop::modify_deferred(int fd, std::uint32_t events, FdHandler* handler) {
  deferred_maybe_ready_ = true;
  return epoll_control(deferred_, EPOLL_CTL_MOD, fd, events, handler, error_);
}

void EventLoop::remove_deferred(int fd) { epoll_ctl(deferred_, EPOLL_CTL_DEL, fd, nullptr); }

bool EventLoop::allow_deferred_wakeup(bool allow) {
  if (allow == deferred_wakes_) return true;
  if (!epoll_control(epoll_, EPOLL_CTL_MOD, deferred_, allow ? std::uint32_t(EPOLLIN) : 0u, kDeferredTag, error_))
    return false;
  deferred_wakes_ = allow;
  return true;
}

int EventLoop::poll_deferred() {
  if (!deferred_maybe_ready_) return 0;
  deferred_maybe_ready_ = false;
  epoll_event events[64];
  int n = epoll_wait(deferred_, events, 64, 0);
  if (n < 0) {
    if (errno == EINTR) return 0;
    fail("epoll_wait");
    return -1;
  }
  for (int i = 0; i < n; ++i) static_cast<FdHandler*>(events[i].data.ptr)->on_events(events[i].events);
  return n;
}

bool EventLoop::arm_timer(TimeUs at) {
  if (at == timer_at_) return true;
  itimerspec spec{};
  if (at != kNever) {
    // 0 would disarm: an already-past deadline fires at the next tick instead.
    TimeUs t = at < 1 ? 1 : at;
    spec.it_value.tv_sec = t / 1000000;
    spec.it_value.tv_nsec = long(t % 1000000) * 1000;
  }
  if (timerfd_settime(timer_, TFD_TIMER_ABSTIME, &spec, nullptr) < 0) return fail("timerfd_settime");
  timer_at_ = at;
  return true;
}

bool EventLoop::watch_signals(std::initializer_list<int> signals) {
  sigset_t set;
  sigemptyset(&set);
  for (int s : signals) sigaddset(&set, s);
  if (sigprocmask(SIG_BLOCK, &set, nullptr) < 0) return fail("sigprocmask");
  if ((signal_ = signalfd(-1, &set, SFD_NONBLOCK | SFD_CLOEXEC)) < 0) return fail("signalfd");
  return add(signal_, EPOLLIN, kSignalTag);
}

int EventLoop::wait(int timeout_ms, bool& timer_fired, int& signal) {
  timer_fired = false;
  signal = 0;
  if (!deferred_wakes_) deferred_maybe_ready_ = true;  // nothing tells while we sleep
  epoll_event events[64];
  int n = epoll_wait(epoll_, events, 64, timeout_ms);
  woke_at_ = monotonic_now();
  woke_cpu_ = thread_cpu_now();
  if (n < 0) {
    if (errno == EINTR) return 0;
    fail("epoll_wait");
    return -1;
  }
  for (int i = 0; i < n; ++i) {
    auto* h = static_cast<FdHandler*>(events[i].data.ptr);
    if (h == kTimerTag) {
      std::uint64_t expirations;
      if (::read(timer_, &expirations, sizeof expirations) > 0) timer_fired = true;
      timer_at_ = kNever;  // one-shot: fired (or about to), re-armed by the owner
    } else if (h == kDeferredTag) {
      deferred_maybe_ready_ = true;
    } else if (h == kSignalTag) {
      signalfd_siginfo info;
      // A termination request outranks a reload arriving in the same batch.
      while (::read(signal_, &info, sizeof info) == ssize_t(sizeof info))
        if (signal != SIGTERM && signal != SIGINT) signal = int(info.ssi_signo);
    } else if (h) {
      h->on_events(events[i].events);
    }
  }
  return n;
}

void PassMeter::pass(TimeUs now, TimeUs length) {
  const TimeUs second = now / 1'000'000;
  const int at = int(second % kWindows);
  if (second_[at] != second) {
    second_[at] = second;
    longest_[at] = 0;
  }
  longest_[at] = std::max(longest_[at], length);
}

TimeUs PassMeter::longest(TimeUs now) const {
  const TimeUs second = now / 1'000'000;
  TimeUs out = 0;
  for (int i = 0; i < kWindows; ++i)
    if (second - second_[i] < kWindows) out = std::max(out, longest_[i]);
  return out;
}

}  // namespace cansim::io
