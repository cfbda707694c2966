#include "io/can_interface.hpp"

#include <linux/can.h>
#include <linux/can/error.h>
#include <linux/can/netlink.h>
#include <linux/can/raw.h>
#include <linux/if_link.h>
#include <linux/net_tstamp.h>
#include <linux/netlink.h>
#include <linux/rtnetlink.h>
#include <net/if.h>
#include <sys/ioctl.h>
#include <sys/socket.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <cstring>
#include <ctime>

#include "io/netlink.hpp"

namespace cansim::io {

bool from_socketcan(const ::can_frame& in, CanFrame& out) {
  if (in.can_id & CAN_ERR_FLAG) return false;
  out = CanFrame{};
  if (in.can_id & CAN_EFF_FLAG) {
    out.id = in.can_id & CAN_EFF_MASK;
    out.flags |= CanFrame::kExtended;
  } else {
    out.id = in.can_id & CAN_SFF_MASK;
  }
  out.dlc = in.len > 8 ? 8 : in.len;
  if (in.can_id & CAN_RTR_FLAG) out.flags |= CanFrame::kRtr;
  else std::memcpy(out.data, in.data, out.dlc);
  return true;
}

void to_socketcan(const CanFrame& in, ::can_frame& out) {
  std::memset(&out, 0, sizeof out);
  out.can_id = in.extended() ? ((in.id & CAN_EFF_MASK) | CAN_EFF_FLAG) : (in.id & CAN_SFF_MASK);
  if (in.rtr()) out.can_id |= CAN_RTR_FLAG;
  out.len = in.dlc > 8 ? 8 : in.dlc;
  if (!in.rtr()) std::memcpy(out.data, in.data, out.len);
}

::can_frame error_frame(BusError e) {
  ::can_frame f;
  std::memset(&f, 0, sizeof f);
  f.len = CAN_ERR_DLC;
  f.can_id = CAN_ERR_FLAG;
  auto counters = [&](std::uint8_t tx) {
    f.can_id |= CAN_ERR_CNT;
    f.data[6] = tx;
  };
  switch (e) {
    case BusError::kWarning:
      f.can_id |= CAN_ERR_CRTL;
      f.data[1] = CAN_ERR_CRTL_TX_WARNING;
      counters(96);
      break;
    case BusError::kPassive:
      f.can_id |= CAN_ERR_CRTL;
      f.data[1] = CAN_ERR_CRTL_TX_PASSIVE;
      counters(128);
      break;
    case BusError::kActive:
      f.can_id |= CAN_ERR_CRTL;
      f.data[1] = CAN_ERR_CRTL_ACTIVE;
      counters(0);
      break;
    case BusError::kBusOff:
      f.can_id |= CAN_ERR_BUSOFF;
      counters(255);
      break;
    case BusError::kRestarted: f.can_id |= CAN_ERR_RESTARTED; break;
    case BusError::kStuff:
      f.can_id |= CAN_ERR_PROT | CAN_ERR_BUSERROR;
      f.data[2] = CAN_ERR_PROT_STUFF;
      f.data[3] = CAN_ERR_PROT_LOC_DATA;
      break;
    case BusError::kForm:
      f.can_id |= CAN_ERR_PROT | CAN_ERR_BUSERROR;
      f.data[2] = CAN_ERR_PROT_FORM;
      f.data[3] = CAN_ERR_PROT_LOC_EOF;
      break;
    case BusError::kAck:
      f.can_id |= CAN_ERR_ACK | CAN_ERR_BUSERROR;
      f.data[3] = CAN_ERR_PROT_LOC_ACK;
      break;
  }
  return f;
}

const char* can_state_name(CanState s) {
  switch (s) {
    case CanState::kErrorActive: return "error-active";
    case CanState::kErrorWarning: return "error-warning";
    case CanState::kErrorPassive: return "error-passive";
    case CanState::kBusOff: return "bus-off";
  }
  return "?";
}

// The kernel's can_change_state() sets CAN_ERR_BUSOFF, or CAN_ERR_CRTL with
// the new state's warning / passive / active bits in data[1] (the higher of
// the RX and TX states); CAN_ERR_RESTARTED follows a restart after bus-off.
ControllerReport decode_error_frame(const ::can_frame& f, CanState state) {
  ControllerReport r;
  r.before = state;
  CanState now = state;
  if (f.can_id & CAN_ERR_RESTARTED) {
    r.restarted = true;
    now = CanState::kErrorActive;
  }
  if (f.can_id & CAN_ERR_CRTL) {
    const std::uint8_t c = f.data[1];
    r.rx_overflow = c & CAN_ERR_CRTL_RX_OVERFLOW;
    r.tx_overflow = c & CAN_ERR_CRTL_TX_OVERFLOW;
    if (c & (CAN_ERR_CRTL_RX_PASSIVE | CAN_ERR_CRTL_TX_PASSIVE)) now = CanState::kErrorPassive;
    else if (c & (CAN_ERR_CRTL_RX_WARNING | CAN_ERR_CRTL_TX_WARNING)) now = CanState::kErrorWarning;
    else if (c & CAN_ERR_CRTL_ACTIVE) now = CanState::kErrorActive;
  }
  if (f.can_id & CAN_ERR_BUSOFF) now = CanState::kBusOff;
  r.tx_timeout = f.can_id & CAN_ERR_TX_TIMEOUT;
  if (f.can_id & CAN_ERR_CNT) {
    r.tx_errors = f.data[6];
    r.rx_errors = f.data[7];
  }
  r.event.state = now;
  r.event.state_changed = now != state;
  r.event.frames_lost = r.rx_overflow || r.tx_overflow;
  return r;
}

CanInterface::CanInterface(std::string name, std::size_t tx_queue_frames)
    : name_(std::move(name)), queue_(tx_queue_frames ? tx_queue_frames : 1) {}

CanInterface::~CanInterface() { close(); }

bool CanInterface::fail(const char* what, int err) {
  error_ = std::string(what) + ": " + std::strerror(err);
  ++stats_.errors;
  close();
  return false;
}

bool CanInterface::open() {
  close();
  if (name_.size() >= IFNAMSIZ) return fail("interface name too long", EINVAL);
  unsigned index = if_nametoindex(name_.c_str());
  if (index == 0) return fail("no such interface", errno);
  fd_ = ::socket(PF_CAN, SOCK_RAW | SOCK_NONBLOCK | SOCK_CLOEXEC, CAN_RAW);
  if (fd_ < 0) return fail("socket(PF_CAN)", errno);
  ifreq ifr{};
  std::memcpy(ifr.ifr_name, name_.c_str(), name_.size());
  if (::ioctl(fd_, SIOCGIFFLAGS, &ifr) < 0) return fail("SIOCGIFFLAGS", errno);
  if (!(ifr.ifr_flags & IFF_UP)) return fail("interface is down", ENETDOWN);
  // A larger receive buffer absorbs bursts (best effort).
  int rcvbuf = 1 << 20;
  ::setsockopt(fd_, SOL_SOCKET, SO_RCVBUF, &rcvbuf, sizeof rcvbuf);
  sockaddr_can addr{};
  addr.can_family = AF_CAN;
  addr.can_ifindex = int(index);
  if (::bind(fd_, reinterpret_cast<sockaddr*>(&addr), sizeof addr) < 0) return fail("bind", errno);
  can_err_mask_t errors = CAN_ERR_TX_TIMEOUT | CAN_ERR_CRTL | CAN_ERR_BUSOFF | CAN_ERR_RESTARTED;
  ::setsockopt(fd_, SOL_CAN_RAW, CAN_RAW_ERR_FILTER, &errors, sizeof errors);
  setup_pacing();
  error_.clear();
  interest_changed_ = true;
  // A controller that was bus-off or passive when we last saw it may have
  // restarted meanwhile (down / up): its state now is the kernel's.
  const KernelLink link = kernel_link(name_);
  has_controller_ = link.real_can();
  const int kernel = has_controller_ ? link.can_state : -1;
  const CanState now = kernel == CAN_STATE_BUS_OFF         ? CanState::kBusOff
                       : kernel == CAN_STATE_ERROR_PASSIVE ? CanState::kErrorPassive
                       : kernel == CAN_STATE_ERROR_WARNING ? CanState::kErrorWarning
                                                           : CanState::kErrorActive;
  if (now != state_) {
    ControllerReport r;
    r.before = state_;
    r.restarted = state_ == CanState::kBusOff && now != CanState::kBusOff;
    r.event.state = now;
    r.event.state_changed = true;
    report(r);
  }
  return true;
}

// SO_TXTIME with CLOCK_TAI and error reports (resend_dropped()); the
// priority of the ETF band.
void CanInterface::setup_pacing() {
  pacing_ = {};
  last_launch_tai_ = 0;
  if (!pacing_wanted_) return;
  pacing_ = kernel_pacing(name_);
  if (!pacing_.available) return;
  const sock_txtime txtime{CLOCK_TAI, SOF_TXTIME_REPORT_ERRORS};
  const bool ok = (pacing_.priority < 0 ||
                   ::setsockopt(fd_, SOL_SOCKET, SO_PRIORITY, &pacing_.priority, sizeof pacing_.priority) == 0) &&
                  ::setsockopt(fd_, SOL_SOCKET, SO_TXTIME, &txtime, sizeof txtime) == 0;
  if (ok) return;
  pacing_.available = false;
  pacing_.why = std::string("SO_TXTIME: ") + std::strerror(errno);
}

void CanInterface::report(const ControllerReport& r) {
  if (r.event.state_changed) state_ = r.event.state;
  if (report_count_ == kReports) {
    // Full: the oldest report goes, folded into the next one: its losses and
    // the state before it (a change there and back is no change).
    ControllerReport& next = reports_[(report_head_ + 1) % kReports];
    const ControllerReport& oldest = reports_[report_head_];
    next.event.frames_lost |= oldest.event.frames_lost;
    next.rx_overflow |= oldest.rx_overflow;
    next.tx_overflow |= oldest.tx_overflow;
    next.tx_timeout |= oldest.tx_timeout;
    next.restarted |= oldest.restarted;
    next.before = oldest.before;
    next.event.state_changed = next.event.state != next.before;
    next.merged += oldest.merged + 1;
    report_head_ = (report_head_ + 1) % kReports;
    --report_count_;
  }
  reports_[(report_head_ + report_count_++) % kReports] = r;
}

bool CanInterface::take_report(ControllerReport& out) {
  if (report_count_ == 0) return false;
  out = reports_[report_head_];
  report_head_ = (report_head_ + 1) % kReports;
  --report_count_;
  return true;
}

int CanInterface::accept(const ::can_frame* in, std::size_t n, CanFrame* out) {
  int kept = 0;
  for (std::size_t i = 0; i < n; ++i) {
    if (in[i].can_id & CAN_ERR_FLAG) {
      if (!has_controller_) {
        ++stats_.error_frames_ignored;
        continue;
      }
      ++stats_.error_frames;
      const ControllerReport r = decode_error_frame(in[i], state_);
      stats_.tx_timeouts += r.tx_timeout;
      if (r.event.state_changed || r.event.frames_lost || r.tx_timeout || r.restarted) report(r);
      continue;
    }
    if (from_socketcan(in[i], out[kept])) ++kept;
  }
  stats_.rx += std::uint64_t(kept);
  return kept;
}

void CanInterface::close() {
  if (fd_ >= 0) ::close(fd_);
  fd_ = -1;
  // Frames waiting for a dead socket are lost, as on a bus that went away.
  stats_.tx_offline += queued_;
  queued_ = 0;
  head_ = 0;
  kernel_full_ = false;
}

void CanInterface::enqueue(const Outgoing& out) {
  if (queued_ == queue_.size()) {
    ++stats_.tx_dropped;
    return;
  }
  if (queued_ == 0) interest_changed_ = true;
  queue_[(head_ + queued_) % queue_.size()] = out;
  ++queued_;
  ++stats_.tx_queued;
}

bool CanInterface::send_now(const Outgoing& out, bool& again) {
  const ::can_frame cf = out.raw();
  again = false;
  ssize_t n = ::write(fd_, &cf, sizeof cf);
  if (n == ssize_t(sizeof cf)) {
    ++stats_.tx;
    return true;
  }
  if (n < 0 && (errno == EAGAIN || errno == ENOBUFS)) {
    again = true;
    return false;
  }
  fail("write", n < 0 ? errno : EIO);
  return false;
}

::can_frame CanInterface::Outgoing::raw() const {
  ::can_frame cf;
  if (error) std::memcpy(&cf, &frame, sizeof cf);
  else to_socketcan(frame, cf);
  return cf;
}

void CanInterface::transmit(const CanFrame& frame) { put({frame, kAsap}); }

void CanInterface::error(BusError e) {
  static_assert(sizeof(CanFrame) >= sizeof(::can_frame));
  Outgoing out{};
  const ::can_frame cf = error_frame(e);
  std::memcpy(static_cast<void*>(&out.frame), &cf, sizeof cf);
  out.error = true;
  out.launch_ns = kAsap;
  ++errors_written_;
  put(out);
}

void CanInterface::transmit_at(const CanFrame& frame, std::int64_t end_ns, std::int64_t length_ns) {
  put({frame, paces() ? end_ns : kAsap, length_ns});
}

void CanInterface::put(const Outgoing& out) {
  if (fd_ < 0) {
    ++stats_.tx_offline;  // interface down: the frame goes nowhere
    return;
  }
  // A paced socket writes every frame with a launch time, in sendmmsg batches.
  if (deferred_ || pacing_.available) {
    if (queued_ == queue_.size()) drain();  // a burst larger than the queue
    if (queued_ < queue_.size()) {
      queue_[(head_ + queued_++) % queue_.size()] = out;
      // A full sendmmsg batch leaves at once: in a long pass the first
      // nodes' frames do not wait for the last nodes' (the same syscalls).
      if ((queued_ >= kBatch || !deferred_) && !kernel_full_) drain();
      return;
    }
  }
  if (queued_ > 0) {  // keep the order: behind what already waits
    enqueue(out);
    return;
  }
  bool again = false;
  if (send_now(out, again)) return;
  if (again) enqueue(out);
  else ++stats_.tx_dropped;
}

namespace {
std::int64_t clock_ns(clockid_t id) {
  timespec ts;
  clock_gettime(id, &ts);
  return std::int64_t(ts.tv_sec) * 1'000'000'000 + ts.tv_nsec;
}
}  // namespace

// ETF takes a frame whose launch time is not before the clock nor before the
// last one it released, and releases it `delta` before it (io/kernel_pacing.hpp):
// a frame is launched at its end + delta, one without a time at now + delta.
// A frame that reaches the kernel after its end (a slow loop pass) leaves
// as soon as it can, and the frames after it keep their spacing from it:
// the bus slips here too rather than releasing them at once.
std::uint64_t CanInterface::launch_tai(const Outgoing& out, std::int64_t tai_now, std::int64_t tai_minus_core) {
  std::int64_t at = std::max(tai_now + pacing_.delta_ns, last_launch_tai_);
  if (out.launch_ns != kAsap) {
    const std::int64_t scheduled = out.launch_ns + tai_minus_core + pacing_.delta_ns;
    if (scheduled < at) ++stats_.tx_late;
    at = std::max({at, scheduled, last_launch_tai_ + out.length_ns});
  }
  last_launch_tai_ = at;
  return std::uint64_t(at);
}

bool CanInterface::drain() {
  while (queued_ > 0 && fd_ >= 0) {
    ::can_frame frames[kBatch];
    mmsghdr msgs[kBatch];
    iovec iov[kBatch];
    alignas(cmsghdr) char control[kBatch][CMSG_SPACE(sizeof(std::uint64_t))];
    const bool paced = pacing_.available;
    const std::int64_t tai_now = paced ? clock_ns(CLOCK_TAI) : 0;
    const std::int64_t tai_minus_core = paced ? tai_now - clock_ns(CLOCK_MONOTONIC) + clock_base_ns_ : 0;
    std::size_t n = std::min(queued_, kBatch);
    for (std::size_t i = 0; i < n; ++i) {
      const Outgoing& out = queue_[(head_ + i) % queue_.size()];
      frames[i] = out.raw();
      iov[i] = {&frames[i], sizeof frames[i]};
      msgs[i] = {};
      msgs[i].msg_hdr.msg_iov = &iov[i];
      msgs[i].msg_hdr.msg_iovlen = 1;
      if (!paced) continue;
      msgs[i].msg_hdr.msg_control = control[i];
      msgs[i].msg_hdr.msg_controllen = sizeof control[i];
      cmsghdr* c = CMSG_FIRSTHDR(&msgs[i].msg_hdr);
      c->cmsg_level = SOL_SOCKET;
      c->cmsg_type = SCM_TXTIME;
      c->cmsg_len = CMSG_LEN(sizeof(std::uint64_t));
      const std::uint64_t at = launch_tai(out, tai_now, tai_minus_core);
      std::memcpy(CMSG_DATA(c), &at, sizeof at);
    }
    int sent = ::sendmmsg(fd_, msgs, unsigned(n), MSG_DONTWAIT);
    if (sent < 0) {
      if (errno != EAGAIN && errno != ENOBUFS) return fail("sendmmsg", errno);
      kernel_full_ = true;  // wait for the next EPOLLOUT (or the owner's retry)
      return true;
    }
    kernel_full_ = std::size_t(sent) < n;
    head_ = (head_ + std::size_t(sent)) % queue_.size();
    queued_ -= std::size_t(sent);
    stats_.tx += std::uint64_t(sent);
    if (kernel_full_) return true;
  }
  if (queued_ == 0) interest_changed_ = true;
  return fd_ >= 0;
}

int CanInterface::resend_dropped() {
  int n = 0;
  for (; fd_ >= 0; ++n) {
    ::can_frame cf;
    alignas(cmsghdr) char control[256];
    iovec iov{&cf, sizeof cf};
    msghdr m{};
    m.msg_iov = &iov;
    m.msg_iovlen = 1;
    m.msg_control = control;
    m.msg_controllen = sizeof control;
    if (::recvmsg(fd_, &m, MSG_ERRQUEUE | MSG_DONTWAIT) < ssize_t(sizeof cf)) break;
    CanFrame f;
    if (!from_socketcan(cf, f)) continue;
    ++stats_.tx_resent;
    put({f, kAsap});
  }
  return n;
}

int CanInterface::read_batch(CanFrame* out, std::size_t max) {
  if (fd_ < 0) return -1;
  ::can_frame frames[kBatch];
  mmsghdr msgs[kBatch];
  iovec iov[kBatch];
  std::size_t n = std::min(max, kBatch);
  for (std::size_t i = 0; i < n; ++i) {
    iov[i] = {&frames[i], sizeof frames[i]};
    msgs[i] = {};
    msgs[i].msg_hdr.msg_iov = &iov[i];
    msgs[i].msg_hdr.msg_iovlen = 1;
  }
  int got = ::recvmmsg(fd_, msgs, unsigned(n), MSG_DONTWAIT, nullptr);
  if (got < 0) {
    if (errno == EAGAIN || errno == EINTR) return 0;
    fail("recvmmsg", errno);
    return -1;
  }
  // Classic CAN frames to the front (CAN FD ones are not for us).
  std::size_t classic = 0;
  for (int i = 0; i < got; ++i)
    if (msgs[i].msg_len >= CAN_MTU) frames[classic++] = frames[i];
  return accept(frames, classic, out);
}

// ---- netlink: IFLA_LINKINFO / IFLA_INFO_DATA / IFLA_CAN_BITTIMING

namespace {

const rtattr* find_attr(const rtattr* a, int len, unsigned short type) {
  for (; RTA_OK(a, len); a = RTA_NEXT(a, len))
    if ((a->rta_type & NLA_TYPE_MASK) == type) return a;
  return nullptr;
}

void read_link(const nlmsghdr* h, KernelLink& out) {
  const auto* ifi = static_cast<const ifinfomsg*>(NLMSG_DATA(h));
  int len = int(h->nlmsg_len) - int(NLMSG_LENGTH(sizeof *ifi));
  out.flags = ifi->ifi_flags;
  if (const rtattr* q = find_attr(IFLA_RTA(ifi), len, IFLA_TXQLEN); q && RTA_PAYLOAD(q) >= sizeof(std::uint32_t))
    std::memcpy(&out.tx_queue_len, RTA_DATA(q), sizeof out.tx_queue_len);
  const rtattr* info = find_attr(IFLA_RTA(ifi), len, IFLA_LINKINFO);
  if (!info) return;
  const auto* nested = static_cast<const rtattr*>(RTA_DATA(info));
  if (const rtattr* kind = find_attr(nested, int(RTA_PAYLOAD(info)), IFLA_INFO_KIND))
    out.kind.assign(static_cast<const char*>(RTA_DATA(kind)),
                    strnlen(static_cast<const char*>(RTA_DATA(kind)), RTA_PAYLOAD(kind)));
  const rtattr* data = find_attr(nested, int(RTA_PAYLOAD(info)), IFLA_INFO_DATA);
  if (!data) return;
  const auto* can = static_cast<const rtattr*>(RTA_DATA(data));
  if (const rtattr* st = find_attr(can, int(RTA_PAYLOAD(data)), IFLA_CAN_STATE);
      st && RTA_PAYLOAD(st) >= sizeof(std::uint32_t)) {
    std::uint32_t v;
    std::memcpy(&v, RTA_DATA(st), sizeof v);
    out.can_state = int(v);
  }
  const rtattr* bt = find_attr(can, int(RTA_PAYLOAD(data)), IFLA_CAN_BITTIMING);
  if (!bt || RTA_PAYLOAD(bt) < sizeof(can_bittiming)) return;
  can_bittiming timing;
  std::memcpy(&timing, RTA_DATA(bt), sizeof timing);
  out.bit_rate = timing.bitrate;
}

}  // namespace

KernelLink kernel_link(const std::string& ifname) {
  KernelLink link;
  const unsigned index = if_nametoindex(ifname.c_str());
  if (index == 0) return link;
  ifinfomsg i{};
  i.ifi_family = AF_UNSPEC;
  i.ifi_index = int(index);
  netlink_route_query(RTM_GETLINK, false, i, [&](const nlmsghdr* h) {
    if (h->nlmsg_type == RTM_NEWLINK) read_link(h, link);
  });
  return link;
}

std::uint32_t kernel_bit_rate(const std::string& ifname) { return kernel_link(ifname).bit_rate; }

}  // namespace cansim::io
