// Store / restore parameters, 0x1010 / 0x1011 (CiA 301 §7.5.2.13-14).
//
// Sub 1 = all groups, 2 = communication, 3 = application, 4..127 =
// manufacturer groups (OdEntry::persist). Writing "save" (0x65766173) to
// 0x1010:n stores the current values of group n; writing "load" (0x64616F6C)
// to 0x1011:n drops the stored values of group n so the defaults apply at the
// next reset node / power cycle (reset communication for group 2). Reads
// return the OD default (capability bits) whatever was written.
//
// Blob (NodeStorage): "CSNV", version 1, LSS node-ID / bit rate, record count,
// records {index u16, sub u8, group u8, length u16, bytes}, CRC-32 of all
// preceding bytes. Loading skips records whose entry no longer exists, is no
// longer persistent or has another size; a bad magic / version / CRC drops the
// whole blob (corrupt() tells the personality, e.g. for a vendor EMCY).
// An entry with a $NODEID default that holds that default is not stored, so
// the pre-defined connection set follows a later node-ID change.
#pragma once

#include <span>
#include <vector>

#include "core/can_frame.hpp"
#include "core/node_service.hpp"
#include "core/od.hpp"

namespace cansim {

class Node;

// What LSS "store configuration" saved (CiA 305); applied at power-on.
struct LssStored {
  bool valid = false;
  std::uint8_t node_id = 0xFF;
  std::uint8_t bit_rate_index = 0;
};

class StoreRestore : private NodeService {
 public:
  static constexpr std::uint32_t kSave = 0x65766173;  // "save"
  static constexpr std::uint32_t kLoad = 0x64616F6C;  // "load"

  explicit StoreRestore(Node& node) : NodeService(node) {}
  // Its slots of the node's deadline board (core/node_service.hpp).
  static constexpr DeadlineSlots kDeadlines{DeadlineSlot::kStore};
  // Reads the blob from NodeStorage into the cache (power-on).
  void load();
  // Applies stored values of entries with index in [first, last] to the OD.
  void apply_stored(std::uint16_t first, std::uint16_t last);
  // Stores / forgets the values of a 0x1010 / 0x1011 sub-index group (1 = all).
  SdoAbort save_group(std::uint8_t sub);
  SdoAbort restore_group(std::uint8_t sub);
  // LSS store configuration, kept in the same blob as the parameters.
  bool save_lss(const LssStored& lss);
  LssStored stored_lss() const { return lss_; }
  // Saves the current values of these entries only (LSS store of vendor
  // node-ID / bit-rate objects); other records stay as they are.
  bool save_entries(std::span<const OdEntry* const> entries);
  // The stored value of a numeric entry; false when nothing is stored for it.
  bool stored_u(const OdEntry& e, std::uint64_t& out) const;
  bool corrupt() const { return corrupt_; }

  // The NodeService contract (core/node_service.hpp):
  void reset(TimeUs now);
  bool on_frame(const CanFrame& frame, TimeUs now);
  void process(TimeUs now);
  TimeUs next_deadline() const { return next_; }
  void collect_rx_ids(std::vector<std::uint32_t>& out) const;
  bool owns(std::uint16_t index) const;
  SdoAbort write(const OdEntry& e, std::span<const std::uint8_t> data, TimeUs now);

 private:
  struct Record {
    std::uint16_t index;
    std::uint8_t sub;
    std::uint8_t group;
    std::span<const std::uint8_t> bytes;
  };
  // Calls fn(record) for every record of the cached blob.
  template <typename Fn>
  void for_each_record(Fn&& fn) const;
  // Rebuilds the blob from the kept cached records plus the current values of
  // entries in `groups`, and saves it.
  // `entries` are replaced by their current values whatever their group.
  bool rewrite(std::uint8_t drop_sub, bool add_current, std::span<const OdEntry* const> entries = {});
  void defaults_to_ram(std::uint8_t sub);
  bool holds_node_id_default(const OdEntry& e) const;

  Deadline next_{node_, kDeadlines.first};
  std::vector<std::uint8_t> blob_;  // validated copy of what storage holds
  LssStored lss_;
  bool corrupt_ = false;
};

}  // namespace cansim
