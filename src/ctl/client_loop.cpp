#include "ctl/client_loop.hpp"

#include <csignal>
#include <cerrno>

namespace cansim::ctl {

struct ClientLoop::Source {
  ClientLoop* loop = nullptr;
  std::function<void(sd_bus_message*)> on_message;
  std::function<void()> on_event;
  std::uint64_t period_us = 0;
  sd_bus_slot* slot = nullptr;
  sd_event_source* source = nullptr;
  ~Source() {
    sd_bus_slot_unref(slot);
    sd_event_source_unref(source);
  }
};

namespace {

int on_stop(sd_event_source* source, const struct signalfd_siginfo*, void*) {
  return sd_event_exit(sd_event_source_get_event(source), 0);
}

}  // namespace

ClientLoop::ClientLoop(Connection& connection) : connection_(connection) {
  expect(sd_event_new(&event_), "cannot create an event loop");
  // sd-event takes signals through a signalfd: they must be blocked first.
  sigset_t set;
  sigemptyset(&set);
  for (int sig : {SIGINT, SIGTERM}) sigaddset(&set, sig);
  expect(sigprocmask(SIG_BLOCK, &set, nullptr) < 0 ? -errno : 0, "cannot block signals");
  for (int sig : {SIGINT, SIGTERM})
    expect(sd_event_add_signal(event_, nullptr, sig, on_stop, nullptr), "cannot watch signals");
  sd_bus* bus = connection_.bus();
  expect(sd_bus_attach_event(bus, event_, SD_EVENT_PRIORITY_NORMAL), "cannot attach the connection");
  sd_bus_set_exit_on_disconnect(bus, 1);  // the loop ends with 1 when the daemon goes
}

ClientLoop::~ClientLoop() {
  sources_.clear();
  sd_bus_detach_event(connection_.bus());
  sd_event_unref(event_);
}

void ClientLoop::guarded(const std::function<void()>& f) {
  try {
    f();
  } catch (const std::exception& e) {
    error_ = e.what();
    sd_event_exit(event_, 1);
  }
}

void ClientLoop::on_signals(const std::string& rule, std::function<void(sd_bus_message*)> handler) {
  auto s = std::make_unique<Source>();
  s->loop = this;
  s->on_message = std::move(handler);
  auto callback = [](sd_bus_message* m, void* userdata, sd_bus_error*) {
    auto* self = static_cast<Source*>(userdata);
    self->loop->guarded([&] { self->on_message(m); });
    return 0;
  };
  expect(sd_bus_add_match(connection_.bus(), &s->slot, rule.c_str(), callback, s.get()), "cannot add a match rule");
  sources_.push_back(std::move(s));
}

void ClientLoop::on_readable(int fd, std::function<void()> handler) {
  auto s = std::make_unique<Source>();
  s->loop = this;
  s->on_event = std::move(handler);
  auto callback = [](sd_event_source*, int, std::uint32_t, void* userdata) {
    auto* self = static_cast<Source*>(userdata);
    self->loop->guarded(self->on_event);
    return 0;
  };
  expect(sd_event_add_io(event_, &s->source, fd, EPOLLIN, callback, s.get()), "cannot watch a socket");
  sources_.push_back(std::move(s));
}

void ClientLoop::every(std::uint64_t period_us, std::function<void()> handler) {
  auto s = std::make_unique<Source>();
  s->loop = this;
  s->on_event = std::move(handler);
  s->period_us = period_us;
  auto callback = [](sd_event_source* source, std::uint64_t usec, void* userdata) {
    auto* self = static_cast<Source*>(userdata);
    self->loop->guarded(self->on_event);
    sd_event_source_set_time(source, usec + self->period_us);
    return sd_event_source_set_enabled(source, SD_EVENT_ON);
  };
  std::uint64_t now = 0;
  expect(sd_event_now(event_, CLOCK_MONOTONIC, &now), "cannot read the clock");
  expect(sd_event_add_time(event_, &s->source, CLOCK_MONOTONIC, now + period_us, 0, callback, s.get()),
         "cannot add a timer");
  sources_.push_back(std::move(s));
}

int ClientLoop::run(const char* verb, bool quiet) {
  int r = sd_event_loop(event_);
  if (!error_.empty()) throw Failure(error_);
  expect(r, "event loop failed");
  if (r != 0 && !quiet) std::fprintf(stderr, "cansimctl %s: cansimd has stopped; done.\n", verb);
  return 0;
}

void ClientLoop::stop() { sd_event_exit(event_, 0); }

}  // namespace cansim::ctl
