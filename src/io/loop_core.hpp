// The sans-I/O heart of the daemon's event loop: every node of the fleet,
// grouped by bus, with one deadline heap and one COB-ID dispatch table per
// bus. The caller passes time in; frames leave through each bus's Transport.
// The epoll loop drives it from CLOCK_MONOTONIC, tests and the benchmark step
// it with a fake clock (sd-event style):
//
//   core.receive(bus, frame, now);   // a frame from the wire
//   core.run_due(now);               // every node whose deadline has come
//   sleep until core.next_deadline()
//
// A frame a node sends goes to its bus's transport and, as on a real bus, to
// the other local nodes of that bus (queued, never delivered re-entrantly; the
// sender does not hear itself). On an ideal bus (the default) it does so the
// instant the node sends it; on a timed bus (io/timed_bus.hpp) when the bus
// has carried it, lowest identifier first, each frame for its length at the
// bus's bit rate: then next_deadline() includes the end of the frame on the
// wire, and a bus due at `now` leaves what its nodes send at `now` to
// arbitration among themselves.
//
// Frames from outside come two ways. receive(): a frame another device
// already put on the wire (a kernel CAN socket read it); it occupies a timed
// bus from its arrival and never loses arbitration. submit(): a frame an
// outside participant wants to send where cansimd is the wire (a socketcand
// client, a replay); it is queued and arbitrated with the nodes' frames as
// theirs are, and reaches the nodes and the transport (transmit_from, which
// does not echo it to its sender) when it ends on the wire.
#pragma once

#include <algorithm>
#include <cstdint>
#include <limits>
#include <memory>
#include <string>
#include <vector>

#include "core/node.hpp"
#include "io/bus_meter.hpp"
#include "io/controller_event.hpp"
#include "io/deadline_heap.hpp"
#include "io/dispatch.hpp"
#include "io/timed_bus.hpp"
#include "io/transport.hpp"

namespace cansim::io {

using BusId = std::uint32_t;
using NodeRef = std::uint32_t;
constexpr NodeRef kNoNode = 0xFFFFFFFFu;

// A node's NodeObserver events as the loop sees them: the same meaning and
// timing (core/observer.hpp), named by NodeRef (node(ref) gives the node).
class LoopObserver {
 public:
  virtual ~LoopObserver() = default;
  virtual void on_nmt_state(NodeRef, NmtState /*old*/, NmtState /*now*/, TimeUs) {}
  virtual void on_boot_up(NodeRef, TimeUs) {}
  virtual void on_emcy(NodeRef, std::uint16_t /*code*/, std::uint8_t /*reg*/, const std::uint8_t /*vendor*/[5],
                       TimeUs) {}
  virtual void on_remote_write(NodeRef, const OdEntry&, WriteVia, TimeUs) {}
  virtual void on_power(NodeRef, bool /*powered*/, TimeUs) {}
  virtual void on_pdo_config(NodeRef, TimeUs) {}
};

// Sees the frames on a bus whose CAN-ID it asked for (LoopCore::tap_ids):
// from the wire as they are received, and local nodes' frames as they go on
// the wire, before any node handles them. Plants decode the controller's
// commands here (docs/plants.md), whatever the transport.
class FrameTap {
 public:
  virtual ~FrameTap() = default;
  virtual void on_frame(BusId bus, const CanFrame& frame, TimeUs now) = 0;
};

enum class BusModel : std::uint8_t {
  kIdeal,  // a frame is on the wire the instant its node sends it
  kTimed,  // it waits for the bus: arbitration and frame length at the bit rate
};

// A bus's traffic now (LoopCore::bus_load). Loads are fractions of the bit
// rate; offered counts what the local nodes wanted to send (dropped frames
// too) plus frames from the wire, carried what went on the wire.
struct BusLoad {
  BusModel model = BusModel::kIdeal;
  double offered_1s = 0, offered_10s = 0;
  double carried_1s = 0, carried_10s = 0;
  TimeUs delay_p50 = 0, delay_p99 = 0, delay_max = 0;  // µs from queued to start, last 10 s
  TimeUs slip_p99 = 0, slip_max = 0;                   // µs a frame left later than its schedule, last 10 s
  std::size_t queued = 0, queue_capacity = 0;          // timed: frames waiting now, bound
  std::uint64_t dropped = 0;                           // timed: frames lost to a full queue
};

struct LoopStats {
  std::uint64_t frames_in = 0;         // frames received from transports
  std::uint64_t frames_out = 0;        // frames nodes sent
  std::uint64_t local_deliveries = 0;  // frames delivered to listening local nodes
  std::uint64_t wakeups = 0;           // advance() calls
  std::uint64_t passes = 0;            // run_due() calls (the loop's wake-ups)
};

class LoopCore {
 public:
  LoopCore();
  ~LoopCore();
  LoopCore(const LoopCore&) = delete;
  LoopCore& operator=(const LoopCore&) = delete;

  // ---- set-up (allocates; not on the frame path)
  BusId add_bus(std::string name, Transport& transport, std::uint8_t bit_rate_index);
  void set_bus_bit_rate(BusId bus, std::uint8_t bit_rate_index);
  const std::string& bus_name(BusId bus) const;
  // Ideal (the default) or timed. Switching a timed bus to ideal sends what
  // waits for it at once. `queue_frames`: the timed bus's bound.
  static constexpr std::size_t kDefaultBusQueue = 1024;
  void set_bus_model(BusId bus, BusModel model, std::size_t queue_frames = kDefaultBusQueue);
  BusModel bus_model(BusId bus) const { return buses_[bus]->timed ? BusModel::kTimed : BusModel::kIdeal; }
  // A timed bus is paced by the loop (a wake-up per frame end), or, when
  // its transport paces (Transport::paces(): SO_TXTIME with the ETF qdisc)
  // or carries nothing (Transport::carries(): an interface down), handed to
  // it ahead in batches. The transport says which when the bus becomes
  // timed; update_pacer() asks it again (an interface opened or closed).
  void update_pacer(BusId bus);
  Pacer bus_pacer(BusId bus) const;
  // The bus's traffic figures at now().
  BusLoad bus_load(BusId bus) const;
  // Timed buses: a mark of the frames taken so far, and whether one taken
  // before it still waits or is on the wire (false on an ideal bus).
  std::uint64_t bus_mark(BusId bus) const { return buses_[bus]->timed ? buses_[bus]->timed->taken() : 0; }
  bool bus_holds_before(BusId bus, std::uint64_t mark) const {
    return buses_[bus]->timed && buses_[bus]->timed->holds_before(mark);
  }
  // The bus is gone (its interface is no longer configured): its queue,
  // meter and dispatch table are freed; frames waiting for its local nodes
  // are dropped. It must have no nodes. Its BusId may be reused.
  void remove_bus(BusId bus);
  bool bus_valid(BusId bus) const { return bus < buses_.size() && buses_[bus]; }
  // Builds a node (not powered yet). The core owns app and storage.
  NodeRef add_node(BusId bus, NodeSetup setup, std::unique_ptr<Application> app = nullptr,
                   std::unique_ptr<NodeStorage> storage = nullptr);
  // Powers the node on (boot-up) at `now`.
  void power_on(NodeRef ref, TimeUs now);
  // The node falls silent and is destroyed; its NodeRef may be reused. The
  // observer hears nothing of it.
  void remove_node(NodeRef ref);
  // Every node's events, present and future ones, go to `observer` (null:
  // none; then the nodes have no observer at all).
  void set_observer(LoopObserver* observer);
  // The frames of the CAN-IDs given per bus go to `tap` (null: none). An
  // identifier flagged cob::kRxIdExtended is a 29-bit one. Replaces what
  // the bus had tapped.
  void set_frame_tap(FrameTap* tap) { tap_ = tap; }
  void tap_ids(BusId bus, const std::vector<std::uint32_t>& ids);

  Node& node(NodeRef ref) { return *slots_[ref]->node; }
  const Node& node(NodeRef ref) const { return *slots_[ref]->node; }
  Application* app(NodeRef ref) { return slots_[ref]->app.get(); }
  BusId bus_of(NodeRef ref) const { return slots_[ref]->bus; }
  bool valid(NodeRef ref) const { return ref < slots_.size() && slots_[ref]; }
  std::size_t node_count() const { return live_; }
  std::size_t node_count(BusId bus) const { return buses_[bus]->nodes; }

  // ---- running (no allocation in steady state)
  // A frame received from the bus's transport (another device on the wire).
  void receive(BusId bus, const CanFrame& frame, TimeUs now);
  // A frame outside participant `from` sends at `now`: on an ideal bus it is
  // on the wire at once; on a timed bus it waits and arbitrates with the
  // nodes' frames. False when the timed bus's queue was full (dropped and
  // counted, as a node's frame would be).
  bool submit(BusId bus, const CanFrame& frame, Participant from, TimeUs now);
  // The bus's CAN controller changed state or lost frames: every node on it
  // reacts as its device does (Node::set_can_state, Node::can_overrun). The
  // state stays the bus's: nodes added later start in it.
  void controller_event(BusId bus, const ControllerEvent& event, TimeUs now);
  CanState controller_state(BusId bus) const { return buses_[bus]->controller; }
  // Advances every node whose deadline is at or before `now`.
  void run_due(TimeUs now);
  // The earliest deadline of any node or timed bus, or kNever.
  TimeUs next_deadline() const { return std::min(heap_.top_time(), bus_next_); }
  // Deterministic stepping for tests and the benchmark: runs every deadline
  // up to `t` in order, each at its own time; returns `t`.
  TimeUs run_until(TimeUs t);
  // The time the core last ran at (the fake clock of tests).
  const TimeUs& now() const { return now_; }

  const LoopStats& stats() const { return stats_; }
  // Re-reads the node's deadline and rx set and delivers the frames it sent
  // to the other local nodes, after the caller touched it directly: a local
  // operation (write_local, store_local, nmt_local, power_cycle, ...) or
  // node(ref).write() in tests and set-up code. Call it at core time now().
  void refresh(NodeRef ref);

 private:
  // A node with everything it owns. The slot is the node's FrameSink, so the
  // core knows who sent each frame.
  // The slot is also the node's observer while the core has one: it adds
  // the NodeRef.
  struct Slot : FrameSink, NodeObserver {
    LoopCore* core = nullptr;
    NodeRef ref = kNoNode;
    BusId bus = 0;
    std::uint32_t epoch_seen = 0;
    bool dirty = false;
    std::unique_ptr<Application> app;
    std::unique_ptr<NodeStorage> storage;
    std::unique_ptr<Node> node;
    void send(const CanFrame& frame) override { core->on_send(ref, frame, kOwn); }
    void send_from(const CanFrame& frame, std::uint8_t controller) override { core->on_send(ref, frame, controller); }
    void withdraw(const FrameFilter& filter, std::uint8_t controller) override {
      core->on_withdraw(ref, filter, controller);
    }
    void error(BusError e) override { core->on_error(bus, e); }
    void on_nmt_state(Node&, NmtState old, NmtState now, TimeUs t) override {
      core->observer_->on_nmt_state(ref, old, now, t);
    }
    void on_boot_up(Node&, TimeUs t) override { core->observer_->on_boot_up(ref, t); }
    void on_emcy(Node&, std::uint16_t code, std::uint8_t reg, const std::uint8_t vendor[5], TimeUs t) override {
      core->observer_->on_emcy(ref, code, reg, vendor, t);
    }
    void on_remote_write(Node&, const OdEntry& e, WriteVia via, TimeUs t) override {
      core->observer_->on_remote_write(ref, e, via, t);
    }
    void on_power(Node&, bool powered, TimeUs t) override { core->observer_->on_power(ref, powered, t); }
    void on_pdo_config(Node&, TimeUs t) override { core->observer_->on_pdo_config(ref, t); }
  };
  struct Bus {
    std::string name;
    Transport* transport = nullptr;
    std::uint8_t bit_rate_index = 3;
    std::size_t nodes = 0;
    RxDispatch dispatch;
    std::unique_ptr<TimedBus> timed;  // null: ideal
    bool carrying = true;             // timed: its transport carried frames when last asked (update_pacer)
    BusMeter meter;
    CanState controller = CanState::kErrorActive;
    // Tapped CAN-IDs: a bit per 11-bit identifier, a sorted list of 29-bit ones.
    std::vector<std::uint64_t> tapped_std;
    std::vector<std::uint32_t> tapped_ext;
    bool tapped(const CanFrame& f) const;
  };
  struct Pending {
    BusId bus;
    NodeRef from;
    CanFrame frame;
  };
  // A sender is a local node (its NodeRef) or an outside participant (tagged).
  static constexpr NodeRef kOutside = 0x80000000u;
  static bool outside(NodeRef from) { return from != kNoNode && (from & kOutside); }

  static Pacer pacer_for(const Transport& transport);
  void on_send(NodeRef from, const CanFrame& frame, std::uint8_t controller);
  void on_withdraw(NodeRef from, const FrameFilter& filter, std::uint8_t controller);
  void on_error(BusId bus, BusError e);
  // A frame is on the wire: to the transport and the other local nodes.
  void put_on_wire(BusId bus, NodeRef from, const CanFrame& frame);
  void write(Bus& b, NodeRef from, const CanFrame& frame);  // to the transport only
  // A frame handed to a transport that carried nothing, written at its end.
  void write_recalled(Bus& b, const QueuedFrame& q);
  // Whether another local node listens to the frame (it is queued for them).
  bool heard_locally(const Bus& b, NodeRef from, const CanFrame& frame) const;
  // A launched frame at its end: to the tap and the other local nodes.
  void hear_at_end(BusId bus, const Departure& d);
  // Timed buses: frames that ended by now_ leave (TimedBus::settle).
  void settle_buses(TimedBus::Phase phase);
  void settle_bus(BusId bus, TimedBus::Phase phase);
  void update_bus_next();
  // from kNoNode: a frame from outside (Node::on_frame's from_outside).
  void deliver(BusId bus, NodeRef from, const CanFrame& frame, TimeUs now);
  void after(NodeRef ref);
  void rebuild_dirty();
  void flush(TimeUs now);
  void push_pending(const Pending& p);

  std::vector<std::unique_ptr<Bus>> buses_;  // null: removed
  std::vector<BusId> free_buses_;
  std::vector<std::unique_ptr<Slot>> slots_;
  std::vector<NodeRef> free_;
  std::vector<NodeRef> dirty_;
  std::vector<std::uint32_t> scratch_ids_;
  // Ring of frames sent by local nodes, waiting to reach the other local nodes
  // (its size is a power of two).
  std::vector<Pending> ring_;
  std::size_t ring_head_ = 0;
  std::size_t ring_size_ = 0;
  DeadlineHeap heap_;
  std::size_t timed_buses_ = 0;
  // Kept here, beside the heap, so that a loop pass of the nodes does not
  // touch the buses' (cold) state: the earliest next_event() and due_ns()
  // of the timed buses, stale once one took, sent or saw a frame.
  TimeUs bus_next_ = kNever;
  std::int64_t bus_due_ns_ = std::numeric_limits<std::int64_t>::max();
  bool bus_next_stale_ = false;
  LoopObserver* observer_ = nullptr;
  FrameTap* tap_ = nullptr;
  std::size_t live_ = 0;
  TimeUs now_ = 0;
  bool flushing_ = false;
  LoopStats stats_;
};

}  // namespace cansim::io
