// LSS slave (CiA 305): switch state, configure node-ID / bit timing, store,
// inquire, identify, fastscan. Requests arrive on 0x7E5, replies go out on
// 0x7E4; every LSS frame has 8 data bytes.
//
// Node-IDs: the *active* node-ID is Node::node_id(); configure node-ID sets a
// *pending* one that becomes active at the next reset communication (CiA 305
// v3.0 Fig. 33 and the NMT/LSS state diagram). NMT calls prepare_reset()
// (through Node::prepare_reset) before the OD is reloaded, so the pending (or,
// at power-on, the stored) node-ID is in place before the $NODEID defaults are
// computed.
// Figure numbers below refer to CiA 305 v3.0.0.
#pragma once

#include <span>
#include <vector>

#include "core/application.hpp"
#include "core/can_frame.hpp"
#include "core/protocol.hpp"
#include "core/node_options.hpp"
#include "core/node_service.hpp"
#include "core/od.hpp"
#include "core/store.hpp"

namespace cansim {

class Node;

class LssSlave : private NodeService {
 public:
  static constexpr std::uint32_t kRequestId = cob::kLssFromMaster;
  static constexpr std::uint32_t kReplyId = cob::kLssToMaster;
  static constexpr std::uint8_t kUnconfigured = lss::kUnconfiguredNodeId;

  enum class State : std::uint8_t { kWaiting = 0, kConfiguration = 1 };

  explicit LssSlave(Node& node) : NodeService(node) {}
  // Its slots of the node's deadline board (core/node_service.hpp).
  static constexpr DeadlineSlots kDeadlines{DeadlineSlot::kLss};
  // Called at the start of every reset, before the OD is reloaded: reset node
  // / communication activate the pending node-ID (power-on: Node::power_on
  // applies what store configuration saved).
  void prepare_reset(ResetKind kind, TimeUs now);
  // The NodeService contract (core/node_service.hpp):
  void reset(TimeUs now);
  bool on_frame(const CanFrame& frame, TimeUs now);
  // process: the bit-rate switch delays.
  void process(TimeUs now);
  TimeUs next_deadline() const { return next_; }
  void collect_rx_ids(std::vector<std::uint32_t>& out) const;
  bool owns(std::uint16_t index) const;
  SdoAbort write(const OdEntry& e, std::span<const std::uint8_t> data, TimeUs now);

  State state() const { return state_; }
  bool configuring() const { return state_ == State::kConfiguration; }
  std::uint8_t pending_node_id() const { return pending_node_id_; }
  std::uint8_t pending_bit_rate_index() const { return pending_bit_rate_; }
  // True while an activate-bit-timing switch is in progress.
  bool switching_bit_rate() const { return switch_phase_ != SwitchPhase::kIdle; }

 private:
  enum class SwitchPhase : std::uint8_t { kIdle, kBeforeSwitch, kAfterSwitch };
  // LSS address = 0x1018:01..04: vendor-ID, product code, revision, serial.
  enum LssNumber : std::uint8_t { kVendor = 0, kProduct = 1, kRevision = 2, kSerial = 3 };

  bool accepts_requests() const;
  void reply(std::uint8_t cs, std::uint8_t b1 = 0, std::uint8_t b2 = 0);
  void reply_u32(std::uint8_t cs, std::uint32_t value);
  std::uint32_t lss_number(LssNumber which) const;
  bool unconfigured() const;
  bool save_config_objects();
  LssStored stored_config() const;

  // One handler per service; `d` is the 8-byte request.
  void switch_state_global(const std::uint8_t* d, TimeUs now);
  void switch_state_selective(const std::uint8_t* d);
  void configure_node_id(const std::uint8_t* d);
  void configure_bit_timing(const std::uint8_t* d);
  void activate_bit_timing(const std::uint8_t* d, TimeUs now);
  void store_configuration();
  void inquire(std::uint8_t cs);
  void identify_remote_slave(const std::uint8_t* d);
  void identify_non_configured();
  void fastscan(const std::uint8_t* d);
  void enter_waiting(TimeUs now);

  Deadline next_{node_, kDeadlines.first};
  State state_ = State::kWaiting;
  std::uint8_t pending_node_id_ = kUnconfigured;
  std::uint8_t pending_bit_rate_ = 0;
  bool configured_since_store_ = false;  // lss_nothing_to_store_error
  std::uint8_t selective_next_ = 0;      // next expected 0x40..0x43, 0 = none
  std::uint8_t identify_next_ = 0;       // next expected 0x46..0x4B, 0 = none
  std::uint32_t identify_revision_low_ = 0;
  std::uint8_t fastscan_pos_ = kVendor;  // LSSPos of the fastscan (Fig. 46)
  SwitchPhase switch_phase_ = SwitchPhase::kIdle;
  std::uint8_t switch_target_rate_ = 0;
  TimeUs switch_delay_ = 0;
  const OdEntry* identity_[4] = {};  // 0x1018:01..04
};

}  // namespace cansim
