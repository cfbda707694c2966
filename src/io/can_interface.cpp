#include "io/can_interface.hpp"

#include <linux/can.h>
#include <linux/can/error.h>
#include <linux/can/netlink.h>
#include <linux/can/raw.h>
#include <linux/if_link.h>
#include <linux/netlink.h>
#include <linux/rtnetlink.h>
#include <net/if.h>
#include <sys/ioctl.h>
#include <sys/socket.h>
#include <unistd.h>

#include <cerrno>
#include <cstring>

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
  error_.clear();
  interest_changed_ = true;
  // A controller that was bus-off or passive when we last saw it may have
  // restarted meanwhile (down / up): its state now is the kernel's.
  const int kernel = kernel_link(name_).can_state;
  const CanState now = kernel == CAN_STATE_BUS_OFF       ? CanState::kBusOff
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

void CanInterface::report(const ControllerReport& r) {
  if (r.event.state_changed) state_ = r.event.state;
  if (report_count_ == kReports) {
    // Full: the oldest report goes, its losses folded into the next one.
    ControllerReport& next = reports_[(report_head_ + 1) % kReports];
    const ControllerReport& oldest = reports_[report_head_];
    next.event.frames_lost |= oldest.event.frames_lost;
    next.event.state_changed |= oldest.event.state_changed;
    next.before = oldest.before;
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

void CanInterface::enqueue(const CanFrame& frame) {
  if (queued_ == queue_.size()) {
    ++stats_.tx_dropped;
    return;
  }
  if (queued_ == 0) interest_changed_ = true;
  queue_[(head_ + queued_) % queue_.size()] = frame;
  ++queued_;
  ++stats_.tx_queued;
}

bool CanInterface::send_now(const CanFrame& frame, bool& again) {
  ::can_frame cf;
  to_socketcan(frame, cf);
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

void CanInterface::transmit(const CanFrame& frame) {
  if (fd_ < 0) {
    ++stats_.tx_offline;  // interface down: the frame goes nowhere
    return;
  }
  if (deferred_) {
    if (queued_ == queue_.size()) drain();  // a burst larger than the queue
    if (queued_ < queue_.size()) {
      queue_[(head_ + queued_++) % queue_.size()] = frame;
      // A full sendmmsg batch leaves at once: in a long pass the first
      // nodes' frames do not wait for the last nodes' (the same syscalls).
      if (queued_ >= kBatch && !kernel_full_) drain();
      return;
    }
  }
  if (queued_ > 0) {  // keep the order: behind what already waits
    enqueue(frame);
    return;
  }
  bool again = false;
  if (send_now(frame, again)) return;
  if (again) enqueue(frame);
  else ++stats_.tx_dropped;
}

bool CanInterface::drain() {
  while (queued_ > 0 && fd_ >= 0) {
    ::can_frame frames[kBatch];
    mmsghdr msgs[kBatch];
    iovec iov[kBatch];
    std::size_t n = std::min(queued_, kBatch);
    for (std::size_t i = 0; i < n; ++i) {
      to_socketcan(queue_[(head_ + i) % queue_.size()], frames[i]);
      iov[i] = {&frames[i], sizeof frames[i]};
      msgs[i] = {};
      msgs[i].msg_hdr.msg_iov = &iov[i];
      msgs[i].msg_hdr.msg_iovlen = 1;
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
  const rtattr* info = find_attr(IFLA_RTA(ifi), len, IFLA_LINKINFO);
  if (!info) return;
  const auto* nested = static_cast<const rtattr*>(RTA_DATA(info));
  if (const rtattr* kind = find_attr(nested, int(RTA_PAYLOAD(info)), IFLA_INFO_KIND))
    out.kind.assign(static_cast<const char*>(RTA_DATA(kind)), strnlen(static_cast<const char*>(RTA_DATA(kind)), RTA_PAYLOAD(kind)));
  const rtattr* data = find_attr(nested, int(RTA_PAYLOAD(info)), IFLA_INFO_DATA);
  if (!data) return;
  const auto* can = static_cast<const rtattr*>(RTA_DATA(data));
  if (const rtattr* st = find_attr(can, int(RTA_PAYLOAD(data)), IFLA_CAN_STATE); st && RTA_PAYLOAD(st) >= sizeof(std::uint32_t)) {
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
  unsigned index = if_nametoindex(ifname.c_str());
  if (index == 0) return link;
  int fd = ::socket(AF_NETLINK, SOCK_RAW | SOCK_CLOEXEC, NETLINK_ROUTE);
  if (fd < 0) return link;
  struct {
    nlmsghdr h;
    ifinfomsg i;
  } req{};
  req.h.nlmsg_len = NLMSG_LENGTH(sizeof req.i);
  req.h.nlmsg_type = RTM_GETLINK;
  req.h.nlmsg_flags = NLM_F_REQUEST;
  req.h.nlmsg_seq = 1;
  req.i.ifi_family = AF_UNSPEC;
  req.i.ifi_index = int(index);
  timeval tv{1, 0};
  ::setsockopt(fd, SOL_SOCKET, SO_RCVTIMEO, &tv, sizeof tv);
  if (::send(fd, &req, req.h.nlmsg_len, 0) >= 0) {
    alignas(nlmsghdr) char buf[16384];
    ssize_t n = ::recv(fd, buf, sizeof buf, 0);
    int len = int(n);
    for (auto* h = reinterpret_cast<nlmsghdr*>(buf); n > 0 && NLMSG_OK(h, len); h = NLMSG_NEXT(h, len))
      if (h->nlmsg_type == RTM_NEWLINK) read_link(h, link);
  }
  ::close(fd);
  return link;
}

std::uint32_t kernel_bit_rate(const std::string& ifname) { return kernel_link(ifname).bit_rate; }

}  // namespace cansim::io
