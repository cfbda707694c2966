// COB-ID -> node dispatch for one bus, O(1) per frame: a 2048-entry table for
// 11-bit identifiers and a hash map for 29-bit ones. Each node registers the
// identifiers from Node::collect_rx_ids(); the loop re-registers a node when
// its rx_epoch() changes (reset communication, LSS node-ID change, PDO COB-ID
// write). Broadcast identifiers (NMT 0x000, SYNC, TIME, LSS 0x7E5) are in
// every node's set, so their lists hold every node of the bus.
//
// Identifier encoding in the rx sets is the services' (SocketCAN style): bit 31
// (CAN_EFF_FLAG, protocol.hpp cob::kRxIdExtended) marks a 29-bit identifier. A CiA 301
// COB-ID with bit 29 set, or an identifier above 0x7FF, is taken as 29-bit too.
#pragma once

#include <cstdint>
#include <span>
#include <unordered_map>
#include <vector>

#include "core/can_frame.hpp"

namespace cansim::io {

class RxDispatch {
 public:
  RxDispatch() : standard_(2048) {}

  // Replaces the identifiers `slot` listens to (duplicates are fine).
  // Allocates: called on (re)configuration, not per frame.
  void set(std::uint32_t slot, std::span<const std::uint32_t> rx_ids);
  void remove(std::uint32_t slot);
  // The slots listening to this frame's identifier, in registration order.
  std::span<const std::uint32_t> lookup(const CanFrame& frame) const;
  // Identifiers a slot is registered under (internal keys, for tests).
  std::span<const std::uint32_t> registered(std::uint32_t slot) const;

  // Internal key: 11-bit ids as is, 29-bit ids | kExtendedKey.
  static constexpr std::uint32_t kExtendedKey = 0x80000000u;
  static std::uint32_t key_of(std::uint32_t rx_id);

 private:
  std::vector<std::uint32_t>& list(std::uint32_t key);
  void unlink(std::uint32_t slot, std::uint32_t key);

  std::vector<std::vector<std::uint32_t>> standard_;
  std::unordered_map<std::uint32_t, std::vector<std::uint32_t>> extended_;
  std::vector<std::vector<std::uint32_t>> by_slot_;
};

}  // namespace cansim::io
