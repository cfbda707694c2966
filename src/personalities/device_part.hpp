// What a sensor device adds to its measurement chain, as parts any
// personality's application holds or calls (sensor_application.hpp):
//   DevicePart        the node's fault schedule at run time (communication
//                     faults, arming, the boot EEPROM check) and the vendor
//                     supervision timer; it takes the schedule (the
//                     measurement source's, null: none) from its owner, so a
//                     device without a CiA 404 chain uses it as well;
//   saturating_count  a counter object that stops at its maximum;
//   SpanMonitor       inside / over / under the span, with hysteresis.
// (An EMCY that follows a condition is the EMCY engine's: Emcy::follow.)
// All are plain values: a copy of an application that holds them is a
// snapshot of it.
#pragma once

#include <algorithm>
#include <cstdint>
#include <type_traits>
#include <vector>

#include "core/node.hpp"
#include "personalities/comm_faults.hpp"
#include "physics/fault.hpp"
#include "physics/sensor.hpp"

namespace cansim::personalities {

class DevicePart {
 public:
  // seed: varies the node's dropped SDO segments (fault sdo_block_drop).
  explicit DevicePart(std::uint64_t seed) : comm_faults_(seed) {}
  // The seed of the node at `index` of its group.
  static std::uint64_t seed_of(std::uint32_t index) { return 0x9E3779B97F4A7C15ull * (index + 1); }

  // From every reset on: supervision runs at once, then every period.
  void on_reset(TimeUs now) { next_supervision_ = last_supervision_ = now; }
  // Application::environment: the communication faults of the schedule.
  TimeUs environment(Node& node, physics::FaultSet* faults, TimeUs now) {
    return comm_faults_.apply(node, faults, now);
  }

  // ---- fault injection at run time (the profile's faults are armed at boot).
  // physics::kInvalidFaultHandle / false without a schedule. The owner's
  // measurement follows the change (Cia404Chain::invalidate).
  physics::FaultHandle arm_fault(Node& node, physics::FaultSet* faults, const physics::FaultSpec& spec, TimeUs now);
  bool cancel_fault(Node& node, physics::FaultSet* faults, physics::FaultHandle h, TimeUs now);
  // The faults still armed at `now` (ids = handles), profile faults included.
  static std::vector<physics::FaultInfo> armed_faults(const physics::FaultSet* faults, TimeUs now);
  // Is a fault of this kind in force (false without a schedule)?
  static bool fault_active(const physics::FaultSet* faults, physics::FaultKind kind, TimeUs now) {
    return faults && faults->active(kind, now);
  }
  // Told of every start / end edge of every armed fault (measurement and
  // communication, profile and run time) when the node reaches it: at the
  // edge time, or at power-on for edges in a power-off time. The listener
  // must not arm or cancel faults.
  void set_fault_listener(FaultListener listener) { comm_faults_.set_listener(std::move(listener)); }

  // The boot EEPROM / data-set check: the stored parameters are corrupt or
  // an eeprom_error fault is in force.
  static bool boot_data_error(Node& node, const physics::FaultSet* faults, TimeUs now) {
    return node.store().corrupt() || fault_active(faults, physics::FaultKind::EepromError, now);
  }

  // Vendor supervision (status monitoring, counters, min / max capture), in
  // every NMT state from the reset on: runs `check` when due, every
  // `period` (0: the device has none); returns when it is next due. A check
  // that returns a time says that nothing it looks at can change before
  // then: the next check is the first point of its grid from there on
  // (kNever: none until resume_supervision()).
  template <class Check>
  TimeUs supervise(TimeUs now, TimeUs period, Check&& check) {
    if (period <= 0) return kNever;
    if (now >= next_supervision_) {
      last_supervision_ = now;
      next_supervision_ = now + period;
      if constexpr (!std::is_void_v<decltype(check())>) {
        const TimeUs quiet = check();
        if (quiet == kNever) next_supervision_ = kNever;
        else if (quiet > next_supervision_)
          next_supervision_ += (quiet - next_supervision_ + period - 1) / period * period;
      } else {
        check();
      }
    }
    return next_supervision_;
  }
  // What a skipped check relied on changed (a read, a write, a fault): the
  // next check is at the next point of its grid.
  void resume_supervision(TimeUs now, TimeUs period) {
    if (period <= 0 || next_supervision_ <= now) return;
    const TimeUs at = last_supervision_ + (now - last_supervision_ + period - 1) / period * period;
    next_supervision_ = std::min(next_supervision_, at);
  }

 private:
  void schedule_changed(Node& node, TimeUs now);

  CommFaultDriver comm_faults_;
  TimeUs next_supervision_ = 0;
  TimeUs last_supervision_ = 0;
};

// Adds one to a counter object, stopping at `max` (no object: nothing).
void saturating_count(Node& node, const OdEntry* counter, std::uint64_t max);

// Where a value is against a span, with an excursion left only `hysteresis`
// back inside (0: at the limit itself).
enum class Span : std::uint8_t { kInside, kOver, kUnder };
struct SpanMonitor {
  Span span = Span::kInside;
  // The span from 0x6150's overload bits (the chain's verdict).
  static Span of_status(std::uint8_t status);
  // Moves to `now`; true when it changed.
  bool move_to(Span now) {
    if (now == span) return false;
    span = now;
    return true;
  }
  // Gems-style: one excursion until the value is `hysteresis` back inside.
  bool track(double v, double start, double end, double hysteresis);
};

}  // namespace cansim::personalities
