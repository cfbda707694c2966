#include "ctl/monitor.hpp"

#include <linux/can.h>
#include <linux/can/raw.h>
#include <net/if.h>
#include <sys/socket.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <cstdio>
#include <cstring>
#include <map>
#include <set>

#include "ctl/client_loop.hpp"
#include "ctl/decode.hpp"
#include "ctl/frame_decoder.hpp"
#include "ctl/json.hpp"

namespace cansim::ctl {

std::string node_label(const std::string& name, std::uint32_t index, bool name_shared) {
  return name_shared ? name + "/" + std::to_string(index) : name;
}

namespace {

// A CAN_RAW socket on one interface, with the kernel's receive time of each frame.
class CanSocket {
 public:
  explicit CanSocket(const std::string& interface) : interface_(interface) {
    fd_ = socket(PF_CAN, SOCK_RAW | SOCK_NONBLOCK | SOCK_CLOEXEC, CAN_RAW);
    if (fd_ < 0) throw Failure("cannot open a CAN socket: " + std::string(std::strerror(errno)));
    const unsigned index = if_nametoindex(interface.c_str());
    if (index == 0) {
      close(fd_);
      throw Failure("no CAN interface " + interface + " (the fleet's nodes on it are off the bus)");
    }
    const int on = 1;
    setsockopt(fd_, SOL_SOCKET, SO_TIMESTAMP, &on, sizeof on);
    const can_err_mask_t errors = CAN_ERR_MASK;
    setsockopt(fd_, SOL_CAN_RAW, CAN_RAW_ERR_FILTER, &errors, sizeof errors);
    sockaddr_can addr{};
    addr.can_family = AF_CAN;
    addr.can_ifindex = int(index);
    if (bind(fd_, reinterpret_cast<sockaddr*>(&addr), sizeof addr) < 0) {
      const int e = errno;
      close(fd_);
      throw Failure("cannot listen on " + interface + ": " + std::strerror(e));
    }
  }
  ~CanSocket() { close(fd_); }
  CanSocket(const CanSocket&) = delete;
  CanSocket& operator=(const CanSocket&) = delete;

  int fd() const { return fd_; }
  const std::string& interface() const { return interface_; }

  // The next frame; false when none is waiting.
  bool receive(RawFrame& out) {
    can_frame frame{};
    iovec iov{&frame, sizeof frame};
    alignas(cmsghdr) char control[CMSG_SPACE(sizeof(timeval))];
    msghdr msg{};
    msg.msg_iov = &iov;
    msg.msg_iovlen = 1;
    msg.msg_control = control;
    msg.msg_controllen = sizeof control;
    const ssize_t n = recvmsg(fd_, &msg, 0);
    if (n < 0) {
      if (errno == EAGAIN || errno == EINTR) return false;
      throw Failure("cannot read " + interface_ + ": " + std::strerror(errno));
    }
    out = RawFrame{};
    out.interface = interface_;
    out.time = receive_time(msg);
    out.extended = frame.can_id & CAN_EFF_FLAG;
    out.rtr = frame.can_id & CAN_RTR_FLAG;
    out.id = frame.can_id & (out.extended ? CAN_EFF_MASK : CAN_SFF_MASK);
    if (frame.can_id & CAN_ERR_FLAG) out.id = frame.can_id & CAN_ERR_MASK;
    out.dlc = std::min<std::uint8_t>(frame.can_dlc, 8);
    std::memcpy(out.data, frame.data, out.dlc);
    return true;
  }

 private:
  static double receive_time(msghdr& msg) {
    for (cmsghdr* c = CMSG_FIRSTHDR(&msg); c; c = CMSG_NXTHDR(&msg, c)) {
      if (c->cmsg_level != SOL_SOCKET || c->cmsg_type != SO_TIMESTAMP) continue;
      timeval tv;
      std::memcpy(&tv, CMSG_DATA(c), sizeof tv);
      return double(tv.tv_sec) + double(tv.tv_usec) / 1e6;
    }
    timespec ts;
    clock_gettime(CLOCK_REALTIME, &ts);
    return double(ts.tv_sec) + double(ts.tv_nsec) / 1e9;
  }

  std::string interface_;
  int fd_ = -1;
};

std::string last_segment(const std::string& key) { return key.substr(key.rfind('/') + 1); }

class Monitor {
 public:
  Monitor(Connection& connection, const MonitorOptions& options, std::ostream& out)
      : connection_(connection),
        options_(options),
        out_(out),
        decoder_([this](NodeInfo& n) { load_objects(n); }) {}

  int run();

 private:
  void load_fleet();
  NodeInfo describe(const std::string& path, const std::string& key, const std::string& label,
                    const std::string& interface, std::uint8_t node_id);
  void refresh(const std::string& path);
  void add(const std::string& path);
  void load_objects(NodeInfo& n);
  void on_signal(sd_bus_message* m);
  void on_frames(CanSocket& socket);
  void print(const DecodedFrame& f);
  std::vector<std::string> fleet_interfaces();

  Connection& connection_;
  const MonitorOptions& options_;
  std::ostream& out_;
  FrameDecoder decoder_;
  std::string only_key_;
  std::map<std::string, std::string> path_by_key_;
  std::map<std::string, int> name_count_;
};

std::string path_of(sd_bus_message* m) {
  const char* p = sd_bus_message_get_path(m);
  return p ? p : "";
}

NodeInfo Monitor::describe(const std::string& path, const std::string& key, const std::string& label,
                           const std::string& interface, std::uint8_t node_id) {
  NodeInfo n;
  n.key = key;
  n.label = label;
  n.interface = interface;
  n.node_id = node_id;
  MessagePtr reply = connection_.call(path, kNodeInterface, "GetPdoMapping");
  n.pdos = read_pdo_infos(reply.get());
  return n;
}

void Monitor::load_fleet() {
  MessagePtr reply = connection_.call(kFleetPath, kFleetInterface, "ListNodes");
  std::vector<NodeRow> rows = read_node_rows(reply.get());
  for (const NodeRow& r : rows) ++name_count_[r.name];
  for (const NodeRow& r : rows) {
    path_by_key_[r.key] = r.path;
    const auto index = std::uint32_t(std::stoul(last_segment(r.key)));
    const std::string label = node_label(r.name, index, name_count_[r.name] > 1);
    decoder_.set_node(describe(r.path, r.key, label, r.interface, r.node_id));
  }
}

// After PdoMappingChanged or a NodeId change: the node's PDOs and node-ID now.
void Monitor::refresh(const std::string& path) {
  const std::string key = node_key_of_path(path);
  NodeInfo* old = decoder_.node(key);
  if (!old) return add(path);
  std::vector<Arg> property{Value(std::string(kNodeInterface)), Value(std::string("NodeId"))};
  MessagePtr reply = connection_.call(path, kPropertiesInterface, "Get", property);
  const Value id = read_value(reply.get());
  NodeInfo n = describe(path, key, old->label, old->interface, std::get<std::uint8_t>(id));
  decoder_.set_node(std::move(n));  // objects reloaded when an SDO needs them (units may have changed)
}

void Monitor::add(const std::string& path) {
  MessagePtr reply = connection_.call(path, kPropertiesInterface, "GetAll", {Value(std::string(kNodeInterface))});
  NodeStatus s = read_node_status(reply.get());
  path_by_key_[s.key] = path;
  const bool shared = ++name_count_[s.name] > 1 || s.index > 0;
  decoder_.set_node(describe(path, s.key, node_label(s.name, s.index, shared), s.interface, s.node_id));
}

// What SDO and EMCY frames need: the node's objects and its EMCY codes.
void Monitor::load_objects(NodeInfo& n) {
  auto it = path_by_key_.find(n.key);
  if (it == path_by_key_.end()) return;
  if (!n.objects) n.objects = read_object_infos(connection_.call(it->second, kNodeInterface, "ListObjects").get());
  if (!n.emcy_codes) n.emcy_codes = read_emcy_codes(connection_.call(it->second, kNodeInterface, "ListEmcyCodes").get());
}

void Monitor::on_signal(sd_bus_message* m) {
  const std::string member = sd_bus_message_get_member(m);
  if (member == "PdoMappingChanged") return refresh(path_of(m));
  if (member == "NodeAdded" || member == "NodeRemoved") {
    const char *path = nullptr, *key = nullptr;
    expect(sd_bus_message_read(m, "os", &path, &key), "unexpected signal from cansimd");
    if (member == "NodeAdded") return add(path);
    decoder_.remove_node(key);
    path_by_key_.erase(key);
    return;
  }
  if (member != "PropertiesChanged") return;
  Event e = read_event(m);
  for (const Field& f : e.fields) {
    const auto* id = std::get_if<std::uint8_t>(&f.value);
    NodeInfo* n = decoder_.node(e.source);
    if (f.name == "NodeId" && id && n && n->node_id != *id) return refresh(path_of(m));
  }
}

void Monitor::print(const DecodedFrame& f) {
  if (!only_key_.empty() && f.node != only_key_) return;
  if (!options_.json) {
    out_ << format_decoded(f) << '\n';
    return;
  }
  JsonWriter json(out_);
  write_decoded_json(json, f);
  out_ << '\n';
}

void Monitor::on_frames(CanSocket& socket) {
  RawFrame frame;
  while (socket.receive(frame)) print(decoder_.decode(frame));
  out_.flush();
}

std::vector<std::string> Monitor::fleet_interfaces() {
  MessagePtr reply = connection_.call(kFleetPath, kFleetInterface, "GetBusStatistics");
  std::vector<std::string> names;
  for (const BusStats& b : read_bus_stats(reply.get())) names.push_back(b.name);
  return names;
}

int Monitor::run() {
  ClientLoop loop(connection_);
  loop.on_signals("type='signal',path_namespace='" + std::string(kFleetPath) + "'",
                  [this](sd_bus_message* m) { on_signal(m); });
  connection_.call(kFleetPath, kFleetInterface, "Subscribe");
  if (!options_.node.empty()) only_key_ = node_key_of_path(connection_.node_path(options_.node));
  load_fleet();
  std::vector<std::string> names = options_.interfaces.empty() ? fleet_interfaces() : options_.interfaces;
  std::vector<std::unique_ptr<CanSocket>> sockets;
  std::string errors;
  for (const std::string& name : names) {
    try {
      sockets.push_back(std::make_unique<CanSocket>(name));
    } catch (const Failure& e) {
      if (!options_.interfaces.empty()) throw;
      errors += std::string(errors.empty() ? "" : "; ") + e.what();
    }
  }
  if (sockets.empty()) throw Failure(errors.empty() ? "the fleet has no interface" : errors);
  if (!errors.empty()) std::fprintf(stderr, "cansimctl: %s\n", errors.c_str());
  for (auto& s : sockets) loop.on_readable(s->fd(), [this, socket = s.get()] { on_frames(*socket); });
  return loop.run();
}

}  // namespace

int run_monitor(Connection& connection, const MonitorOptions& options, std::ostream& out) {
  return Monitor(connection, options, out).run();
}

}  // namespace cansim::ctl
