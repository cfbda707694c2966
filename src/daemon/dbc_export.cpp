#include "daemon/dbc_export.hpp"

#include <map>

#include "config/dbc_writer.hpp"
#include "core/protocol.hpp"
#include "daemon/daemon.hpp"
#include "personalities/pdo_view.hpp"

namespace cansim::daemon {

namespace {

struct NoBus : FrameSink {
  void send(const CanFrame&) override {}
};

// The EMCY codes the CiA 301 services of `node` may send (its options and
// objects say which), as CiA 301 Table 21 names them.
std::map<std::uint16_t, std::string> core_emcy_codes(const Node& node) {
  const NodeOptions& o = node.options();
  const bool consumer = node.od().find(0x1016, 1) || node.od().find(0x100C, 0);  // heartbeat consumer, guarding
  const bool rpdos = !node.pdo().rpdos().empty();
  const std::pair<std::int64_t, const char*> codes[] = {
      {o.can_overrun_emcy, "CAN overrun (objects lost)"},
      {o.error_passive_emcy, "CAN in error passive mode"},
      {o.bus_off_recovery_emcy, "recovered from bus off"},
      {consumer ? o.heartbeat_consumer_emcy : 0, "life guard error or heartbeat error"},
      {rpdos ? emcy::kPdoLength : 0, "PDO not processed due to length error"},
      {rpdos && o.rpdo_length_exceeded_emcy ? emcy::kPdoLengthExceeded : 0, "PDO length exceeded"},
      {rpdos ? emcy::kRpdoTimeout : 0, "RPDO timeout"},
      {node.od().find(0x1005, 0) && !o.sync_accept_any_dlc ? emcy::kSyncLength : 0, "unexpected SYNC data length"},
  };
  std::map<std::uint16_t, std::string> out;
  for (const auto& [code, name] : codes)
    if (code != 0) out.emplace(std::uint16_t(code), name);
  return out;
}

std::string chosen_interface(const config::FleetConfig& fleet, const std::string& wanted) {
  std::string names;
  for (const config::InterfaceConfig& ic : fleet.interfaces) {
    if (ic.name == wanted) return wanted;
    names += (names.empty() ? "" : ", ") + ic.name;
  }
  if (!wanted.empty()) throw config::ConfigError(fleet.file + ": no interface " + wanted + " (it has " + names + ")");
  if (fleet.interfaces.size() == 1) return fleet.interfaces.front().name;
  throw config::ConfigError(fleet.file + ": the fleet is on " + names +
                            "; a DBC describes one bus: name it with --interface");
}

}  // namespace

std::string export_dbc(const config::FleetConfig& fleet, const std::string& interface) {
  config::DbcBus bus;
  bus.name = chosen_interface(fleet, interface);
  if (const config::InterfaceConfig* ic = fleet.interface(bus.name); ic && ic->bit_rate_kbit)
    bus.bit_rate_kbit = ic->bit_rate_kbit;
  std::map<std::string, int> name_count;
  for (const config::NodeConfig& n : fleet.nodes)
    if (n.interface == bus.name) ++name_count[n.name];
  NoBus no_bus;
  for (config::NodeConfig n : fleet.nodes) {
    if (n.interface != bus.name) continue;
    n.record_file.clear();  // an export must not truncate recordings
    std::unique_ptr<Application> app = make_node_application(n, fleet.seed);
    Node node(node_setup(n, fleet.seed), no_bus, app.get());
    node.power_on(0);
    config::DbcNode d;
    d.label = name_count[n.name] > 1 ? n.name + "/" + std::to_string(n.index) : n.name;
    d.key = n.key;
    d.profile = n.profile->name;
    d.node_id = node.node_id();
    d.pdos = personalities::pdo_views(node);
    d.emcy_codes = n.profile->emcy_codes;       // the device's names first
    d.emcy_codes.merge(core_emcy_codes(node));  // then its CiA 301 services' codes it does not name
    bus.nodes.push_back(std::move(d));
  }
  return config::write_dbc(bus);
}

}  // namespace cansim::daemon
