#include "core/lss_slave.hpp"

#include "core/node.hpp"

namespace cansim {

namespace {

using namespace lss;

bool is_node_id(std::uint8_t id) { return id >= 1 && id <= 127; }

}  // namespace

// ---- lifecycle

void LssSlave::prepare_reset(ResetKind kind, TimeUs) {
  if (kind != ResetKind::kPowerOn) {
    // The pending node-ID becomes the active one (CiA 305: at NMT reset
    // communication, which reset node includes).
    if (pending_node_id_ != node_.node_id()) node_.set_node_id(pending_node_id_);
    if (kind == ResetKind::kNode && node_.options().lss_reset_node_activates_bit_rate &&
        node_.store().stored_lss().valid)
      node_.set_bit_rate_index(node_.store().stored_lss().bit_rate_index);
    return;
  }
  // Power-on: Node::power_on already took the stored node-ID / bit rate; an
  // interrupted bit-rate switch is gone with the power.
  switch_phase_ = SwitchPhase::kIdle;
  next_ = kNever;
}

void LssSlave::reset(TimeUs) {
  for (std::uint8_t i = 0; i < 4; ++i) identity_[i] = node_.od().find(0x1018, std::uint8_t(i + 1));
  state_ = State::kWaiting;
  pending_node_id_ = node_.node_id();
  pending_bit_rate_ = node_.bit_rate_index();
  configured_since_store_ = false;
  selective_next_ = 0;
  identify_next_ = 0;
  fastscan_pos_ = kVendor;
  // A bit-rate switch in progress is a physical-layer matter: it survives an
  // NMT reset; next_ keeps its deadline.
  if (switch_phase_ == SwitchPhase::kIdle) next_ = kNever;
}

void LssSlave::collect_rx_ids(std::vector<std::uint32_t>& out) const {
  if (node_.options().lss_supported) out.push_back(kRequestId);
}

bool LssSlave::owns(std::uint16_t) const { return false; }

SdoAbort LssSlave::write(const OdEntry& e, std::span<const std::uint8_t> data, TimeUs) {
  node_.values().set_bytes(e, data);
  return SdoAbort::kNone;
}

// ---- frame dispatch

bool LssSlave::accepts_requests() const {
  if (!node_.options().lss_only_in_stopped || configuring()) return true;
  // Vendor restriction (DSP 305 v1.0-era devices): LSS only in STOPPED. An
  // unconfigured node (LSS-only initialisation) must still be reachable.
  const NmtState s = node_.state();
  return s == NmtState::kStopped || s == NmtState::kInitialising || unconfigured();
}

bool LssSlave::on_frame(const CanFrame& frame, TimeUs now) {
  const NodeOptions& o = node_.options();
  if (!o.lss_supported || frame.extended()) return false;
  if (frame.id == cob::kNmt && o.lss_configuration_blocks_nmt && configuring()) return true;
  if (frame.id != kRequestId) return false;
  if (frame.rtr() || frame.dlc != 8 || !accepts_requests()) return true;  // LSS frames: DLC 8

  const std::uint8_t* d = frame.data;
  const std::uint8_t cs = d[0];
  const bool config = configuring();
  if (cs == kSwitchGlobal) {
    switch_state_global(d, now);
  } else if (cs >= kSelectiveVendor && cs <= kSelectiveSerial) {
    if (!config) switch_state_selective(d);  // Fig. 32: waiting state only
  } else if (cs >= kIdentifyVendor && cs <= kIdentifySerialHigh) {
    if (o.lss_identify_services) identify_remote_slave(d);
  } else if (cs == kIdentifyNonConfigured) {
    if (o.lss_identify_services) identify_non_configured();
  } else if (cs == kFastscan) {
    if (o.lss_fastscan && !config) fastscan(d);
  } else if (config) {
    // Configuration-state-only services (Figs. 33-41): ignored while waiting.
    switch (cs) {
      case kConfigureNodeId: configure_node_id(d); break;
      case kConfigureBitTiming: configure_bit_timing(d); break;
      case kActivateBitTiming: activate_bit_timing(d, now); break;
      case kStoreConfiguration: store_configuration(); break;
      default:
        if (cs >= kInquireVendor && cs <= kInquireNodeId && o.lss_inquire_services) inquire(cs);
        break;
    }
  }
  return true;
}

// ---- services

// Fig. 31. No reply. Leaving configuration may activate a node-ID.
void LssSlave::switch_state_global(const std::uint8_t* d, TimeUs now) {
  selective_next_ = 0;
  if (d[1] == kModeConfiguration && !configuring()) {
    state_ = State::kConfiguration;
    configured_since_store_ = false;
  } else if (d[1] == kModeWaiting && configuring()) {
    enter_waiting(now);
  }
}

void LssSlave::enter_waiting(TimeUs now) {
  state_ = State::kWaiting;
  const std::uint8_t active = node_.node_id();
  bool reset_communication = false;
  if (node_.options().lss_waiting_applies_stored_node_id) {
    // Vendor behaviour: unstored values are dropped; a stored node-ID other
    // than the active one takes effect at once.
    const LssStored s = stored_config();
    pending_node_id_ = s.valid ? s.node_id : active;
    pending_bit_rate_ = s.valid ? s.bit_rate_index : node_.bit_rate_index();
    reset_communication = pending_node_id_ != active;
  } else {
    // CiA 305: an unconfigured node that got a node-ID leaves the LSS-only
    // initialisation through NMT reset communication and boots with it.
    reset_communication = active == kUnconfigured && pending_node_id_ != kUnconfigured;
  }
  if (!reset_communication) return;
  node_.set_node_id(pending_node_id_);
  node_.nmt().command(kNmtResetCommunication, now);
}

// Fig. 32: 0x40..0x43 in this order, all equal to 0x1018:01..04 -> 0x44.
void LssSlave::switch_state_selective(const std::uint8_t* d) {
  const std::uint8_t cs = d[0];
  const std::uint32_t value = get_u32(d + 1);
  const auto which = LssNumber(cs - kSelectiveVendor);
  const bool in_sequence = cs == kSelectiveVendor || cs == selective_next_;
  const bool wildcard = which == kRevision && value == 0 && node_.options().lss_revision_zero_wildcard;
  if (!in_sequence || (value != lss_number(which) && !wildcard)) {
    selective_next_ = 0;  // a mismatch restarts matching
    return;
  }
  if (cs != kSelectiveSerial) {
    selective_next_ = std::uint8_t(cs + 1);
    return;
  }
  selective_next_ = 0;
  state_ = State::kConfiguration;
  configured_since_store_ = false;
  reply(kSelectiveReply);
}

// Fig. 33: 1..127 or 0xFF (back to unconfigured); pending until reset communication.
void LssSlave::configure_node_id(const std::uint8_t* d) {
  const std::uint8_t id = d[1];
  const bool valid = is_node_id(id) || (id == kUnconfigured && node_.options().lss_node_id_ff_allowed);
  if (!valid) {
    reply(kConfigureNodeId, kOutOfRange);
    return;
  }
  pending_node_id_ = id;
  configured_since_store_ = true;
  reply(kConfigureNodeId, kOk);
}

// Fig. 34: [0x13, table selector, table index]; selector 0 = CiA bit timing table.
void LssSlave::configure_bit_timing(const std::uint8_t* d) {
  const NodeOptions& o = node_.options();
  std::uint8_t selector = d[1];
  std::uint8_t index = d[2];
  if (o.lss_bit_timing_manual_layout && selector != 0 && index == 0) {
    index = selector;  // "13 ii 00": the index printed in byte 1
    selector = 0;
  }
  const bool cia_table = selector == 0 || (selector == 1 && o.lss_table_selector_1_is_cia);
  if (!cia_table || !node_.options().lss_bit_rates.has(index)) {
    reply(kConfigureBitTiming, kOutOfRange);  // "bit timing not supported"
    return;
  }
  pending_bit_rate_ = index;
  configured_since_store_ = true;
  reply(kConfigureBitTiming, kOk);
}

// Fig. 35: no reply. Silent for the switch delay, switch, silent for the
// switch delay again; then the node speaks at the new rate.
void LssSlave::activate_bit_timing(const std::uint8_t* d, TimeUs now) {
  std::uint8_t target = pending_bit_rate_;
  if (node_.options().lss_activate_stored_bit_rate) {
    const LssStored s = stored_config();
    target = s.valid ? s.bit_rate_index : node_.bit_rate_index();
  }
  switch_target_rate_ = target;
  switch_delay_ = ms(get_u16(d + 1));
  switch_phase_ = SwitchPhase::kBeforeSwitch;
  node_.set_silent(true);
  next_ = now + switch_delay_;
}

void LssSlave::process(TimeUs now) {
  while (switch_phase_ != SwitchPhase::kIdle && next_ <= now) {
    if (switch_phase_ == SwitchPhase::kBeforeSwitch) {
      node_.set_bit_rate_index(switch_target_rate_);
      switch_phase_ = SwitchPhase::kAfterSwitch;
      next_ += switch_delay_;
    } else {
      switch_phase_ = SwitchPhase::kIdle;
      next_ = kNever;
      node_.set_silent(false);
      if (node_.options().lss_boot_up_after_bit_rate_switch) node_.nmt().send_boot_up(now);
    }
  }
}

// Fig. 36: saves the pending node-ID and bit rate.
void LssSlave::store_configuration() {
  const NodeOptions& o = node_.options();
  const auto cs = std::uint8_t(o.lss_store_reply_cs);
  if (!o.lss_store_supported) {
    reply(cs, kOutOfRange);  // 1 = store configuration not supported
    return;
  }
  if (o.lss_nothing_to_store_error && !configured_since_store_) {
    reply(cs, kManufacturer, 1);
    return;
  }
  const bool saved = node_.store().save_lss({true, pending_node_id_, pending_bit_rate_}) && save_config_objects();
  if (saved) configured_since_store_ = false;
  reply(cs, saved ? kOk : kStoreFailed);
}

// Figs. 37-41: LSS address parts and the active node-ID.
void LssSlave::inquire(std::uint8_t cs) {
  if (cs <= kInquireSerial) {
    reply_u32(cs, lss_number(LssNumber(cs - kInquireVendor)));
    return;
  }
  std::uint8_t id = node_.node_id();
  if (node_.options().lss_inquire_node_id_stored) {
    const LssStored s = stored_config();
    if (s.valid) id = s.node_id;
  }
  reply(kInquireNodeId, id);
}

// Fig. 42: vendor, product, revision low/high, serial low/high in this order;
// every slave inside all ranges answers 0x4F. Valid in both LSS states.
void LssSlave::identify_remote_slave(const std::uint8_t* d) {
  const std::uint8_t cs = d[0];
  const std::uint32_t v = get_u32(d + 1);
  if (cs != kIdentifyVendor && cs != identify_next_) {
    identify_next_ = 0;
    return;
  }
  bool inside = false;
  switch (cs - kIdentifyVendor) {
    case 0: inside = v == lss_number(kVendor); break;
    case 1: inside = v == lss_number(kProduct); break;
    case 2:
      identify_revision_low_ = v;
      inside = v <= lss_number(kRevision);
      break;
    case 3:
      inside = v >= lss_number(kRevision) ||
               (node_.options().lss_identify_revision_zero_wildcard && identify_revision_low_ == 0 && v == 0);
      break;
    case 4: inside = v <= lss_number(kSerial); break;
    default: inside = v >= lss_number(kSerial); break;
  }
  if (!inside) {
    identify_next_ = 0;
    return;
  }
  identify_next_ = cs == kIdentifySerialHigh ? 0 : std::uint8_t(cs + 1);
  if (cs == kIdentifySerialHigh) reply(kIdentifySlaveReply);
}

// Fig. 44: only a slave with neither an active nor a pending node-ID answers.
void LssSlave::identify_non_configured() {
  if (unconfigured()) reply(kNonConfiguredReply);
}

// Fig. 46: [0x51, IDNumber (4), BitChecked, LSSSub, LSSNext]. Only unconfigured
// slaves in waiting state take part. A slave answers when the bits 31..BitChecked
// of LSS number LSSSub equal IDNumber's and LSSSub is its current position; a
// slave that did not match when the master moved on to the next number keeps
// its old position and stays silent until the next reset (BitChecked 0x80).
void LssSlave::fastscan(const std::uint8_t* d) {
  if (!unconfigured()) return;
  const std::uint32_t id_number = get_u32(d + 1);
  const std::uint8_t bit_checked = d[5];
  const std::uint8_t sub = d[6];
  const std::uint8_t next = d[7];
  if (bit_checked == kFastscanConfirm) {
    fastscan_pos_ = kVendor;
    reply(kIdentifySlaveReply);
    return;
  }
  if (bit_checked > 31 || sub > kSerial || next > kSerial || sub != fastscan_pos_) return;
  const std::uint32_t mask = 0xFFFFFFFFu << bit_checked;
  if ((id_number ^ lss_number(LssNumber(sub))) & mask) return;
  fastscan_pos_ = next;
  // Complete when the serial number was checked down to bit 0 and the master
  // wraps around to the vendor-ID.
  if (bit_checked == 0 && sub == kSerial && next == kVendor) {
    state_ = State::kConfiguration;
    configured_since_store_ = false;
  }
  reply(kIdentifySlaveReply);
}

// ---- helpers

// Vendor node-ID / bit-rate objects (options node_id_object / bit_rate_object)
// show the stored values: store configuration writes and saves them.
bool LssSlave::save_config_objects() {
  const OdEntry* entries[2] = {node_.config_object(node_.options().node_id_object),
                               node_.config_object(node_.options().bit_rate_object)};
  const std::uint8_t values[2] = {pending_node_id_, pending_bit_rate_};
  std::size_t n = 0;
  for (int i = 0; i < 2; ++i) {
    if (!entries[i]) continue;
    node_.values().set_u(*entries[i], values[i]);
    entries[n++] = entries[i];
  }
  return n == 0 || node_.store().save_entries(std::span<const OdEntry* const>(entries, n));
}

// What store configuration (or, with vendor objects, 0x1010 "save") left in
// non-volatile memory; an object's default when nothing is stored for it.
LssStored LssSlave::stored_config() const {
  LssStored s = node_.store().stored_lss();
  const OdEntry* id = node_.config_object(node_.options().node_id_object);
  const OdEntry* rate = node_.config_object(node_.options().bit_rate_object);
  if (!id && !rate) return s;
  std::uint64_t v = 0;
  if (id) s.node_id = node_.store().stored_u(*id, v) ? std::uint8_t(v) : node_.configured_node_id();
  if (rate) s.bit_rate_index = node_.store().stored_u(*rate, v) ? std::uint8_t(v) : node_.configured_bit_rate_index();
  if (!s.valid) {  // one object only: the other value is the active one
    if (!id) s.node_id = node_.node_id();
    if (!rate) s.bit_rate_index = node_.bit_rate_index();
  }
  s.valid = true;
  return s;
}

bool LssSlave::unconfigured() const { return node_.node_id() == kUnconfigured && pending_node_id_ == kUnconfigured; }

std::uint32_t LssSlave::lss_number(LssNumber which) const {
  const OdEntry* e = identity_[which];
  return e ? std::uint32_t(node_.values().get_u(*e)) : 0;
}

void LssSlave::reply(std::uint8_t cs, std::uint8_t b1, std::uint8_t b2) {
  node_.send(CanFrame::make(kReplyId, {cs, b1, b2, 0, 0, 0, 0, 0}));
}

void LssSlave::reply_u32(std::uint8_t cs, std::uint32_t value) {
  CanFrame f = CanFrame::make(kReplyId, {cs, 0, 0, 0, 0, 0, 0, 0});
  put_u32(f.data + 1, value);
  node_.send(f);
}

}  // namespace cansim
