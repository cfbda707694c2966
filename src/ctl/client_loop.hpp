// The event loop of cansimctl's long-running verbs (watch, monitor, top):
// sd-event with the connection attached, SIGINT / SIGTERM ending it, and the
// sources each verb adds (signal matches, CAN sockets, a refresh timer). A
// handler that throws ends the loop; run() then throws Failure with its text.
// cansimd stopping ends the loop as Ctrl-C does: the verb is done, not failed.
#pragma once

#include <systemd/sd-event.h>

#include <cstdint>
#include <cstdio>
#include <functional>
#include <memory>
#include <string>
#include <vector>

#include "ctl/connection.hpp"

namespace cansim::ctl {

class ClientLoop {
 public:
  explicit ClientLoop(Connection& connection);
  ~ClientLoop();
  ClientLoop(const ClientLoop&) = delete;
  ClientLoop& operator=(const ClientLoop&) = delete;

  // Signals matching `rule` (a D-Bus match rule) go to `handler`.
  void on_signals(const std::string& rule, std::function<void(sd_bus_message*)> handler);
  // `handler` runs whenever fd is readable.
  void on_readable(int fd, std::function<void()> handler);
  // `handler` runs every period_us, the first time period_us from now.
  void every(std::uint64_t period_us, std::function<void()> handler);
  // Runs until SIGINT / SIGTERM, stop() or cansimd closing the connection
  // (then "cansimctl VERB: cansimd has stopped; done." on stderr, unless
  // quiet); returns 0. A failing handler throws Failure.
  int run(const char* verb, bool quiet);
  // Ends the loop from a handler: run() returns 0.
  void stop();

 private:
  struct Source;
  void guarded(const std::function<void()>& f);

  Connection& connection_;
  sd_event* event_ = nullptr;
  std::vector<std::unique_ptr<Source>> sources_;
  std::string error_;
};

}  // namespace cansim::ctl
