// io.cansim.Fleet1 on /io/cansim/Cansimd1.
#include <exception>

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
      if (ControlService::NodeContext* n = s.context(k); n && r >= 0) r = sd_bus_message_append(reply, "o", n->path.c_str());
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

int reload(sd_bus_message* m, void* userdata, sd_bus_error* e) {
  try {
    service_of(userdata).host().reload();
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
// 1 s, carried 10 s, queueing delay p50 / p99 / max in µs, frames queued,
// queue bound, frames dropped by the full queue).
int get_bus_load(sd_bus*, const char*, const char*, const char*, sd_bus_message* reply, void* userdata, sd_bus_error*) {
  int r = sd_bus_message_open_container(reply, 'a', "(ssddddxxxuut)");
  for (const BusStatistics& b : service_of(userdata).host().buses()) {
    const io::BusLoad& l = b.load;
    if (r >= 0)
      r = sd_bus_message_append(reply, "(ssddddxxxuut)", b.name.c_str(), b.model.c_str(), l.offered_1s, l.offered_10s,
                                l.carried_1s, l.carried_10s, std::int64_t(l.delay_p50), std::int64_t(l.delay_p99),
                                std::int64_t(l.delay_max), std::uint32_t(l.queued), std::uint32_t(l.queue_capacity),
                                std::uint64_t(l.dropped));
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

constexpr std::uint64_t kCall = SD_BUS_VTABLE_UNPRIVILEGED;

}  // namespace

const sd_bus_vtable kFleetVtable[] = {
    SD_BUS_VTABLE_START(0),
    SD_BUS_METHOD_WITH_NAMES("ListNodes", "", , "a(osssysss)", SD_BUS_PARAM(nodes), list_nodes, kCall),
    SD_BUS_METHOD_WITH_NAMES("GetNode", "s", SD_BUS_PARAM(node), "o", SD_BUS_PARAM(path), get_node, kCall),
    SD_BUS_METHOD_WITH_NAMES("AddNodes", "s", SD_BUS_PARAM(yaml), "ao", SD_BUS_PARAM(paths), audited_fleet<add_nodes>, kCall),
    SD_BUS_METHOD_WITH_NAMES("RemoveNode", "s", SD_BUS_PARAM(node), "", , audited_fleet<remove_node>, kCall),
    SD_BUS_METHOD("Reload", "", "", audited_fleet<reload>, kCall),
    SD_BUS_METHOD_WITH_NAMES("GetBusStatistics", "", , "a(sbuttttdd)", SD_BUS_PARAM(buses), bus_statistics, kCall),
    SD_BUS_METHOD("Subscribe", "", "", subscribe, kCall),
    SD_BUS_METHOD("Unsubscribe", "", "", unsubscribe, kCall),
    SD_BUS_PROPERTY("Version", "s", get_version, 0, SD_BUS_VTABLE_PROPERTY_CONST),
    SD_BUS_PROPERTY("SimulatedTime", "x", get_time, 0, 0),
    SD_BUS_PROPERTY("NodeCount", "u", get_node_count, 0, 0),
    SD_BUS_PROPERTY("ConfigFile", "s", get_config_file, 0, 0),
    SD_BUS_PROPERTY("BusLoad", "a(ssddddxxxuut)", get_bus_load, 0, 0),
    SD_BUS_PROPERTY("BusStates", "a{ss}", get_bus_states, 0, SD_BUS_VTABLE_PROPERTY_EMITS_CHANGE),
    SD_BUS_SIGNAL_WITH_NAMES("NodeAdded", "os", SD_BUS_PARAM(path) SD_BUS_PARAM(key), 0),
    SD_BUS_SIGNAL_WITH_NAMES("NodeRemoved", "os", SD_BUS_PARAM(path) SD_BUS_PARAM(key), 0),
    SD_BUS_SIGNAL_WITH_NAMES("BusStateChanged", "xsss",
                             SD_BUS_PARAM(t) SD_BUS_PARAM(interface) SD_BUS_PARAM(old) SD_BUS_PARAM(state), 0),
    SD_BUS_VTABLE_END,
};

}  // namespace cansim::control
