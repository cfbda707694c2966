#include "daemon/daemon.hpp"

#include <spdlog/spdlog.h>
#include <sys/epoll.h>
#include <systemd/sd-daemon.h>

#include <algorithm>
#include <csignal>
#include <filesystem>
#include <set>

#include "core/node.hpp"
#include "daemon/bus_load.hpp"
#include "daemon/file_storage.hpp"
#include "daemon/logging.hpp"
#include "personalities/registry.hpp"

#ifndef CANSIM_PROFILE_DIR
#define CANSIM_PROFILE_DIR ""
#endif

namespace cansim::daemon {

namespace {
constexpr TimeUs kRetryPeriod = 1'000'000;      // reopen a missing / down interface
constexpr TimeUs kDrainRetry = 1'000;           // kernel queue full (ENOBUFS): retry
constexpr TimeUs kStatusPeriod = 5'000'000;     // STATUS= and drop reports
constexpr TimeUs kDownReminder = 30'000'000;    // repeat "still down" warnings
constexpr int kReadBatchesPerWake = 16;         // fairness between interfaces

// The configured rate, else the kernel's (real CAN), else 250 kbit/s.
std::uint32_t resolve_bit_rate(const config::InterfaceConfig& ic, bool* from_kernel = nullptr) {
  if (ic.bit_rate_kbit) return ic.bit_rate_kbit;
  std::uint32_t kernel = io::kernel_bit_rate(ic.name);
  if (from_kernel) *from_kernel = kernel != 0;
  return kernel ? kernel / 1000 : 250;
}
}  // namespace

// ---------------------------------------------------------------- building

config::ProfileSearch profile_search(const std::string& config_file) {
  return config::default_search(config_file, CANSIM_PROFILE_DIR);
}

NodeSetup node_setup(const config::NodeConfig& node) {
  NodeSetup setup = config::node_setup(*node.profile, node.node_id, node.index);
  setup.bit_rate_index = config::bit_rate_selector(node.bit_rate_kbit);
  if (node.serial) setup.serial_number = node.serial;
  return setup;
}

std::unique_ptr<Application> make_node_application(const config::NodeConfig& node, std::uint64_t seed,
                                                   const std::string& state_dir) {
  personalities::NodeContext ctx;
  ctx.fleet_seed = seed;
  ctx.index = node.index;
  ctx.key = node.key;
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

std::vector<BitRateMismatch> bit_rate_mismatches(const config::FleetConfig& fleet,
                                                 const std::function<std::uint32_t(const config::InterfaceConfig&)>& bus_kbit) {
  std::vector<BitRateMismatch> out;
  std::map<std::string, std::uint32_t> rates;
  for (const auto& ic : fleet.interfaces) rates[ic.name] = bus_kbit(ic);
  for (const auto& n : fleet.nodes) {
    auto rate = rates.find(n.interface);
    if (rate != rates.end() && config::bit_rate_selector(n.bit_rate_kbit) !=
                                     config::bit_rate_selector(rate->second))
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
  for (config::NodeConfig n : fleet.nodes) {
    n.record_file.clear();  // --check must not truncate recordings
    make_node_application(n, fleet.seed);
  }
  if (warnings) *warnings = load_warnings(fleet);
  if (warnings)
    for (const BitRateMismatch& m : bit_rate_mismatches(fleet, effective_bit_rate)) warnings->push_back(describe(m));
  return fleet.file + ": ok, " + std::to_string(fleet.nodes.size()) + " node(s) on " +
         std::to_string(fleet.interfaces.size()) + " interface(s)";
}

// ---------------------------------------------------------------- interfaces

struct Daemon::Interface : io::FdHandler {
  Interface(Daemon& d, std::string name) : daemon(d), can(std::move(name)) {}
  void on_events(std::uint32_t events) override { daemon.on_can_events(*this, events); }

  Daemon& daemon;
  io::CanInterface can;
  io::BusId bus = 0;
  std::uint32_t bit_rate_kbit = 250;
  bool configured = false;
  bool in_epoll = false;
  std::uint32_t mask = 0;
  TimeUs retry_at = kNever;
  TimeUs drain_at = kNever;
  TimeUs last_down_log = 0;
  bool reported_down = false;
  std::uint64_t last_frames = 0;  // rx + tx at the last status report
  double measured_load = 0;       // fraction of the bit rate over the last status period
  config::BusModelChoice bus_model = config::BusModelChoice::kAuto;
  bool real_can = false;          // the kernel says: a CAN controller (it paces the bus)
  std::uint64_t bus_drops_reported = 0;
};

Daemon::Daemon(DaemonSettings settings) : settings_(std::move(settings)) {}
Daemon::~Daemon() {
  endpoints_.reset();
  core_.set_observer(nullptr);
}

Daemon::Interface& Daemon::ensure_interface(const config::InterfaceConfig& ic) {
  Interface* iface = nullptr;
  for (auto& i : interfaces_)
    if (i->can.name() == ic.name) iface = i.get();
  if (!iface) {
    interfaces_.push_back(std::make_unique<Interface>(*this, ic.name));
    iface = interfaces_.back().get();
    iface->bus = core_.add_bus(ic.name, iface->can, 3);
    iface->can.set_deferred(true);
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
  apply_bus_model(*iface, io::kernel_link(ic.name));
  iface->configured = true;
  return *iface;
}

// Timed on a virtual bus unless `bus_model: ideal`; a real CAN controller
// paces its own bus (README "The bus model"). A missing interface counts as
// virtual until it appears.
void Daemon::apply_bus_model(Interface& iface, const io::KernelLink& link) {
  iface.real_can = link.real_can();
  const bool timed = !iface.real_can && iface.bus_model != config::BusModelChoice::kIdeal;
  const io::BusModel model = timed ? io::BusModel::kTimed : io::BusModel::kIdeal;
  if (core_.bus_model(iface.bus) == model) return;
  core_.set_bus_model(iface.bus, model);
  const auto subject = LogSubject::interface(iface.can.name());
  if (iface.real_can && iface.bus_model == config::BusModelChoice::kTimed)
    spdlog::info("{}: a real CAN controller paces this bus itself: bus_model: timed has no effect", iface.can.name());
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
  flush(now);  // the answers to what was just read
}

// A real controller's error frames: its nodes react as their devices do, the
// journal and the control API's subscribers hear of it.
void Daemon::take_controller_reports(Interface& iface, TimeUs now) {
  io::ControllerReport r;
  while (iface.can.take_report(r)) {
    if (r.event.state_changed || r.event.frames_lost) core_.controller_event(iface.bus, r.event, now);
    const auto subject = LogSubject::interface(iface.can.name());
    const std::string& name = iface.can.name();
    const std::size_t nodes = core_.node_count(iface.bus);
    std::string counters;
    if (r.tx_errors >= 0) counters = fmt::format(", TX errors {}, RX errors {}", r.tx_errors, r.rx_errors);
    if (r.event.state_changed) {
      const char* now_name = io::can_state_name(r.event.state);
      const char* was = io::can_state_name(r.before);
      if (r.event.state == CanState::kBusOff)
        spdlog::error("{}: CAN controller bus-off (was {}{}): its {} node(s) are off the bus", name, was, counters, nodes);
      else if (r.event.state == CanState::kErrorActive)
        spdlog::info("{}: CAN controller {} ({}was {}): its {} node(s) are on the bus", name, now_name,
                     r.restarted ? "restarted, " : "", was, nodes);
      else
        spdlog::warn("{}: CAN controller {} (was {}{})", name, now_name, was, counters);
      if (control_) control_->bus_state_changed(name, r.before, r.event.state, now);
    }
    if (r.event.frames_lost)
      spdlog::warn("{}: CAN controller lost frames ({}{}{})", name, r.rx_overflow ? "RX overflow" : "",
                   r.rx_overflow && r.tx_overflow ? ", " : "", r.tx_overflow ? "TX overflow" : "");
    if (r.tx_timeout) spdlog::warn("{}: transmission timed out (driver)", name);
  }
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
  for (auto& i : interfaces_)
    if (i->can.wants_write() && i->drain_at == kNever) drain(*i, now);
}

void Daemon::sweep_interfaces(TimeUs now) {
  for (auto& ip : interfaces_) {
    Interface& i = *ip;
    if (i.in_epoll && !i.can.is_open()) {
      const auto subject = LogSubject::interface(i.can.name());
      i.in_epoll = false;  // closing the fd took it out of the epoll set
      i.retry_at = now + kRetryPeriod;
      i.last_down_log = now;
      i.reported_down = true;
      spdlog::warn("{}: {}; its {} node(s) keep running off the bus, retrying every second", i.can.name(),
                   i.can.error(), core_.node_count(i.bus));
    }
    if (!i.in_epoll) continue;
    std::uint32_t want = EPOLLIN | (i.can.wants_write() && i.drain_at == kNever ? EPOLLOUT : 0u);
    i.can.take_interest_changed();
    if (want != i.mask) {
      loop_.modify(i.can.fd(), want, &i);
      i.mask = want;
    }
  }
}

void Daemon::try_open(Interface& i, TimeUs now) {
  const auto subject = LogSubject::interface(i.can.name());
  if (i.can.open()) {
    loop_.add(i.can.fd(), EPOLLIN, &i);
    i.in_epoll = true;
    i.mask = EPOLLIN;
    i.retry_at = kNever;
    apply_bus_model(i, io::kernel_link(i.can.name()));
    const char* model = i.real_can ? "paced by its controller"
                        : core_.bus_model(i.bus) == io::BusModel::kTimed ? "timed bus" : "ideal bus";
    if (i.reported_down)
      spdlog::info("{}: interface is back, {} node(s) on the bus again", i.can.name(), core_.node_count(i.bus));
    else
      spdlog::info("{}: open, {} kbit/s, {}", i.can.name(), i.bit_rate_kbit, model);
    i.reported_down = false;
    take_controller_reports(i, now);
    return;
  }
  i.retry_at = now + kRetryPeriod;
  if (!i.reported_down || now - i.last_down_log >= kDownReminder) {
    spdlog::warn("{}: {}; its {} node(s) keep running off the bus, retrying every second", i.can.name(),
                 i.can.error(), core_.node_count(i.bus));
    i.reported_down = true;
    i.last_down_log = now;
  }
}

void Daemon::housekeeping(TimeUs now) {
  for (auto& ip : interfaces_) {
    Interface& i = *ip;
    if (i.retry_at <= now && i.configured && !i.can.is_open()) try_open(i, now);
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
}

TimeUs Daemon::housekeeping_deadline() const {
  TimeUs t = std::min(next_status_, watchdog_us_ ? next_watchdog_ : kNever);
  for (const auto& i : interfaces_) {
    if (i->configured && !i->can.is_open()) t = std::min(t, i->retry_at);
    t = std::min(t, i->drain_at);
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
    up += i->can.is_open();
    const std::uint64_t frames = i->can.stats().rx + i->can.stats().tx;
    // 111 bits per 8-byte frame without stuffing (bus_load.hpp).
    if (dt > 0 && i->bit_rate_kbit) i->measured_load = double(frames - i->last_frames) * 111.0 / dt / (i->bit_rate_kbit * 1000.0);
    i->last_frames = frames;
    std::uint64_t drops = i->can.take_new_drops();
    const auto subject = LogSubject::interface(i->can.name());
    if (drops && i->can.is_open())
      spdlog::warn("{}: {} frame(s) dropped in the last {:.0f} s (kernel queue full)", i->can.name(), drops, dt);
    const io::BusLoad load = core_.bus_load(i->bus);
    if (load.dropped > i->bus_drops_reported)
      spdlog::warn("{}: {} frame(s) dropped in the last {:.0f} s: the bus's queue of {} frames was full (offered {:.0f} % "
                   "of {} kbit/s over 10 s)",
                   i->can.name(), load.dropped - i->bus_drops_reported, dt, load.queue_capacity, load.offered_10s * 100,
                   i->bit_rate_kbit);
    i->bus_drops_reported = load.dropped;
  }
  std::size_t configured = std::count_if(interfaces_.begin(), interfaces_.end(), [](const auto& i) { return i->configured; });
  char buf[160];
  std::snprintf(buf, sizeof buf, "STATUS=%zu node(s), %zu/%zu interface(s) up, %.0f frames/s out, %.0f in",
                core_.node_count(), up, configured, frames_per_s_, in_per_s);
  sd_notify(0, buf);
  spdlog::debug("{}", buf + 7);
}

void Daemon::check_bus_load() {
  for (const auto& ip : interfaces_) {
    if (!ip->configured) continue;
    const auto subject = LogSubject::interface(ip->can.name());
    Traffic t;
    for (const auto& [key, e] : nodes_)
      if (core_.bus_of(e.ref) == ip->bus) t += estimate_traffic(core_.node(e.ref));
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
  notify("READY=1");
}

// ---------------------------------------------------------------- fleet changes

struct Daemon::Pending {
  const config::NodeConfig* cfg;
  std::unique_ptr<Application> app;
};

void Daemon::remove_node(NodeEntry& e) {
  core_.remove_node(e.ref);
  e.ref = io::kNoNode;
}

void Daemon::apply(config::FleetConfig cfg, TimeUs now) {
  const std::uint64_t seed = settings_.seed.value_or(cfg.seed);
  // Phase 1 (may throw): decide what changes and build the new applications,
  // so an invalid reload leaves the running fleet untouched.
  std::set<std::string> wanted;
  std::vector<Pending> to_add = plan(cfg, seed, wanted);
  // Phase 2: interfaces, removals, additions.
  for (auto& i : interfaces_) i->configured = false;
  for (const auto& ic : cfg.interfaces) ensure_interface(ic);
  const auto [removed, changed] = remove_stale(wanted, to_add);
  std::vector<io::NodeRef> fresh;
  std::vector<BitRateMismatch> mismatched;  // (re)started nodes at another rate than their bus: one warning per entry
  for (Pending& p : to_add) fresh.push_back(add_node(p, seed, mismatched));
  close_unconfigured_interfaces();
  // Open new interfaces now, so the boot-up frames reach the bus. Building
  // the nodes took time: they power on now, not when the reload began (their
  // heartbeat would come early by as much).
  now = clock_now();
  for (auto& i : interfaces_)
    if (i->configured && !i->can.is_open() && i->retry_at <= now) try_open(*i, now);
  for (io::NodeRef ref : fresh) core_.power_on(ref, now);
  spdlog::info("fleet: {} node(s) on {} interface(s); {} started, {} restarted, {} removed", nodes_.size(),
               cfg.interfaces.size(), fresh.size() - changed, changed, removed);
  for (const BitRateMismatch& m : mismatched) {
    const auto subject = LogSubject::interface(m.interface);
    spdlog::warn("{}", describe(m));
  }
  check_bus_load();
}

// The nodes of `cfg` that are new or changed, with their applications built;
// `wanted` receives every key of `cfg`.
std::vector<Daemon::Pending> Daemon::plan(const config::FleetConfig& cfg, std::uint64_t seed,
                                          std::set<std::string>& wanted) {
  auto bus_rate = [&](const std::string& iface) {
    return config::bit_rate_selector(resolve_bit_rate(*cfg.interface(iface)));
  };
  std::vector<Pending> to_add;
  for (const auto& n : cfg.nodes) {
    wanted.insert(n.key);
    auto it = nodes_.find(n.key);
    if (it != nodes_.end() && it->second.cfg.fingerprint == n.fingerprint && it->second.seed == seed &&
        it->second.cfg.interface == n.interface && it->second.bus_rate == bus_rate(n.interface))
      continue;
    to_add.push_back({&n, make_node_application(n, seed, settings_.state_dir)});
  }
  return to_add;
}

// Removes the running nodes that are no longer wanted or are about to be
// replaced; returns how many of each.
std::pair<std::size_t, std::size_t> Daemon::remove_stale(const std::set<std::string>& wanted,
                                                         const std::vector<Pending>& to_add) {
  std::size_t removed = 0, changed = 0;
  for (auto it = nodes_.begin(); it != nodes_.end();) {
    bool replaced = std::any_of(to_add.begin(), to_add.end(), [&](const Pending& p) { return p.cfg->key == it->first; });
    if (!wanted.count(it->first) || replaced) {
      const auto subject = LogSubject::node(it->first);
      spdlog::info("{}: node 0x{:02X} {}", it->first, it->second.cfg.node_id, replaced ? "changed, restarting" : "removed");
      (replaced ? changed : removed) += 1;
      if (control_) control_->node_removed(it->first);
      remove_node(it->second);
      it = nodes_.erase(it);
    } else {
      ++it;
    }
  }
  return {removed, changed};
}

// Adds a planned node to the loop and the control API (not yet powered).
io::NodeRef Daemon::add_node(Pending& p, std::uint64_t seed, std::vector<BitRateMismatch>& mismatched) {
  const config::NodeConfig& n = *p.cfg;
  Interface* iface = nullptr;
  for (auto& i : interfaces_)
    if (i->can.name() == n.interface) iface = i.get();
  const NodeSetup setup = node_setup(n);
  auto storage = std::make_unique<FileStorage>(settings_.state_dir, n.key);
  NodeEntry e;
  e.cfg = n;
  e.seed = seed;
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
  {
    const auto subject = LogSubject::node(n.key);
    spdlog::debug("{}: node 0x{:02X} ({}, {})", n.key, n.node_id, n.profile->name, n.profile->personality);
  }
  if (control_) control_->node_added(stored.handle);
  return stored.ref;
}

void Daemon::close_unconfigured_interfaces() {
  for (auto& i : interfaces_)
    if (!i->configured && i->can.is_open()) {
      const auto subject = LogSubject::interface(i->can.name());
      spdlog::info("{}: no longer configured, closed", i->can.name());
      i->can.close();
      i->in_epoll = false;
    }
}

config::FleetConfig Daemon::combined() const {
  config::FleetConfig cfg = file_config_;
  std::erase_if(cfg.nodes, [&](const config::NodeConfig& n) { return removed_.count(n.key) > 0; });
  for (const config::FleetConfig& extra : added_) config::merge_fleet(cfg, extra);
  return cfg;
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
  config::FleetConfig fresh = settings_.load();
  std::swap(file_config_, fresh);
  std::set<std::string> removed;
  std::swap(removed_, removed);  // the file's nodes come back
  try {
    apply(combined(), clock_now());
  } catch (...) {
    std::swap(file_config_, fresh);
    std::swap(removed_, removed);
    throw;
  }
}

// ---------------------------------------------------------------- control API

std::vector<const control::NodeHandle*> Daemon::nodes() const {
  std::vector<const control::NodeHandle*> out;
  out.reserve(nodes_.size());
  for (const auto& [key, e] : nodes_) out.push_back(&e.handle);
  return out;
}

const control::NodeHandle* Daemon::find(const std::string& key) const {
  auto it = nodes_.find(key);
  return it == nodes_.end() ? nullptr : &it->second.handle;
}

std::vector<std::string> Daemon::add_nodes(const std::string& yaml) {
  const std::string label = "<AddNodes #" + std::to_string(++fragments_) + ">";
  config::FleetConfig running = combined();
  config::ProfileSearch search = profile_search(settings_.config_file);
  search.strict = settings_.strict;
  search.strict_eds = settings_.strict_eds;
  search.confined_to = profile_folders();
  config::FleetConfig extra = config::parse_fleet_fragment(yaml, label, search, running);
  for (const std::string& w : load_warnings(extra)) spdlog::warn("{}", w);
  config::merge_fleet(running, extra);  // throws on a collision
  added_.push_back(extra);
  try {
    apply(std::move(running), clock_now());
  } catch (...) {
    added_.pop_back();
    throw;
  }
  std::vector<std::string> keys;
  for (const auto& n : extra.nodes) keys.push_back(n.key);
  spdlog::info("control: added {} node(s)", keys.size());
  return keys;
}

void Daemon::remove_node(const std::string& key) {
  bool runtime = false;
  for (config::FleetConfig& extra : added_)
    runtime |= std::erase_if(extra.nodes, [&](const config::NodeConfig& n) { return n.key == key; }) > 0;
  if (!runtime) removed_.insert(key);
  std::erase_if(added_, [](const config::FleetConfig& f) { return f.nodes.empty(); });  // and their profiles
  apply(combined(), clock_now());
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
    b.up = i.can.is_open();
    b.bit_rate_kbit = i.bit_rate_kbit;
    b.frames_in = i.can.stats().rx;
    b.frames_out = i.can.stats().tx;
    b.drops = i.can.stats().tx_dropped;
    b.offline = i.can.stats().tx_offline;
    b.measured_load = i.measured_load;
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
    Traffic t;
    for (const auto& [key, e] : nodes_)
      if (core_.bus_of(e.ref) == i->bus) t += estimate_traffic(core_.node(e.ref));
    b.offered_load = i->bit_rate_kbit ? t.bits_per_s / (i->bit_rate_kbit * 1000.0) : 0;
  }
  return out;
}

bool Daemon::interface_up(const std::string& name) const {
  for (const auto& i : interfaces_)
    if (i->configured && i->can.name() == name) return i->can.is_open();
  return false;
}

void Daemon::log_action(const control::ActionRecord& r) {
  LogSubject subject = LogSubject::action(r.interface, r.node, r.uid ? std::optional<unsigned>(*r.uid) : std::nullopt);
  spdlog::info("{}", r.text);
}

void Daemon::start_control() {
  control_ = std::make_unique<control::ControlService>(*this);
  core_.set_observer(control_.get());
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

int Daemon::run() {
  epoch_ = io::monotonic_now();
  loop_.watch_signals({SIGINT, SIGTERM, SIGHUP});
  TimeUs now = clock_now();
  last_status_ = now;
  file_config_ = settings_.load();
  start_control();
  apply(combined(), now);
  now = clock_now();
  if (sd_watchdog_enabled(0, &watchdog_us_) <= 0) watchdog_us_ = 0;
  next_watchdog_ = now;
  housekeeping(now);  // opens the interfaces
  flush(now);         // the boot-ups are on the bus before READY=1
  sweep_interfaces(now);
  report_status(now);
  ready_when_sent();
  int signal = 0;
  for (;;) {
    now = clock_now();
    core_.run_due(now);
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
    TimeUs next = std::min(core_.next_deadline(), housekeeping_deadline());
    if (control_at != kNever) next = std::min(next, control_at - epoch_);
    endpoints_->before_sleep(next == kNever ? kNever : next + epoch_);
    loop_.arm_timer(next == kNever ? kNever : next + epoch_);
    bool timer = false;
    loop_.wait(-1, timer, signal);
    if (signal == SIGHUP) reload(clock_now());
    else if (signal == SIGTERM || signal == SIGINT) break;
  }
  notify("STOPPING=1");
  spdlog::info("{}: stopping, {} node(s) fall silent", strsignal(signal), nodes_.size());
  for (auto& [key, e] : nodes_) remove_node(e);
  nodes_.clear();
  endpoints_.reset();
  return 0;
}

}  // namespace cansim::daemon
