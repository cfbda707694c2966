// Frame faults of one node (docs/faults.md "Frame faults"): what
// happens to the frames it sends, and to the frames from outside it hears,
// between the node and the wire. A fault of the schedule
// (personalities/comm_faults) becomes a rule here while it is in force:
//
//   drop       the frame never reaches the wire
//   delay      it reaches it `delay` (+ up to `jitter`) later: frames may
//              overtake each other, as through a gateway
//   freeze     its data stop changing: the first frame the rule selected
//              goes on being sent, with its length
//   corrupt    chosen bytes get a value (or random bits flipped), or one
//              random byte when none is chosen
//   dlc        it has another length (longer: zero bytes added)
//   duplicate  it is sent twice, back to back
//
// A rule selects the frames of one of the node's services (TPDO n,
// heartbeat, EMCY, SDO answers, boot-up, LSS answers: Node::tx_source, so a
// reconfigured COB-ID is followed) or of one COB-ID; a COB-ID rule also acts
// on the frames from outside the node hears with that identifier (a lossy
// harness: the master's SDO requests, NMT, SYNC). Each frame is affected with
// the rule's probability, drawn from the rule's own generator seeded from the
// fleet seed and the fault's handle: a run with the same seed and the same
// faults affects the same frames in the same way.
//
// Rules apply in the order they were set (the schedule's handle order). Held
// frames (delay) wait in a fixed ring, allocated with the first delay rule;
// beyond it a frame is dropped (counted). No allocation per frame. A value:
// copies with the node's snapshot.
#pragma once

#include <array>
#include <cstdint>
#include <vector>

#include "core/can_frame.hpp"
#include "core/fault_random.hpp"

namespace cansim {

class Node;
enum class TxService : std::uint8_t;

enum class FrameFaultKind : std::uint8_t { kDrop, kDelay, kFreeze, kCorrupt, kDlc, kDuplicate };

// Which frames a rule (or another fault of the node) acts on.
struct FrameSelector {
  TxService service{};     // kOther: by cob_id
  std::uint16_t tpdo = 0;  // TxService::kTpdo: its number, 1..512
  std::uint32_t cob_id = 0;
  bool extended = false;  // a 29-bit cob_id
  bool by_cob_id() const;
  bool matches(const Node& node, const CanFrame& f) const;
  bool matches_id(const CanFrame& f) const { return f.id == cob_id && f.extended() == extended; }
};

struct FrameFaultRule {
  std::uint32_t id = 0;  // the schedule's fault handle
  FrameFaultKind kind = FrameFaultKind::kDrop;
  FrameSelector select;
  double probability = 1.0;
  TimeUs delay = 0, jitter = 0;  // kDelay
  std::uint8_t bytes = 0;        // kCorrupt: bit i = byte i; 0: one random byte
  int value = -1;                // kCorrupt: the bytes' value; -1: flip random bits
  std::uint8_t dlc = 0;          // kDlc
  std::uint64_t seed = 1;
};

class FrameFaults {
 public:
  static constexpr std::size_t kMaxRules = 8;
  static constexpr std::size_t kHeld = 256;

  // Replaces the rule with the same id, or adds it (false when full).
  bool set(const FrameFaultRule& rule);
  void clear(std::uint32_t id);
  bool has(std::uint32_t id) const;
  // The node's power-on number `power_on`: every rule's generator starts
  // again from its seed and that number (so does every rule set later).
  void restart(std::uint32_t power_on);
  bool any() const { return n_ > 0 || held_n_ > 0; }
  bool any_rule() const { return n_ > 0; }

  // The node sends `f` at `now`: hands what leaves now to `out(frame)`;
  // held frames leave later through process().
  template <typename Out>
  void send(const Node& node, const CanFrame& f, TimeUs now, Out&& out) {
    Pass pass{f};
    if (apply(node, pass, now, false)) emit(pass, now, false, out);
  }
  // The same, held `delay` more (the node's response time).
  void send_after(const Node& node, const CanFrame& f, TimeUs now, TimeUs delay) {
    Pass pass{f};
    pass.delay = delay;
    if (apply(node, pass, now, false)) emit(pass, now, false, [](const CanFrame&) {});
  }
  // A frame from outside that the node hears at `now`: `out(frame)` for
  // what it hears now.
  template <typename Out>
  void receive(const CanFrame& f, TimeUs now, Out&& out) {
    Pass pass{f};
    if (apply_rx(pass, now)) emit(pass, now, true, out);
  }
  // Held frames due by `now`: out(frame, from_outside).
  template <typename Out>
  void process(TimeUs now, Out&& out) {
    while (held_n_ > 0 && held_[held_head_].at <= now) {
      const Held h = held_[held_head_];
      held_head_ = (held_head_ + 1) % held_.size();
      --held_n_;
      out(h.frame, h.from_outside);
    }
  }
  TimeUs next_deadline() const { return held_n_ ? held_[held_head_].at : kNever; }
  // Allocates the ring of held frames (before a delay is on the frame path).
  void reserve_held() {
    if (held_.empty()) held_.resize(kHeld);
  }
  // Every held frame goes (power off).
  void drop_held() { held_n_ = 0; }
  // Drops the held frames of the node's own that `drop(frame)` selects (the
  // controller's buffer withdrawn at a reset).
  template <typename Pred>
  void withdraw(Pred&& drop);

  std::uint64_t affected() const { return affected_; }      // frames any rule changed, held or dropped
  std::uint64_t overflowed() const { return overflowed_; }  // held frames lost to a full ring

 private:
  struct Slot {
    FrameFaultRule rule;
    FaultRandom random{1};
    bool frozen = false;
    CanFrame frozen_frame;
  };
  // A frame on its way: what the rules made of it.
  struct Pass {
    CanFrame frame;
    int copies = 1;
    TimeUs delay = 0;
  };
  struct Held {
    TimeUs at = 0;
    CanFrame frame;
    bool from_outside = false;
  };

  bool apply(const Node& node, Pass& p, TimeUs now, bool rx);
  bool apply_rx(Pass& p, TimeUs now);
  bool apply_rule(Slot& s, Pass& p);
  template <typename Out>
  void emit(const Pass& p, TimeUs now, bool from_outside, Out&& out) {
    for (int i = 0; i < p.copies; ++i) {
      if (p.delay > 0) hold(p.frame, now + p.delay, from_outside);
      else out(p.frame);
    }
  }
  void hold(const CanFrame& f, TimeUs at, bool from_outside);

  // The counts first: a node reads them at every wake-up, the slots rarely.
  std::size_t n_ = 0;
  std::size_t held_head_ = 0, held_n_ = 0;
  std::uint32_t power_on_ = 0;
  std::vector<Held> held_;  // ring sorted by time, sized by the first delay rule
  std::uint64_t affected_ = 0, overflowed_ = 0;
  std::array<Slot, kMaxRules> slots_{};
};

template <typename Pred>
void FrameFaults::withdraw(Pred&& drop) {
  std::size_t kept = 0;
  for (std::size_t i = 0; i < held_n_; ++i) {
    const Held h = held_[(held_head_ + i) % held_.size()];
    if (!h.from_outside && drop(h.frame)) continue;
    held_[(held_head_ + kept++) % held_.size()] = h;
  }
  held_n_ = kept;
}

}  // namespace cansim
