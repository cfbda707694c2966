#include "io/loop_core.hpp"

#include <algorithm>

namespace cansim::io {

LoopCore::LoopCore() : ring_(256) {}
LoopCore::~LoopCore() = default;

BusId LoopCore::add_bus(std::string name, Transport& transport, std::uint8_t bit_rate_index) {
  auto bus = std::make_unique<Bus>();
  bus->name = std::move(name);
  bus->transport = &transport;
  bus->bit_rate_index = bit_rate_index;
  buses_.push_back(std::move(bus));
  return BusId(buses_.size() - 1);
}

void LoopCore::set_bus_bit_rate(BusId bus, std::uint8_t bit_rate_index) {
  buses_[bus]->bit_rate_index = bit_rate_index;
  for (auto& s : slots_)
    if (s && s->bus == bus) s->node->set_bus_bit_rate(bit_rate_index);
}

const std::string& LoopCore::bus_name(BusId bus) const { return buses_[bus]->name; }

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
  slots_[ref]->node->power_on(now_);
  after(ref);
  rebuild_dirty();
  flush(now_);
}

void LoopCore::remove_node(NodeRef ref) {
  Slot& s = *slots_[ref];
  s.node->set_observer(nullptr);
  s.node->power_off();
  buses_[s.bus]->dispatch.remove(ref);
  heap_.set(ref, kNever);
  // Frames it already sent still reach the others (they were on the wire).
  for (std::size_t i = 0; i < ring_size_; ++i) {
    Pending& p = ring_[(ring_head_ + i) & (ring_.size() - 1)];
    if (p.from == ref) p.from = kNoNode;
  }
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

void LoopCore::refresh(NodeRef ref) {
  after(ref);
  rebuild_dirty();
  flush(now_);
}

void LoopCore::receive(BusId bus, const CanFrame& frame, TimeUs now) {
  now_ = std::max(now_, now);
  ++stats_.frames_in;
  deliver(bus, kNoNode, frame, now_);
  rebuild_dirty();
  flush(now_);
}

void LoopCore::run_due(TimeUs now) {
  now_ = std::max(now_, now);
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
}

TimeUs LoopCore::run_until(TimeUs t) {
  while (heap_.top_time() <= t) run_due(std::max(now_, heap_.top_time()));
  now_ = std::max(now_, t);
  return now_;
}

void LoopCore::on_send(NodeRef from, const CanFrame& frame) {
  BusId bus = slots_[from]->bus;
  ++stats_.frames_out;
  buses_[bus]->transport->transmit(frame);
  // Other local nodes receive it in the flush, as they listen now. A frame
  // only its sender listens to (a TPDO: for remote requests) or nobody, as
  // most PDOs and heartbeats, is not queued.
  Bus& b = *buses_[bus];
  if (b.nodes < 2) return;
  for (NodeRef ref : b.dispatch.lookup(frame))
    if (ref != from) return push_pending({bus, from, frame});
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
    slots_[ref]->node->on_frame(frame, now);
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
