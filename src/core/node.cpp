#include "core/node.hpp"

#include <algorithm>
#include <cassert>
#include <cmath>

#include "core/protocol.hpp"

namespace cansim {

Node::Node(NodeSetup setup, FrameSink& sink, Application* app, NodeStorage* storage)
    : setup_(std::move(setup)),
      sink_(sink),
      app_(app),
      storage_(storage),
      values_(setup_.layout),
      node_id_(setup_.node_id),
      bit_rate_(setup_.bit_rate_index),
      bus_bit_rate_(setup_.bit_rate_index) {
  if (!setup_.options) setup_.options = std::make_shared<NodeOptions>();
}

static_assert(ServiceContract<LssSlave> && ServiceContract<NmtSlave> && ServiceContract<SdoServer> &&
              ServiceContract<Heartbeat> && ServiceContract<NodeGuarding> && ServiceContract<SyncConsumer> &&
              ServiceContract<PdoEngine> && ServiceContract<Emcy> && ServiceContract<StoreRestore>);

// Every slot of the deadline board has exactly one service.
template <typename... S>
constexpr bool board_tiled() {
  std::array<int, kDeadlineSlots> owners{};
  for (const DeadlineSlots r : {S::kDeadlines...})
    for (std::size_t i = 0; i < r.count; ++i) ++owners[std::size_t(r.first) + i];
  for (int n : owners)
    if (n != 1) return false;
  return true;
}
static_assert(
    board_tiled<LssSlave, NmtSlave, SdoServer, Heartbeat, NodeGuarding, SyncConsumer, PdoEngine, Emcy, StoreRestore>());

template <typename Fn>
void Node::for_each_service(Fn&& fn) {
  fn(lss_);
  fn(nmt_);
  fn(sdo_);
  fn(heartbeat_);
  fn(guarding_);
  fn(sync_);
  fn(pdo_);
  fn(emcy_);
  fn(store_);
}

template <typename Fn>
void Node::for_each_service(Fn&& fn) const {
  const_cast<Node*>(this)->for_each_service([&](const auto& s) { fn(s); });
}

TimeUs* deadline_slot(Node& node, DeadlineSlot slot) { return &node.due_[std::size_t(slot)]; }

template <typename S>
TimeUs Node::due(const S&) const {
  const auto first = due_.begin() + std::size_t(S::kDeadlines.first);
  return *std::min_element(first, first + S::kDeadlines.count);
}

bool Node::board_holds() const {
  bool holds = true;
  for_each_service([&](const auto& s) { holds = holds && due(s) == s.next_deadline(); });
  return holds;
}

// Power-on: what LSS "store configuration" saved overrides the configured
// node-ID and bit rate (CiA 305).
void Node::power_on(TimeUs now) {
  note(now);
  const bool was_powered = powered_;
  powered_ = true;
  silent_ = false;
  bus_off_ = false;
  power_on_at_ = kNever;
  if (!was_powered) {
    frame_faults_.restart(++power_ons_);
    sdo_.restart_faults(power_ons_);
  }
  if (observer_ && !was_powered) observer_->on_power(*this, true, now);
  if (app_) {
    env_next_ = app_->environment(*this, now);
    if (!powered_) return;  // cycled again at once
  }
  store_.load();
  LssStored lss = store_.stored_lss();
  node_id_ = lss.valid ? lss.node_id : setup_.node_id;
  bit_rate_ = lss.valid ? lss.bit_rate_index : setup_.bit_rate_index;
  nmt_.power_on(now);
}

void Node::power_off() {
  if (powered_) withdraw_for(NmtState::kInitialising);
  frame_faults_.drop_held();
  powered_ = false;
  nmt_.power_off();
  power_on_at_ = kNever;
  rx_changed();
}

// The NMT state falls back to INITIALISING silently (nobody hears a dead
// node); only the observer learns of it.
void Node::power_off(TimeUs now) {
  const bool was_powered = powered_;
  const NmtState old = state();
  power_off();
  if (!observer_ || !was_powered) return;
  observer_->on_power(*this, false, now);
  if (old != state()) observer_->on_nmt_state(*this, old, state(), now);
}

void Node::power_cycle(TimeUs now, TimeUs off_for) {
  note(now);
  power_off(now);
  power_on_at_ = now + std::max<TimeUs>(off_for, 0);
}

void Node::set_bus_off(bool off, TimeUs now) {
  note(now);
  if (off == bus_off_ || !powered_) return;
  const bool was_off = off_bus();
  bus_off_ = off;
  bus_off_changed(was_off, now);
}

void Node::bus_off_changed(bool was_off, TimeUs now) {
  if (off_bus() == was_off) return;
  const NodeOptions& o = options();
  if (!was_off) {
    if (o.bus_off_comm_error_reaction && nmt_.booted()) nmt_.communication_error(now);
    return;
  }
  if (const auto code = std::uint16_t(o.bus_off_recovery_emcy)) {
    emcy_.raise(code, std::uint8_t(o.bus_off_recovery_emcy_register), now);
    if (o.bus_off_recovery_emcy_clears) emcy_.clear(code, now);
  }
}

// A restart after bus-off leaves the controller error active: the passive
// error ends first, then the recovery EMCY.
void Node::set_can_state(CanState state, TimeUs now) {
  note(now);
  if (state == can_state_) return;
  const bool was_off = off_bus();
  can_state_ = state;
  if (!powered_) return;
  const auto passive = std::uint16_t(options().error_passive_emcy);
  if (passive && state == CanState::kErrorPassive && !emcy_.active(passive))
    emcy_.raise(passive, std::uint8_t(options().error_passive_emcy_register), now);
  if (passive && state < CanState::kErrorPassive && emcy_.active(passive)) emcy_.clear(passive, now);
  bus_off_changed(was_off, now);
}

void Node::can_overrun(TimeUs now) {
  note(now);
  const auto code = std::uint16_t(options().can_overrun_emcy);
  if (!code || !powered_) return;
  emcy_.raise(code, std::uint8_t(options().can_overrun_emcy_register), now);
  emcy_.clear(code, now);
}

bool Node::allowed(Service s) const { return allowed_in(state(), s); }

bool Node::allowed_in(NmtState state, Service s) const {
  switch (state) {
    case NmtState::kOperational: return true;
    case NmtState::kPreOperational: return s != Service::kPdo;
    case NmtState::kStopped: return s == Service::kSdo && options().sdo_in_stopped;
    default: return false;
  }
}

bool Node::send(const CanFrame& frame) {
  if (!on_bus()) return false;
  ++frames_sent_;
  if (!frame_faults_.any_rule()) {
    sink_.send(frame);
    return true;
  }
  frame_faults_.send(*this, frame, now_, [&](const CanFrame& f) { sink_.send(f); });
  return true;
}

bool Node::send_after(const CanFrame& frame, TimeUs delay) {
  if (delay <= 0) return send(frame);
  if (!on_bus()) return false;
  ++frames_sent_;
  frame_faults_.send_after(*this, frame, now_, delay);
  return true;
}

void Node::run_faults(TimeUs now) {
  frame_faults_.process(now, [&](const CanFrame& f, bool from_outside) {
    if (from_outside) hear(f, now);
    else if (on_bus()) sink_.send(f);
  });
  disturbance_.process(
      now,
      [&](const CanFrame& f) {
        if (on_bus()) sink_.send_from(f, FrameSink::kBabbler);
      },
      [&](BusError e) { sink_.error(e); });
}

TimeUs Node::local_duration(TimeUs nominal) const {
  if (drift_ppm_ == 0 || nominal <= 0 || nominal == kNever) return nominal;
  return std::max<TimeUs>(1, std::llround(double(nominal) / (1.0 + drift_ppm_ * 1e-6)));
}

void Node::set_twin(bool on, TimeUs now) {
  if (on == bool(twin_)) return;
  if (!on) {
    twin_->power_off();
    twin_.reset();
    rx_changed();
    return;
  }
  NodeSetup s = setup_;
  s.node_id = node_id_;
  s.bit_rate_index = bit_rate_;
  s.seed = setup_.seed ^ 0x7417;
  if (const OdEntry* e = od().find(0x1018, 4)) s.serial_number = std::uint32_t(values_.get_u(*e) + 1);
  twin_ = std::make_unique<Node>(std::move(s), twin_sink_);
  twin_->set_bus_bit_rate(bus_bit_rate_);
  twin_->power_on(now);
  rx_changed();
}

TxSource Node::tx_source(const CanFrame& f) const {
  if (f.extended()) {
    // Only EMCY, SDO and PDOs may be given 29-bit COB-IDs.
  } else if (f.id == cob::kNmt) {
    return {TxService::kNmt};
  } else if (f.id == cob::kLssToMaster) {
    return {TxService::kLss};
  } else if (f.id == cob::kErrorControlBase + node_id_) {
    return {f.dlc == 1 && f.data[0] == 0x00 ? TxService::kBootUp : TxService::kHeartbeat};
  }
  if (emcy_.sends(f)) return {TxService::kEmcy};
  if (sdo_.sends(f)) return {TxService::kSdo};
  for (const Tpdo& t : pdo_.tpdos())
    if (!(t.cfg.cobid & kPdoCobInvalid) && cob::frame_id(t.cfg.cobid) == (f.id | (f.extended() ? cob::kFrame29Bit : 0)))
      return {TxService::kTpdo, std::uint16_t(t.cfg.comm_index - 0x1800 + 1)};
  return {};
}

namespace {
// CiA 301 Table 82: the frames a state no longer sends. A reset (and
// power-off) clears the controller's transmit buffer; the boot-up follows.
class NmtWithdrawal final : public FrameFilter {
 public:
  NmtWithdrawal(const Node& node, NmtState state) : node_(node), state_(state) {}
  bool matches(const CanFrame& f) const override {
    const TxService s = node_.tx_source(f).service;
    switch (state_) {
      case NmtState::kOperational: return false;
      case NmtState::kPreOperational: return s == TxService::kTpdo;
      case NmtState::kStopped:
        return s != TxService::kHeartbeat && s != TxService::kLss &&
               !(s == TxService::kSdo && node_.allowed_in(state_, Service::kSdo));
      default: return true;
    }
  }

 private:
  const Node& node_;
  NmtState state_;
};
}  // namespace

void Node::withdraw_for(NmtState now) {
  if (now == NmtState::kOperational) return;
  const NmtWithdrawal filter(*this, now);
  sink_.withdraw(filter);
  frame_faults_.withdraw([&](const CanFrame& f) { return filter.matches(f); });
}

void Node::on_frame(const CanFrame& frame, TimeUs now, bool from_outside) {
  note(now);
  if (twin_) twin_->on_frame(frame, now, from_outside);
  if (from_outside && frame_faults_.any_rule())
    frame_faults_.receive(frame, now, [&](const CanFrame& f) { hear(f, now); });
  else hear(frame, now);
}

void Node::hear(const CanFrame& frame, TimeUs now) {
  if (!powered_ || off_bus() || bit_rate_ != bus_bit_rate_) return;
  // Every service sees the frame until one claims it; the order puts the
  // broadcast services (LSS, NMT) first.
  bool done = false;
  for_each_service([&](auto& s) {
    if (!done && hears(s)) done = s.on_frame(frame, now);
  });
}

void Node::advance(TimeUs now) {
  note(now);
  if (twin_ && twin_->next_deadline() <= now) twin_->advance(now);
  if (!powered_) {
    if (power_on_at_ > now) return;
    power_on(now);
    if (!powered_) return;
  }
  if (app_ && env_next_ <= now) {
    env_next_ = app_->environment(*this, now);
    if (!powered_) return;
  }
  if (std::min(frame_faults_.next_deadline(), disturbance_.next_deadline()) <= now) run_faults(now);
  for_each_service([&](auto& s) {
    if (due(s) <= now) s.process(now);
  });
  if (app_ && app_next_ <= now) app_next_ = app_->process(*this, now);
}

TimeUs Node::next_deadline() const {
  const TimeUs twin = twin_ ? twin_->next_deadline() : kNever;
  if (!powered_) return std::min(power_on_at_, twin);
  assert(board_holds());
  const TimeUs services = *std::min_element(due_.begin(), due_.end());
  return std::min({services, app_next_, env_next_, twin, frame_faults_.next_deadline(), disturbance_.next_deadline()});
}

void Node::collect_rx_ids(std::vector<std::uint32_t>& out) const {
  if (twin_) twin_->collect_rx_ids(out);
  if (!powered_) return;
  for_each_service([&](const auto& s) { s.collect_rx_ids(out); });
}

SdoAbort Node::read(const OdEntry& e, TimeUs now, std::span<const std::uint8_t>& out) {
  if (!readable(e.access)) return SdoAbort::kWriteOnly;
  return read_value(e, now, out);
}

SdoAbort Node::read_local(const OdEntry& e, TimeUs now, std::span<const std::uint8_t>& out) {
  note(now);
  return read_value(e, now, out);
}

SdoAbort Node::read_value(const OdEntry& e, TimeUs now, std::span<const std::uint8_t>& out) {
  // Owning services may refuse a read (0x1003 sub above the error count).
  SdoAbort refused = SdoAbort::kNone;
  for_each_service([&](auto& s) {
    if constexpr (requires { s.check_read(e); })
      if (ok(refused) && s.owns(e.index)) refused = s.check_read(e);
  });
  if (!ok(refused)) return refused;
  refresh(e, now);
  out = values_.bytes(e);
  return SdoAbort::kNone;
}

SdoAbort Node::read(std::uint16_t index, std::uint8_t sub, TimeUs now, std::span<const std::uint8_t>& out) {
  SdoAbort why = SdoAbort::kNone;
  const OdEntry* e = od().lookup(index, sub, why);
  return e ? read(*e, now, out) : why;
}

void Node::refresh(const OdEntry& e, TimeUs now) {
  if ((e.hooks & kHookRead) && app_) app_->refresh(*this, e, now);
}

SdoAbort Node::write(const OdEntry& e, std::span<const std::uint8_t> data, TimeUs now) {
  if (!writable(e.access)) return SdoAbort::kReadOnly;
  return write_value(e, data, now);
}

SdoAbort Node::write_local(const OdEntry& e, std::span<const std::uint8_t> data, TimeUs now) {
  note(now);
  return write_value(e, data, now);
}

SdoAbort Node::write_value(const OdEntry& e, std::span<const std::uint8_t> data, TimeUs now) {
  if (SdoAbort a = check_value(e, data); !ok(a)) return a;
  SdoAbort result = SdoAbort::kNone;
  bool handled = false;
  for_each_service([&](auto& s) {
    if (!handled && s.owns(e.index)) {
      handled = true;
      result = s.write(e, data, now);
    }
  });
  if (handled) return result;
  if ((e.hooks & kHookWrite) && app_) {
    if (SdoAbort a = app_->check_write(*this, e, data, now); !ok(a)) return a;
  }
  values_.set_bytes(e, data);
  if ((e.hooks & kHookWrite) && app_) app_->after_write(*this, e, now);
  return SdoAbort::kNone;
}

SdoAbort Node::write(std::uint16_t index, std::uint8_t sub, std::span<const std::uint8_t> data, TimeUs now) {
  SdoAbort why = SdoAbort::kNone;
  const OdEntry* e = od().lookup(index, sub, why);
  return e ? write(*e, data, now) : why;
}

SdoAbort Node::store_local(std::uint8_t sub, TimeUs now) {
  return write_signature(0x1010, sub, StoreRestore::kSave, now);
}

SdoAbort Node::restore_local(std::uint8_t sub, TimeUs now) {
  return write_signature(0x1011, sub, StoreRestore::kLoad, now);
}

// The signature is what a master writes to 0x1010 / 0x1011 (CiA 301
// §7.5.2.13-14): the same owning service and checks run.
SdoAbort Node::write_signature(std::uint16_t index, std::uint8_t sub, std::uint32_t signature, TimeUs now) {
  SdoAbort why = SdoAbort::kNone;
  const OdEntry* e = od().lookup(index, sub, why);
  if (!e) return why;
  std::uint8_t bytes[4];
  put_u32(bytes, signature);
  return write_local(*e, bytes, now);
}

// As the master's NMT frame, except that a start / stop / pre-operational
// command does nothing before the boot-up (CiA 301 §7.3.2: INITIALISING
// ends on its own); resets are always possible while powered.
bool Node::nmt_local(std::uint8_t cs, TimeUs now) {
  note(now);
  if (!powered_) return false;
  switch (cs) {
    case kNmtResetNode:
    case kNmtResetCommunication: break;
    case kNmtStart:
    case kNmtStop:
    case kNmtEnterPreOperational:
      if (state() == NmtState::kInitialising) return false;
      break;
    default: return false;
  }
  nmt_.command(cs, now);
  return true;
}

void Node::prepare_reset(ResetKind kind, TimeUs now) {
  for_each_service([&](auto& s) {
    if constexpr (requires { s.prepare_reset(kind, now); }) s.prepare_reset(kind, now);
  });
}

void Node::nmt_state_changed(NmtState old, TimeUs now) {
  withdraw_for(state());
  // The observer first, so it hears the change before its consequences
  // (e.g. EMCYs that waited for the boot-up).
  if (observer_) observer_->on_nmt_state(*this, old, state(), now);
  for_each_service([&](auto& s) {
    if constexpr (requires { s.on_nmt_state(old, now); }) s.on_nmt_state(old, now);
  });
  if (app_) app_->on_nmt_state(*this, state(), now);
}

void Node::reset_to_defaults(std::uint16_t first, std::uint16_t last) {
  values_.reset(default_node_id(), first, last);
  if (!setup_.serial_number || first > 0x1018 || last < 0x1018) return;
  if (const OdEntry* e = od().find(0x1018, 4)) values_.set_u(*e, *setup_.serial_number);
}

void Node::reset_values(ResetKind kind) {
  if (kind == ResetKind::kCommunication) {
    reset_to_defaults(0x1000, 0x1FFF);
    store_.apply_stored(0x1000, 0x1FFF);
    return;
  }
  load_all_values();
  // Vendor node-ID / bit-rate objects: what is stored there is active from
  // power-on and reset node on; the $NODEID defaults then follow the new ID.
  if (const OdEntry* e = config_object(options().bit_rate_object)) bit_rate_ = std::uint8_t(values_.get_u(*e));
  if (const OdEntry* e = config_object(options().node_id_object)) {
    const std::uint64_t id = values_.get_u(*e);
    if (id >= 1 && id <= 127 && id != node_id_) {
      node_id_ = std::uint8_t(id);
      load_all_values();
    }
  }
}

void Node::load_all_values() {
  reset_to_defaults();
  // Their default is the configured (factory) node-ID / bit rate of this node.
  if (const OdEntry* e = config_object(options().node_id_object)) values_.set_u(*e, setup_.node_id);
  if (const OdEntry* e = config_object(options().bit_rate_object)) values_.set_u(*e, setup_.bit_rate_index);
  store_.apply_stored(0x0000, 0xFFFF);
}

const OdEntry* Node::config_object(std::int64_t index) const {
  return index > 0 && index <= 0xFFFF ? od().find(std::uint16_t(index), 0) : nullptr;
}

NodeSnapshot::NodeSnapshot(const Node& node)
    : values_(node.values_),
      node_id_(node.node_id_),
      bit_rate_(node.bit_rate_),
      bus_bit_rate_(node.bus_bit_rate_),
      powered_(node.powered_),
      silent_(node.silent_),
      muted_(node.muted_),
      bus_off_(node.bus_off_),
      can_state_(node.can_state_),
      power_ons_(node.power_ons_),
      env_next_(node.env_next_),
      power_on_at_(node.power_on_at_),
      app_next_(node.app_next_),
      now_(node.now_),
      drift_ppm_(node.drift_ppm_),
      frame_faults_(node.frame_faults_),
      disturbance_(node.disturbance_),
      nmt_(node.nmt_),
      lss_(node.lss_),
      sdo_(node.sdo_),
      heartbeat_(node.heartbeat_),
      guarding_(node.guarding_),
      sync_(node.sync_),
      pdo_(node.pdo_),
      emcy_(node.emcy_),
      store_(node.store_) {}

bool Node::restore(const NodeSnapshot& s) {
  if (&s.values_.layout() != &od()) return false;
  values_ = s.values_;
  node_id_ = s.node_id_;
  bit_rate_ = s.bit_rate_;
  bus_bit_rate_ = s.bus_bit_rate_;
  powered_ = s.powered_;
  silent_ = s.silent_;
  muted_ = s.muted_;
  bus_off_ = s.bus_off_;
  can_state_ = s.can_state_;
  power_ons_ = s.power_ons_;
  env_next_ = s.env_next_;
  power_on_at_ = s.power_on_at_;
  app_next_ = s.app_next_;
  now_ = s.now_;
  drift_ppm_ = s.drift_ppm_;
  frame_faults_ = s.frame_faults_;
  disturbance_ = s.disturbance_;
  twin_.reset();
  nmt_ = s.nmt_;
  lss_ = s.lss_;
  sdo_ = s.sdo_;
  heartbeat_ = s.heartbeat_;
  guarding_ = s.guarding_;
  sync_ = s.sync_;
  pdo_ = s.pdo_;
  emcy_ = s.emcy_;
  store_ = s.store_;
  rx_changed();  // a dispatcher re-reads the COB-IDs the node listens to
  return true;
}

void Node::reset_services(TimeUs now) {
  for_each_service([&](auto& s) { s.reset(now); });
  app_next_ = app_ ? now : kNever;  // no application: no application deadline
  rx_changed();
}

}  // namespace cansim
