// One SocketCAN CAN_RAW socket per interface, shared by every node on it.
// Kernel loopback stays on (other programs on this host see our frames) and
// CAN_RAW_RECV_OWN_MSGS stays off (we do not read our own frames back: the
// loop core delivers local frames itself). Writes never block: when the
// kernel queue is full (EAGAIN / ENOBUFS) frames wait in a bounded queue that
// drains on EPOLLOUT; beyond that they are dropped and counted. An interface
// that is missing or goes down is closed and reopened by the owner's retry
// timer; its nodes keep running and resume on the wire when it is back.
//
// The socket also takes the controller's error frames (CAN_RAW_ERR_FILTER:
// bus-off, controller problems, restarted, TX timeout; not the per-frame
// protocol and bus errors, which may flood): they become ControllerReports
// for the owner, who passes them on to the nodes (LoopCore::controller_event).
// Only a real controller (link kind "can", as open() finds it) has a state:
// on a virtual bus (vcan, vxcan, ...) an error frame was written by some
// program (`cansend vcan0 20000040#...` by any local user), so it is counted
// (CanStats::error_frames_ignored) and otherwise ignored, and the interface
// stays error-active.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "core/can_frame.hpp"
#include "io/controller_event.hpp"
#include "io/kernel_pacing.hpp"
#include "io/transport.hpp"

struct can_frame;

namespace cansim::io {

struct CanStats {
  std::uint64_t rx = 0;
  std::uint64_t tx = 0;
  std::uint64_t tx_dropped = 0;  // kernel queue and our queue full
  std::uint64_t tx_offline = 0;  // sent while the interface was down / missing
  std::uint64_t tx_queued = 0;
  std::uint64_t errors = 0;
  std::uint64_t error_frames = 0;          // from the controller (CAN_ERR_FLAG)
  std::uint64_t error_frames_ignored = 0;  // error frames on a bus without a controller (written by a program)
  std::uint64_t tx_timeouts = 0;           // reported by the driver
  std::uint64_t tx_late = 0;               // paced: reached the kernel after its launch time, sent as soon as it could
  std::uint64_t tx_resent = 0;             // paced: released too late and dropped by the kernel, written again
};

// One error frame of the controller (linux/can/error.h), decoded.
struct ControllerReport {
  ControllerEvent event;  // for the nodes
  CanState before = CanState::kErrorActive;
  bool rx_overflow = false, tx_overflow = false, tx_timeout = false;
  bool restarted = false;              // CAN_ERR_RESTARTED, or the interface reopened
  int tx_errors = -1, rx_errors = -1;  // the error counters when the frame has them (CAN_ERR_CNT)
  std::uint32_t merged = 0;            // earlier reports folded into this one (CanInterface::kReports full)
};
// `state`: the controller's state before this frame.
ControllerReport decode_error_frame(const ::can_frame& f, CanState state);
const char* can_state_name(CanState s);  // "error-active", "error-warning", "error-passive", "bus-off"

// The CAN_ERR_FLAG frame a master's controller would deliver for `e`
// (linux/can/error.h): controller states with their counters (CAN_ERR_CNT:
// TX 96 / 128 / 255 at warning / passive / bus-off), protocol errors as bus
// errors with their type and location.
::can_frame error_frame(BusError e);

// Conversion between SocketCAN frames and core frames (EFF <-> kExtended,
// RTR <-> kRtr). Returns false for frames the core does not take (error frames).
bool from_socketcan(const ::can_frame& in, CanFrame& out);
void to_socketcan(const CanFrame& in, ::can_frame& out);

class CanInterface : public Transport {
 public:
  static constexpr std::size_t kBatch = 32;

  explicit CanInterface(std::string name, std::size_t tx_queue_frames = 1024);
  ~CanInterface() override;
  CanInterface(const CanInterface&) = delete;
  CanInterface& operator=(const CanInterface&) = delete;

  const std::string& name() const { return name_; }
  // Opens and binds the socket. On failure returns false and sets error().
  bool open();
  void close();
  bool is_open() const { return fd_ >= 0; }
  int fd() const { return fd_; }
  const std::string& error() const { return error_; }

  // Transport: sends now (or, deferred, at the next drain()), or queues
  // while the kernel is full, or drops (counted).
  void transmit(const CanFrame& frame) override;
  // Kernel pacing (io/kernel_pacing.hpp): from the next open() on, when the
  // interface has an ETF qdisc, every frame is written with SO_TXTIME: a
  // timed bus's at the end it has on the modelled bus (transmit_at, ns of
  // the loop core's clock, which is CLOCK_MONOTONIC - clock_base_ns), any
  // other at once. Without the qdisc the interface is not paced.
  void set_kernel_pacing(bool wanted, std::int64_t clock_base_ns) {
    pacing_wanted_ = wanted;
    clock_base_ns_ = clock_base_ns;
  }
  bool paces() const override { return fd_ >= 0 && pacing_.available; }
  bool carries() const override { return fd_ >= 0; }
  // Counted as sent while down when it was handed over; written now.
  void recalled() override {
    if (stats_.tx_offline > 0) --stats_.tx_offline;
  }
  void transmit_at(const CanFrame& frame, std::int64_t end_ns, std::int64_t length_ns) override;
  // An error frame on the interface for the other programs on it (a
  // master's CAN_RAW_ERR_FILTER): written like a frame, never read back.
  void error(BusError e) override;
  std::uint64_t errors_written() const { return errors_written_; }
  // What open() found (why: where the ETF qdisc is, or why none is used).
  const KernelPacing& pacing() const { return pacing_; }
  // Deferred sending: frames collect in the queue and go out in sendmmsg
  // batches, in order: each full batch of kBatch at once, the rest when the
  // owner drains at the end of each loop iteration.
  void set_deferred(bool deferred) { deferred_ = deferred; }
  // Reads up to kBatch frames (recvmmsg). Returns the count, 0 when nothing
  // is pending, -1 when the interface failed (is_open() is then false).
  // Error frames among them become reports (take_report()).
  int read_batch(CanFrame* out, std::size_t max);
  // What read_batch does with received kernel frames: data and remote frames
  // to `out` (returns their count), error frames to the reports.
  int accept(const ::can_frame* in, std::size_t n, CanFrame* out);
  // The controller's state (from the kernel at open, then its error frames;
  // always error-active without a controller).
  CanState controller_state() const { return state_; }
  // A real CAN controller is behind the interface: open() sets it from the
  // kernel's link kind (tests of the receive path set it themselves).
  bool has_controller() const { return has_controller_; }
  void set_has_controller(bool real) { has_controller_ = real; }
  // The next report not yet taken, oldest first; false when none. At most
  // kReports wait: beyond, the oldest are merged away (the state stays exact).
  static constexpr std::size_t kReports = 16;
  bool take_report(ControllerReport& out);
  // Sends queued frames (sendmmsg); returns false if the interface failed.
  bool drain();
  // Paced: the frames the kernel's timers released too late (ETF drops a
  // frame whose launch time passed while it waited: the socket's error
  // queue has them, EPOLLERR) are written again at once. Returns how many.
  int resend_dropped();
  // True while frames wait for EPOLLOUT.
  bool wants_write() const { return queued_ > 0; }
  // Set when the caller must update the epoll mask (write interest changed).
  bool take_interest_changed() {
    bool c = interest_changed_;
    interest_changed_ = false;
    return c;
  }
  const CanStats& stats() const { return stats_; }
  // Drops since the last call (for rate-limited logging).
  std::uint64_t take_new_drops() {
    std::uint64_t d = stats_.tx_dropped - drops_reported_;
    drops_reported_ = stats_.tx_dropped;
    return d;
  }

 private:
  // A frame waiting to be written; launch: paced, its end (core ns), or kAsap.
  struct Outgoing {
    ::can_frame raw() const;
    CanFrame frame;
    std::int64_t launch_ns;
    std::int64_t length_ns = 0;  // paced: its length on the modelled bus
    bool error = false;          // an error frame: `frame` holds its can_frame's bytes
  };
  static constexpr std::int64_t kAsap = -1;
  bool fail(const char* what, int err);
  void enqueue(const Outgoing& out);
  void put(const Outgoing& out);
  bool send_now(const Outgoing& out, bool& again);
  void setup_pacing();
  // The SCM_TXTIME of a frame (CLOCK_TAI ns).
  std::uint64_t launch_tai(const Outgoing& out, std::int64_t tai_now, std::int64_t tai_minus_core);

  void report(const ControllerReport& r);

  std::string name_;
  int fd_ = -1;
  CanState state_ = CanState::kErrorActive;
  bool has_controller_ = false;
  ControllerReport reports_[kReports];
  std::size_t report_head_ = 0, report_count_ = 0;
  std::string error_;
  std::vector<Outgoing> queue_;  // ring, fixed size
  std::size_t head_ = 0;
  std::size_t queued_ = 0;
  bool interest_changed_ = false;
  bool deferred_ = false;
  bool kernel_full_ = false;  // the last drain() met EAGAIN / ENOBUFS
  bool pacing_wanted_ = false;
  std::int64_t clock_base_ns_ = 0;
  KernelPacing pacing_;
  std::uint64_t errors_written_ = 0;
  std::int64_t last_launch_tai_ = 0;
  CanStats stats_;
  std::uint64_t drops_reported_ = 0;
};

// What the kernel says of a network interface (netlink RTM_GETLINK): its
// link kind ("vcan", "can", "vxcan", ...; empty when missing or unknown) and,
// for a real CAN controller, its nominal bit rate (IFLA_CAN_BITTIMING, bit/s;
// 0 when unknown).
struct KernelLink {
  std::string kind;
  std::uint32_t bit_rate = 0;
  int can_state = -1;              // IFLA_CAN_STATE (enum can_state), -1 when unknown
  std::uint32_t tx_queue_len = 0;  // IFLA_TXQLEN
  unsigned flags = 0;              // IFF_*
  // A CAN controller with a bit timing: it paces the frames itself.
  bool real_can() const { return kind == "can"; }
};
KernelLink kernel_link(const std::string& ifname);
std::uint32_t kernel_bit_rate(const std::string& ifname);

}  // namespace cansim::io
