// io.cansim.Node1: what a node's frames mean (the decoded bus monitor,
// cansimctl monitor): its objects with their names, types and units, its
// PDOs as the engine runs them now, its EMCY codes as its manual names them
// (docs/control-api.md, ListObjects, GetPdoMapping, ListEmcyCodes,
// PdoMappingChanged).
#include "control/service_internal.hpp"
#include "personalities/pdo_view.hpp"

namespace cansim::control {

namespace {

using NodeContext = ControlService::NodeContext;

// (s name, s type, d scale, s unit) of an entry, inside an open struct.
int append_meaning(sd_bus_message* m, const OdEntry* e, const personalities::ObjectMeaning& meaning) {
  return sd_bus_message_append(m, "ssds", e ? e->name.c_str() : "", e ? type_name(e->type) : "", meaning.scale,
                               meaning.unit.c_str());
}

int append_pdo(sd_bus_message* m, const personalities::PdoView& p) {
  int r = sd_bus_message_open_container(m, 'r', "subya(qyyssds)");
  if (r >= 0) r = sd_bus_message_append(m, "suby", p.name().c_str(), p.can_id | (p.extended ? 1u << 29 : 0u),
                                        int(p.valid), p.transmission_type);
  if (r >= 0) r = sd_bus_message_open_container(m, 'a', "(qyyssds)");
  for (const personalities::PdoEntryView& e : p.entries) {
    if (r >= 0) r = sd_bus_message_open_container(m, 'r', "qyyssds");
    if (r >= 0) r = sd_bus_message_append(m, "qyy", e.index, e.sub, e.bits);
    if (r >= 0) r = append_meaning(m, e.entry, e.meaning);
    if (r >= 0) r = sd_bus_message_close_container(m);
  }
  if (r >= 0) r = sd_bus_message_close_container(m);
  return r < 0 ? r : sd_bus_message_close_container(m);
}

}  // namespace

int node_list_objects(sd_bus_message* m, void* userdata, sd_bus_error*) {
  Node& node = NodeContext::of(userdata).node();
  return reply_with(m, [&](sd_bus_message* reply) {
    int r = sd_bus_message_open_container(reply, 'a', "(qyssds)");
    for (const OdEntry& e : node.od().entries()) {
      if (r >= 0) r = sd_bus_message_open_container(reply, 'r', "qyssds");
      if (r >= 0) r = sd_bus_message_append(reply, "qy", e.index, e.sub);
      if (r >= 0) r = append_meaning(reply, &e, personalities::object_meaning(node, e));
      if (r >= 0) r = sd_bus_message_close_container(reply);
    }
    return r < 0 ? r : sd_bus_message_close_container(reply);
  });
}

int node_list_emcy_codes(sd_bus_message* m, void* userdata, sd_bus_error*) {
  const NodeHandle& h = *NodeContext::of(userdata).handle;
  return reply_with(m, [&](sd_bus_message* reply) {
    int r = sd_bus_message_open_container(reply, 'a', "(qs)");
    if (h.emcy_codes)
      for (const auto& [code, meaning] : *h.emcy_codes)
        if (r >= 0) r = sd_bus_message_append(reply, "(qs)", code, meaning.c_str());
    return r < 0 ? r : sd_bus_message_close_container(reply);
  });
}

int node_get_pdo_mapping(sd_bus_message* m, void* userdata, sd_bus_error*) {
  Node& node = NodeContext::of(userdata).node();
  return reply_with(m, [&](sd_bus_message* reply) {
    int r = sd_bus_message_open_container(reply, 'a', "(subya(qyyssds))");
    for (const personalities::PdoView& p : personalities::pdo_views(node))
      if (r >= 0) r = append_pdo(reply, p);
    return r < 0 ? r : sd_bus_message_close_container(reply);
  });
}

}  // namespace cansim::control
