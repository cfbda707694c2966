#include "io/loop_core.hpp"

#include <algorithm>

#include "core/protocol.hpp"
#include "io/wire_bits.hpp"

namespace cansim::io {

LoopCore::LoopCore() : ring_(256) {}
LoopCore::~LoopCore() = default;

BusId LoopCore::add_bus(std::string name, Transport& transport, std::uint8_t bit_rate_index) {
  auto bus = std::make_unique<Bus>();
  bus->name = std::move(name);
  bus->transport = &transport;
  bus->bit_rate_index = bit_rate_index;
  bus->meter.reset(now_);
  if (!free_buses_.empty()) {
    const BusId id = free_buses_.back();
    free_buses_.pop_back();
    buses_[id] = std::move(bus);
    return id;
  }
  buses_.push_back(std::move(bus));
  return BusId(buses_.size() - 1);
}

void LoopCore::remove_bus(BusId bus) {
  if (buses_[bus]->timed) --timed_buses_;
  std::size_t kept = 0;
  for (std::size_t i = 0; i < ring_size_; ++i) {
    const Pending& p = ring_[(ring_head_ + i) & (ring_.size() - 1)];
    if (p.bus != bus) ring_[(ring_head_ + kept++) & (ring_.size() - 1)] = p;
  }
  ring_size_ = kept;
  buses_[bus].reset();
  free_buses_.push_back(bus);
  update_bus_next();
}

void LoopCore::set_bus_bit_rate(BusId bus, std::uint8_t bit_rate_index) {
  if (buses_[bus]->bit_rate_index == bit_rate_index) return;  // its nodes know it
  buses_[bus]->bit_rate_index = bit_rate_index;
  if (buses_[bus]->timed) {
    buses_[bus]->timed->set_bit_ns(bit_time_ns(bit_rate_index));
    update_bus_next();
  }
  for (auto& s : slots_)
    if (s && s->bus == bus) s->node->set_bus_bit_rate(bit_rate_index);
}

const std::string& LoopCore::bus_name(BusId bus) const { return buses_[bus]->name; }

void LoopCore::set_bus_model(BusId bus, BusModel model, std::size_t queue_frames) {
  Bus& b = *buses_[bus];
  if ((model == BusModel::kTimed) == bool(b.timed)) return;
  if (model == BusModel::kTimed) {
    b.timed = std::make_unique<TimedBus>(bit_time_ns(b.bit_rate_index), queue_frames);
    b.timed->set_pacer(pacer_for(*b.transport));
    b.carrying = b.transport->carries();
    ++timed_buses_;
  } else {
    std::unique_ptr<TimedBus> timed = std::move(b.timed);
    --timed_buses_;
    timed->drain([&](const QueuedFrame& q) { write_recalled(b, q); }, [&](const Departure& d) { hear_at_end(bus, d); },
                 [&](const QueuedFrame& q) {
                   b.meter.carried(q.bits, now_);
                   put_on_wire(bus, q.from, q.frame);
                 });
    flush(now_);
  }
  update_bus_next();
}

Pacer LoopCore::pacer_for(const Transport& transport) {
  return transport.paces() || !transport.carries() ? Pacer::kAhead : Pacer::kLoop;
}

void LoopCore::update_pacer(BusId bus) {
  Bus& b = *buses_[bus];
  if (!b.timed) return;
  const bool carrying = b.transport->carries();
  if (carrying && !b.carrying) b.timed->recall();  // what was handed to nobody and ends later is written then
  b.carrying = carrying;
  const Pacer want = pacer_for(*b.transport);
  if (b.timed->pacer() != want) b.timed->set_pacer(want);
  update_bus_next();
}

Pacer LoopCore::bus_pacer(BusId bus) const { return buses_[bus]->timed ? buses_[bus]->timed->pacer() : Pacer::kLoop; }

BusLoad LoopCore::bus_load(BusId bus) const {
  const Bus& b = *buses_[bus];
  const BusMeter::Figures f = b.meter.figures(now_);
  const std::int64_t ns = bit_time_ns(b.bit_rate_index);
  const double per_bit = ns ? double(ns) * 1e-9 : 0;  // load = bits/s x s/bit
  BusLoad load;
  load.model = bus_model(bus);
  load.offered_1s = f.offered_1s * per_bit;
  load.offered_10s = f.offered_10s * per_bit;
  // A bus carries at most its bit rate: what an ideal bus or a flood from
  // outside offered beyond it is overload, shown as offered. (A timed bus
  // counts a frame in the bin it ends in: a window edge may round it over.)
  load.carried_1s = std::min(f.carried_1s * per_bit, 1.0);
  load.carried_10s = std::min(f.carried_10s * per_bit, 1.0);
  load.delay_p50 = f.delay_p50;
  load.delay_p99 = f.delay_p99;
  load.delay_max = f.delay_max;
  load.slip_p99 = f.slip_p99;
  load.slip_max = f.slip_max;
  if (b.timed) {
    load.queued = b.timed->queued();
    load.queue_capacity = b.timed->capacity();
    load.dropped = b.timed->dropped();
  }
  return load;
}

NodeRef LoopCore::add_node(BusId bus, NodeSetup setup, std::unique_ptr<Application> app,
                           std::unique_ptr<NodeStorage> storage) {
  NodeRef ref;
  if (!free_.empty()) {
    ref = free_.back();
    free_.pop_back();
  } else {
    ref = NodeRef(slots_.size());
    slots_.emplace_back();
  }
  auto slot = std::make_unique<Slot>();
  slot->core = this;
  slot->ref = ref;
  slot->bus = bus;
  slot->app = std::move(app);
  slot->storage = std::move(storage);
  slot->node = std::make_unique<Node>(std::move(setup), *slot, slot->app.get(), slot->storage.get());
  slot->node->set_bus_bit_rate(buses_[bus]->bit_rate_index);
  slot->node->set_can_state(buses_[bus]->controller, now_);
  if (observer_) slot->node->set_observer(slot.get());
  slot->epoch_seen = slot->node->rx_epoch() - 1;  // forces the first registration
  slots_[ref] = std::move(slot);
  heap_.reserve_slots(slots_.size());
  dirty_.reserve(slots_.size());
  ++live_;
  ++buses_[bus]->nodes;
  return ref;
}

void LoopCore::power_on(NodeRef ref, TimeUs now) {
  now_ = std::max(now_, now);
  if (timed_buses_) {
    settle_buses(TimedBus::Phase::kBefore);
    flush(now_);
  }
  slots_[ref]->node->power_on(now_);
  after(ref);
  rebuild_dirty();
  flush(now_);
  settle_buses(TimedBus::Phase::kAt);
}

void LoopCore::remove_node(NodeRef ref) {
  Slot& s = *slots_[ref];
  s.node->set_observer(nullptr);
  s.node->power_off();  // its queued frames are withdrawn
  buses_[s.bus]->dispatch.remove(ref);
  heap_.set(ref, kNever);
  // Frames it already sent still reach the others (they were on the wire).
  for (std::size_t i = 0; i < ring_size_; ++i) {
    Pending& p = ring_[(ring_head_ + i) & (ring_.size() - 1)];
    if (p.from == ref) p.from = kNoNode;
  }
  if (buses_[s.bus]->timed)
    buses_[s.bus]->timed->for_each([ref](QueuedFrame& q) {
      if (q.from == ref) q.from = kNoNode;
    });
  std::erase(dirty_, ref);
  --buses_[s.bus]->nodes;
  --live_;
  slots_[ref].reset();
  free_.push_back(ref);
}

void LoopCore::set_observer(LoopObserver* observer) {
  observer_ = observer;
  for (auto& s : slots_)
    if (s) s->node->set_observer(observer ? s.get() : nullptr);
}

void LoopCore::tap_ids(BusId bus, const std::vector<std::uint32_t>& ids) {
  Bus& b = *buses_[bus];
  b.tapped_std.assign(ids.empty() ? 0 : 2048 / 64, 0);
  b.tapped_ext.clear();
  for (std::uint32_t id : ids) {
    if (id & cob::kRxIdExtended) b.tapped_ext.push_back(id & cob::kId29Mask);
    else b.tapped_std[(id & 0x7FF) / 64] |= std::uint64_t(1) << (id % 64);
  }
  std::sort(b.tapped_ext.begin(), b.tapped_ext.end());
}

bool LoopCore::Bus::tapped(const CanFrame& f) const {
  if (f.extended()) return std::binary_search(tapped_ext.begin(), tapped_ext.end(), f.id);
  return !tapped_std.empty() && f.id < 2048 && ((tapped_std[f.id / 64] >> (f.id % 64)) & 1u);
}

void LoopCore::refresh(NodeRef ref) {
  after(ref);
  rebuild_dirty();
  flush(now_);
  settle_buses(TimedBus::Phase::kAt);
}

void LoopCore::receive(BusId bus, const CanFrame& frame, TimeUs now) {
  now_ = std::max(now_, now);
  ++stats_.frames_in;
  Bus& b = *buses_[bus];
  if (timed_buses_) {
    // Our frames that were on the wire before this one come first.
    settle_buses(TimedBus::Phase::kBefore);
    flush(now_);
  }
  if (b.timed) {
    const int bits = wire_bits(frame);
    b.meter.offered(bits, now_);
    b.meter.carried(b.timed->occupy(bits, now_), now_);
    bus_next_stale_ = true;
  } else {
    b.meter.offered_and_carried(unstuffed_wire_bits(frame), now_);
  }
  if (tap_ && b.tapped(frame)) tap_->on_frame(bus, frame, now_);
  deliver(bus, kNoNode, frame, now_);
  rebuild_dirty();
  flush(now_);
  settle_buses(TimedBus::Phase::kAt);
}

bool LoopCore::submit(BusId bus, const CanFrame& frame, Participant from, TimeUs now) {
  now_ = std::max(now_, now);
  ++stats_.frames_in;
  Bus& b = *buses_[bus];
  const NodeRef sender = kOutside | from;
  if (timed_buses_) {
    settle_buses(TimedBus::Phase::kBefore);
    flush(now_);
  }
  bool queued = true;
  if (b.timed) {
    const int bits = wire_bits(frame);
    b.meter.offered(bits, now_);
    queued = b.timed->submit({frame, now_, sender, std::uint16_t(bits)}, now_);
    bus_next_stale_ = true;
  } else {
    b.meter.offered_and_carried(unstuffed_wire_bits(frame), now_);
    put_on_wire(bus, sender, frame);
  }
  flush(now_);
  settle_buses(TimedBus::Phase::kAt);
  return queued;
}

void LoopCore::controller_event(BusId bus, const ControllerEvent& event, TimeUs now) {
  now_ = std::max(now_, now);
  if (event.state_changed) buses_[bus]->controller = event.state;
  for (auto& s : slots_) {
    if (!s || s->bus != bus) continue;
    if (event.state_changed) s->node->set_can_state(event.state, now_);
    if (event.frames_lost) s->node->can_overrun(now_);
    after(s->ref);
  }
  rebuild_dirty();
  flush(now_);
  settle_buses(TimedBus::Phase::kAt);
}

void LoopCore::run_due(TimeUs now) {
  now_ = std::max(now_, now);
  ++stats_.passes;
  if (timed_buses_) {
    settle_buses(TimedBus::Phase::kBefore);
    if (ring_size_) flush(now_);
  }
  while (heap_.top_time() <= now_) {
    NodeRef ref = heap_.top();
    Node& n = *slots_[ref]->node;
    ++stats_.wakeups;
    n.advance(now_);
    after(ref);
    // A deadline still due right after advance() would spin the loop; run it
    // again at the next microsecond instead.
    if (heap_.deadline(ref) <= now_) heap_.set(ref, now_ + 1);
    rebuild_dirty();
    flush(now_);
  }
  settle_buses(TimedBus::Phase::kAt);
}

TimeUs LoopCore::run_until(TimeUs t) {
  while (next_deadline() <= t) run_due(std::max(now_, next_deadline()));
  now_ = std::max(now_, t);
  return now_;
}

void LoopCore::on_withdraw(NodeRef from, const FrameFilter& filter, std::uint8_t controller) {
  Bus& b = *buses_[slots_[from]->bus];
  if (!b.timed) return;  // an ideal bus: every frame is on the wire already
  if (b.timed->withdraw([&](const QueuedFrame& q) {
        return q.from == from && q.controller == controller && filter.matches(q.frame);
      }))
    bus_next_stale_ = true;
}

// A protocol error takes the bus for an error frame's time (error flag,
// delimiter, intermission); every error goes to the transport for the
// master's controller to report, never to the local nodes.
void LoopCore::on_error(BusId bus, BusError e) {
  Bus& b = *buses_[bus];
  if (b.timed && on_the_wire(e)) {
    b.meter.offered(kErrorFrameBits, now_);
    b.meter.carried(b.timed->occupy(kErrorFrameBits, now_), now_);
    bus_next_stale_ = true;
  }
  b.transport->error(e);
}

void LoopCore::on_send(NodeRef from, const CanFrame& frame, std::uint8_t controller) {
  const BusId bus = slots_[from]->bus;
  Bus& b = *buses_[bus];
  ++stats_.frames_out;
  // Ideal buses count frames without stuff bits: computing them costs a
  // timed bus about a dozen table reads a frame (io/wire_bits.hpp).
  if (b.timed) {
    // A babbling controller's buffer is full: its software tries again later.
    if (controller == FrameSink::kBabbler && b.timed->babbling() >= TimedBus::kBabbleBuffer) return;
    const int bits = wire_bits(frame);
    b.meter.offered(bits, now_);
    b.timed->submit({frame, now_, from, std::uint16_t(bits), controller}, now_);
    bus_next_stale_ = true;
    return;
  }
  b.meter.offered_and_carried(unstuffed_wire_bits(frame), now_);
  put_on_wire(bus, from, frame);
}

void LoopCore::write(Bus& b, NodeRef from, const CanFrame& frame) {
  if (outside(from)) b.transport->transmit_from(frame, from & ~kOutside);
  else b.transport->transmit(frame);
}

void LoopCore::put_on_wire(BusId bus, NodeRef from, const CanFrame& frame) {
  Bus& b = *buses_[bus];
  write(b, from, frame);
  if (tap_ && b.tapped(frame)) tap_->on_frame(bus, frame, now_);
  // Other local nodes receive it in the flush, as they listen now.
  if (heard_locally(b, from, frame)) push_pending({bus, from, frame});
}

// A frame only its sender listens to (a TPDO: for remote requests) or
// nobody, as most PDOs and heartbeats, is not queued for local delivery;
// an outside participant's frame reaches every node that listens.
bool LoopCore::heard_locally(const Bus& b, NodeRef from, const CanFrame& frame) const {
  if (b.nodes < (outside(from) ? 1u : 2u)) return false;
  for (NodeRef ref : b.dispatch.lookup(frame))
    if (ref != from) return true;
  return false;
}

void LoopCore::write_recalled(Bus& b, const QueuedFrame& q) {
  b.transport->recalled();
  write(b, q.from, q.frame);
}

void LoopCore::hear_at_end(BusId bus, const Departure& d) {
  const Bus& b = *buses_[bus];
  if (tap_ && b.tapped(d.q.frame)) tap_->on_frame(bus, d.q.frame, now_);
  if (heard_locally(b, d.q.from, d.q.frame)) push_pending({bus, d.q.from, d.q.frame});
}

void LoopCore::settle_bus(BusId bus, TimedBus::Phase phase) {
  Bus& b = *buses_[bus];
  Departure d;
  bus_next_stale_ = true;
  // kAhead: launched frames the other local nodes (and the tap) hear at their end.
  while (b.timed->heard(now_, d)) hear_at_end(bus, d);
  while (b.timed->settle(now_, phase, d)) {
    if (d.recalled) {  // metered and heard when it was handed over
      write_recalled(b, d.q);
      continue;
    }
    // A collision before it: its error frames for the master's controller
    // (a receiver sees each error flag as a stuff error).
    for (int i = 0; i < d.collisions; ++i) b.transport->error(BusError::kStuff);
    b.meter.carried(d.q.bits + d.collision_bits, now_);
    b.meter.delay((d.start_ns - d.q.queued_at * 1000) / 1000, now_);
    b.meter.slip(d.slip_ns / 1000, now_);
    if (!d.launched) {
      put_on_wire(bus, d.q.from, d.q.frame);
      continue;
    }
    b.transport->transmit_at(d.q.frame, d.end_ns, d.q.bits * b.timed->bit_ns());
    // Heard at its end by the other local nodes, or by the fleet's tap (plants).
    if (heard_locally(b, d.q.from, d.q.frame) || (tap_ && b.tapped(d.q.frame))) b.timed->hear_at_end(d);
  }
}

// Before now: every bus once (their frames' deliveries wait for the caller's
// flush, so what the receivers answer at now is not in an arbitration before
// now). At now: until the deliveries of what ended cause nothing more.
void LoopCore::settle_buses(TimedBus::Phase phase) {
  if (timed_buses_ == 0 || (!bus_next_stale_ && now_ * 1000 < bus_due_ns_)) return;
  for (;;) {
    for (BusId bus = 0; bus < buses_.size(); ++bus)
      if (buses_[bus] && buses_[bus]->timed && buses_[bus]->timed->due_ns() <= now_ * 1000) settle_bus(bus, phase);
    if (phase == TimedBus::Phase::kBefore) return;  // kAt follows
    if (ring_size_ == 0) break;
    flush(now_);
  }
  if (bus_next_stale_) update_bus_next();
}

void LoopCore::update_bus_next() {
  bus_next_stale_ = false;
  bus_next_ = kNever;
  bus_due_ns_ = std::numeric_limits<std::int64_t>::max();
  for (const auto& b : buses_)
    if (b && b->timed) {
      bus_next_ = std::min(bus_next_, b->timed->next_event());
      bus_due_ns_ = std::min(bus_due_ns_, b->timed->due_ns());
    }
}

void LoopCore::push_pending(const Pending& p) {
  if (ring_size_ == ring_.size()) {
    // Rare: a burst larger than the ring. Grow (allocates once per doubling).
    std::vector<Pending> bigger(ring_.size() * 2);
    for (std::size_t i = 0; i < ring_size_; ++i) bigger[i] = ring_[(ring_head_ + i) & (ring_.size() - 1)];
    ring_.swap(bigger);
    ring_head_ = 0;
  }
  ring_[(ring_head_ + ring_size_) & (ring_.size() - 1)] = p;
  ++ring_size_;
}

void LoopCore::deliver(BusId bus, NodeRef from, const CanFrame& frame, TimeUs now) {
  // The list is not modified while we walk it: rx-set changes are only
  // recorded (dirty_) and applied by rebuild_dirty() afterwards.
  for (NodeRef ref : buses_[bus]->dispatch.lookup(frame)) {
    if (ref == from) continue;
    slots_[ref]->node->on_frame(frame, now, from == kNoNode);
    after(ref);
  }
}

void LoopCore::after(NodeRef ref) {
  Slot& s = *slots_[ref];
  heap_.set(ref, s.node->next_deadline());
  if (s.node->rx_epoch() != s.epoch_seen && !s.dirty) {
    s.dirty = true;
    dirty_.push_back(ref);
  }
}

void LoopCore::rebuild_dirty() {
  for (NodeRef ref : dirty_) {
    Slot& s = *slots_[ref];
    s.dirty = false;
    s.epoch_seen = s.node->rx_epoch();
    scratch_ids_.clear();
    s.node->collect_rx_ids(scratch_ids_);
    buses_[s.bus]->dispatch.set(ref, scratch_ids_);
  }
  dirty_.clear();
}

void LoopCore::flush(TimeUs now) {
  if (flushing_) return;
  flushing_ = true;
  while (ring_size_ > 0) {
    Pending p = ring_[ring_head_];
    ring_head_ = (ring_head_ + 1) & (ring_.size() - 1);
    --ring_size_;
    ++stats_.local_deliveries;
    deliver(p.bus, p.from, p.frame, now);
    rebuild_dirty();
  }
  flushing_ = false;
}

}  // namespace cansim::io
