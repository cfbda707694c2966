// Shared by the control service's files: per-node and per-connection state,
// the method handlers of each interface, and small reply helpers.
#pragma once

#include <systemd/sd-bus.h>

#include <cstdint>
#include <string>

#include "config/limits.hpp"
#include "control/names.hpp"
#include "control/node_names.hpp"
#include "control/service.hpp"
#include "core/node.hpp"
#include "personalities/measurement_control.hpp"

namespace cansim::control {

struct ControlService::NodeContext {
  ControlService* service = nullptr;
  const NodeHandle* handle = nullptr;
  std::string path;
  personalities::MeasurementControl* sensor = nullptr;  // null: no measurement chain
  Node& node() const { return service->host().core().node(handle->ref); }
  // A method acts now: what was due before the call happens first.
  TimeUs act_now() const {
    io::LoopCore& core = service->host().core();
    core.run_due(service->host().now());
    return core.now();
  }
  // The context a node's vtable entries get as userdata.
  static NodeContext& of(void* userdata) { return *static_cast<NodeContext*>(userdata); }
};

struct ControlService::PlantContext {
  ControlService* service = nullptr;
  std::string name;
  std::string path;
  // A method acts now: what was due before the call happens first.
  TimeUs act_now() const {
    io::LoopCore& core = service->host().core();
    core.run_due(service->host().now());
    return core.now();
  }
  static PlantContext& of(void* userdata) { return *static_cast<PlantContext*>(userdata); }
};

struct ControlService::Connection {
  sd_bus* bus = nullptr;
  bool peer = false;
  bool peer_subscribed = false;   // peer-to-peer: messages carry no sender to track
  sd_bus_track* track = nullptr;  // bus: subscribed unique names
  std::vector<sd_bus_slot*> slots;
  bool subscribed() const { return peer ? peer_subscribed : (track && sd_bus_track_count(track) > 0); }
  // Signals go to a subscriber while fewer than limits::kQueuedMessages wait
  // for it (the endpoints drop a peer that falls further behind).
  bool wants_signals() const {
    std::uint64_t queued = 0;
    return subscribed() && (sd_bus_get_n_queued_write(bus, &queued) < 0 || queued < limits::kQueuedMessages);
  }
};

// Fills `e` and returns the negative errno sd-bus expects from a handler.
int fail(sd_bus_error* e, const char* name, const std::string& message);

const char* nmt_state_name(NmtState s);

// ArmFault's a{ss} (a node's or a plant's): the fault's parameters as key
// and value texts, bounded by limits::kFaultParams and kFaultValueBytes
// ("kind" is the method's first argument, not a parameter). >= 0, or a
// negative errno with `e` filled (node_physics.cpp).
int read_fault_params(sd_bus_message* m, sd_bus_error* e, std::vector<std::pair<std::string, std::string>>& keys);

// The vtables, one per interface (defined in fleet_methods.cpp / node_methods.cpp).
extern const sd_bus_vtable kFleetVtable[];
extern const sd_bus_vtable kNodeVtable[];
extern const sd_bus_vtable kPlantVtable[];  // plant_methods.cpp

// Node1 handlers defined in node_physics.cpp (channels, overrides, faults, recording).
int node_hold(sd_bus_message* m, void* userdata, sd_bus_error* e);
int node_step(sd_bus_message* m, void* userdata, sd_bus_error* e);
int node_ramp(sd_bus_message* m, void* userdata, sd_bus_error* e);
int node_set_model(sd_bus_message* m, void* userdata, sd_bus_error* e);
int node_restore_model(sd_bus_message* m, void* userdata, sd_bus_error* e);
int node_override(sd_bus_message* m, void* userdata, sd_bus_error* e);
int node_clear_override(sd_bus_message* m, void* userdata, sd_bus_error* e);
int node_arm_fault(sd_bus_message* m, void* userdata, sd_bus_error* e);
int node_cancel_fault(sd_bus_message* m, void* userdata, sd_bus_error* e);
int node_list_faults(sd_bus_message* m, void* userdata, sd_bus_error* e);
int node_start_recording(sd_bus_message* m, void* userdata, sd_bus_error* e);
int node_stop_recording(sd_bus_message* m, void* userdata, sd_bus_error* e);
// Node1 handlers defined in node_decoding.cpp (what the node's frames mean).
int node_list_objects(sd_bus_message* m, void* userdata, sd_bus_error* e);
int node_get_pdo_mapping(sd_bus_message* m, void* userdata, sd_bus_error* e);
int node_list_emcy_codes(sd_bus_message* m, void* userdata, sd_bus_error* e);
int node_list_count_scaling(sd_bus_message* m, void* userdata, sd_bus_error* e);
// Fleet1 handler defined there too: the GetPdoMapping of every node of a bus at once.
int fleet_get_pdo_mappings(sd_bus_message* m, void* userdata, sd_bus_error* e);
int node_get_channel(sd_bus* bus, const char* path, const char* iface, const char* property, sd_bus_message* reply,
                     void* userdata, sd_bus_error* e);
int node_get_channel_counts(sd_bus* bus, const char* path, const char* iface, const char* property,
                            sd_bus_message* reply, void* userdata, sd_bus_error* e);
int node_get_overrides(sd_bus* bus, const char* path, const char* iface, const char* property, sd_bus_message* reply,
                       void* userdata, sd_bus_error* e);
int node_get_faults(sd_bus* bus, const char* path, const char* iface, const char* property, sd_bus_message* reply,
                    void* userdata, sd_bus_error* e);
int node_get_recording(sd_bus* bus, const char* path, const char* iface, const char* property, sd_bus_message* reply,
                       void* userdata, sd_bus_error* e);

// A node's acting method, logged with its outcome (audit.hpp).
template <sd_bus_message_handler_t handler>
int audited_node(sd_bus_message* m, void* userdata, sd_bus_error* e) {
  const ControlService::NodeContext& n = ControlService::NodeContext::of(userdata);
  ControlService* service = n.service;
  const std::string key = n.handle->key, interface = n.handle->interface;
  const int r = handler(m, userdata, e);
  service->audit(m, key, interface, r, e);
  return r;
}

// A plant's acting method, logged as "plant:NAME" (audit.hpp).
template <sd_bus_message_handler_t handler>
int audited_plant(sd_bus_message* m, void* userdata, sd_bus_error* e) {
  const ControlService::PlantContext& p = ControlService::PlantContext::of(userdata);
  ControlService* service = p.service;
  const std::string key = "plant:" + p.name;
  const int r = handler(m, userdata, e);
  service->audit(m, key, "", r, e);
  return r;
}

// A fleet's acting method; RemoveNode's line names the node it removes.
template <sd_bus_message_handler_t handler>
int audited_fleet(sd_bus_message* m, void* userdata, sd_bus_error* e) {
  auto* service = static_cast<ControlService*>(userdata);
  std::string key, interface;
  if (sd_bus_message_is_method_call(m, kFleetInterface, "RemoveNode")) {
    const char* spec = nullptr;
    if (sd_bus_message_read(m, "s", &spec) > 0)
      if (const NodeHandle* h = resolve_node(service->host(), spec, nullptr)) key = h->key, interface = h->interface;
    sd_bus_message_rewind(m, 1);
  }
  const int r = handler(m, userdata, e);
  service->audit(m, key, interface, r, e);
  return r;
}

// Answers `m` with what `fill` appends (returns sd-bus's result, negative on error).
template <typename Fill>
int reply_with(sd_bus_message* m, Fill&& fill) {
  sd_bus_message* reply = nullptr;
  int r = sd_bus_message_new_method_return(m, &reply);
  if (r >= 0) r = fill(reply);
  if (r >= 0) r = sd_bus_send(nullptr, reply, nullptr);
  sd_bus_message_unref(reply);
  return r;
}

template <typename Build>
void ControlService::emit(const std::string& path, const char* interface, const char* member, Build&& build) {
  for (auto& c : connections_) {
    if (!c->wants_signals()) continue;
    sd_bus_message* m = nullptr;
    if (sd_bus_message_new_signal(c->bus, &m, path.c_str(), interface, member) < 0) continue;
    if (build(m) >= 0) sd_bus_send(c->bus, m, nullptr);
    sd_bus_message_unref(m);
  }
}

}  // namespace cansim::control
