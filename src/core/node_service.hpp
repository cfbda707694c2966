// Base of the services a Node owns (NMT, LSS, SDO, PDO, ...): the node they
// serve. Copying a service copies its state; an assigned service goes on
// serving its own node. So a service's whole state is saved and brought back
// with its implicit copy operations (NodeSnapshot), and a member added to a
// service is part of it without further code.
//
// What a service is to its node, stated once (ServiceContract below; Node
// checks every service against it, core/node.cpp): one file pair per CiA
// service with a non-blocking process(now) and its next deadline, as
// CANopenNode's process(dt, &next).
#pragma once

#include <concepts>
#include <cstddef>
#include <cstdint>
#include <span>
#include <vector>

#include "core/can_frame.hpp"
#include "core/od.hpp"

namespace cansim {

class Node;

// Where each service's deadlines live in its node: the node's deadline board
// (Node::due_), a few adjacent cache lines beside its clock, so that a
// wake-up finds what is due without touching the services that are not
// (at 1,000 nodes a node's lines are cold at each wake-up: docs/benchmarks.md).
enum class DeadlineSlot : std::uint8_t {
  kLss,
  kNmt,
  kSdoTransfer,  // SDO: the transfer's timeout,
  kSdoBlockAck,  // a stalled sub-block's acknowledgement,
  kSdoDelayed,   // the first answer held by the response time
  kHeartbeat,
  kGuarding,
  kSync,
  kPdo,
  kEmcy,
  kStore,
};
inline constexpr std::size_t kDeadlineSlots = std::size_t(DeadlineSlot::kStore) + 1;
// The board's slots a service owns (Node::due(s): the earliest of them).
struct DeadlineSlots {
  DeadlineSlot first;
  std::uint8_t count = 1;
};
// The node's board slot (core/node.cpp).
TimeUs* deadline_slot(Node& node, DeadlineSlot slot);

// A service's deadline: its value, written through to its node's board slot
// on every change. A copy (a NodeSnapshot's service) writes to no board; an
// assignment (a snapshot restored) keeps its own slot and updates it.
class Deadline {
 public:
  Deadline(Node& node, DeadlineSlot slot) : board_(deadline_slot(node, slot)) { *board_ = value_; }
  Deadline(const Deadline& o) : value_(o.value_) {}
  Deadline& operator=(const Deadline& o) { return *this = o.value_; }
  Deadline& operator=(TimeUs t) {
    value_ = t;
    if (board_) *board_ = t;
    return *this;
  }
  Deadline& operator+=(TimeUs d) { return *this = value_ + d; }
  operator TimeUs() const { return value_; }
  TimeUs value() const { return value_; }

 private:
  TimeUs value_ = kNever;
  TimeUs* board_ = nullptr;
};

class NodeService {
 protected:
  explicit NodeService(Node& node) : node_(node) {}
  NodeService(const NodeService&) = default;
  NodeService& operator=(const NodeService&) { return *this; }  // the node stays
  ~NodeService() = default;

  Node& node_;
};

// The contract of a node's service:
//   reset(now)           re-reads its configuration from the OD (after a reset / power-on);
//   on_frame(f, now)     true when the frame was addressed to this service (NMT gates it first);
//   process(now)         runs the work due at or before now; next_deadline() says when that is;
//   collect_rx_ids(out)  the COB-IDs it wants to receive (for the bus dispatcher; 29-bit ones
//                        carry cob::kRxIdExtended);
//   owns(index)          true for OD indices whose remote writes it handles itself, which
//   write(e, data, now)  then validates, stores and reacts to (the result is the SDO abort).
// Optional, found by the node when a service defines them: prepare_reset(kind, now) as the
// first step of every reset, on_nmt_state(old, now) after every state change,
// check_read(e) before a remote read of an owned entry.
template <class S>
concept ServiceContract = requires(S& s, const S& cs, const CanFrame& frame, TimeUs now,
                                   std::vector<std::uint32_t>& ids, const OdEntry& e,
                                   std::span<const std::uint8_t> data, std::uint16_t index) {
  { s.reset(now) } -> std::same_as<void>;
  { s.on_frame(frame, now) } -> std::same_as<bool>;
  { s.process(now) } -> std::same_as<void>;
  { cs.next_deadline() } -> std::same_as<TimeUs>;
  { cs.collect_rx_ids(ids) } -> std::same_as<void>;
  { cs.owns(index) } -> std::same_as<bool>;
  { s.write(e, data, now) } -> std::same_as<SdoAbort>;
};

}  // namespace cansim
