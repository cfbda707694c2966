// NMT slave state machine, boot-up and reset sequences (CiA 301 §7.3.2).
//
// Sequence of a reset (power-on, NMT reset node 0x81, reset communication
// 0x82): state INITIALISING, services that define prepare_reset() run it (LSS
// applies a pending node-ID), OD reload (defaults, then stored values), every
// service re-reads its configuration, Application::on_reset (may edit
// boot_plan()), then after boot_up_delay_ms the boot-up frame 0x700+id [00]
// and PRE-OPERATIONAL (or OPERATIONAL per boot plan). boot_up_jitter_ms adds
// 0..jitter (µs resolution) to that delay, drawn at each reset from the
// node's seed. Until the boot-up the node is deaf: in INITIALISING it hears
// no NMT command, SDO request, RPDO, SYNC or guarding RTR and sends nothing
// (CiA 301 Table 82); only LSS (CiA 305) answers, as an unconfigured node
// must. A node whose node-ID is 0xFF (LSS-unconfigured, CiA 305) stays
// INITIALISING without boot-up until the LSS slave configured an ID and
// calls command(0x82, now).
#pragma once

#include <span>
#include <vector>

#include "core/can_frame.hpp"
#include "core/node_options.hpp"
#include "core/node_service.hpp"
#include "core/od.hpp"
#include "core/protocol.hpp"
#include "core/response_time.hpp"

namespace cansim {

class Node;
enum class ResetKind : std::uint8_t;

// What happens after a reset: derived from the options and 0x1F80 by reset(),
// editable by Application::on_reset (vendor start-up quirks).
struct BootPlan {
  bool send_boot_up = true;
  bool self_start = false;      // enter OPERATIONAL by itself
  TimeUs self_start_delay = 0;  // after the boot-up
  TimeUs start_all_delay = -1;  // send NMT start-all this long after boot-up (< 0: never)
  TimeUs boot_up_delay = 0;     // from the reset to the boot-up
};

class NmtSlave : private NodeService {
 public:
  explicit NmtSlave(Node& node) : NodeService(node) {}
  // Its slots of the node's deadline board (core/node_service.hpp).
  static constexpr DeadlineSlots kDeadlines{DeadlineSlot::kNmt};
  // Power-on: initialisation, boot-up, then pre-operational (or operational).
  void power_on(TimeUs now);
  // Power lost: INITIALISING again, silently (nobody hears a dead node).
  void power_off() {
    state_ = NmtState::kInitialising;
    booted_ = false;
  }
  NmtState state() const { return state_; }
  // Executes an NMT command specifier (0x01, 0x02, 0x80, 0x81, 0x82) locally,
  // whatever the current state (the LSS slave uses 0x82 to boot a node that
  // just got its node-ID). Unknown specifiers are ignored.
  void command(std::uint8_t cs, TimeUs now);
  // Communication error reaction per 0x1029:01 (heartbeat consumer timeout,
  // life-guarding event; CiA 301 §7.5.2.32).
  void communication_error(TimeUs now);
  // The reaction 0x1029:<error_class> prescribes for a device error (sub 1:
  // communication, as above; 2 and up: device profile or manufacturer
  // errors, CiA 301 §7.5.2.32). No 0x1029 sub: no reaction.
  void error_reaction(std::uint8_t error_class, TimeUs now);
  // A vendor reboot (e.g. a node-ID object, "simulates a complete reboot"):
  // like reset communication, but no value is reloaded from defaults or storage.
  void reboot_keeping_values(TimeUs now);
  // Counts resets: the SDO server does not confirm a write that reset the node.
  std::uint32_t reset_count() const { return resets_; }
  BootPlan& boot_plan() { return plan_; }
  // True once the boot-up of the current reset cycle happened.
  bool booted() const { return booted_; }
  // Sends the boot-up frame 0x700+id [00] (CiA 301 §7.2.8.3.2, boot-up
  // protocol); the observer hears of it when it left (the node is on the bus).
  void send_boot_up(TimeUs now);

  // The NodeService contract (core/node_service.hpp):
  void reset(TimeUs now);
  bool on_frame(const CanFrame& frame, TimeUs now);
  void process(TimeUs now);
  TimeUs next_deadline() const { return next_; }
  void collect_rx_ids(std::vector<std::uint32_t>& out) const;
  bool owns(std::uint16_t index) const;
  SdoAbort write(const OdEntry& e, std::span<const std::uint8_t> data, TimeUs now);

 private:
  // A 0x1029 value: 0 pre-operational (from operational), 1 no change, 2 stopped.
  void react(std::int64_t reaction, TimeUs now);
  void restart(ResetKind kind, TimeUs now, bool reload = true);
  void boot_up(TimeUs now);
  void send_start_all(TimeUs now);
  void set_state(NmtState s, TimeUs now);
  void update_deadline();

  Deadline next_{node_, kDeadlines.first};
  TimeUs boot_at_ = kNever;
  TimeUs start_at_ = kNever;
  TimeUs start_all_at_ = kNever;
  NmtState state_ = NmtState::kInitialising;
  bool booted_ = false;
  std::uint32_t resets_ = 0;
  BootPlan plan_;
  ResponseTime boot_time_{ResponseTime::Stream::kBootUp};
};

}  // namespace cansim
