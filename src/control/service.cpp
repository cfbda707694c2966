#include "control/service.hpp"

#include <spdlog/spdlog.h>

#include <algorithm>
#include <cstdlib>

#include "config/limits.hpp"
#include "control/od_values.hpp"
#include "control/service_internal.hpp"
#include "io/can_interface.hpp"

namespace cansim::control {

namespace {

// ---- the bus daemon's own calls, answered on peer-to-peer connections:
// busctl and gdbus send Hello (and AddMatch, GetNameOwner) first.
int peer_hello(sd_bus_message* m, void*, sd_bus_error*) { return sd_bus_reply_method_return(m, "s", ":1.1"); }
int peer_ignore(sd_bus_message* m, void*, sd_bus_error*) { return sd_bus_reply_method_return(m, ""); }
int peer_name_owner(sd_bus_message* m, void*, sd_bus_error*) { return sd_bus_reply_method_return(m, "s", ":1.0"); }
int peer_list_names(sd_bus_message* m, void*, sd_bus_error*) {
  return sd_bus_reply_method_return(m, "as", 2, "org.freedesktop.DBus", kBusName);
}
const sd_bus_vtable kPeerBusVtable[] = {
    SD_BUS_VTABLE_START(0),
    SD_BUS_METHOD("Hello", "", "s", peer_hello, SD_BUS_VTABLE_UNPRIVILEGED),
    SD_BUS_METHOD("AddMatch", "s", "", peer_ignore, SD_BUS_VTABLE_UNPRIVILEGED),
    SD_BUS_METHOD("RemoveMatch", "s", "", peer_ignore, SD_BUS_VTABLE_UNPRIVILEGED),
    SD_BUS_METHOD("GetNameOwner", "s", "s", peer_name_owner, SD_BUS_VTABLE_UNPRIVILEGED),
    SD_BUS_METHOD("ListNames", "", "as", peer_list_names, SD_BUS_VTABLE_UNPRIVILEGED),
    SD_BUS_VTABLE_END,
};

// Fallback lookup: the node behind a path, or 0 (sd-bus answers UnknownObject).
int find_node(sd_bus*, const char* path, const char*, void* userdata, void** found, sd_bus_error*) {
  auto* service = static_cast<ControlService*>(userdata);
  char *iface = nullptr, *name = nullptr, *index = nullptr;
  if (sd_bus_path_decode_many(path, "/io/cansim/Cansimd1/node/%/%/%", &iface, &name, &index) <= 0) return 0;
  std::string key = std::string(iface) + "/" + name + "/" + index;
  std::free(iface);
  std::free(name);
  std::free(index);
  ControlService::NodeContext* n = service->context(key);
  if (!n) return 0;
  *found = n;
  return 1;
}

int find_plant(sd_bus*, const char* path, const char*, void* userdata, void** found, sd_bus_error*) {
  auto* service = static_cast<ControlService*>(userdata);
  char* name = nullptr;
  if (sd_bus_path_decode_many(path, "/io/cansim/Cansimd1/plant/%", &name) <= 0) return 0;
  ControlService::PlantContext* p = service->plant_context(name);
  std::free(name);
  if (!p) return 0;
  *found = p;
  return 1;
}

int enumerate_plants(sd_bus*, const char*, void* userdata, char*** nodes, sd_bus_error*) {
  auto* service = static_cast<ControlService*>(userdata);
  physics::PlantSet* set = service->host().plants();
  const std::size_t n = set ? set->plants().size() : 0;
  char** list = static_cast<char**>(std::calloc(n + 1, sizeof(char*)));
  if (!list) return -ENOMEM;
  for (std::size_t i = 0; i < n; ++i) list[i] = strdup(plant_path(set->plants()[i]->name()).c_str());
  *nodes = list;
  return 1;
}

int enumerate_nodes(sd_bus*, const char*, void* userdata, char*** nodes, sd_bus_error*) {
  auto* service = static_cast<ControlService*>(userdata);
  auto handles = service->host().nodes();
  char** list = static_cast<char**>(std::calloc(handles.size() + 1, sizeof(char*)));
  if (!list) return -ENOMEM;
  std::size_t k = 0;
  for (const NodeHandle* h : handles)
    if (ControlService::NodeContext* n = service->context(h->key)) list[k++] = strdup(n->path.c_str());
  *nodes = list;
  return 1;
}

}  // namespace

int fail(sd_bus_error* e, const char* name, const std::string& message) {
  if (message.size() <= limits::kErrorMessageBytes) return sd_bus_error_set(e, name, message.c_str());
  std::string cut = message.substr(0, limits::kErrorMessageBytes);
  while (!cut.empty() && (static_cast<unsigned char>(cut.back()) & 0xC0) == 0x80)
    cut.pop_back();  // whole UTF-8 characters
  if (!cut.empty() && static_cast<unsigned char>(cut.back()) >= 0xC0) cut.pop_back();
  return sd_bus_error_set(e, name, (cut + "...").c_str());
}

const char* nmt_state_name(NmtState s) {
  switch (s) {
    case NmtState::kInitialising: return "initialising";
    case NmtState::kStopped: return "stopped";
    case NmtState::kOperational: return "operational";
    case NmtState::kPreOperational: return "pre-operational";
  }
  return "unknown";
}

std::string node_path(const NodeHandle& h) {
  char* out = nullptr;
  const std::string index = std::to_string(h.index);
  if (sd_bus_path_encode_many(&out, "/io/cansim/Cansimd1/node/%/%/%", h.interface.c_str(), h.name.c_str(),
                              index.c_str()) < 0)
    return {};
  std::string path(out);
  std::free(out);
  return path;
}

std::string plant_path(const std::string& name) {
  char* out = nullptr;
  if (sd_bus_path_encode_many(&out, "/io/cansim/Cansimd1/plant/%", name.c_str()) < 0) return {};
  std::string path(out);
  std::free(out);
  return path;
}

ControlService::ControlService(ControlHost& host) : host_(host) {}

ControlService::~ControlService() {
  while (!connections_.empty()) detach(connections_.back()->bus);
  if (auto line = action_limiter_.flush()) host_.log_action(*line);
}

void ControlService::audit(sd_bus_message* m, const std::string& key, const std::string& interface, int r,
                           const sd_bus_error* e) {
  const ActionLimiter::Admission admission = action_limiter_.admit(ActionLimiter::Clock::now());
  if (admission.suppressed) host_.log_action(*admission.suppressed);
  if (!admission.log) return;
  const char* member = sd_bus_message_get_member(m);
  const std::optional<uid_t> uid = callers_.of(m);
  host_.log_action({key, interface,
                    "control: " + (key.empty() ? std::string("fleet") : key) + ": " + (member ? member : "?") +
                        describe_arguments(m) + " " + action_outcome(uid, r, e),
                    uid});
}

int ControlService::attach(sd_bus* bus, bool peer, std::optional<uid_t> peer_uid) {
  if (peer_uid) callers_.set_peer(bus, *peer_uid);
  auto c = std::make_unique<Connection>();
  c->bus = bus;
  c->peer = peer;
  sd_bus_slot* slot = nullptr;
  int r = 0;
  auto add = [&](int result) {
    if (result >= 0 && slot) c->slots.push_back(slot);
    slot = nullptr;
    if (r >= 0 && result < 0) r = result;
  };
  add(sd_bus_add_object_vtable(bus, &slot, kRootPath, kFleetInterface, kFleetVtable, this));
  add(sd_bus_add_fallback_vtable(bus, &slot, kNodePrefix, kNodeInterface, kNodeVtable, find_node, this));
  add(sd_bus_add_node_enumerator(bus, &slot, kNodePrefix, enumerate_nodes, this));
  add(sd_bus_add_fallback_vtable(bus, &slot, kPlantPrefix, kPlantInterface, kPlantVtable, find_plant, this));
  add(sd_bus_add_node_enumerator(bus, &slot, kPlantPrefix, enumerate_plants, this));
  add(sd_bus_add_object_manager(bus, &slot, kRootPath));
  if (peer)
    add(sd_bus_add_object_vtable(bus, &slot, "/org/freedesktop/DBus", "org.freedesktop.DBus", kPeerBusVtable, this));
  else
    add(sd_bus_track_new(bus, &c->track, nullptr,
                         nullptr));  // with a handler, an empty track is dispatched on every sd_bus_process()
  connections_.push_back(std::move(c));
  if (r < 0) detach(bus);
  return r;
}

void ControlService::detach(sd_bus* bus) {
  callers_.forget(bus);
  auto it = std::find_if(connections_.begin(), connections_.end(), [&](const auto& c) { return c->bus == bus; });
  if (it == connections_.end()) return;
  for (sd_bus_slot* s : (*it)->slots) sd_bus_slot_unref(s);
  if ((*it)->track) sd_bus_track_unref((*it)->track);
  connections_.erase(it);
}

bool ControlService::has_subscribers() const {
  return std::any_of(connections_.begin(), connections_.end(), [](const auto& c) { return c->subscribed(); });
}

void ControlService::subscribe(sd_bus_message* m, bool on) {
  sd_bus* bus = sd_bus_message_get_bus(m);
  for (auto& c : connections_) {
    if (c->bus != bus) continue;
    if (c->peer) c->peer_subscribed = on;
    else if (on) sd_bus_track_add_sender(c->track, m);
    else sd_bus_track_remove_sender(c->track, m);
  }
}

ControlService::NodeContext* ControlService::context(const std::string& key) {
  auto it = by_key_.find(key);
  return it == by_key_.end() ? nullptr : it->second.get();
}

ControlService::NodeContext* ControlService::context(io::NodeRef ref) {
  return ref < by_ref_.size() ? by_ref_[ref] : nullptr;
}

ControlService::PlantContext* ControlService::plant_context(const std::string& name) {
  physics::PlantSet* set = host_.plants();
  if (!set || !set->find(name)) return nullptr;
  std::unique_ptr<PlantContext>& p = plants_[name];
  if (!p) p = std::make_unique<PlantContext>(PlantContext{this, name, plant_path(name)});
  return p.get();
}

void ControlService::plant_fault_edge(const std::string& plant, std::uint32_t id, std::uint8_t kind,
                                      const std::string& target, bool started, TimeUs t) {
  if (!has_subscribers()) return;
  const std::string path = plant_path(plant);
  const std::string name(physics::to_string(physics::FaultKind(kind)));
  emit(path, kPlantInterface, started ? "FaultStarted" : "FaultEnded", [&](sd_bus_message* m) {
    return sd_bus_message_append(m, "xuss", std::int64_t(t), id, name.c_str(), target.c_str());
  });
  emit_properties_changed(path, kPlantInterface, {"Faults"});
}

void ControlService::node_added(const NodeHandle& h) {
  auto n = std::make_unique<NodeContext>();
  n->service = this;
  n->handle = &h;
  n->path = node_path(h);
  n->sensor = personalities::measurement_control(h.app);
  if (n->sensor) {
    NodeContext* raw = n.get();
    n->sensor->set_fault_listener([raw](const physics::FaultEdge& edge) {
      raw->service->fault_edge(*raw, edge.handle, std::uint8_t(edge.kind), edge.started, edge.time_us);
    });
  }
  if (by_ref_.size() <= h.ref) by_ref_.resize(h.ref + 1, nullptr);
  by_ref_[h.ref] = n.get();
  const std::string path = n->path;
  by_key_[h.key] = std::move(n);
  emit(kRootPath, kFleetInterface, "NodeAdded",
       [&](sd_bus_message* m) { return sd_bus_message_append(m, "os", path.c_str(), h.key.c_str()); });
}

void ControlService::node_removed(const std::string& key) {
  auto it = by_key_.find(key);
  if (it == by_key_.end()) return;
  const std::string path = it->second->path;
  const io::NodeRef ref = it->second->handle->ref;
  if (it->second->sensor) it->second->sensor->set_fault_listener(nullptr);
  if (ref < by_ref_.size() && by_ref_[ref] == it->second.get()) by_ref_[ref] = nullptr;
  by_key_.erase(it);
  emit(kRootPath, kFleetInterface, "NodeRemoved",
       [&](sd_bus_message* m) { return sd_bus_message_append(m, "os", path.c_str(), key.c_str()); });
}

void ControlService::bus_state_changed(const std::string& interface, CanState old, CanState now, TimeUs t) {
  emit(kRootPath, kFleetInterface, "BusStateChanged", [&](sd_bus_message* m) {
    return sd_bus_message_append(m, "xsss", std::int64_t(t), interface.c_str(), io::can_state_name(old),
                                 io::can_state_name(now));
  });
  emit_properties_changed(kRootPath, kFleetInterface, {"BusStates"});
}

void ControlService::touched(const NodeContext& n) { host_.core().refresh(n.handle->ref); }

void ControlService::emit_properties_changed(const std::string& path, const char* interface,
                                             std::initializer_list<const char*> names) {
  std::vector<char*> list;
  for (const char* s : names) list.push_back(const_cast<char*>(s));
  list.push_back(nullptr);
  for (auto& c : connections_)
    if (c->wants_signals()) sd_bus_emit_properties_changed_strv(c->bus, path.c_str(), interface, list.data());
}

// ---------------------------------------------------------------- core events

void ControlService::on_nmt_state(io::NodeRef ref, NmtState old, NmtState now, TimeUs t) {
  NodeContext* n = context(ref);
  if (!n || !has_subscribers()) return;
  emit(n->path, kNodeInterface, "NmtStateChanged", [&](sd_bus_message* m) {
    return sd_bus_message_append(m, "xss", std::int64_t(t), nmt_state_name(old), nmt_state_name(now));
  });
  emit_properties_changed(n->path, kNodeInterface, {"NmtState", "NodeId"});
}

void ControlService::on_boot_up(io::NodeRef ref, TimeUs t) {
  NodeContext* n = context(ref);
  if (!n || !has_subscribers()) return;
  const std::uint8_t id = n->node().node_id();
  emit(n->path, kNodeInterface, "BootUp",
       [&](sd_bus_message* m) { return sd_bus_message_append(m, "xy", std::int64_t(t), id); });
}

void ControlService::on_emcy(io::NodeRef ref, std::uint16_t code, std::uint8_t reg, const std::uint8_t vendor[5],
                             TimeUs t) {
  NodeContext* n = context(ref);
  if (!n || !has_subscribers()) return;
  emit(n->path, kNodeInterface, "EmcySent", [&](sd_bus_message* m) {
    int r = sd_bus_message_append(m, "xqy", std::int64_t(t), code, reg);
    return r < 0 ? r : sd_bus_message_append_array(m, 'y', vendor, 5);
  });
}

void ControlService::on_remote_write(io::NodeRef ref, const OdEntry& e, WriteVia via, TimeUs t) {
  NodeContext* n = context(ref);
  if (!n || !has_subscribers()) return;
  auto bytes = n->node().values().bytes(e);
  emit(n->path, kNodeInterface, "ObjectWritten", [&](sd_bus_message* m) {
    int r = sd_bus_message_append(m, "xqy", std::int64_t(t), e.index, e.sub);
    if (r >= 0) r = append_value(m, e, bytes);
    return r < 0 ? r : sd_bus_message_append(m, "s", via == WriteVia::kRpdo ? "rpdo" : "sdo");
  });
}

void ControlService::on_power(io::NodeRef ref, bool, TimeUs) {
  NodeContext* n = context(ref);
  if (!n || !has_subscribers()) return;
  emit_properties_changed(n->path, kNodeInterface, {"Powered"});
}

void ControlService::on_pdo_config(io::NodeRef ref, TimeUs t) {
  NodeContext* n = context(ref);
  if (!n || !has_subscribers()) return;
  emit(n->path, kNodeInterface, "PdoMappingChanged",
       [&](sd_bus_message* m) { return sd_bus_message_append(m, "x", std::int64_t(t)); });
}

void ControlService::fault_edge(NodeContext& n, std::uint32_t id, std::uint8_t kind, bool started, TimeUs t) {
  if (!has_subscribers()) return;
  const std::string name(physics::to_string(physics::FaultKind(kind)));
  emit(n.path, kNodeInterface, started ? "FaultStarted" : "FaultEnded",
       [&](sd_bus_message* m) { return sd_bus_message_append(m, "xus", std::int64_t(t), id, name.c_str()); });
  emit_properties_changed(n.path, kNodeInterface, {"Faults"});
}

}  // namespace cansim::control
