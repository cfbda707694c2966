// io.cansim.Node1: what a node's frames mean (the decoded bus monitor,
// cansimctl monitor): its objects with their names, types and units, its
// PDOs as the engine runs them now, its EMCY codes as its manual names them
// (docs/control-api.md, ListObjects, GetPdoMapping, ListEmcyCodes,
// PdoMappingChanged).
#include "control/service_internal.hpp"
#include "core/protocol.hpp"
#include "personalities/pdo_view.hpp"

namespace cansim::control {

namespace {

using NodeContext = ControlService::NodeContext;

// (s name, s type, d scale, s unit) of an entry, inside an open struct: what
// the device's own value is (counts, where it is counts: ListCountScaling
// gives the engineering value).
int append_meaning(sd_bus_message* m, const OdEntry* e, const personalities::ObjectMeaning& meaning) {
  return sd_bus_message_append(m, "ssds", e ? e->name.c_str() : "", e ? type_name(e->type) : "",
                               meaning.counts ? meaning.count_scale : meaning.scale,
                               meaning.counts ? "counts" : meaning.unit.c_str());
}

int append_pdo(sd_bus_message* m, const personalities::PdoView& p) {
  int r = sd_bus_message_open_container(m, 'r', "subya(qyyssds)");
  if (r >= 0)
    r = sd_bus_message_append(m, "suby", p.name().c_str(), p.can_id | (p.extended ? cob::kFrame29Bit : 0u),
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

int append_pdos(sd_bus_message* m, const std::vector<personalities::PdoView>& pdos) {
  int r = sd_bus_message_open_container(m, 'a', "(subya(qyyssds))");
  for (const personalities::PdoView& p : pdos)
    if (r >= 0) r = append_pdo(m, p);
  return r < 0 ? r : sd_bus_message_close_container(m);
}

// ListCountScaling's rows of the objects the PDOs map (what decoding them needs).
int append_mapped_count_scaling(sd_bus_message* m, const std::vector<personalities::PdoView>& pdos) {
  int r = sd_bus_message_open_container(m, 'a', "(qydds)");
  for (const personalities::PdoView& p : pdos)
    for (const personalities::PdoEntryView& e : p.entries)
      if (e.meaning.counts && r >= 0)
        r = sd_bus_message_append(m, "(qydds)", e.index, e.sub, e.meaning.scale, e.meaning.offset,
                                  e.meaning.unit.c_str());
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

int node_list_count_scaling(sd_bus_message* m, void* userdata, sd_bus_error*) {
  Node& node = NodeContext::of(userdata).node();
  return reply_with(m, [&](sd_bus_message* reply) {
    int r = sd_bus_message_open_container(reply, 'a', "(qydds)");
    for (const OdEntry& e : node.od().entries()) {
      const personalities::ObjectMeaning meaning = personalities::object_meaning(node, e);
      if (meaning.counts && r >= 0)
        r = sd_bus_message_append(reply, "(qydds)", e.index, e.sub, meaning.scale, meaning.offset,
                                  meaning.unit.c_str());
    }
    return r < 0 ? r : sd_bus_message_close_container(reply);
  });
}

int node_get_pdo_mapping(sd_bus_message* m, void* userdata, sd_bus_error*) {
  Node& node = NodeContext::of(userdata).node();
  return reply_with(m, [&](sd_bus_message* reply) { return append_pdos(reply, personalities::pdo_views(node)); });
}

// Fleet1.GetPdoMappings: what a monitor needs of every node of a bus, in one
// call (a bus of 127 nodes in one round trip, not 127; one bus at a time, so
// that no call holds the loop for the whole fleet: 14 us a node here, and
// nothing for the nodes of other buses).
int fleet_get_pdo_mappings(sd_bus_message* m, void* userdata, sd_bus_error*) {
  ControlService& s = *static_cast<ControlService*>(userdata);
  const char* interface = nullptr;
  if (int r = sd_bus_message_read(m, "s", &interface); r < 0) return r;
  return reply_with(m, [&](sd_bus_message* reply) {
    int r = sd_bus_message_open_container(reply, 'a', "(sa(subya(qyyssds))a(qydds))");
    for (const NodeHandle* h : s.host().nodes_on(interface)) {
      NodeContext* n = s.context(h->key);
      if (!n || r < 0) continue;
      const std::vector<personalities::PdoView> pdos = personalities::pdo_views(n->node());
      r = sd_bus_message_open_container(reply, 'r', "sa(subya(qyyssds))a(qydds)");
      if (r >= 0) r = sd_bus_message_append(reply, "s", h->key.c_str());
      if (r >= 0) r = append_pdos(reply, pdos);
      if (r >= 0) r = append_mapped_count_scaling(reply, pdos);
      if (r >= 0) r = sd_bus_message_close_container(reply);
    }
    return r < 0 ? r : sd_bus_message_close_container(reply);
  });
}

}  // namespace cansim::control
