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
#include <cstdint>
#include <span>
#include <vector>

#include "core/can_frame.hpp"
#include "core/od.hpp"

namespace cansim {

class Node;

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
