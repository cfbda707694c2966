// The journal knows what a bench did: every control action (a method that
// changes the fleet: set, ramp, override, faults, power, NMT, writes, store /
// restore, recordings, add / remove / reload) logs one line naming the node
// (CANSIM_NODE=, CANSIM_IFACE= through ControlHost::log_action), the action
// with its arguments, the caller's uid and the outcome:
//
//   control: vcan0/generic/0: Step pressure 5 bar by uid 1000: done
//   control: vcan0/dps/0: Write 0x1017:00 70000 by uid 0: refused (OutOfRange: ...)
//
// Bounded: at most `burst` lines per `window`; the lines over it are counted
// and the count is logged ("control: 1234 action lines suppressed in 5 s")
// with the next line after the window, or when the service ends.
//
// The vtables wrap each acting method in audited_node<> / audited_fleet<>,
// which call it and then log what it did: the handlers stay as they are.
#pragma once

#include <systemd/sd-bus.h>
#include <sys/types.h>

#include <chrono>
#include <cstdint>
#include <optional>
#include <string>
#include <unordered_map>

namespace cansim::control {

struct ActionRecord {
  std::string node;            // fleet key; "" for a fleet action
  std::string interface;       // the node's interface; "" for a fleet action
  std::string text;            // "control: vcan0/generic/0: Step pressure 5 bar by uid 1000: done"
  std::optional<uid_t> uid{};  // the caller's, when known (journal field CANSIM_CALLER_UID=)
};

class ActionLimiter {
 public:
  using Clock = std::chrono::steady_clock;
  explicit ActionLimiter(std::size_t burst = 50, Clock::duration window = std::chrono::seconds(5))
      : burst_(burst), window_(window) {}

  struct Admission {
    bool log = false;                          // the line may be logged (false: it is counted)
    std::optional<ActionRecord> suppressed{};  // first: the count of the window that ended
  };
  // Asked before a line is built, so a flood costs a count, not a line.
  Admission admit(Clock::time_point now);
  // The count still owed, at the end.
  std::optional<ActionRecord> flush();

 private:
  std::optional<ActionRecord> suppressed_line();

  std::size_t burst_;
  Clock::duration window_;
  Clock::time_point window_start_{};
  std::size_t in_window_ = 0;
  std::uint64_t suppressed_ = 0;
};

// The arguments of a method call as the journal shows them: strings and
// numbers as they are, "0x1017:00" for a leading (q index, y sub),
// {key=value, ...} for a{ss}, hex for ay, a variant's value; YAML and long
// strings cut with "...". Reads `m` from its start.
std::string describe_arguments(sd_bus_message* m);

// The caller's effective uid: the peer's on the private socket (as the
// endpoints read it from the socket when they accepted it, else sd-bus's),
// the sender's on a bus (asked once per sender name, then cached).
class CallerIds {
 public:
  std::optional<uid_t> of(sd_bus_message* m);
  void set_peer(sd_bus* bus, uid_t uid) { by_bus_[bus] = uid; }
  void forget(sd_bus* bus) { by_bus_.erase(bus); }

 private:
  std::unordered_map<std::string, uid_t> by_sender_;
  std::unordered_map<sd_bus*, uid_t> by_bus_;
};

// "by uid 1000: done" / "by uid 0: refused (OutOfRange: value outside ...)".
std::string action_outcome(std::optional<uid_t> uid, int r, const sd_bus_error* e);

}  // namespace cansim::control
