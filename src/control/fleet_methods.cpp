// io.cansim.Fleet1 on /io/cansim/Cansimd1.
#include <linux/can.h>

#include <cstring>
#include <exception>
#include <stdexcept>

#include "config/limits.hpp"
#include "config/profile.hpp"
#include "control/node_names.hpp"
#include "control/service_internal.hpp"
#include "io/can_interface.hpp"

#ifndef CANSIM_VERSION
#define CANSIM_VERSION "unknown"
#endif

namespace cansim::control {

namespace {

ControlService& service_of(void* userdata) { return *static_cast<ControlService*>(userdata); }

int list_nodes(sd_bus_message* m, void* userdata, sd_bus_error*) {
  ControlService& s = service_of(userdata);
  return reply_with(m, [&](sd_bus_message* reply) {
    int r = sd_bus_message_open_container(reply, 'a', "(osssysss)");
    for (const NodeHandle* h : s.host().nodes()) {
      ControlService::NodeContext* n = s.context(h->key);
      if (!n || r < 0) continue;
      const Node& node = n->node();
      r = sd_bus_message_append(reply, "(osssysss)", n->path.c_str(), h->key.c_str(), h->name.c_str(),
                                h->interface.c_str(), node.node_id(), h->profile.c_str(), h->personality.c_str(),
                                nmt_state_name(node.state()));
    }
    return r < 0 ? r : sd_bus_message_close_container(reply);
  });
}

// Reads the (s node) argument and resolves it; null with the error set (*r).
ControlService::NodeContext* node_argument(sd_bus_message* m, ControlService& s, sd_bus_error* e, int* r) {
  const char* spec = nullptr;
  if ((*r = sd_bus_message_read(m, "s", &spec)) < 0) return nullptr;
  std::string why;
  const NodeHandle* h = resolve_node(s.host(), spec, &why);
  ControlService::NodeContext* n = h ? s.context(h->key) : nullptr;
  if (!n) *r = fail(e, kErrorUnknownNode, why.empty() ? "no node '" + std::string(spec) + "'" : why);
  return n;
}

int get_node(sd_bus_message* m, void* userdata, sd_bus_error* e) {
  int r = 0;
  ControlService::NodeContext* n = node_argument(m, service_of(userdata), e, &r);
  return n ? sd_bus_reply_method_return(m, "o", n->path.c_str()) : r;
}

int add_nodes(sd_bus_message* m, void* userdata, sd_bus_error* e) {
  ControlService& s = service_of(userdata);
  const char* yaml = nullptr;
  int r = sd_bus_message_read(m, "s", &yaml);
  if (r < 0) return r;
  std::vector<std::string> keys;
  try {
    config::check_yaml_size(yaml, "<AddNodes>", limits::kYamlTextBytes);
    keys = s.host().add_nodes(yaml);
  } catch (const config::TooLarge& ex) {
    return fail(e, kErrorTooLarge, ex.what());
  } catch (const std::exception& ex) {
    return fail(e, kErrorConfig, ex.what());
  }
  return reply_with(m, [&](sd_bus_message* reply) {
    int r = sd_bus_message_open_container(reply, 'a', "o");
    for (const std::string& k : keys)
      if (ControlService::NodeContext* n = s.context(k); n && r >= 0)
        r = sd_bus_message_append(reply, "o", n->path.c_str());
    return r < 0 ? r : sd_bus_message_close_container(reply);
  });
}

int remove_node(sd_bus_message* m, void* userdata, sd_bus_error* e) {
  ControlService& s = service_of(userdata);
  int r = 0;
  ControlService::NodeContext* n = node_argument(m, s, e, &r);
  if (!n) return r;
  s.host().remove_node(std::string(n->handle->key));  // a copy: removal destroys the context
  return sd_bus_reply_method_return(m, "");
}

// Reload and Reset: the fleet as its configuration says, or a Config error
// with the running fleet untouched.
template <void (ControlHost::*operation)()>
int reconfigure(sd_bus_message* m, void* userdata, sd_bus_error* e) {
  try {
    (service_of(userdata).host().*operation)();
  } catch (const std::exception& ex) {
    return fail(e, kErrorConfig, ex.what());
  }
  return sd_bus_reply_method_return(m, "");
}

int bus_statistics(sd_bus_message* m, void* userdata, sd_bus_error*) {
  ControlService& s = service_of(userdata);
  return reply_with(m, [&](sd_bus_message* reply) {
    int r = sd_bus_message_open_container(reply, 'a', "(sbuttttdd)");
    for (const BusStatistics& b : s.host().bus_statistics())
      if (r >= 0)
        r = sd_bus_message_append(reply, "(sbuttttdd)", b.name.c_str(), int(b.up), b.bit_rate_kbit, b.frames_in,
                                  b.frames_out, b.drops, b.offline, b.offered_load, b.measured_load);
    return r < 0 ? r : sd_bus_message_close_container(reply);
  });
}

// BusLoad: per interface (name, model, offered 1 s, offered 10 s, carried
// 1 s, carried 10 s, queueing delay p50 / p99 / max in µs, slip p99 / max
// in µs (how much later than its schedule a frame left), frames queued,
// queue bound, frames dropped by the full queue).
int get_bus_load(sd_bus*, const char*, const char*, const char*, sd_bus_message* reply, void* userdata, sd_bus_error*) {
  int r = sd_bus_message_open_container(reply, 'a', "(ssddddxxxxxuut)");
  for (const BusStatistics& b : service_of(userdata).host().buses()) {
    const io::BusLoad& l = b.load;
    if (r >= 0)
      r = sd_bus_message_append(reply, "(ssddddxxxxxuut)", b.name.c_str(), b.model.c_str(), l.offered_1s, l.offered_10s,
                                l.carried_1s, l.carried_10s, std::int64_t(l.delay_p50), std::int64_t(l.delay_p99),
                                std::int64_t(l.delay_max), std::int64_t(l.slip_p99), std::int64_t(l.slip_max),
                                std::uint32_t(l.queued), std::uint32_t(l.queue_capacity), std::uint64_t(l.dropped));
  }
  return r < 0 ? r : sd_bus_message_close_container(reply);
}

int get_bus_states(sd_bus*, const char*, const char*, const char*, sd_bus_message* reply, void* userdata,
                   sd_bus_error*) {
  int r = sd_bus_message_open_container(reply, 'a', "{ss}");
  for (const BusStatistics& b : service_of(userdata).host().buses())
    if (r >= 0) r = sd_bus_message_append(reply, "{ss}", b.name.c_str(), io::can_state_name(b.state));
  return r < 0 ? r : sd_bus_message_close_container(reply);
}

// One (x t, u can_id, y dlc, ay data) of QueueFrames: can_id as SocketCAN
// has it (bit 31: a 29-bit identifier, bit 30: a remote frame). "" or why not.
std::string read_scheduled_frame(sd_bus_message* m, ScheduledFrame& out, int& r) {
  constexpr std::uint32_t kEff = CAN_EFF_FLAG, kRtr = CAN_RTR_FLAG, kErr = CAN_ERR_FLAG;
  std::int64_t at = 0;
  std::uint32_t id = 0;
  std::uint8_t dlc = 0;
  const void* data = nullptr;
  std::size_t size = 0;
  if ((r = sd_bus_message_enter_container(m, 'r', "xuyay")) <= 0 ||
      (r = sd_bus_message_read(m, "xuy", &at, &id, &dlc)) < 0 ||
      (r = sd_bus_message_read_array(m, 'y', &data, &size)) < 0 || (r = sd_bus_message_exit_container(m)) < 0)
    return "expected (x t, u can_id, y dlc, ay data)";
  out = {};
  out.at = at;
  CanFrame& f = out.frame;
  if (id & kErr) return "error frames are not sent";
  const bool ext = id & kEff;
  f.id = id & 0x1FFFFFFFu;
  if (!ext && f.id > 0x7FF) return "an 11-bit identifier above 0x7FF (bit 31 marks a 29-bit one)";
  if (ext) f.flags |= CanFrame::kExtended;
  if (id & kRtr) f.flags |= CanFrame::kRtr;
  if (dlc > 8) return "a DLC above 8 (classic CAN only)";
  if ((id & kRtr) ? size != 0 : size != dlc) return "data of the DLC's length (none for a remote frame)";
  f.dlc = dlc;
  if (size) std::memcpy(f.data, data, size);
  return {};
}

// QueueFrames(s interface, a(xuyay) frames) -> u taken: docs/control-api.md.
int queue_frames(sd_bus_message* m, void* userdata, sd_bus_error* e) {
  ControlService& s = service_of(userdata);
  const char* iface = nullptr;
  int r = sd_bus_message_read(m, "s", &iface);
  if (r < 0) return r;
  if ((r = sd_bus_message_enter_container(m, 'a', "(xuyay)")) < 0) return r;
  const TimeUs latest = s.host().now() + limits::kQueueAheadUs;
  std::vector<ScheduledFrame> frames;
  for (;;) {
    if ((r = sd_bus_message_at_end(m, 0)) != 0) break;
    if (frames.size() == limits::kQueueFramesPerCall)
      return fail(e, kErrorTooLarge,
                  "QueueFrames takes at most " + std::to_string(limits::kQueueFramesPerCall) + " frames a call");
    ScheduledFrame f;
    const std::string why = read_scheduled_frame(m, f, r);
    if (r < 0) return r;
    if (!why.empty()) return fail(e, kErrorInvalidArgument, "frame " + std::to_string(frames.size()) + ": " + why);
    if (f.at > latest)
      return fail(e, kErrorOutOfRange,
                  "frame " + std::to_string(frames.size()) + ": its time is more than " +
                      std::to_string(limits::kQueueAheadUs / 1000000) + " s ahead");
    frames.push_back(f);
  }
  if (r < 0) return r;
  std::size_t taken = 0;
  try {
    taken = s.host().queue_frames(iface, frames);
  } catch (const std::out_of_range& ex) {
    return fail(e, kErrorInvalidArgument, ex.what());
  }
  return sd_bus_reply_method_return(m, "u", std::uint32_t(taken));
}

// SocketcandBuses: per socketcand bus (name, address, port (0 while it does
// not listen), clients connected now); docs/socketcand.md.
int get_socketcand_buses(sd_bus*, const char*, const char*, const char*, sd_bus_message* reply, void* userdata,
                         sd_bus_error*) {
  int r = sd_bus_message_open_container(reply, 'a', "(ssqu)");
  for (const BusStatistics& b : service_of(userdata).host().buses())
    if (r >= 0 && b.transport == "socketcand")
      r = sd_bus_message_append(reply, "(ssqu)", b.name.c_str(), b.listen_host.c_str(), b.listen_port,
                                std::uint32_t(b.clients));
  return r < 0 ? r : sd_bus_message_close_container(reply);
}

int subscribe(sd_bus_message* m, void* userdata, sd_bus_error*) {
  service_of(userdata).subscribe(m, true);
  return sd_bus_reply_method_return(m, "");
}

int unsubscribe(sd_bus_message* m, void* userdata, sd_bus_error*) {
  service_of(userdata).subscribe(m, false);
  return sd_bus_reply_method_return(m, "");
}

int get_version(sd_bus*, const char*, const char*, const char*, sd_bus_message* reply, void*, sd_bus_error*) {
  return sd_bus_message_append(reply, "s", CANSIM_VERSION);
}

int get_time(sd_bus*, const char*, const char*, const char*, sd_bus_message* reply, void* userdata, sd_bus_error*) {
  return sd_bus_message_append(reply, "x", std::int64_t(service_of(userdata).host().now()));
}

int get_node_count(sd_bus*, const char*, const char*, const char*, sd_bus_message* reply, void* userdata,
                   sd_bus_error*) {
  return sd_bus_message_append(reply, "u", std::uint32_t(service_of(userdata).host().nodes().size()));
}

int get_config_file(sd_bus*, const char*, const char*, const char*, sd_bus_message* reply, void* userdata,
                    sd_bus_error*) {
  return sd_bus_message_append(reply, "s", service_of(userdata).host().config_file().c_str());
}

// Plants (docs/control-api.md "Plants").
int list_plants(sd_bus_message* m, void* userdata, sd_bus_error*) {
  ControlService& s = service_of(userdata);
  physics::PlantSet* set = s.host().plants();
  return reply_with(m, [&](sd_bus_message* reply) {
    int r = sd_bus_message_open_container(reply, 'a', "(os)");
    if (set)
      for (const auto& p : set->plants())
        if (r >= 0) r = sd_bus_message_append(reply, "(os)", plant_path(p->name()).c_str(), p->name().c_str());
    return r < 0 ? r : sd_bus_message_close_container(reply);
  });
}

int get_plant(sd_bus_message* m, void* userdata, sd_bus_error* e) {
  ControlService& s = service_of(userdata);
  const char* name = nullptr;
  int r = sd_bus_message_read(m, "s", &name);
  if (r < 0) return r;
  if (!s.plant_context(name)) {
    std::string names;
    if (physics::PlantSet* set = s.host().plants())
      for (const auto& p : set->plants()) names += (names.empty() ? "" : ", ") + p->name();
    return fail(e, kErrorUnknownPlant,
                "no plant '" + std::string(name) + "' (plants: " + (names.empty() ? "none" : names) + ")");
  }
  return sd_bus_reply_method_return(m, "o", plant_path(name).c_str());
}

// The plant inputs read from frames, for a monitor to decode them:
// (plant, input, interface, CAN-ID, 29-bit, start bit, length, type 0
// unsigned / 1 signed / 2 real32, little-endian, scale, offset, unit).
int list_plant_signals(sd_bus_message* m, void* userdata, sd_bus_error*) {
  ControlService& s = service_of(userdata);
  const config::PlantsConfig* cfg = s.host().plant_config();
  return reply_with(m, [&](sd_bus_message* reply) {
    int r = sd_bus_message_open_container(reply, 'a', "(sssubqyybdds)");
    if (cfg)
      for (const config::PlantInputBinding& b : cfg->bindings) {
        if (b.kind != config::PlantInputBinding::Kind::kFrame || r < 0) continue;
        const CanSignal& sig = b.signal;
        const std::string unit = b.unit.name.empty() ? "" : std::string(b.unit.name);
        r = sd_bus_message_append(reply, "(sssubqyybdds)", b.plant.c_str(), b.input.c_str(), b.interface.c_str(),
                                  sig.can_id, int(sig.extended), sig.start, sig.length, std::uint8_t(sig.type),
                                  int(sig.little_endian), sig.scale, sig.offset, unit.c_str());
      }
    return r < 0 ? r : sd_bus_message_close_container(reply);
  });
}

int get_longest_pass(sd_bus*, const char*, const char*, const char*, sd_bus_message* reply, void* userdata,
                     sd_bus_error*) {
  return sd_bus_message_append(reply, "t", std::uint64_t(service_of(userdata).host().longest_loop_pass()));
}

int get_longest_pass_cpu(sd_bus*, const char*, const char*, const char*, sd_bus_message* reply, void* userdata,
                         sd_bus_error*) {
  return sd_bus_message_append(reply, "t", std::uint64_t(service_of(userdata).host().longest_loop_pass_cpu()));
}

constexpr std::uint64_t kCall = SD_BUS_VTABLE_UNPRIVILEGED;

}  // namespace

const sd_bus_vtable kFleetVtable[] = {
    SD_BUS_VTABLE_START(0),
    SD_BUS_METHOD_WITH_NAMES("ListNodes", "", , "a(osssysss)", SD_BUS_PARAM(nodes), list_nodes, kCall),
    SD_BUS_METHOD_WITH_NAMES("GetPdoMappings", "s", SD_BUS_PARAM(interface), "a(sa(subya(qyyssds))a(qydds))",
                             SD_BUS_PARAM(nodes), fleet_get_pdo_mappings, kCall),
    SD_BUS_METHOD_WITH_NAMES("GetNode", "s", SD_BUS_PARAM(node), "o", SD_BUS_PARAM(path), get_node, kCall),
    SD_BUS_METHOD_WITH_NAMES("AddNodes", "s", SD_BUS_PARAM(yaml), "ao", SD_BUS_PARAM(paths), audited_fleet<add_nodes>,
                             kCall),
    SD_BUS_METHOD_WITH_NAMES("RemoveNode", "s", SD_BUS_PARAM(node), "", , audited_fleet<remove_node>, kCall),
    SD_BUS_METHOD("Reload", "", "", audited_fleet<reconfigure<&ControlHost::reload>>, kCall),
    SD_BUS_METHOD("Reset", "", "", audited_fleet<reconfigure<&ControlHost::reset>>, kCall),
    SD_BUS_METHOD_WITH_NAMES("GetBusStatistics", "", , "a(sbuttttdd)", SD_BUS_PARAM(buses), bus_statistics, kCall),
    SD_BUS_METHOD_WITH_NAMES("QueueFrames", "sa(xuyay)", SD_BUS_PARAM(interface) SD_BUS_PARAM(frames), "u",
                             SD_BUS_PARAM(taken), queue_frames, kCall),
    SD_BUS_METHOD_WITH_NAMES("ListPlants", "", , "a(os)", SD_BUS_PARAM(plants), list_plants, kCall),
    SD_BUS_METHOD_WITH_NAMES("GetPlant", "s", SD_BUS_PARAM(plant), "o", SD_BUS_PARAM(path), get_plant, kCall),
    SD_BUS_METHOD_WITH_NAMES("ListPlantSignals", "", , "a(sssubqyybdds)", SD_BUS_PARAM(signals), list_plant_signals,
                             kCall),
    SD_BUS_METHOD("Subscribe", "", "", subscribe, kCall),
    SD_BUS_METHOD("Unsubscribe", "", "", unsubscribe, kCall),
    SD_BUS_PROPERTY("Version", "s", get_version, 0, SD_BUS_VTABLE_PROPERTY_CONST),
    SD_BUS_PROPERTY("SimulatedTime", "x", get_time, 0, 0),
    SD_BUS_PROPERTY("NodeCount", "u", get_node_count, 0, 0),
    SD_BUS_PROPERTY("ConfigFile", "s", get_config_file, 0, 0),
    SD_BUS_PROPERTY("BusLoad", "a(ssddddxxxxxuut)", get_bus_load, 0, 0),
    SD_BUS_PROPERTY("BusStates", "a{ss}", get_bus_states, 0, SD_BUS_VTABLE_PROPERTY_EMITS_CHANGE),
    SD_BUS_PROPERTY("LongestLoopPass", "t", get_longest_pass, 0, 0),
    SD_BUS_PROPERTY("LongestLoopPassCpu", "t", get_longest_pass_cpu, 0, 0),
    SD_BUS_PROPERTY("SocketcandBuses", "a(ssqu)", get_socketcand_buses, 0, 0),
    SD_BUS_SIGNAL_WITH_NAMES("NodeAdded", "os", SD_BUS_PARAM(path) SD_BUS_PARAM(key), 0),
    SD_BUS_SIGNAL_WITH_NAMES("NodeRemoved", "os", SD_BUS_PARAM(path) SD_BUS_PARAM(key), 0),
    SD_BUS_SIGNAL_WITH_NAMES("BusStateChanged", "xsss",
                             SD_BUS_PARAM(t) SD_BUS_PARAM(interface) SD_BUS_PARAM(old) SD_BUS_PARAM(state), 0),
    SD_BUS_VTABLE_END,
};

}  // namespace cansim::control
