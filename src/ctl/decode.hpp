// Reads the control API's replies and signals (sd-bus messages) into the
// plain data of replies.hpp. A reply of another shape throws Failure.
#pragma once

#include <systemd/sd-bus.h>

#include <cstdint>
#include <map>
#include <optional>
#include <string>
#include <vector>

#include "ctl/frame_decoder.hpp"
#include "ctl/replies.hpp"

namespace cansim::ctl {

// The next argument: a basic type, "ay", or a variant holding one of them.
Value read_value(sd_bus_message* m);

std::int64_t read_int64(sd_bus_message* m);  // x, or a variant holding x (Properties.Get)
std::uint32_t read_uint32(sd_bus_message* m);
std::string read_object_path(sd_bus_message* m);
std::string read_text(sd_bus_message* m);                       // s
std::vector<std::string> read_object_paths(sd_bus_message* m);  // ao
std::vector<NodeRow> read_node_rows(sd_bus_message* m);
std::vector<FaultRow> read_fault_rows(sd_bus_message* m);
std::vector<BusStats> read_bus_stats(sd_bus_message* m);
// Fills the BusLoad (a variant of a(ssddddxxxxxuut)) and BusStates (a variant
// of a{ss}) properties into the rows of the same interfaces.
void read_bus_load(sd_bus_message* m, std::vector<BusStats>& rows);
void read_bus_states(sd_bus_message* m, std::vector<BusStats>& rows);
void read_socketcand_buses(sd_bus_message* m, std::vector<BusStats>& rows);
NodeStatus read_node_status(sd_bus_message* m);  // a{sv} of io.cansim.Node1
// ObjectManager.GetManagedObjects of the fleet object: each node's io.cansim.Node1 properties.
std::vector<NodeStatus> read_managed_nodes(sd_bus_message* m);
std::vector<PdoInfo> read_pdo_infos(sd_bus_message* m);                   // GetPdoMapping: a(subya(qyyssds))
std::vector<ObjectInfo> read_object_infos(sd_bus_message* m);             // ListObjects: a(qyssds)
std::map<std::uint16_t, std::string> read_emcy_codes(sd_bus_message* m);  // ListEmcyCodes: a(qs)
// ListCountScaling: a(qydds), as objects with only their address and `engineering`.
std::vector<ObjectInfo> read_count_scaling(sd_bus_message* m);
// Fleet1.GetPdoMappings: every node's PDOs by key, their objects in counts
// with their engineering conversion attached.
std::map<std::string, std::vector<PdoInfo>> read_fleet_pdo_mappings(sd_bus_message* m);
// The mapped objects whose value is in counts (ListObjects unit `counts`).
std::vector<ObjectInfo*> counts_of(std::vector<PdoInfo>& pdos);
// Sets the engineering conversion of each of `objects` that `scaling` lists.
void attach_count_scaling(std::vector<ObjectInfo*> objects, const std::vector<ObjectInfo>& scaling);

// "vcan0/dps/0" for a node object path, "" for any other path.
std::string node_key_of_path(const std::string& path);

// A signal of the fleet or a node object (PropertiesChanged included) as
// watch prints it.
Event read_event(sd_bus_message* signal);

}  // namespace cansim::ctl
