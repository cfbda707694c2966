// EMCY producer 0x1014 / 0x1015, error register 0x1001 and pre-defined error
// field 0x1003 (CiA 301 §7.2.7, §7.5.2.2-4, §7.5.2.17-18).
//
// Errors are raised and cleared by code. raise() records the error as active,
// updates 0x1001, pushes it into 0x1003 (newest at sub 1) and sends
// [code lo, code hi, 0x1001, mfr0..mfr4] on 0x1014. When the last active error
// clears, an error-reset EMCY (code 0x0000, register after clearing) follows;
// option emcy_on_partial_clear says what a partial clear sends. report() is a
// one-shot event (e.g. SYNC length) that is sent and recorded but not kept
// active. EMCYs are not sent in STOPPED (recorded only, CiA 301 Table 82);
// EMCYs raised while INITIALISING wait for the boot-up. Inhibit 0x1015
// (×100 µs): EMCYs raised inside it wait in a small ring and go out when it
// expires.
#pragma once

#include <span>
#include <vector>

#include "core/can_frame.hpp"
#include "core/node_service.hpp"
#include "core/od.hpp"

namespace cansim {

class Node;
enum class NmtState : std::uint8_t;

class Emcy : private NodeService {
 public:
  static constexpr std::size_t kMaxActive = 16;
  static constexpr std::size_t kQueueSize = 8;

  explicit Emcy(Node& node) : NodeService(node) {}
  // Its slots of the node's deadline board (core/node_service.hpp).
  static constexpr DeadlineSlots kDeadlines{DeadlineSlot::kEmcy};

  // An error became active. reg_bits are ORed into 0x1001 while it is active
  // (on top of the bits derived from the code class); mfr = 5 manufacturer
  // bytes of the frame (zeros when null).
  void raise(std::uint16_t code, std::uint8_t reg_bits, const std::uint8_t mfr[5], TimeUs now);
  void raise(std::uint16_t code, std::uint8_t reg_bits, TimeUs now) { raise(code, reg_bits, nullptr, now); }
  // A one-shot error event: sent and recorded in 0x1003, not kept active.
  void report(std::uint16_t code, std::uint8_t reg_bits, const std::uint8_t mfr[5], TimeUs now);
  // Marks an error active again without sending or recording it (an error a
  // vendor keeps latched across a soft reset, e.g. until power-off).
  void restore_active(std::uint16_t code, std::uint8_t reg_bits);
  void clear(std::uint16_t code, TimeUs now);
  void clear_all(TimeUs now);
  // An error that follows a condition: raised when `active` and the error is
  // not active, cleared when not `active` and it is. The active errors are
  // the state (forgotten at a reset, as the node forgets its errors), so a
  // caller keeps no record of what it reported.
  void follow(std::uint16_t code, bool active, std::uint8_t reg_bits, const std::uint8_t mfr[5], TimeUs now) {
    if (active == this->active(code)) return;
    if (active) raise(code, reg_bits, mfr, now);
    else clear(code, now);
  }
  void follow(std::uint16_t code, bool active, std::uint8_t reg_bits, TimeUs now) {
    follow(code, active, reg_bits, nullptr, now);
  }
  std::size_t active_count() const { return active_n_; }
  bool active(std::uint16_t code) const;
  std::uint8_t error_register() const { return register_; }
  // The frame is this node's EMCY (its COB-ID now).
  bool sends(const CanFrame& f) const { return valid_ && f.id == can_id_ && f.extended() == extended_; }
  // An EMCY frame that left (handed to the sink; time kNever: none yet).
  struct Sent {
    TimeUs time = kNever;
    std::uint16_t code = 0;
    std::uint8_t reg = 0;
    std::uint8_t vendor[5] = {};
  };
  // EMCY frames sent and the last one, kept over resets and power cycles
  // (the node's lifetime; no observer needed).
  std::uint32_t sent_count() const { return sent_count_; }
  const Sent& last_emcy() const { return last_emcy_; }
  // Bits 0x1001 gets from an error code (CiA 301 Table 48 classes).
  static std::uint8_t class_bits(std::uint16_t code);

  // NMT hook (called by Node on every state change).
  void on_nmt_state(NmtState old, TimeUs now);
  // 0x1003 subs above the error count have no data (option).
  SdoAbort check_read(const OdEntry& e) const;

  // The NodeService contract (core/node_service.hpp):
  void reset(TimeUs now);
  bool on_frame(const CanFrame& frame, TimeUs now);
  void process(TimeUs now);
  TimeUs next_deadline() const { return next_; }
  void collect_rx_ids(std::vector<std::uint32_t>& out) const;
  bool owns(std::uint16_t index) const;
  SdoAbort write(const OdEntry& e, std::span<const std::uint8_t> data, TimeUs now);

 private:
  struct Active {
    std::uint16_t code;
    std::uint8_t reg;
  };
  struct Pending {
    std::uint8_t data[8];
  };

  void read_config();
  void update_register();
  void record(std::uint16_t code, std::uint8_t reg, const std::uint8_t* mfr);
  void clear_history();
  std::uint8_t history_count() const;
  void emit(std::uint16_t code, std::uint8_t reg, const std::uint8_t* mfr, TimeUs now);
  bool may_send_now(TimeUs now) const;
  void send_front(TimeUs now);
  void note_sent(const std::uint8_t data[8], TimeUs now);
  void update_deadline(TimeUs now);
  SdoAbort write_cob_id(const OdEntry& e, std::uint32_t v);

  Deadline next_{node_, kDeadlines.first};
  TimeUs last_sent_ = kNever;
  TimeUs inhibit_us_ = 0;
  std::uint32_t can_id_ = 0;
  bool extended_ = false;
  bool valid_ = true;
  std::uint8_t register_ = 0;
  std::uint8_t history_depth_ = 0;
  std::uint8_t active_n_ = 0;
  Active active_[kMaxActive] = {};
  Pending queue_[kQueueSize] = {};
  std::uint8_t queue_head_ = 0;
  std::uint8_t queue_n_ = 0;
  std::uint32_t sent_count_ = 0;
  Sent last_emcy_;
};

}  // namespace cansim
