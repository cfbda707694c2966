// One CANopen slave: the object dictionary values plus every CiA 301 / 305
// service, driven by frames and time passed in by the caller. No sockets, no
// clock, no threads: the caller delivers frames (on_frame), advances time
// (advance) and sleeps until next_deadline().
#pragma once

#include <array>
#include <cstdint>
#include <memory>
#include <optional>
#include <span>
#include <vector>

#include "core/application.hpp"
#include "core/can_frame.hpp"
#include "core/disturbance.hpp"
#include "core/emcy.hpp"
#include "core/frame_faults.hpp"
#include "core/guarding.hpp"
#include "core/heartbeat.hpp"
#include "core/lss_slave.hpp"
#include "core/nmt.hpp"
#include "core/node_options.hpp"
#include "core/observer.hpp"
#include "core/od.hpp"
#include "core/pdo.hpp"
#include "core/sdo_server.hpp"
#include "core/store.hpp"
#include "core/sync.hpp"

namespace cansim {

struct NodeSetup {
  std::shared_ptr<const OdLayout> layout;      // shared by all nodes of a profile
  std::shared_ptr<const NodeOptions> options;  // shared by all nodes of a profile
  std::uint8_t node_id = 1;                    // 1..127, 0xFF = LSS-unconfigured
  std::uint8_t bit_rate_index = 3;             // CiA 305 table index (3 = 250 kbit/s)
  // The node's 0x1018:04 default (a fleet entry's `serial:`, a profile's
  // `serial_number_base` + the node's index): applied wherever the profile's
  // defaults are, as $NODEID is, so the application's on_reset (vendor
  // copies of the serial) sees it. Unset: the profile's default.
  std::optional<std::uint32_t> serial_number;
  // The node's own randomness (its response times' jitter); from the fleet
  // seed and the node's key where the daemon builds it.
  std::uint64_t seed = 1;
};

// Services gated by NMT state (CiA 301 Table 82).
enum class Service : std::uint8_t { kSdo, kSync, kEmcy, kPdo, kTime };

// Which of a node's services sent a frame (Node::tx_source).
enum class TxService : std::uint8_t { kOther, kNmt, kEmcy, kTpdo, kSdo, kBootUp, kHeartbeat, kLss };
struct TxSource {
  TxService service = TxService::kOther;
  std::uint16_t tpdo = 0;  // kTpdo: its number, 1..512
};

class Node;

// A node's whole state at one instant (Node::snapshot): OD values, node-ID and
// bit rates, power and bus flags, its own timers, and every service with its
// timers, transfers and histories. Not in it: the configuration and what the
// node is wired to (sink, application, storage, observer), which a restore
// leaves as they are.
class NodeSnapshot {
 private:
  friend class Node;
  explicit NodeSnapshot(const Node& node);

  OdValues values_;
  std::uint8_t node_id_, bit_rate_, bus_bit_rate_;
  bool powered_, silent_, muted_, bus_off_;
  CanState can_state_;
  std::uint32_t power_ons_;
  TimeUs env_next_, power_on_at_, app_next_, now_;
  double drift_ppm_;
  FrameFaults frame_faults_;
  Disturbance disturbance_;
  NmtSlave nmt_;
  LssSlave lss_;
  SdoServer sdo_;
  Heartbeat heartbeat_;
  NodeGuarding guarding_;
  SyncConsumer sync_;
  PdoEngine pdo_;
  Emcy emcy_;
  StoreRestore store_;
};

class Node {
 public:
  Node(NodeSetup setup, FrameSink& sink, Application* app = nullptr, NodeStorage* storage = nullptr);
  Node(const Node&) = delete;
  Node& operator=(const Node&) = delete;

  // ---- lifecycle and I/O (called by the loop or a test)
  void power_on(TimeUs now);
  // Falls silent, as an unpowered sensor. With a time the observer hears of
  // it (on_power, then the NMT state INITIALISING); without, nobody does
  // (the node is being destroyed).
  void power_off(TimeUs now);
  void power_off();
  bool powered() const { return powered_; }
  // Power cut now, power back `off_for` later (>= 0): then the node boots as
  // at power-on (stored values kept, volatile ones lost). Safe to call from
  // inside advance() (e.g. by the application); the power-on is a deadline.
  void power_cycle(TimeUs now, TimeUs off_for);
  // from_outside: a frame nobody local wrote (frame faults by COB-ID act
  // on it, docs/faults.md).
  void on_frame(const CanFrame& frame, TimeUs now, bool from_outside = false);
  void advance(TimeUs now);
  TimeUs next_deadline() const;

  // The bus the node is attached to runs at this CiA 305 bit-rate index. A node
  // whose own rate differs neither hears nor speaks.
  void set_bus_bit_rate(std::uint8_t index) { bus_bit_rate_ = index; }
  std::uint8_t bit_rate_index() const { return bit_rate_; }
  void set_bit_rate_index(std::uint8_t index) { bit_rate_ = index; }
  bool on_bus() const { return powered_ && !silent_ && !muted_ && !off_bus() && bit_rate_ == bus_bit_rate_; }
  // Alive but sending nothing (LSS bit-timing switch delay); cleared at power-on.
  void set_silent(bool silent) { silent_ = silent; }
  // Alive but sending nothing (fault injection); kept over power cycles.
  void set_muted(bool muted) { muted_ = muted; }
  bool muted() const { return muted_; }
  // The CAN controller went bus-off (fault injection): the node neither hears
  // nor sends until it recovers; entering runs the 0x1029:01 reaction,
  // recovering sends the bus_off_recovery_emcy (CiA 301 0x8140). Power-on
  // starts with the controller error-active.
  void set_bus_off(bool off, TimeUs now);
  bool bus_off() const { return bus_off_; }
  // The error state of the CAN controller of the real interface the node is
  // on, from its error frames (io::LoopCore::controller_event; ISO 11898-1
  // fault confinement). Error passive raises error_passive_emcy (CiA 301
  // 0x8120) until the controller is error active again; bus-off and the
  // controller's restart act as set_bus_off() does (0x1029:01 reaction,
  // recovery EMCY). The state is the interface's: a power cycle keeps it.
  void set_can_state(CanState state, TimeUs now);
  CanState can_state() const { return can_state_; }
  // The controller lost frames (rx / tx overflow): can_overrun_emcy.
  void can_overrun(TimeUs now);

  // Sends a frame if the node is on the bus; true when it was handed to the sink.
  bool send(const CanFrame& frame);
  // Which service sends `frame`, from the configuration now: the error
  // control COB-ID with 0x00 is the boot-up, with anything else a heartbeat
  // or node guarding answer.
  TxSource tx_source(const CanFrame& frame) const;
  // The same, `delay` later (response times): held like a delayed frame.
  bool send_after(const CanFrame& frame, TimeUs delay);
  // Frames handed to the sink since the node was built (the control API's FramesSent).
  std::uint64_t frames_sent() const { return frames_sent_; }

  // ---- network fault injection (personalities/comm_faults drives
  // these from the fault schedule at its edges)
  FrameFaults& frame_faults() { return frame_faults_; }
  const FrameFaults& frame_faults() const { return frame_faults_; }
  Disturbance& disturbance() { return disturbance_; }
  // node_id_collision: a second device of the node's profile at its node-ID
  // (its own default values, the serial number + 1, no application) boots
  // now and runs beside it until off: its boot-up, heartbeat, SDO answers
  // and PDOs reach the wire from the controller FrameSink::kTwin. It hears
  // what the node hears; neither hears the other.
  void set_twin(bool on, TimeUs now);
  const Node* twin() const { return twin_.get(); }
  // clock_drift: the node's time base runs fast (ppm > 0) or slow: every
  // duration it measures with its own clock (heartbeat producer and
  // consumer, event timers, inhibit times, the SYNC window, node guarding)
  // takes local_duration() in true time, from its next start on.
  void set_clock_drift(double ppm) { drift_ppm_ = ppm; }
  double clock_drift() const { return drift_ppm_; }
  TimeUs local_duration(TimeUs nominal) const;
  // error_frames: the master's controller reports `e` (never the local nodes).
  void report_bus_error(BusError e) { sink_.error(e); }

  // ---- observation: one observer per node (null: none, zero cost)
  void set_observer(NodeObserver* observer) { observer_ = observer; }
  NodeObserver* observer() const { return observer_; }

  // ---- identity and state
  std::uint8_t node_id() const { return node_id_; }
  // Sets the active node-ID (LSS / vendor objects); takes effect for COB-IDs
  // at the next reset communication, as CiA 305 says.
  void set_node_id(std::uint8_t id) { node_id_ = id; }
  std::uint8_t configured_node_id() const { return setup_.node_id; }
  // The node-ID that $NODEID defaults add (option node_id_defaults_follow_lss).
  std::uint8_t default_node_id() const { return options().node_id_defaults_follow_lss ? node_id_ : setup_.node_id; }
  std::uint8_t configured_bit_rate_index() const { return setup_.bit_rate_index; }
  NmtState state() const { return nmt_.state(); }
  // NMT decides which services run (CiA 301 Table 82, as lely-core's
  // per-state service sets): in the current state / in `state`.
  bool allowed(Service s) const;
  bool allowed_in(NmtState state, Service s) const;

  const OdLayout& od() const { return *setup_.layout; }
  OdValues& values() { return values_; }
  const OdValues& values() const { return values_; }
  const NodeOptions& options() const { return *setup_.options; }
  // The node's own randomness (ResponseTime draws) since its last power-on:
  // NodeSetup::seed and the power-on's number.
  std::uint64_t seed() const { return mix_seed(setup_.seed, power_ons_); }
  // How often the node was powered on (the first power-on is 1).
  std::uint32_t power_ons() const { return power_ons_; }
  Application* app() { return app_; }
  // Makes Application::process run at `at` at the latest (NMT change, write).
  void wake_app(TimeUs at) {
    if (app_ && at < app_next_) app_next_ = at;
  }
  // Makes Application::environment run at `at` at the latest (fault armed).
  void wake_environment(TimeUs at) {
    if (app_ && at < env_next_) env_next_ = at;
  }
  NodeStorage* storage() { return storage_; }

  // ---- OD access as a remote client (SDO, RPDO) sees it: access rights,
  // type length, limits, owning service, application hooks.
  SdoAbort read(const OdEntry& e, TimeUs now, std::span<const std::uint8_t>& out);
  SdoAbort read(std::uint16_t index, std::uint8_t sub, TimeUs now, std::span<const std::uint8_t>& out);
  SdoAbort write(const OdEntry& e, std::span<const std::uint8_t> data, TimeUs now);
  SdoAbort write(std::uint16_t index, std::uint8_t sub, std::span<const std::uint8_t> data, TimeUs now);
  // Refreshes a kHookRead entry (TPDO sampling) without access checks.
  void refresh(const OdEntry& e, TimeUs now);

  // ---- local access, as the device's own application: no access-right check
  // (read-only / const objects may be written, write-only ones read); type
  // length, limits, owning service, application hooks and their consequences
  // (PDO events, reconfiguration) as for a remote access. Not observed as a
  // remote write. After a local operation the caller re-reads next_deadline()
  // and the rx set (LoopCore::refresh).
  SdoAbort read_local(const OdEntry& e, TimeUs now, std::span<const std::uint8_t>& out);
  SdoAbort write_local(const OdEntry& e, std::span<const std::uint8_t> data, TimeUs now);
  // "save" to 0x1010:sub / "load" to 0x1011:sub (CiA 301 §7.5.2.13-14);
  // kNoObject / kNoSubIndex when the profile lacks it.
  SdoAbort store_local(std::uint8_t sub, TimeUs now);
  SdoAbort restore_local(std::uint8_t sub, TimeUs now);
  // An NMT command specifier (0x01, 0x02, 0x80, 0x81, 0x82) executed by the
  // device itself, through the same path as the master's frame (state
  // changes, reset node / communication, boot-up). False when the node is
  // unpowered or the specifier unknown (then nothing happens).
  bool nmt_local(std::uint8_t cs, TimeUs now);

  // ---- reset building blocks (used by NMT and LSS)
  // First step of every reset: services that define
  // `void prepare_reset(ResetKind, TimeUs)` run it (LSS: apply a pending node-ID).
  void prepare_reset(ResetKind kind, TimeUs now);
  void reset_values(ResetKind kind);  // defaults, then stored values
  // The entry of a node_id_object / bit_rate_object option (null when 0 / absent).
  const OdEntry* config_object(std::int64_t index) const;
  void reset_services(TimeUs now);  // services re-read their OD configuration
  // Called by NMT after every state change: services that define
  // `void on_nmt_state(NmtState old, TimeUs)` run it, then Application::on_nmt_state.
  void nmt_state_changed(NmtState old, TimeUs now);

  // ---- dispatch support: the COB-IDs this node listens to. rx_epoch()
  // changes whenever that set may have changed.
  void collect_rx_ids(std::vector<std::uint32_t>& out) const;
  std::uint32_t rx_epoch() const { return rx_epoch_ + (twin_ ? twin_->rx_epoch() : 0); }
  void rx_changed() { ++rx_epoch_; }

  // ---- services
  NmtSlave& nmt() { return nmt_; }
  SdoServer& sdo() { return sdo_; }
  Heartbeat& heartbeat() { return heartbeat_; }
  NodeGuarding& guarding() { return guarding_; }
  SyncConsumer& sync() { return sync_; }
  PdoEngine& pdo() { return pdo_; }
  const PdoEngine& pdo() const { return pdo_; }
  Emcy& emcy() { return emcy_; }
  StoreRestore& store() { return store_; }
  LssSlave& lss() { return lss_; }

  std::size_t memory_bytes() const { return sizeof(*this) + values_.memory_bytes(); }

  // ---- snapshots: the node's state taken whole and brought back with plain
  // copies (no reset sequence run, nothing sent, the observer not told; no
  // allocation once the node's buffers are as large as the snapshot's). A
  // fuzz input starts from the state right after power-on this way.
  // restore() takes a snapshot of a node of the same layout (false, and
  // nothing changes, for another); the application and the storage are the
  // caller's to bring back alongside.
  NodeSnapshot snapshot() const { return NodeSnapshot(*this); }
  bool restore(const NodeSnapshot& snapshot);

 private:
  void load_all_values();
  // The profile's defaults of [first, last] with this node's: $NODEID and
  // NodeSetup::serial_number.
  void reset_to_defaults(std::uint16_t first = 0x0000, std::uint16_t last = 0xFFFF);
  // The access-right independent part of read / write (owning service,
  // limits, application hooks).
  SdoAbort read_value(const OdEntry& e, TimeUs now, std::span<const std::uint8_t>& out);
  SdoAbort write_value(const OdEntry& e, std::span<const std::uint8_t> data, TimeUs now);
  SdoAbort write_signature(std::uint16_t index, std::uint8_t sub, std::uint32_t signature, TimeUs now);
  template <typename Fn>
  void for_each_service(Fn&& fn);
  template <typename Fn>
  void for_each_service(Fn&& fn) const;
  // NMT gating of received frames (CiA 301 Table 82); LSS, NMT and error
  // control hear every frame, SYNC and EMCY gate themselves.
  bool hears(const SdoServer&) const { return allowed(Service::kSdo); }
  bool hears(const PdoEngine&) const { return allowed(Service::kPdo); }
  template <typename S>
  bool hears(const S&) const {
    return true;
  }
  bool off_bus() const { return bus_off_ || can_state_ == CanState::kBusOff; }
  // What the NMT state `now` no longer sends leaves the transmit buffer.
  void withdraw_for(NmtState now);
  // Entry points note the time: frames sent later in the same call (held
  // by a delay fault) count from it.
  void note(TimeUs now) { now_ = std::max(now_, now); }
  void hear(const CanFrame& frame, TimeUs now);
  void run_faults(TimeUs now);
  // The twin's frames, from its own controller.
  struct TwinSink final : FrameSink {
    explicit TwinSink(Node& n) : node(n) {}
    void send(const CanFrame& f) override { node.sink_.send_from(f, kTwin); }
    void withdraw(const FrameFilter& filter, std::uint8_t) override { node.sink_.withdraw(filter, kTwin); }
    Node& node;
  };
  // After bus_off_ or can_state_ changed: the reaction to going off the bus,
  // or the recovery EMCY.
  void bus_off_changed(bool was_off, TimeUs now);

  friend class NodeSnapshot;

  NodeSetup setup_;
  FrameSink& sink_;
  Application* app_;
  NodeStorage* storage_;
  NodeObserver* observer_ = nullptr;
  std::uint64_t frames_sent_ = 0;
  // The state: every member from here on is in NodeSnapshot (add new ones
  // there and to restore() too), rx_epoch_ excepted (restore() moves it on).
  OdValues values_;
  std::uint8_t node_id_;
  std::uint8_t bit_rate_;
  std::uint8_t bus_bit_rate_;
  bool powered_ = false;
  bool silent_ = false;
  bool muted_ = false;
  bool bus_off_ = false;
  CanState can_state_ = CanState::kErrorActive;
  TimeUs env_next_ = kNever;
  TimeUs power_on_at_ = kNever;  // while unpowered: when power comes back
  std::uint32_t rx_epoch_ = 0;
  std::uint32_t power_ons_ = 0;
  TimeUs app_next_ = kNever;
  TimeUs now_ = 0;  // the last time an entry point was called with
  // Not state: a snapshot has none (restore() ends it). Beside now_, as
  // the deadline board and the faults' counts: advance() reads them at
  // every wake-up.
  std::unique_ptr<Node> twin_;
  // The services' deadlines, written through by their Deadline members
  // (core/node_service.hpp): not state of its own (a restore writes it).
  std::array<TimeUs, kDeadlineSlots> due_ = [] {
    std::array<TimeUs, kDeadlineSlots> none;
    none.fill(kNever);
    return none;
  }();
  friend TimeUs* deadline_slot(Node& node, DeadlineSlot slot);
  template <typename S>
  TimeUs due(const S&) const;
  // The board says what each service's next_deadline() says (asserted).
  bool board_holds() const;
  double drift_ppm_ = 0;
  Disturbance disturbance_;  // its count first, beside the board
  FrameFaults frame_faults_;
  TwinSink twin_sink_{*this};

  NmtSlave nmt_{*this};
  LssSlave lss_{*this};
  SdoServer sdo_{*this};
  Heartbeat heartbeat_{*this};
  NodeGuarding guarding_{*this};
  SyncConsumer sync_{*this};
  PdoEngine pdo_{*this};
  Emcy emcy_{*this};
  StoreRestore store_{*this};
};

}  // namespace cansim
