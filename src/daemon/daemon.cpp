#include "daemon/daemon.hpp"

#include <spdlog/spdlog.h>
#include <sys/epoll.h>
#include <systemd/sd-daemon.h>

#include <algorithm>
#include <csignal>
#include <filesystem>
#include <fstream>
#include <set>

#include "core/node.hpp"
#include "daemon/bus_load.hpp"
#include "daemon/file_storage.hpp"
#include "daemon/free_memory.hpp"
#include "daemon/logging.hpp"
#include "io/frame_schedule.hpp"
#include "personalities/registry.hpp"
#include "physics/random.hpp"

#ifndef CANSIM_PROFILE_DIR
#define CANSIM_PROFILE_DIR ""
#endif

namespace cansim::daemon {

namespace {
constexpr TimeUs kRetryPeriod = 1'000'000;    // reopen a missing / down interface
constexpr TimeUs kDrainRetry = 1'000;         // kernel queue full (ENOBUFS): retry
constexpr TimeUs kStatusPeriod = 5'000'000;   // STATUS= and drop reports
constexpr TimeUs kDownReminder = 30'000'000;  // repeat "still down" warnings
constexpr int kReadBatchesPerWake = 16;       // fairness between interfaces
constexpr TimeUs kTrimDelay = 1'000'000;      // removed nodes' memory back to the kernel
// CAN-controller journal lines of one interface: at most this many per period.
constexpr int kControllerLinesBurst = 8;
constexpr TimeUs kControllerLinePeriod = 10'000'000;

// The configured rate, else the kernel's (real CAN), else 250 kbit/s.
std::uint32_t resolve_bit_rate(const config::InterfaceConfig& ic, bool* from_kernel = nullptr) {
  if (ic.bit_rate_kbit) return ic.bit_rate_kbit;
  if (ic.socketcand()) return 250;  // no kernel behind it
  std::uint32_t kernel = io::kernel_bit_rate(ic.name);
  if (from_kernel) *from_kernel = kernel != 0;
  return kernel ? kernel / 1000 : 250;
}
// A socketcand bus's settings: its `listen:` and the bounds of config/limits.hpp.
io::SocketcandSettings socketcand_settings(const config::InterfaceConfig& ic) {
  io::SocketcandSettings s;
  s.bus = ic.name;
  s.host = ic.listen_host;
  s.port = ic.listen_port;
  s.max_clients = limits::kSocketcandClients;
  s.max_unread = limits::kSocketcandUnread;
  s.send_buffer = limits::kSocketcandSendBuffer;
  s.read_per_pass = limits::kSocketcandReadPerPass;
  s.max_in_flight = limits::kSocketcandInFlight;
  s.rawmode_hold = limits::kSocketcandRawmodeHoldUs;
  s.warning_period = limits::kWarningPeriodUs;
  return s;
}

// The server's journal lines, with the bus as their subject (CANSIM_IFACE=).
io::SocketcandServer::Log socketcand_log(const std::string& name) {
  return [name](io::SocketcandServer::Level level, const std::string& line) {
    const auto subject = LogSubject::interface(name);
    if (level == io::SocketcandServer::Level::kWarn) spdlog::warn("{}", line);
    else if (level == io::SocketcandServer::Level::kInfo) spdlog::info("{}", line);
    else spdlog::debug("{}", line);
  };
}

// --socketcand: every interface a kernel-free bus of its own name on a free
// loopback port, so a test's fleet runs where the kernel has no CAN and
// fleets started side by side never share a bus.
void serve_as_socketcand(std::vector<config::InterfaceConfig>& interfaces) {
  for (config::InterfaceConfig& ic : interfaces) {
    ic.transport = config::TransportKind::kSocketcand;
    ic.listen_host = "127.0.0.1";
    ic.listen_port = 0;
    ic.allow_remote = false;
  }
}

std::string endpoint(const std::string& host, std::uint16_t port) {
  const bool v6 = host.find(':') != std::string::npos;
  return (v6 ? "[" + host + "]" : host) + ":" + std::to_string(port);
}

}  // namespace

// ---------------------------------------------------------------- building

config::ProfileSearch profile_search(const std::string& config_file) {
  return config::default_search(config_file, CANSIM_PROFILE_DIR);
}

namespace {
// The node's place in the fleet, as its physics and its response times see it.
personalities::NodeContext node_context(const config::NodeConfig& node, std::uint64_t fleet_seed) {
  personalities::NodeContext ctx;
  ctx.fleet_seed = fleet_seed;
  ctx.index = node.index;
  ctx.key = node.key;
  return ctx;
}
}  // namespace

NodeSetup node_setup(const config::NodeConfig& node, std::uint64_t fleet_seed) {
  NodeSetup setup = config::node_setup(*node.profile, node.node_id, node.index);
  setup.bit_rate_index = config::bit_rate_selector(node.bit_rate_kbit);
  if (node.serial) setup.serial_number = node.serial;
  setup.seed = physics::derive_seed(personalities::node_seed(node_context(node, fleet_seed)),
                                    physics::hash_string("response times"));
  return setup;
}

std::unique_ptr<Application> make_node_application(const config::NodeConfig& node, std::uint64_t seed,
                                                   const std::string& state_dir, const physics::PlantResolver* plants) {
  personalities::NodeContext ctx = node_context(node, seed);
  ctx.plants = plants;
  ctx.record_file = node.record_file;
  ctx.state_dir = state_dir;
  if (!ctx.record_file.empty()) {
    std::error_code ec;  // a failure shows when the file is opened
    std::filesystem::create_directories(std::filesystem::path(ctx.record_file).parent_path(), ec);
  }
  return personalities::make_application(*node.profile, ctx);
}

std::uint32_t effective_bit_rate(const config::InterfaceConfig& ic) { return resolve_bit_rate(ic); }

namespace {
// Counts `n` in its entry's mismatch (fleet entries are contiguous, in order).
void add_mismatch(std::vector<BitRateMismatch>& out, const config::NodeConfig& n, std::uint32_t bus_kbit) {
  auto it = std::find_if(out.begin(), out.end(), [&](const BitRateMismatch& m) {
    return m.interface == n.interface && m.name == n.name && m.node_kbit == n.bit_rate_kbit;
  });
  if (it == out.end()) {
    out.push_back({n.interface, n.name, 0, n.node_id, n.node_id, n.bit_rate_kbit, bus_kbit});
    it = out.end() - 1;
  }
  ++it->count;
  it->first_id = std::min(it->first_id, n.node_id);
  it->last_id = std::max(it->last_id, n.node_id);
}
}  // namespace

std::vector<BitRateMismatch> bit_rate_mismatches(
    const config::FleetConfig& fleet, const std::function<std::uint32_t(const config::InterfaceConfig&)>& bus_kbit) {
  std::vector<BitRateMismatch> out;
  std::map<std::string, std::uint32_t> rates;
  for (const auto& ic : fleet.interfaces) rates[ic.name] = bus_kbit(ic);
  for (const auto& n : fleet.nodes) {
    auto rate = rates.find(n.interface);
    if (rate != rates.end() && config::bit_rate_selector(n.bit_rate_kbit) != config::bit_rate_selector(rate->second))
      add_mismatch(out, n, rate->second);
  }
  return out;
}

std::string describe(const BitRateMismatch& m) {
  char ids[48];
  if (m.first_id == 255) std::snprintf(ids, sizeof ids, "LSS-unconfigured");
  else if (m.first_id == m.last_id) std::snprintf(ids, sizeof ids, "node-ID 0x%02X", m.first_id);
  else std::snprintf(ids, sizeof ids, "node-IDs 0x%02X..0x%02X", m.first_id, m.last_id);
  const bool one = m.count == 1;
  return m.interface + "/" + m.name + ": " + std::to_string(m.count) + (one ? " node (" : " nodes (") + ids + ") run" +
         (one ? "s" : "") + " at " + std::to_string(m.node_kbit) + " kbit/s but " + m.interface + " at " +
         std::to_string(m.bus_kbit) + " kbit/s: " + (one ? "it stays" : "they stay") +
         " silent until the rates match. Fix: set `bit_rate: " + std::to_string(m.bus_kbit) +
         "` on the node entry (or `bit_rate: " + std::to_string(m.node_kbit) + "` on interface " + m.interface + ")";
}

std::vector<std::string> load_warnings(const config::FleetConfig& fleet) {
  std::vector<std::string> out;
  std::set<std::string> seen;  // a fleet entry's variant carries its profile's
  for (const auto& p : fleet.profiles)
    for (const std::string& w : p->warnings)
      if (seen.insert(w).second) out.push_back(w);
  return out;
}

std::string check_fleet(config::FleetConfig& fleet, std::vector<std::string>* warnings) {
  const std::unique_ptr<physics::PlantSet> plants = PlantWiring::build(fleet.plants, fleet.seed);
  const physics::PlantSetResolver resolver(*plants);
  for (config::NodeConfig n : fleet.nodes) {
    n.record_file.clear();  // --check must not truncate recordings
    make_node_application(n, fleet.seed, {}, &resolver);
  }
  if (warnings) *warnings = load_warnings(fleet);
  if (warnings)
    for (const BitRateMismatch& m : bit_rate_mismatches(fleet, effective_bit_rate)) warnings->push_back(describe(m));
  std::string plants_text;
  if (!fleet.plants.empty()) plants_text = ", " + std::to_string(fleet.plants.specs.size()) + " plant(s)";
  return fleet.file + ": ok, " + std::to_string(fleet.nodes.size()) + " node(s) on " +
         std::to_string(fleet.interfaces.size()) + " interface(s)" + plants_text;
}

// ---------------------------------------------------------------- interfaces

struct Daemon::Interface : io::FdHandler {
  Interface(Daemon& d, std::string name) : daemon(d), can(std::move(name)) {}
  void on_events(std::uint32_t events) override { daemon.on_can_events(*this, events); }
  // Open (a kernel interface) or listening (a socketcand bus).
  bool up() const { return tcp ? tcp->listening() : can.is_open(); }
  std::uint64_t frames_in() const { return tcp ? tcp->stats().frames_in : can.stats().rx; }
  std::uint64_t frames_out() const { return tcp ? tcp->stats().frames_out : can.stats().tx; }

  Daemon& daemon;
  io::CanInterface can;                       // a kernel interface (unused, never opened, for a socketcand bus)
  std::unique_ptr<io::SocketcandServer> tcp;  // `transport: socketcand`: cansimd is the wire
  io::FrameSchedule scheduled{limits::kQueuedFramesPerBus};  // Fleet1.QueueFrames: a replay's frames
  io::BusId bus = 0;
  std::uint32_t bit_rate_kbit = 250;
  bool configured = false;
  bool in_epoll = false;
  std::uint32_t mask = 0;
  TimeUs retry_at = kNever;
  TimeUs drain_at = kNever;
  TimeUs last_down_log = 0;
  bool reported_down = false;
  config::BusModelChoice bus_model = config::BusModelChoice::kAuto;
  bool real_can = false;  // the kernel says: a CAN controller (it paces the bus)
  std::uint64_t bus_drops_reported = 0;
  std::uint64_t resent_reported = 0, late_reported = 0;  // kernel pacing
  std::set<std::string> node_keys;                       // the running nodes on it
  LineBudget controller_lines{kControllerLinesBurst, kControllerLinePeriod};
  std::uint64_t ignored_reported = 0;  // error frames ignored (no controller), as last logged
  TimeUs next_ignored_line = 0;
};

// The loop lives as long as the daemon: start() adds the interfaces and the
// control API to it, run() the signals.
Daemon::Daemon(DaemonSettings settings) : settings_(std::move(settings)) {
  if (!loop_.open()) throw std::runtime_error(loop_.error());
}
Daemon::~Daemon() {
  endpoints_.reset();
  plants_.detach(core_.now());
  core_.set_observer(nullptr);
}

Daemon::Interface& Daemon::ensure_interface(const config::InterfaceConfig& ic) {
  Interface* iface = nullptr;
  for (auto& i : interfaces_)
    if (i->can.name() == ic.name) iface = i.get();
  if (!iface) {
    interfaces_.push_back(std::make_unique<Interface>(*this, ic.name));
    iface = interfaces_.back().get();
    if (ic.socketcand()) {
      iface->tcp = std::make_unique<io::SocketcandServer>(loop_, socketcand_settings(ic));
      iface->bus = core_.add_bus(ic.name, *iface->tcp, 3);
      iface->tcp->attach(
          core_, iface->bus, [this] { return clock_now(); }, socketcand_log(ic.name));
    } else {
      iface->bus = core_.add_bus(ic.name, iface->can, 3);
      // Timed buses on an interface with an ETF qdisc are paced by the kernel.
      iface->can.set_kernel_pacing(true, epoch_ * 1000);
    }
    iface->retry_at = 0;  // open at the next housekeeping pass
  }
  const auto subject = LogSubject::interface(ic.name);
  bool from_kernel = false;
  std::uint32_t kbit = resolve_bit_rate(ic, &from_kernel);
  if (ic.bit_rate_kbit == 0 && kbit != iface->bit_rate_kbit)
    spdlog::info("{}: bit rate {} kbit/s ({})", ic.name, kbit, from_kernel ? "from the kernel" : "default");
  if (config::bit_rate_index(kbit) < 0)
    spdlog::warn("{}: {} kbit/s is not in the CiA 305 table: every node will stay silent", ic.name, kbit);
  iface->bit_rate_kbit = kbit;
  core_.set_bus_bit_rate(iface->bus, config::bit_rate_selector(kbit));
  iface->bus_model = ic.bus_model;
  apply_bus_model(*iface, iface->tcp ? io::KernelLink{} : io::kernel_link(ic.name));
  iface->configured = true;
  return *iface;
}

// Timed on a virtual bus unless `bus_model: ideal`; a real CAN controller
// paces its own bus (docs/bus-model.md). A missing interface counts as
// virtual until it appears.
void Daemon::apply_bus_model(Interface& iface, const io::KernelLink& link) {
  iface.real_can = link.real_can();
  const bool timed = !iface.real_can && iface.bus_model != config::BusModelChoice::kIdeal;
  const io::BusModel model = timed ? io::BusModel::kTimed : io::BusModel::kIdeal;
  const bool changed = core_.bus_model(iface.bus) != model;
  if (changed) core_.set_bus_model(iface.bus, model);
  update_pacer(iface);
  const auto subject = LogSubject::interface(iface.can.name());
  if (changed && iface.real_can && iface.bus_model == config::BusModelChoice::kTimed)
    spdlog::info("{}: a real CAN controller paces this bus itself: bus_model: timed has no effect", iface.can.name());
}

// The kernel's pacing, the loop's, or none while the interface is closed
// (Transport::carries()).
void Daemon::update_pacer(Interface& iface) {
  core_.update_pacer(iface.bus);
  // Frames leave in sendmmsg batches at the end of a loop pass, except on a
  // bus the loop paces: there each is written when it ends (the pass's other
  // work would make it late, and the next one follows from then).
  const bool loop_paced =
      core_.bus_model(iface.bus) == io::BusModel::kTimed && core_.bus_pacer(iface.bus) == io::Pacer::kLoop;
  iface.can.set_deferred(!loop_paced);
}

void Daemon::on_can_events(Interface& iface, std::uint32_t events) {
  TimeUs now = clock_now();
  // What was due before these frames arrived happens first (a fault edge, a
  // heartbeat), even when epoll reports the CAN socket before the timer.
  core_.run_due(now);
  if (events & (EPOLLIN | EPOLLERR | EPOLLHUP)) {
    CanFrame frames[io::CanInterface::kBatch];
    for (int b = 0; b < kReadBatchesPerWake; ++b) {
      int n = iface.can.read_batch(frames, io::CanInterface::kBatch);
      for (int i = 0; i < n; ++i) core_.receive(iface.bus, frames[i], now);
      take_controller_reports(iface, now);
      if (n < int(io::CanInterface::kBatch)) break;
    }
  }
  if (events & EPOLLOUT) drain(iface, now);
  if (events & EPOLLERR) iface.can.resend_dropped();
  flush(now);  // the answers to what was just read
}

// A real controller's error frames: its nodes react as their devices do, the
// journal and the control API's subscribers hear of it. The journal lines
// are rate-limited (a flapping controller may send thousands a second), each
// says what changed; error frames on a virtual bus are counted, not obeyed.
void Daemon::take_controller_reports(Interface& iface, TimeUs now) {
  io::ControllerReport r;
  while (iface.can.take_report(r)) {
    if (r.event.state_changed || r.event.frames_lost) core_.controller_event(iface.bus, r.event, now);
    if (r.event.state_changed && control_) control_->bus_state_changed(iface.can.name(), r.before, r.event.state, now);
    log_controller_report(iface, r, now);
  }
  report_ignored_error_frames(iface, now);
}

void Daemon::log_controller_report(Interface& iface, const io::ControllerReport& r, TimeUs now) {
  const auto subject = LogSubject::interface(iface.can.name());
  const std::string& name = iface.can.name();
  const auto line = [&](spdlog::level::level_enum level, const std::string& text) {
    if (iface.controller_lines.allow(now)) spdlog::log(level, "{}{}", text, iface.controller_lines.take_held());
  };
  std::string counters;
  if (r.tx_errors >= 0) counters = fmt::format(", TX errors {}, RX errors {}", r.tx_errors, r.rx_errors);
  if (r.merged) counters += fmt::format(", {} report(s) merged in a flood", r.merged);
  if (r.event.state_changed) {
    const char* now_name = io::can_state_name(r.event.state);
    const char* was = io::can_state_name(r.before);
    const std::size_t nodes = core_.node_count(iface.bus);
    if (r.event.state == CanState::kBusOff)
      line(spdlog::level::err, fmt::format("{}: CAN controller bus-off (was {}{}): its {} node(s) are off the bus",
                                           name, was, counters, nodes));
    else if (r.event.state == CanState::kErrorActive)
      line(spdlog::level::info, fmt::format("{}: CAN controller {} ({}was {}{}): its {} node(s) are on the bus", name,
                                            now_name, r.restarted ? "restarted, " : "", was, counters, nodes));
    else line(spdlog::level::warn, fmt::format("{}: CAN controller {} (was {}{})", name, now_name, was, counters));
  }
  if (r.rx_overflow || r.tx_overflow)
    line(spdlog::level::warn, fmt::format("{}: CAN controller lost frames ({})", name,
                                          r.rx_overflow && r.tx_overflow ? "RX and TX overflow"
                                          : r.rx_overflow                ? "RX overflow"
                                                                         : "TX overflow"));
  if (r.tx_timeout) line(spdlog::level::warn, fmt::format("{}: transmission timed out (driver)", name));
}

// At most one line per kControllerLinePeriod with the count since the last.
void Daemon::report_ignored_error_frames(Interface& iface, TimeUs now) {
  const std::uint64_t ignored = iface.can.stats().error_frames_ignored;
  if (ignored == iface.ignored_reported || now < iface.next_ignored_line) return;
  const auto subject = LogSubject::interface(iface.can.name());
  spdlog::warn(
      "{}: {} error frame(s) from the wire ignored: a virtual bus has no CAN controller (some program wrote "
      "them), its {} node(s) stay error-active",
      iface.can.name(), ignored - iface.ignored_reported, core_.node_count(iface.bus));
  iface.ignored_reported = ignored;
  iface.next_ignored_line = now + kControllerLinePeriod;
}

void Daemon::drain(Interface& iface, TimeUs now) {
  if (!iface.can.is_open()) return;
  std::uint64_t before = iface.can.stats().tx;
  iface.can.drain();
  // ENOBUFS with a writable socket would spin on EPOLLOUT: poll by timer.
  if (iface.can.wants_write() && iface.can.stats().tx == before) iface.drain_at = now + kDrainRetry;
}

// Frames are sent deferred: what one pass of the loop produced leaves in
// sendmmsg batches (CanInterface::set_deferred).
void Daemon::flush(TimeUs now) {
  for (auto& i : interfaces_) {
    if (i->can.wants_write() && i->drain_at == kNever) drain(*i, now);
    if (i->tcp) i->tcp->flush();
  }
}

void Daemon::sweep_interfaces(TimeUs now) {
  for (auto& ip : interfaces_) {
    Interface& i = *ip;
    if (i.in_epoll && !i.can.is_open()) {
      const auto subject = LogSubject::interface(i.can.name());
      i.in_epoll = false;  // closing the fd took it out of the epoll set
      i.retry_at = now + kRetryPeriod;
      update_pacer(i);
      i.last_down_log = now;
      i.reported_down = true;
      spdlog::warn("{}: {}; its {} node(s) keep running off the bus, retrying every second", i.can.name(),
                   i.can.error(), core_.node_count(i.bus));
    }
    if (!i.in_epoll) continue;
    std::uint32_t want = EPOLLIN | (i.can.wants_write() && i.drain_at == kNever ? EPOLLOUT : 0u);
    i.can.take_interest_changed();
    if (want != i.mask) {
      if (!loop_.modify(i.can.fd(), want, &i))
        spdlog::warn("{}: {} (writes wait for the next pass)", i.can.name(), loop_.error());
      else i.mask = want;
    }
  }
}

void Daemon::try_open(Interface& i, TimeUs now) {
  if (i.tcp) return try_listen(i, now);
  const auto subject = LogSubject::interface(i.can.name());
  std::string refused;  // the loop's reason, when it could not watch an open interface
  if (i.can.open() && !loop_.add(i.can.fd(), EPOLLIN, &i)) {
    refused = loop_.error();
    i.can.close();
  }
  if (i.can.is_open()) {
    i.in_epoll = true;
    i.mask = EPOLLIN;
    i.retry_at = kNever;
    apply_bus_model(i, io::kernel_link(i.can.name()));
    std::string model = i.real_can                                       ? "paced by its controller"
                        : core_.bus_model(i.bus) == io::BusModel::kIdeal ? "ideal bus"
                        : core_.bus_pacer(i.bus) == io::Pacer::kAhead
                            ? fmt::format("timed bus paced by the kernel ({}, delta {} µs)", i.can.pacing().why,
                                          i.can.pacing().delta_ns / 1000)
                            : "timed bus paced by the loop (" + i.can.pacing().why + ")";
    if (i.reported_down)
      spdlog::info("{}: interface is back, {} node(s) on the bus again, {}", i.can.name(), core_.node_count(i.bus),
                   model);
    else spdlog::info("{}: open, {} kbit/s, {}", i.can.name(), i.bit_rate_kbit, model);
    i.reported_down = false;
    take_controller_reports(i, now);
    return;
  }
  i.retry_at = now + kRetryPeriod;
  if (!i.reported_down || now - i.last_down_log >= kDownReminder) {
    spdlog::warn("{}: {}; its {} node(s) keep running off the bus, retrying every second", i.can.name(),
                 refused.empty() ? i.can.error() : refused, core_.node_count(i.bus));
    i.reported_down = true;
    i.last_down_log = now;
  }
}

// A socketcand bus listens (docs/socketcand.md). At start a failure is
// fatal (READY=1 would announce a bus nobody can reach); later, as a
// missing kernel interface, it is retried every second.
void Daemon::try_listen(Interface& i, TimeUs now) {
  const auto subject = LogSubject::interface(i.can.name());
  if (!i.tcp->listen()) {
    if (starting_) throw std::runtime_error(i.can.name() + ": cannot listen on " + i.tcp->error());
    i.retry_at = now + kRetryPeriod;
    if (!i.reported_down || now - i.last_down_log >= kDownReminder) {
      spdlog::warn("{}: cannot listen on {}; its {} node(s) keep running off the bus, retrying every second",
                   i.can.name(), i.tcp->error(), core_.node_count(i.bus));
      i.reported_down = true;
      i.last_down_log = now;
    }
    return;
  }
  i.retry_at = kNever;
  i.reported_down = false;
  const char* model = core_.bus_model(i.bus) == io::BusModel::kTimed ? "timed bus" : "ideal bus";
  const std::string where = endpoint(i.tcp->host(), i.tcp->port());
  spdlog::info("{}: socketcand on {}, {} kbit/s, {}", i.can.name(), where, i.bit_rate_kbit, model);
  if (!config::is_loopback_address(i.tcp->host()))
    spdlog::warn(
        "{}: socketcand on {} serves anyone who reaches it (allow_remote: true): the protocol has no "
        "authentication",
        i.can.name(), where);
}

void Daemon::write_address_file() const {
  if (settings_.address_file.empty()) return;
  const std::string tmp = settings_.address_file + ".tmp";
  {
    std::ofstream f(tmp, std::ios::trunc);
    for (const auto& i : interfaces_)
      if (i->configured && i->tcp && i->tcp->listening())
        f << i->can.name() << ' ' << i->tcp->host() << ' ' << i->tcp->port() << '\n';
    if (!f) {
      spdlog::error("{}: cannot write the address file", tmp);
      return;
    }
  }
  std::error_code ec;
  std::filesystem::rename(tmp, settings_.address_file, ec);
  if (ec) spdlog::error("{}: cannot write the address file: {}", settings_.address_file, ec.message());
}

void Daemon::housekeeping(TimeUs now) {
  for (auto& ip : interfaces_) {
    Interface& i = *ip;
    if (i.retry_at <= now && i.configured && !i.up()) try_open(i, now);
    if (i.drain_at <= now) {
      std::uint64_t before = i.can.stats().tx;
      i.can.drain();
      i.drain_at = (i.can.wants_write() && i.can.stats().tx == before) ? now + kDrainRetry : kNever;
    }
  }
  if (watchdog_us_ && now >= next_watchdog_) {
    sd_notify(0, "WATCHDOG=1");
    // Every quarter of WatchdogSec: systemd wants a ping at least every half,
    // and a ping scheduled at exactly half (from a wake-up that is itself a
    // little late) always came a few ms after half the interval.
    next_watchdog_ = now + TimeUs(watchdog_us_ / 4);
  }
  if (now >= next_status_) report_status(now);
  if (now >= trim_at_) trim_at_ = free_memory_.release() ? kNever : now + kTrimDelay;
}

void Daemon::trim_later() {
  if (trim_at_ == kNever) trim_at_ = clock_now() + kTrimDelay;
}

TimeUs Daemon::housekeeping_deadline() const {
  TimeUs t = std::min({next_status_, watchdog_us_ ? next_watchdog_ : kNever, trim_at_});
  for (const auto& i : interfaces_) {
    if (i->configured && !i->up()) t = std::min(t, i->retry_at);
    t = std::min(t, i->drain_at);
    if (i->tcp) t = std::min(t, i->tcp->next_deadline());
    t = std::min(t, i->scheduled.next());
  }
  return t;
}

void Daemon::report_status(TimeUs now) {
  const io::LoopStats& s = core_.stats();
  double dt = double(now - last_status_) / 1e6;
  if (dt > 0) frames_per_s_ = double(s.frames_out - last_frames_out_) / dt;
  double in_per_s = dt > 0 ? double(s.frames_in - last_frames_in_) / dt : 0;
  last_status_ = now;
  last_frames_out_ = s.frames_out;
  last_frames_in_ = s.frames_in;
  next_status_ = now + kStatusPeriod;
  std::size_t up = 0;
  for (const auto& i : interfaces_) {
    if (!i->configured) continue;
    up += i->up();
    std::uint64_t drops = i->can.take_new_drops();
    const auto subject = LogSubject::interface(i->can.name());
    if (drops && i->can.is_open())
      spdlog::warn("{}: {} frame(s) dropped in the last {:.0f} s (kernel queue full)", i->can.name(), drops, dt);
    const io::CanStats& cs = i->can.stats();
    if (cs.tx_resent > i->resent_reported)
      spdlog::warn(
          "{}: the kernel released {} frame(s) too late in the last {:.0f} s (its timers lagged by more than "
          "the ETF qdisc's delta of {} µs) and dropped them: sent again at once, after their place",
          i->can.name(), cs.tx_resent - i->resent_reported, dt, i->can.pacing().delta_ns / 1000);
    if (cs.tx_late > i->late_reported)
      spdlog::info(
          "{}: {} frame(s) reached the kernel after their time in the last {:.0f} s (a late loop pass): "
          "the bus slipped",
          i->can.name(), cs.tx_late - i->late_reported, dt);
    i->resent_reported = cs.tx_resent;
    i->late_reported = cs.tx_late;
    const io::BusLoad load = core_.bus_load(i->bus);
    if (load.dropped > i->bus_drops_reported)
      spdlog::warn(
          "{}: {} frame(s) dropped in the last {:.0f} s: the bus's queue of {} frames was full (offered {:.0f} % "
          "of {} kbit/s over 10 s)",
          i->can.name(), load.dropped - i->bus_drops_reported, dt, load.queue_capacity, load.offered_10s * 100,
          i->bit_rate_kbit);
    i->bus_drops_reported = load.dropped;
    report_ignored_error_frames(*i, now);
    if (i->controller_lines.summary_due(now))
      spdlog::warn("{}: CAN controller {} now{}", i->can.name(), io::can_state_name(i->can.controller_state()),
                   i->controller_lines.take_held());
  }
  std::size_t configured =
      std::count_if(interfaces_.begin(), interfaces_.end(), [](const auto& i) { return i->configured; });
  char buf[160];
  std::snprintf(buf, sizeof buf, "STATUS=%zu node(s), %zu/%zu interface(s) up, %.0f frames/s out, %.0f in",
                core_.node_count(), up, configured, frames_per_s_, in_per_s);
  sd_notify(0, buf);
  spdlog::debug("{}", buf + 7);
}

Traffic Daemon::offered(const Interface& i) const {
  Traffic t;
  for (const std::string& key : i.node_keys) t += estimate_traffic(core_.node(nodes_.at(key).ref));
  return t;
}

void Daemon::check_bus_load(const std::set<Interface*>& only) {
  for (const auto& ip : interfaces_) {
    if (!ip->configured || (!only.empty() && !only.count(ip.get()))) continue;
    const auto subject = LogSubject::interface(ip->can.name());
    const Traffic t = offered(*ip);
    double capacity = double(ip->bit_rate_kbit) * 1000.0;
    double load = capacity > 0 ? t.bits_per_s / capacity : 0;
    double worst = capacity > 0 ? t.stuffed_bits_per_s / capacity : 0;
    if (load > 1.0)
      spdlog::warn("{}: the fleet offers {:.0f} frames/s = {:.0f}% of {} kbit/s: more than the bus can carry",
                   ip->can.name(), t.frames_per_s, load * 100, ip->bit_rate_kbit);
    else if (worst > 1.0)
      spdlog::warn("{}: the fleet offers {:.0f} frames/s = {:.0f}% of {} kbit/s ({:.0f}% with worst-case bit stuffing)",
                   ip->can.name(), t.frames_per_s, load * 100, ip->bit_rate_kbit, worst * 100);
    else
      spdlog::info("{}: {} node(s) offer about {:.0f} frames/s, {:.1f}% of {} kbit/s", ip->can.name(),
                   core_.node_count(ip->bus), t.frames_per_s, load * 100, ip->bit_rate_kbit);
  }
}

void Daemon::notify(const std::string& state) { sd_notify(0, state.c_str()); }

void Daemon::ready_when_sent() {
  ready_marks_.clear();
  for (const auto& i : interfaces_)
    if (i->configured) ready_marks_.emplace_back(i->bus, core_.bus_mark(i->bus));
  ready_pending_ = true;
  check_ready();
}

void Daemon::check_ready() {
  for (const auto& [bus, mark] : ready_marks_)
    if (core_.bus_holds_before(bus, mark)) return;
  ready_pending_ = false;
  write_address_file();
  notify("READY=1");
}

// ---------------------------------------------------------------- fleet changes

// A running bus keeps its transport and listen address: the loop core's bus
// holds its transport (throws config::ConfigError, changing nothing).
void Daemon::check_transports(const std::vector<config::InterfaceConfig>& interfaces, const std::string& file) const {
  for (const auto& ic : interfaces)
    for (const auto& i : interfaces_) {
      if (i->can.name() != ic.name) continue;
      const bool moved = i->tcp && (i->tcp->host() != ic.listen_host ||
                                    (ic.listen_port != 0 && i->tcp->listening() && i->tcp->port() != ic.listen_port));
      if (bool(i->tcp) != ic.socketcand() || moved)
        throw config::ConfigError(file + ": interfaces." + ic.name +
                                  ": its transport and listen address stay as cansimd started them (restart cansimd "
                                  "to change them)");
    }
}

struct Daemon::Pending {
  const config::NodeConfig* cfg;
  std::unique_ptr<Application> app;
  std::uint64_t source = kFileSource;
};

void Daemon::remove_node(NodeEntry& e) {
  core_.remove_node(e.ref);
  e.ref = io::kNoNode;
}

Daemon::Interface* Daemon::interface_named(const std::string& name) {
  for (auto& i : interfaces_)
    if (i->can.name() == name) return i.get();
  return nullptr;
}

std::uint64_t Daemon::fleet_seed() const { return settings_.seed.value_or(file_config_.seed); }

// The whole fleet, as at start, at every reload and at a reset (`erase`:
// the stored parameters that go, every node rebuilt): every node is checked
// against what runs (its digest, seed, interface and bus rate).
void Daemon::apply(Combined cfg, TimeUs now, const std::set<std::string>* erase) {
  if (settings_.socketcand) serve_as_socketcand(cfg.interfaces);
  const std::uint64_t seed = fleet_seed();
  const config::PlantsConfig& plants = file_config_.plants;  // only the file has them
  // Phase 1 (may throw): decide what changes and build the new plants and
  // applications, so an invalid reload leaves the running fleet untouched.
  // Plants change with their section or the seed (a Reset starts them
  // afresh too, as every node); the nodes that read them restart with them.
  std::unique_ptr<physics::PlantSet> new_plants;
  std::unique_ptr<physics::PlantSetResolver> new_resolver;
  if (!plants_built_ || erase || plants.fingerprint != plants_.config().fingerprint || seed != plants_seed_) {
    new_plants = PlantWiring::build(plants, seed);
    new_resolver = std::make_unique<physics::PlantSetResolver>(*new_plants);
  }
  check_transports(cfg.interfaces, file_config_.file);
  const std::uint64_t generation = ++generation_;
  std::vector<Pending> to_add = plan(cfg, seed, generation, erase != nullptr,
                                     new_resolver ? new_resolver.get() : plants_.resolver(), new_plants != nullptr);
  // Phase 2: interfaces, removals, plants, additions.
  plants_.detach(core_.now());
  std::set<Interface*> touched;
  for (auto& i : interfaces_) i->configured = false;
  for (const auto& ic : cfg.interfaces) {
    const bool fresh = !interface_named(ic.name);
    Interface& i = ensure_interface(ic);
    if (fresh) touched.insert(&i);
  }
  declare_all();
  index_ = std::move(cfg.index);
  for (const Pending& p : to_add)
    if (auto it = nodes_.find(p.cfg->key); it != nodes_.end()) it->second.restart = true;
  std::size_t removed = 0, restarted = 0;
  for (auto it = nodes_.begin(); it != nodes_.end();) {
    if (!it->second.restart && it->second.seen == generation) {
      ++it;
      continue;
    }
    (it->second.restart ? restarted : removed) += 1;
    if (Interface* i = interface_named(it->second.cfg.interface); i && i->configured) touched.insert(i);
    it = drop_node(it, it->second.restart ? "changed, restarting" : "removed");
  }
  (void)now;
  if (erase)
    for (const std::string& key : *erase) erase_stored(key);
  if (new_plants) {
    plants_.replace(std::move(new_plants), plants);
    plants_seed_ = seed;
    plants_built_ = true;
  }
  start_nodes(to_add, seed, restarted, removed, cfg.interfaces.size());
  for (const Pending& p : to_add) touched.insert(interface_named(p.cfg->interface));
  if (!touched.empty()) check_bus_load(touched);
}

// Adds the planned nodes, binds the plants' inputs again, opens new
// interfaces, powers the nodes on and says what changed. `restarted` of them
// replace running nodes.
void Daemon::start_nodes(std::vector<Pending>& to_add, std::uint64_t seed, std::size_t restarted, std::size_t removed,
                         std::size_t interfaces) {
  std::vector<io::NodeRef> fresh;
  std::vector<BitRateMismatch> mismatched;  // (re)started nodes at another rate than their bus: one warning per entry
  for (Pending& p : to_add) fresh.push_back(add_node(p, seed, mismatched));
  attach_plants(core_.now());
  close_unconfigured_interfaces();
  // Open new interfaces now, so the boot-up frames reach the bus. Building
  // the nodes took time: they power on now, not when the reload began (their
  // heartbeat would come early by as much).
  const TimeUs now = clock_now();
  for (auto& i : interfaces_)
    if (i->configured && !i->up() && i->retry_at <= now) try_open(*i, now);
  for (io::NodeRef ref : fresh) core_.power_on(ref, now);
  spdlog::info("fleet: {} node(s) on {} interface(s); {} started, {} restarted, {} removed", nodes_.size(), interfaces,
               fresh.size() - restarted, restarted, removed);
  for (const BitRateMismatch& m : mismatched) {
    const auto subject = LogSubject::interface(m.interface);
    spdlog::warn("{}", describe(m));
  }
}

// The nodes of `cfg` that are new or changed (all of them for a `rebuild`,
// and those that read plants when the plants are replaced), with their
// applications built; every running node `cfg` keeps is marked seen in
// `generation`.
std::vector<Daemon::Pending> Daemon::plan(const Combined& cfg, std::uint64_t seed, std::uint64_t generation,
                                          bool rebuild, const physics::PlantResolver* plants, bool plants_replaced) {
  std::map<std::string, std::uint8_t> bus_rates;  // each interface asked once (the kernel's rate)
  for (const auto& ic : cfg.interfaces) bus_rates[ic.name] = config::bit_rate_selector(resolve_bit_rate(ic));
  std::vector<Pending> to_add;
  for (const auto& [node, source] : cfg.nodes) {
    const config::NodeConfig& n = *node;
    auto it = nodes_.find(n.key);
    // A node built on the plants that go would read freed plants.
    if (!rebuild && it != nodes_.end() && it->second.cfg.fingerprint == n.fingerprint && it->second.seed == seed &&
        it->second.cfg.interface == n.interface && it->second.bus_rate == bus_rates.at(n.interface) &&
        !(plants_replaced && config::reads_plant(*n.profile))) {
      it->second.seen = generation;
      continue;
    }
    to_add.push_back({&n, make_node_application(n, seed, settings_.state_dir, plants), source});
  }
  return to_add;
}

// The node falls silent and leaves the loop, the control API and its
// interface; returns the next entry.
std::map<std::string, Daemon::NodeEntry>::iterator Daemon::drop_node(std::map<std::string, NodeEntry>::iterator it,
                                                                     const char* why) {
  {
    const auto subject = LogSubject::node(it->first);
    spdlog::info("{}: node 0x{:02X} {}", it->first, it->second.cfg.node_id, why);
  }
  if (control_) control_->node_removed(it->first);
  remove_node(it->second);
  if (Interface* i = interface_named(it->second.cfg.interface)) i->node_keys.erase(it->first);
  index_.erase(it->second.cfg);
  trim_later();
  return nodes_.erase(it);
}

// Adds a planned node to the loop and the control API (not yet powered).
io::NodeRef Daemon::add_node(Pending& p, std::uint64_t seed, std::vector<BitRateMismatch>& mismatched) {
  const config::NodeConfig& n = *p.cfg;
  Interface* iface = interface_named(n.interface);
  const NodeSetup setup = node_setup(n, seed);
  auto storage = std::make_unique<FileStorage>(settings_.state_dir, n.key);
  NodeEntry e;
  e.cfg = n;
  e.seed = seed;
  e.source = p.source;
  e.bus_rate = config::bit_rate_selector(iface->bit_rate_kbit);
  e.ref = core_.add_node(iface->bus, setup, std::move(p.app), std::move(storage));
  if (setup.bit_rate_index != e.bus_rate) add_mismatch(mismatched, n, iface->bit_rate_kbit);
  e.handle.key = n.key;
  e.handle.name = n.name;
  e.handle.index = n.index;
  e.handle.profile = n.profile->name;
  e.handle.personality = n.profile->personality;
  e.handle.interface = n.interface;
  e.handle.ref = e.ref;
  e.handle.app = core_.app(e.ref);
  e.handle.emcy_codes = &e.cfg.profile->emcy_codes;
  NodeEntry& stored = nodes_[n.key] = std::move(e);
  iface->node_keys.insert(n.key);
  index_.insert(n);
  {
    const auto subject = LogSubject::node(n.key);
    spdlog::debug("{}: node 0x{:02X} ({}, {})", n.key, n.node_id, n.profile->name, n.profile->personality);
  }
  if (control_) control_->node_added(stored.handle);
  return stored.ref;
}

// The plants' inputs bound to the running nodes and interfaces.
void Daemon::attach_plants(TimeUs now) {
  plants_.attach(
      [this](const std::string& key) {
        auto it = nodes_.find(key);
        return it == nodes_.end() ? io::kNoNode : it->second.ref;
      },
      [this](const std::string& name, io::BusId& bus) {
        for (const auto& i : interfaces_)
          if (i->configured && i->can.name() == name) return bus = i->bus, true;
        return false;
      },
      now);
}

// An interface no configuration declares any more closes; without nodes it
// is forgotten with its bus (queue, meter and dispatch memory go back).
void Daemon::close_unconfigured_interfaces() {
  for (auto it = interfaces_.begin(); it != interfaces_.end();) {
    Interface& i = **it;
    if (i.configured) {
      ++it;
      continue;
    }
    if (i.up()) {
      const auto subject = LogSubject::interface(i.can.name());
      spdlog::info("{}: no longer configured, closed", i.can.name());
      if (i.tcp) i.tcp->close();
      i.can.close();
      i.in_epoll = false;
      i.retry_at = 0;  // opened again when configured again
      update_pacer(i);
    }
    if (!i.node_keys.empty()) {
      ++it;
      continue;
    }
    std::erase_if(ready_marks_, [&](const auto& mark) { return mark.first == i.bus; });
    core_.remove_bus(i.bus);
    it = interfaces_.erase(it);
  }
}

Daemon::Combined Daemon::combined() const {
  Combined cfg;
  std::set<std::string> declared;
  const auto add = [&](const config::FleetConfig& part, std::uint64_t source) {
    if (source != kFileSource) cfg.index.check(part);  // throws what merge_fleet throws
    for (const auto& n : part.nodes)
      if (source != kFileSource || !removed_.count(n.key)) {
        cfg.nodes.emplace_back(&n, source);
        cfg.index.insert(n);
      }
    for (const auto& ic : part.interfaces)
      if (declared.insert(ic.name).second) cfg.interfaces.push_back(ic);
  };
  add(file_config_, kFileSource);
  for (const auto& [id, extra] : added_) add(extra, id);
  return cfg;
}

// ---- who declares each interface (the file, AddNodes fragments)

void Daemon::declare_all() {
  declared_.clear();
  for (const auto& ic : file_config_.interfaces) declared_[ic.name].emplace(kFileSource, ic);
  for (const auto& [id, extra] : added_)
    for (const auto& ic : extra.interfaces) declared_[ic.name].emplace(id, ic);
}

std::vector<config::InterfaceConfig> Daemon::running_interfaces() const {
  std::vector<config::InterfaceConfig> out;
  out.reserve(declared_.size());
  for (const auto& [name, by] : declared_) out.push_back(by.begin()->second);
  return out;
}

// A new fragment's interfaces: the first to declare one sets it up, as
// combined() keeps the first declaration.
void Daemon::declare(std::uint64_t source, const std::vector<config::InterfaceConfig>& interfaces) {
  for (const auto& ic : interfaces) {
    auto& by = declared_[ic.name];
    const bool first = by.empty();
    by.emplace(source, ic);
    if (first) ensure_interface(ic);
  }
}

// A fragment's interfaces once its last node left: an interface nobody
// declares any more closes; one whose first declaration this was takes the
// next one's settings, and its nodes whose bus rate that changes restart.
// Returns those nodes' planned restarts.
std::vector<Daemon::Pending> Daemon::undeclare(std::uint64_t source,
                                               const std::vector<config::InterfaceConfig>& interfaces) {
  std::vector<Pending> restarts;
  for (const auto& ic : interfaces) {
    auto d = declared_.find(ic.name);
    if (d == declared_.end()) continue;
    const bool was_first = d->second.begin()->first == source;
    d->second.erase(source);
    Interface* iface = interface_named(ic.name);
    if (d->second.empty()) {
      declared_.erase(d);
      if (iface) iface->configured = false;
      continue;
    }
    if (!was_first || !iface) continue;
    ensure_interface(d->second.begin()->second);
    const std::uint8_t rate = config::bit_rate_selector(iface->bit_rate_kbit);
    for (const std::string& key : iface->node_keys) {
      const NodeEntry& e = nodes_.at(key);
      if (e.bus_rate != rate) restarts.push_back({&e.cfg, nullptr, e.source});
    }
  }
  return restarts;
}

// ---- control calls: each costs what its own nodes cost

std::vector<std::string> Daemon::add_nodes(const std::string& yaml) {
  const std::uint64_t id = ++fragments_;
  const std::string label = "<AddNodes #" + std::to_string(id) + ">";
  config::ProfileSearch search = profile_search(settings_.config_file);
  search.strict = settings_.strict;
  search.strict_eds = settings_.strict_eds;
  search.confined_to = profile_folders();
  search.store = &profile_store_;  // the same profile file: the same Profile for every call
  config::FleetConfig extra =
      config::parse_fleet_fragment(yaml, label, search, running_interfaces(), nodes_.size(), file_config_.plants);
  for (const std::string& w : load_warnings(extra)) spdlog::warn("{}", w);
  index_.check(extra);  // throws on a collision
  if (settings_.socketcand) serve_as_socketcand(extra.interfaces);
  std::vector<config::InterfaceConfig> fresh_interfaces;  // an interface declared before keeps its first settings
  for (const auto& ic : extra.interfaces)
    if (!declared_.count(ic.name)) fresh_interfaces.push_back(ic);
  check_transports(fresh_interfaces, file_config_.file);
  const auto [it, fresh] = added_.emplace(id, std::move(extra));
  const config::FleetConfig& stored = it->second;
  const std::uint64_t seed = fleet_seed();
  std::vector<Pending> to_add;
  try {
    for (const auto& n : stored.nodes)
      to_add.push_back({&n, make_node_application(n, seed, settings_.state_dir, plants_.resolver()), id});
  } catch (...) {
    added_.erase(it);
    throw;
  }
  declare(id, stored.interfaces);
  start_nodes(to_add, seed, 0, 0, declared_.size());
  std::vector<std::string> keys;
  std::set<Interface*> touched;
  for (const auto& n : stored.nodes) {
    keys.push_back(n.key);
    touched.insert(interface_named(n.interface));
  }
  check_bus_load(touched);
  spdlog::info("control: added {} node(s)", keys.size());
  return keys;
}

void Daemon::remove_node(const std::string& key) {
  auto it = nodes_.find(key);
  if (it == nodes_.end()) return;
  const std::uint64_t source = it->second.source;
  const std::string interface = it->second.cfg.interface;
  plants_.detach(core_.now());  // bound again once the fleet is (restart())
  drop_node(it, "removed");
  std::vector<Pending> restarts;
  if (source == kFileSource) {
    removed_.insert(key);  // until the next reload
  } else if (auto f = added_.find(source); f != added_.end()) {
    std::erase_if(f->second.nodes, [&](const config::NodeConfig& n) { return n.key == key; });
    if (f->second.nodes.empty()) {  // and its profiles and interfaces
      restarts = undeclare(source, f->second.interfaces);
      added_.erase(f);
    }
  }
  restart(restarts, 1);
  if (Interface* i = interface_named(interface); i && i->configured) check_bus_load({i});
}

// Restarts running nodes with their configuration as it is (their bus's
// rate changed) and says what changed (`removed` nodes left before).
void Daemon::restart(std::vector<Pending>& planned, std::size_t removed) {
  const std::uint64_t seed = fleet_seed();
  std::vector<config::NodeConfig> configs;  // copies: dropping a node destroys its entry
  configs.reserve(planned.size());
  for (Pending& p : planned) configs.push_back(*p.cfg);
  try {
    for (std::size_t i = 0; i < planned.size(); ++i) {
      planned[i].cfg = &configs[i];
      planned[i].app = make_node_application(configs[i], seed, settings_.state_dir, plants_.resolver());
    }
  } catch (const std::exception& e) {  // they run on at the old rate until the next reload
    spdlog::error("fleet: {} node(s) not restarted at their bus's new bit rate: {}", planned.size(), e.what());
    planned.clear();
    configs.clear();
  }
  plants_.detach(core_.now());  // bound again as they start
  for (const auto& n : configs) drop_node(nodes_.find(n.key), "changed, restarting");
  start_nodes(planned, seed, planned.size(), removed, declared_.size());
}

void Daemon::reload(TimeUs now) {
  spdlog::info("SIGHUP: reloading the configuration");
  try {
    reload();
  } catch (const std::exception& e) {
    spdlog::error("reload failed, keeping the running fleet: {}", e.what());
  }
  (void)now;
}

// Throws config::ConfigError with the running fleet untouched.
void Daemon::reload() {
  // sd_notify wants the host's CLOCK_MONOTONIC here, not simulated time.
  notify("RELOADING=1\nMONOTONIC_USEC=" + std::to_string(io::monotonic_now()));
  struct Ready {
    Daemon& d;
    ~Ready() {
      TimeUs t = d.clock_now();
      d.flush(t);  // the new nodes' boot-ups are on the bus before READY=1
      d.report_status(t);
      d.ready_when_sent();
    }
  } ready{*this};
  config::FleetConfig fresh = settings_.load(&profile_store_);
  profile_store_.put_all(fresh);
  std::swap(file_config_, fresh);
  std::set<std::string> removed;
  std::swap(removed_, removed);  // the file's nodes come back
  try {
    apply(combined(), clock_now());
  } catch (...) {
    std::swap(file_config_, fresh);
    std::swap(removed_, removed);
    declare_all();
    throw;
  }
}

// Throws config::ConfigError with the running fleet untouched.
void Daemon::reset() {
  std::set<std::string> keys;  // whose stored parameters go: the running nodes and the file's
  for (const auto& [key, e] : nodes_) keys.insert(key);
  for (const auto& n : file_config_.nodes) keys.insert(n.key);
  std::map<std::uint64_t, config::FleetConfig> added;
  std::set<std::string> removed;
  std::swap(added_, added);
  std::swap(removed_, removed);
  try {
    apply(combined(), clock_now(), &keys);
  } catch (...) {
    std::swap(added_, added);
    std::swap(removed_, removed);
    declare_all();
    throw;
  }
  spdlog::info("control: fleet reset to power-on: {} node(s), stored parameters erased", nodes_.size());
}

// A node's stored parameters, erased (Reset): its next load finds none.
void Daemon::erase_stored(const std::string& key) {
  std::error_code ec;
  const std::string path = FileStorage(settings_.state_dir, key).path();
  if (!std::filesystem::remove(path, ec) && ec) {
    const auto subject = LogSubject::node(key);
    spdlog::warn("{}: cannot erase its stored parameters {}: {}", key, path, ec.message());
  }
}

// ---------------------------------------------------------------- control API

std::vector<const control::NodeHandle*> Daemon::nodes() const {
  std::vector<const control::NodeHandle*> out;
  out.reserve(nodes_.size());
  for (const auto& [key, e] : nodes_) out.push_back(&e.handle);
  return out;
}

std::vector<const control::NodeHandle*> Daemon::nodes_on(const std::string& interface) const {
  std::vector<const control::NodeHandle*> out;
  for (const auto& i : interfaces_) {
    if (i->can.name() != interface) continue;
    out.reserve(i->node_keys.size());
    for (const std::string& key : i->node_keys) out.push_back(&nodes_.at(key).handle);
  }
  return out;
}

const control::NodeHandle* Daemon::find(const std::string& key) const {
  auto it = nodes_.find(key);
  return it == nodes_.end() ? nullptr : &it->second.handle;
}

// Where AddNodes may take profiles from: the profile search folders, the
// fleet file's folder and every folder the running fleet took one from.
std::vector<std::string> Daemon::profile_folders() const {
  std::vector<std::string> dirs = profile_search(settings_.config_file).dirs;
  const auto folder = [](const std::string& file) {
    const std::string dir = std::filesystem::path(file).parent_path().string();
    return dir.empty() ? std::string(".") : dir;
  };
  if (!settings_.config_file.empty()) dirs.push_back(folder(settings_.config_file));
  for (const auto& p : file_config_.profiles) dirs.push_back(folder(p->file));
  std::sort(dirs.begin(), dirs.end());
  dirs.erase(std::unique(dirs.begin(), dirs.end()), dirs.end());
  return dirs;
}

std::vector<control::BusStatistics> Daemon::buses() const {
  std::vector<control::BusStatistics> out;
  for (const auto& ip : interfaces_) {
    const Interface& i = *ip;
    if (!i.configured) continue;
    control::BusStatistics b;
    b.name = i.can.name();
    b.up = i.up();
    b.bit_rate_kbit = i.bit_rate_kbit;
    b.frames_in = i.frames_in();
    b.frames_out = i.frames_out();
    b.drops = i.tcp ? i.tcp->stats().frames_lost : i.can.stats().tx_dropped;
    b.offline = i.can.stats().tx_offline;
    if (i.tcp) {
      b.transport = "socketcand";
      b.listen_host = i.tcp->host();
      b.listen_port = i.tcp->listening() ? i.tcp->port() : 0;
      b.clients = i.tcp->clients();
    }
    b.measured_load = core_.bus_load(i.bus).carried_10s;  // the one figure: at most 100 %
    b.model = i.real_can ? "controller" : core_.bus_model(i.bus) == io::BusModel::kTimed ? "timed" : "ideal";
    b.state = i.can.controller_state();
    b.load = core_.bus_load(i.bus);
    out.push_back(b);
  }
  return out;
}

std::vector<control::BusStatistics> Daemon::bus_statistics() const {
  std::vector<control::BusStatistics> out = buses();
  for (control::BusStatistics& b : out) {
    const Interface* i = nullptr;
    for (const auto& ip : interfaces_)
      if (ip->configured && ip->can.name() == b.name) i = ip.get();
    const Traffic t = offered(*i);
    b.offered_load = i->bit_rate_kbit ? t.bits_per_s / (i->bit_rate_kbit * 1000.0) : 0;
  }
  return out;
}

bool Daemon::interface_up(const std::string& name) const {
  for (const auto& i : interfaces_)
    if (i->configured && i->can.name() == name) return i->up();
  return false;
}

std::size_t Daemon::queue_frames(const std::string& interface, const std::vector<control::ScheduledFrame>& frames) {
  for (auto& i : interfaces_) {
    if (!i->configured || i->can.name() != interface) continue;
    std::size_t taken = 0;
    while (taken < frames.size() && i->scheduled.push(frames[taken].at, frames[taken].frame)) ++taken;
    return taken;
  }
  throw std::out_of_range("no interface '" + interface + "' in the fleet");
}

// The queued frames whose time has come go to their buses, as an outside
// participant's (a timed bus arbitrates them with the nodes' frames).
void Daemon::release_scheduled(TimeUs now) {
  for (auto& i : interfaces_)
    i->scheduled.release(now, [&](const CanFrame& f) { core_.submit(i->bus, f, io::kReplayParticipant, now); });
}

void Daemon::log_action(const control::ActionRecord& r) {
  LogSubject subject = LogSubject::action(r.interface, r.node, r.uid ? std::optional<unsigned>(*r.uid) : std::nullopt);
  spdlog::info("{}", r.text);
}

void Daemon::start_control() {
  control_ = std::make_unique<control::ControlService>(*this);
  // The plants see what masters write into the nodes first, then the control API.
  plants_.set_next(control_.get());
  core_.set_observer(&plants_);
  plants_.set_fault_listener([this](const std::string& plant, physics::FaultHandle id, physics::FaultKind kind,
                                    const std::string& target, bool started, TimeUs t) {
    control_->plant_fault_edge(plant, id, std::uint8_t(kind), target, started, t);
  });
  endpoints_ = std::make_unique<control::ControlEndpoints>(loop_, *control_, settings_.max_clients);
  if (settings_.control_socket != "none") {
    const std::string path =
        settings_.control_socket.empty() ? control::default_control_socket() : settings_.control_socket;
    try {
      endpoints_->listen(path);
      spdlog::info("control: private D-Bus socket {}", path);
    } catch (const std::exception& e) {
      if (!settings_.control_socket.empty()) throw;
      spdlog::warn("control: no private socket: {}", e.what());
    }
  }
  try {
    std::string bus = endpoints_->connect_bus(settings_.bus);
    if (!bus.empty()) spdlog::info("control: {} as {}", bus, control::kBusName);
  } catch (const std::exception& e) {
    if (settings_.bus != control::BusChoice::kAuto) throw;
    spdlog::warn("control: {}", e.what());
  }
}

// Simulated time is CLOCK_MONOTONIC counted from the daemon's start, so a
// profile's `at: 10 s` (faults, ramps, tables) means 10 s after cansimd started.
TimeUs Daemon::clock_now() const { return io::monotonic_now() - epoch_; }

void Daemon::start() {
  epoch_ = io::monotonic_now();
  TimeUs now = clock_now();
  last_status_ = now;
  file_config_ = settings_.load(&profile_store_);
  profile_store_.put_all(file_config_);
  start_control();
  apply(combined(), now);
  now = clock_now();
  if (sd_watchdog_enabled(0, &watchdog_us_) <= 0) watchdog_us_ = 0;
  next_watchdog_ = now;
  housekeeping(now);  // opens the interfaces
  flush(now);         // the boot-ups are on the bus before READY=1
  sweep_interfaces(now);
  report_status(now);
  starting_ = false;
  ready_when_sent();
}

int Daemon::run() {
  if (!loop_.watch_signals({SIGINT, SIGTERM, SIGHUP})) throw std::runtime_error(loop_.error());
  start();
  int signal = 0;
  for (;;) {
    TimeUs now = clock_now();
    core_.run_due(now);
    release_scheduled(now);
    plants_.run_due(core_.now());
    // Control calls act here, between two passes: atomically with respect to
    // frames. What the nodes sent before is on the wire before any answer.
    if (endpoints_->connections()) flush(now);
    const TimeUs control_at = endpoints_->process();
    // A node a call touched may be due at once: run it in this pass rather
    // than arming the timer in the past for another wake-up.
    if (endpoints_->connections()) core_.run_due(clock_now());
    flush(now);
    housekeeping(now);
    sweep_interfaces(now);
    if (ready_pending_) check_ready();
    TimeUs next = std::min({core_.next_deadline(), housekeeping_deadline(), plants_.next_deadline()});
    if (control_at != kNever) next = std::min(next, control_at - epoch_);
    endpoints_->before_sleep(next == kNever ? kNever : next + epoch_);
    const bool armed = loop_.arm_timer(next == kNever ? kNever : next + epoch_);
    if (loop_.woke_at()) {  // 0 before the first wait: start-up is no pass
      const TimeUs end = io::monotonic_now();
      passes_.pass(end, end - loop_.woke_at());
      pass_cpu_.pass(end, io::thread_cpu_now() - loop_.woke_cpu());
    }
    bool timer = false;
    if (!armed || loop_.wait(-1, timer, signal) < 0) throw std::runtime_error(loop_.error());
    if (signal == SIGHUP) reload(clock_now());
    else if (signal == SIGTERM || signal == SIGINT) break;
  }
  notify("STOPPING=1");
  spdlog::info("{}: stopping, {} node(s) fall silent", strsignal(signal), nodes_.size());
  plants_.detach(core_.now());
  for (auto& [key, e] : nodes_) remove_node(e);
  nodes_.clear();
  endpoints_.reset();
  std::error_code ec;
  if (!settings_.address_file.empty()) std::filesystem::remove(settings_.address_file, ec);
  return 0;
}

}  // namespace cansim::daemon
