// io.cansim.Node1: identity and state properties, node life (power, NMT,
// store / restore) and local object dictionary access. The measurement
// methods (channels, overrides, faults, recording) are in node_physics.cpp.
#include <cmath>
#include <cstdio>

#include "config/eds_writer.hpp"
#include "config/profile.hpp"
#include "control/od_values.hpp"
#include "control/service_internal.hpp"
#include "core/emcy.hpp"
#include "core/nmt.hpp"

namespace cansim::control {

namespace {

using NodeContext = ControlService::NodeContext;

std::string abort_text(SdoAbort a) {
  char buf[16];
  std::snprintf(buf, sizeof buf, "0x%08X", unsigned(a));
  return buf;
}

int refused(sd_bus_error* e, const char* what, SdoAbort a) {
  return fail(e, kErrorRefused, std::string(what) + ": the node answers SDO abort " + abort_text(a));
}

const OdEntry* find_entry(NodeContext& n, std::uint16_t index, std::uint8_t sub, sd_bus_error* e, int* r) {
  SdoAbort why = SdoAbort::kNone;
  const OdEntry* entry = n.node().od().lookup(index, sub, why);
  if (!entry) {
    char buf[80];
    std::snprintf(buf, sizeof buf, "no object 0x%04X:%02X (%s)", index, sub,
                  why == SdoAbort::kNoSubIndex ? "no such sub-index" : "no such object");
    *r = fail(e, kErrorUnknownObject, buf);
  }
  return entry;
}

// ---- properties

// A property that is one value of the node: `n` is its context.
#define CANSIM_GETTER(fn, type, value)                                                                           \
  int fn(sd_bus*, const char*, const char*, const char*, sd_bus_message* reply, void* userdata, sd_bus_error*) { \
    const NodeContext& n = NodeContext::of(userdata);                                                            \
    return sd_bus_message_append(reply, type, value);                                                            \
  }

CANSIM_GETTER(get_key, "s", n.handle->key.c_str())
CANSIM_GETTER(get_name, "s", n.handle->name.c_str())
CANSIM_GETTER(get_index, "u", n.handle->index)
CANSIM_GETTER(get_profile, "s", n.handle->profile.c_str())
CANSIM_GETTER(get_personality, "s", n.handle->personality.c_str())
CANSIM_GETTER(get_interface, "s", n.handle->interface.c_str())
CANSIM_GETTER(get_node_id, "y", n.node().node_id())
CANSIM_GETTER(get_nmt_state, "s", nmt_state_name(n.node().state()))
CANSIM_GETTER(get_powered, "b", int(n.node().powered()))
CANSIM_GETTER(get_on_bus, "b", int(n.node().on_bus() && n.service->host().interface_up(n.handle->interface)))
CANSIM_GETTER(get_emcy_count, "u", n.node().emcy().sent_count())
CANSIM_GETTER(get_frames_sent, "t", std::uint64_t(n.node().frames_sent()))
#undef CANSIM_GETTER
int get_last_emcy(sd_bus*, const char*, const char*, const char*, sd_bus_message* reply, void* userdata,
                  sd_bus_error*) {
  const Emcy::Sent& last = NodeContext::of(userdata).node().emcy().last_emcy();
  int r = sd_bus_message_open_container(reply, 'r', "xqyay");
  if (r >= 0)
    r = sd_bus_message_append(reply, "xqy", std::int64_t(last.time == kNever ? -1 : last.time), last.code, last.reg);
  if (r >= 0) r = sd_bus_message_append_array(reply, 'y', last.vendor, 5);
  return r < 0 ? r : sd_bus_message_close_container(reply);
}

// ---- methods

int power_cycle(sd_bus_message* m, void* userdata, sd_bus_error* e) {
  NodeContext& n = NodeContext::of(userdata);
  double off = 0;
  int r = sd_bus_message_read(m, "d", &off);
  if (r < 0) return r;
  if (!std::isfinite(off) || off < 0 || off > 1e9) return fail(e, kErrorOutOfRange, "expected an off time >= 0 s");
  TimeUs t = n.act_now();
  n.node().power_cycle(t, TimeUs(std::llround(off * 1e6)));
  n.service->touched(n);
  return sd_bus_reply_method_return(m, "");
}

// The command specifier of a local NMT command (CiA 301 §7.2.8.3.1).
std::uint8_t command_specifier(NmtCommand c) {
  switch (c) {
    case NmtCommand::kStart: return kNmtStart;
    case NmtCommand::kStop: return kNmtStop;
    case NmtCommand::kPreOperational: return kNmtEnterPreOperational;
    case NmtCommand::kResetNode: return kNmtResetNode;
    case NmtCommand::kResetCommunication: return kNmtResetCommunication;
  }
  return 0;
}

int nmt(sd_bus_message* m, void* userdata, sd_bus_error* e) {
  NodeContext& n = NodeContext::of(userdata);
  const char* word = nullptr;
  int r = sd_bus_message_read(m, "s", &word);
  if (r < 0) return r;
  const std::optional<NmtCommand> command = parse_nmt_command(word);
  if (!command)
    return fail(e, kErrorInvalidArgument,
                "unknown NMT command '" + std::string(word) + "': expected " + kNmtCommandsText);
  TimeUs t = n.act_now();
  const bool done = n.node().nmt_local(command_specifier(*command), t);
  n.service->touched(n);
  if (!done)
    return fail(e, kErrorRefused,
                n.node().powered() ? "the node has not booted (INITIALISING, e.g. LSS-unconfigured)"
                                   : "the node is powered off");
  return sd_bus_reply_method_return(m, "");
}

// As if the master wrote "save" to 0x1010:sub or "load" to 0x1011:sub.
int store_or_restore(sd_bus_message* m, NodeContext& n, bool store, sd_bus_error* e) {
  std::uint8_t sub = 0;
  int r = sd_bus_message_read(m, "y", &sub);
  if (r < 0) return r;
  if (sub == 0 || sub > 127) return fail(e, kErrorOutOfRange, "expected a sub-index 1..127 (1: all parameters)");
  const std::uint16_t index = store ? 0x1010 : 0x1011;
  if (!find_entry(n, index, sub, e, &r)) return r;
  TimeUs t = n.act_now();
  SdoAbort a = store ? n.node().store_local(sub, t) : n.node().restore_local(sub, t);
  n.service->touched(n);
  if (a != SdoAbort::kNone) return refused(e, store ? "store" : "restore", a);
  return sd_bus_reply_method_return(m, "");
}

int store(sd_bus_message* m, void* userdata, sd_bus_error* e) {
  return store_or_restore(m, NodeContext::of(userdata), true, e);
}
int restore(sd_bus_message* m, void* userdata, sd_bus_error* e) {
  return store_or_restore(m, NodeContext::of(userdata), false, e);
}

// Reads the (q index, y sub) arguments and finds the entry.
const OdEntry* entry_argument(sd_bus_message* m, NodeContext& n, sd_bus_error* e, int* r) {
  std::uint16_t index = 0;
  std::uint8_t sub = 0;
  if ((*r = sd_bus_message_read(m, "qy", &index, &sub)) < 0) return nullptr;
  return find_entry(n, index, sub, e, r);
}

int read_object(sd_bus_message* m, void* userdata, sd_bus_error* e) {
  NodeContext& n = NodeContext::of(userdata);
  int r = 0;
  const OdEntry* entry = entry_argument(m, n, e, &r);
  if (!entry) return r;
  TimeUs t = n.act_now();
  std::span<const std::uint8_t> bytes;
  SdoAbort a = n.node().read_local(*entry, t, bytes);
  if (a != SdoAbort::kNone) return refused(e, "read", a);
  return reply_with(m, [&](sd_bus_message* reply) { return append_value(reply, *entry, bytes); });
}

int write_object(sd_bus_message* m, void* userdata, sd_bus_error* e) {
  NodeContext& n = NodeContext::of(userdata);
  int r = 0;
  const OdEntry* entry = entry_argument(m, n, e, &r);
  if (!entry) return r;
  std::vector<std::uint8_t> bytes;
  std::string error_name, message;
  if (!read_value(m, *entry, bytes, error_name, message)) return fail(e, error_name.c_str(), message);
  TimeUs t = n.act_now();
  SdoAbort a = n.node().write_local(*entry, bytes, t);
  n.service->touched(n);
  if (a == SdoAbort::kValueTooHigh || a == SdoAbort::kValueTooLow || a == SdoAbort::kInvalidValue)
    return fail(e, kErrorOutOfRange, "value outside the object's limits (SDO abort " + abort_text(a) + ")");
  if (a != SdoAbort::kNone) return refused(e, "write", a);
  return sd_bus_reply_method_return(m, "");
}

// D-Bus strings are UTF-8: bytes a master wrote into a VISIBLE_STRING that
// are not become '?'.
std::string valid_utf8(std::string text) {
  for (std::size_t i = 0; i < text.size();) {
    const auto c = static_cast<unsigned char>(text[i]);
    const std::size_t n = c < 0x80 ? 1 : (c >> 5) == 0x6 ? 2 : (c >> 4) == 0xE ? 3 : (c >> 3) == 0x1E ? 4 : 0;
    bool ok = n > 0 && i + n <= text.size() && !(n == 1 && c == 0);
    for (std::size_t k = 1; ok && k < n; ++k) ok = (static_cast<unsigned char>(text[i + k]) >> 6) == 0x2;
    if (!ok) {
      text[i++] = '?';
      continue;
    }
    i += n;
  }
  return text;
}

// CiA 306 DCF of the node now: its EDS, [DeviceComissioning] and the value
// each entry answers (a refused read: the stored value).
int get_dcf(sd_bus_message* m, void* userdata, sd_bus_error*) {
  NodeContext& n = NodeContext::of(userdata);
  Node& node = n.node();
  const TimeUs t = n.act_now();
  config::EdsIdentity id;
  id.name = n.handle->profile;
  id.file_name = n.handle->name + ".dcf";
  id.description = "DCF of node " + n.handle->key;
  id.bit_rate_kbit = config::bit_rate_kbit(node.configured_bit_rate_index());
  config::DcfValues dcf;
  dcf.node_id = node.node_id();
  dcf.node_name = n.handle->name;
  dcf.bit_rate_kbit = config::bit_rate_kbit(node.bit_rate_index());
  dcf.value = [&](const OdEntry& e) {
    std::span<const std::uint8_t> bytes;
    if (!readable(e.access) || node.read_local(e, t, bytes) != SdoAbort::kNone) bytes = node.values().bytes(e);
    return bytes;
  };
  const std::string text = valid_utf8(config::write_eds(node.od(), node.options(), id, &dcf));
  n.service->touched(n);
  return sd_bus_reply_method_return(m, "s", text.c_str());
}

constexpr std::uint64_t kCall = SD_BUS_VTABLE_UNPRIVILEGED;
constexpr std::uint64_t kEmits = SD_BUS_VTABLE_PROPERTY_EMITS_CHANGE;

}  // namespace

const sd_bus_vtable kNodeVtable[] = {
    SD_BUS_VTABLE_START(0),
    SD_BUS_PROPERTY("Key", "s", get_key, 0, SD_BUS_VTABLE_PROPERTY_CONST),
    SD_BUS_PROPERTY("Name", "s", get_name, 0, SD_BUS_VTABLE_PROPERTY_CONST),
    SD_BUS_PROPERTY("Index", "u", get_index, 0, SD_BUS_VTABLE_PROPERTY_CONST),
    SD_BUS_PROPERTY("Profile", "s", get_profile, 0, SD_BUS_VTABLE_PROPERTY_CONST),
    SD_BUS_PROPERTY("Personality", "s", get_personality, 0, SD_BUS_VTABLE_PROPERTY_CONST),
    SD_BUS_PROPERTY("Interface", "s", get_interface, 0, SD_BUS_VTABLE_PROPERTY_CONST),
    SD_BUS_PROPERTY("NodeId", "y", get_node_id, 0, kEmits),
    SD_BUS_PROPERTY("NmtState", "s", get_nmt_state, 0, kEmits),
    SD_BUS_PROPERTY("Powered", "b", get_powered, 0, kEmits),
    SD_BUS_PROPERTY("OnBus", "b", get_on_bus, 0, 0),
    SD_BUS_PROPERTY("Pressure", "(ddsy)", node_get_channel, 0, 0),
    SD_BUS_PROPERTY("Temperature", "(ddsy)", node_get_channel, 0, 0),
    SD_BUS_PROPERTY("PressureCounts", "d", node_get_channel_counts, 0, 0),
    SD_BUS_PROPERTY("TemperatureCounts", "d", node_get_channel_counts, 0, 0),
    SD_BUS_PROPERTY("Overrides", "a(sds)", node_get_overrides, 0, 0),
    SD_BUS_PROPERTY("Faults", "a(usb)", node_get_faults, 0, kEmits),
    SD_BUS_PROPERTY("EmcyCount", "u", get_emcy_count, 0, 0),
    SD_BUS_PROPERTY("LastEmcy", "(xqyay)", get_last_emcy, 0, 0),
    SD_BUS_PROPERTY("FramesSent", "t", get_frames_sent, 0, 0),
    SD_BUS_PROPERTY("Recording", "s", node_get_recording, 0, 0),
    SD_BUS_METHOD_WITH_NAMES("Hold", "s", SD_BUS_PARAM(channel), "", , audited_node<node_hold>, kCall),
    SD_BUS_METHOD_WITH_NAMES("Step", "sds", SD_BUS_PARAM(channel) SD_BUS_PARAM(value) SD_BUS_PARAM(unit), "", ,
                             audited_node<node_step>, kCall),
    SD_BUS_METHOD_WITH_NAMES("Ramp", "sdsd",
                             SD_BUS_PARAM(channel) SD_BUS_PARAM(value) SD_BUS_PARAM(unit) SD_BUS_PARAM(seconds), "", ,
                             audited_node<node_ramp>, kCall),
    SD_BUS_METHOD_WITH_NAMES("SetModel", "ss", SD_BUS_PARAM(channel) SD_BUS_PARAM(yaml), "", ,
                             audited_node<node_set_model>, kCall),
    SD_BUS_METHOD_WITH_NAMES("RestoreModel", "s", SD_BUS_PARAM(channel), "", , audited_node<node_restore_model>, kCall),
    SD_BUS_METHOD_WITH_NAMES("Override", "sds", SD_BUS_PARAM(channel) SD_BUS_PARAM(value) SD_BUS_PARAM(unit), "", ,
                             audited_node<node_override>, kCall),
    SD_BUS_METHOD_WITH_NAMES("ClearOverride", "s", SD_BUS_PARAM(channel), "", , audited_node<node_clear_override>,
                             kCall),
    SD_BUS_METHOD_WITH_NAMES("ArmFault", "sa{ss}", SD_BUS_PARAM(kind) SD_BUS_PARAM(params), "u", SD_BUS_PARAM(id),
                             audited_node<node_arm_fault>, kCall),
    SD_BUS_METHOD_WITH_NAMES("CancelFault", "u", SD_BUS_PARAM(id), "", , audited_node<node_cancel_fault>, kCall),
    SD_BUS_METHOD_WITH_NAMES("ListFaults", "", , "a(ussbxxxu)", SD_BUS_PARAM(faults), node_list_faults, kCall),
    SD_BUS_METHOD_WITH_NAMES("PowerCycle", "d", SD_BUS_PARAM(off_seconds), "", , audited_node<power_cycle>, kCall),
    SD_BUS_METHOD_WITH_NAMES("Nmt", "s", SD_BUS_PARAM(command), "", , audited_node<nmt>, kCall),
    SD_BUS_METHOD_WITH_NAMES("Store", "y", SD_BUS_PARAM(sub), "", , audited_node<store>, kCall),
    SD_BUS_METHOD_WITH_NAMES("Restore", "y", SD_BUS_PARAM(sub), "", , audited_node<restore>, kCall),
    SD_BUS_METHOD_WITH_NAMES("Read", "qy", SD_BUS_PARAM(index) SD_BUS_PARAM(sub), "v", SD_BUS_PARAM(value), read_object,
                             kCall),
    SD_BUS_METHOD_WITH_NAMES("Write", "qyv", SD_BUS_PARAM(index) SD_BUS_PARAM(sub) SD_BUS_PARAM(value), "", ,
                             audited_node<write_object>, kCall),
    SD_BUS_METHOD_WITH_NAMES("GetDcf", "", , "s", SD_BUS_PARAM(dcf), get_dcf, kCall),
    SD_BUS_METHOD_WITH_NAMES("ListObjects", "", , "a(qyssds)", SD_BUS_PARAM(objects), node_list_objects, kCall),
    SD_BUS_METHOD_WITH_NAMES("GetPdoMapping", "", , "a(subya(qyyssds))", SD_BUS_PARAM(pdos), node_get_pdo_mapping,
                             kCall),
    SD_BUS_METHOD_WITH_NAMES("ListEmcyCodes", "", , "a(qs)", SD_BUS_PARAM(codes), node_list_emcy_codes, kCall),
    SD_BUS_METHOD_WITH_NAMES("ListCountScaling", "", , "a(qydds)", SD_BUS_PARAM(objects), node_list_count_scaling,
                             kCall),
    SD_BUS_METHOD_WITH_NAMES("StartRecording", "s", SD_BUS_PARAM(path), "", , audited_node<node_start_recording>,
                             kCall),
    SD_BUS_METHOD("StopRecording", "", "", audited_node<node_stop_recording>, kCall),
    SD_BUS_SIGNAL_WITH_NAMES("NmtStateChanged", "xss", SD_BUS_PARAM(t) SD_BUS_PARAM(old) SD_BUS_PARAM(new), 0),
    SD_BUS_SIGNAL_WITH_NAMES("BootUp", "xy", SD_BUS_PARAM(t) SD_BUS_PARAM(node_id), 0),
    SD_BUS_SIGNAL_WITH_NAMES("EmcySent", "xqyay",
                             SD_BUS_PARAM(t) SD_BUS_PARAM(code) SD_BUS_PARAM(register) SD_BUS_PARAM(vendor), 0),
    SD_BUS_SIGNAL_WITH_NAMES(
        "ObjectWritten", "xqyvs",
        SD_BUS_PARAM(t) SD_BUS_PARAM(index) SD_BUS_PARAM(sub) SD_BUS_PARAM(value) SD_BUS_PARAM(via), 0),
    SD_BUS_SIGNAL_WITH_NAMES("FaultStarted", "xus", SD_BUS_PARAM(t) SD_BUS_PARAM(id) SD_BUS_PARAM(kind), 0),
    SD_BUS_SIGNAL_WITH_NAMES("FaultEnded", "xus", SD_BUS_PARAM(t) SD_BUS_PARAM(id) SD_BUS_PARAM(kind), 0),
    SD_BUS_SIGNAL_WITH_NAMES("PdoMappingChanged", "x", SD_BUS_PARAM(t), 0),
    SD_BUS_VTABLE_END,
};

}  // namespace cansim::control
