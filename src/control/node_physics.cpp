// io.cansim.Node1, the measurement side: the true process value (hold, step,
// ramp, any YAML model), reported-value overrides, faults and recording.
// Everything goes through the node's measurement control
// (personalities::MeasurementControl: its CiA 404 chain and device part), so
// PDOs and events follow.
#include <cmath>
#include <cstring>

#include "config/limits.hpp"
#include "config/physics_config.hpp"
#include "control/service_internal.hpp"
#include "physics/units.hpp"

namespace cansim::control {

namespace {

using NodeContext = ControlService::NodeContext;
using physics::Channel;

// The node's chain, or an error when it has none / not this channel.
personalities::MeasurementControl* chain(NodeContext& n, const char* channel, Channel* ch, sd_bus_error* e, int* r) {
  const std::string_view name = channel;
  const std::optional<Channel> parsed = physics::parse_channel(name);
  if (!parsed) {
    *r = fail(e, kErrorUnknownChannel, "unknown channel '" + std::string(name) + "': expected pressure or temperature");
    return nullptr;
  }
  *ch = *parsed;
  if (!n.sensor) {
    *r = fail(e, kErrorNotSupported,
              n.handle->key + " has no measurement channels (personality " + n.handle->personality + ")");
    return nullptr;
  }
  if (!n.sensor->has_channel(*ch)) {
    *r = fail(e, kErrorUnknownChannel, n.handle->key + " has no " + std::string(name) + " channel");
    return nullptr;
  }
  return n.sensor;
}

// value + unit -> Pa / K.
bool to_si(Channel ch, double value, const char* unit, double& si, sd_bus_error* e, int* r) {
  if (!std::isfinite(value)) {
    *r = fail(e, kErrorOutOfRange, "expected a finite value");
    return false;
  }
  if (ch == Channel::Pressure) {
    if (auto u = physics::parse_pressure_unit(unit)) {
      si = physics::to_pa(value, *u);
      if (std::isfinite(si)) return true;
      *r = fail(e, kErrorOutOfRange, "expected a pressure that is finite in Pa");
      return false;
    }
    *r = fail(e, kErrorUnknownUnit,
              "unknown pressure unit '" + std::string(unit) + "': expected bar, mbar, psi, Pa, kPa or MPa");
    return false;
  }
  if (auto u = physics::parse_temperature_unit(unit)) {
    si = physics::to_kelvin(value, *u);
    if (si >= 0 && std::isfinite(si)) return true;
    *r = fail(e, kErrorOutOfRange,
              si >= 0 ? "expected a temperature that is finite in K" : "temperature below absolute zero");
    return false;
  }
  *r = fail(e, kErrorUnknownUnit, "unknown temperature unit '" + std::string(unit) + "': expected degC, degF or K");
  return false;
}

// Runs `change` on the chain now; refused when the node's source has no process model.
template <typename Change>
int change_process(sd_bus_message* m, NodeContext& n, Change&& change, sd_bus_error* e) {
  const TimeUs t = n.act_now();
  bool done = false;
  try {
    done = change(t);
  } catch (const std::exception& ex) {
    return fail(e, kErrorInvalidArgument, ex.what());
  }
  n.service->touched(n);
  if (!done) return fail(e, kErrorNotSupported, n.handle->key + "'s measurement source has no process model");
  return sd_bus_reply_method_return(m, "");
}

// Reads (s channel, d value, s unit) and resolves them.
struct ValueArgs {
  Channel ch;
  double si = 0;
};
bool read_value_args(sd_bus_message* m, NodeContext& n, ValueArgs& a, sd_bus_error* e, int* r) {
  const char *channel = nullptr, *unit = nullptr;
  double value = 0;
  if ((*r = sd_bus_message_read(m, "sds", &channel, &value, &unit)) < 0) return false;
  return chain(n, channel, &a.ch, e, r) && to_si(a.ch, value, unit, a.si, e, r);
}

}  // namespace

int node_hold(sd_bus_message* m, void* userdata, sd_bus_error* e) {
  NodeContext& n = NodeContext::of(userdata);
  const char* channel = nullptr;
  int r = sd_bus_message_read(m, "s", &channel);
  Channel ch;
  if (r < 0 || !chain(n, channel, &ch, e, &r)) return r;
  return change_process(
      m, n, [&](TimeUs t) { return n.sensor->hold(n.node(), ch, t); }, e);
}

int node_step(sd_bus_message* m, void* userdata, sd_bus_error* e) {
  NodeContext& n = NodeContext::of(userdata);
  ValueArgs a;
  int r = 0;
  if (!read_value_args(m, n, a, e, &r)) return r;
  return change_process(
      m, n, [&](TimeUs t) { return n.sensor->step(n.node(), a.ch, a.si, t); }, e);
}

int node_ramp(sd_bus_message* m, void* userdata, sd_bus_error* e) {
  NodeContext& n = NodeContext::of(userdata);
  ValueArgs a;
  int r = 0;
  if (!read_value_args(m, n, a, e, &r)) return r;
  double seconds = 0;
  if ((r = sd_bus_message_read(m, "d", &seconds)) < 0) return r;
  if (!std::isfinite(seconds) || seconds < 0 || seconds > 1e9)
    return fail(e, kErrorOutOfRange, "expected a ramp duration >= 0 s");
  return change_process(
      m, n, [&](TimeUs t) { return n.sensor->ramp(n.node(), a.ch, a.si, seconds, t); }, e);
}

int node_set_model(sd_bus_message* m, void* userdata, sd_bus_error* e) {
  NodeContext& n = NodeContext::of(userdata);
  const char *channel = nullptr, *yaml = nullptr;
  int r = sd_bus_message_read(m, "ss", &channel, &yaml);
  Channel ch;
  if (r < 0 || !chain(n, channel, &ch, e, &r)) return r;
  std::vector<physics::TermSpec> terms;
  try {
    config::check_yaml_size(yaml, "<SetModel>", limits::kYamlTextBytes);
    const config::ConfinedFiles tables(n.service->host().profile_folders());
    terms = config::parse_channel_model_text("<SetModel>", channel, yaml, ch);
  } catch (const config::TooLarge& ex) {
    return fail(e, kErrorTooLarge, ex.what());
  } catch (const std::exception& ex) {
    return fail(e, kErrorInvalidArgument, ex.what());
  }
  return change_process(
      m, n, [&](TimeUs t) { return n.sensor->set_process(n.node(), ch, terms, t); }, e);
}

int node_restore_model(sd_bus_message* m, void* userdata, sd_bus_error* e) {
  NodeContext& n = NodeContext::of(userdata);
  const char* channel = nullptr;
  int r = sd_bus_message_read(m, "s", &channel);
  Channel ch;
  if (r < 0 || !chain(n, channel, &ch, e, &r)) return r;
  return change_process(
      m, n, [&](TimeUs t) { return n.sensor->restore_process(n.node(), ch, t); }, e);
}

int node_override(sd_bus_message* m, void* userdata, sd_bus_error* e) {
  NodeContext& n = NodeContext::of(userdata);
  ValueArgs a;
  int r = 0;
  if (!read_value_args(m, n, a, e, &r)) return r;
  n.sensor->set_override(n.node(), a.ch, a.si, n.act_now());
  n.service->touched(n);
  return sd_bus_reply_method_return(m, "");
}

int node_clear_override(sd_bus_message* m, void* userdata, sd_bus_error* e) {
  NodeContext& n = NodeContext::of(userdata);
  const char* channel = nullptr;
  int r = sd_bus_message_read(m, "s", &channel);
  if (r < 0) return r;
  const TimeUs t = n.act_now();
  if (!*channel) {  // every channel the node has
    if (!n.sensor) return fail(e, kErrorNotSupported, n.handle->key + " has no measurement channels");
    for (Channel ch : {Channel::Pressure, Channel::Temperature})
      if (n.sensor->has_channel(ch)) n.sensor->set_override(n.node(), ch, std::nullopt, t);
  } else {
    Channel ch;
    if (!chain(n, channel, &ch, e, &r)) return r;
    n.sensor->set_override(n.node(), ch, std::nullopt, t);
  }
  n.service->touched(n);
  return sd_bus_reply_method_return(m, "");
}

int read_fault_params(sd_bus_message* m, sd_bus_error* e, std::vector<std::pair<std::string, std::string>>& keys) {
  int r = sd_bus_message_enter_container(m, 'a', "{ss}");
  if (r < 0) return r;
  const char *key = nullptr, *value = nullptr;
  while ((r = sd_bus_message_read(m, "{ss}", &key, &value)) > 0) {
    if (std::string_view(key) == "kind")
      return fail(e, kErrorInvalidArgument, "'kind' is the first argument, not a parameter");
    if (keys.size() == limits::kFaultParams)
      return fail(e, kErrorTooLarge, "more than " + std::to_string(limits::kFaultParams) + " parameters");
    if (std::strlen(key) > limits::kFaultValueBytes || std::strlen(value) > limits::kFaultValueBytes)
      return fail(e, kErrorTooLarge, "a parameter longer than " + std::to_string(limits::kFaultValueBytes) + " bytes");
    keys.emplace_back(key, value);
  }
  return r < 0 ? r : sd_bus_message_exit_container(m);
}

int node_arm_fault(sd_bus_message* m, void* userdata, sd_bus_error* e) {
  NodeContext& n = NodeContext::of(userdata);
  const char* kind = nullptr;
  int r = sd_bus_message_read(m, "s", &kind);
  if (r < 0) return r;
  // The same parser as a profile's `faults:` entry, the values as YAML scalars.
  std::vector<std::pair<std::string, std::string>> keys;
  if ((r = read_fault_params(m, e, keys)) < 0) return r;
  physics::FaultSpec spec;
  try {
    spec = config::parse_fault_text("<ArmFault>", kind, keys);
  } catch (const config::TooLarge& ex) {
    return fail(e, kErrorTooLarge, ex.what());
  } catch (const std::exception& ex) {
    const bool bad_kind = !physics::parse_fault_kind(kind);
    return fail(e, bad_kind ? kErrorUnknownFault : kErrorInvalidArgument, ex.what());
  }
  if (!n.sensor) return fail(e, kErrorNotSupported, n.handle->key + " has no fault schedule");
  const TimeUs t = n.act_now();
  physics::FaultHandle id = n.sensor->arm_fault(n.node(), spec, t);
  if (id == physics::kInvalidFaultHandle) return fail(e, kErrorNotSupported, n.handle->key + " has no fault schedule");
  n.service->touched(n);
  n.service->emit_properties_changed(n.path, kNodeInterface, {"Faults"});
  return sd_bus_reply_method_return(m, "u", std::uint32_t(id));
}

int node_cancel_fault(sd_bus_message* m, void* userdata, sd_bus_error* e) {
  NodeContext& n = NodeContext::of(userdata);
  std::uint32_t id = 0;
  int r = sd_bus_message_read(m, "u", &id);
  if (r < 0) return r;
  const TimeUs t = n.act_now();
  // Only a fault still armed (not cancelled, not finished) can be cancelled.
  bool armed = false;
  if (n.sensor)
    for (const physics::FaultInfo& f : n.sensor->faults(t)) armed |= f.handle == id;
  if (!armed || !n.sensor->cancel_fault(n.node(), id, t))
    return fail(e, kErrorUnknownFault, "no armed fault " + std::to_string(id) + " on " + n.handle->key);
  n.service->touched(n);
  n.service->emit_properties_changed(n.path, kNodeInterface, {"Faults"});
  return sd_bus_reply_method_return(m, "");
}

int node_list_faults(sd_bus_message* m, void* userdata, sd_bus_error*) {
  NodeContext& n = NodeContext::of(userdata);
  const TimeUs t = n.act_now();
  return reply_with(m, [&](sd_bus_message* reply) {
    int r = sd_bus_message_open_container(reply, 'a', "(ussbxxxu)");
    if (n.sensor)
      for (const physics::FaultInfo& f : n.sensor->faults(t))
        if (r >= 0)
          r = sd_bus_message_append(reply, "(ussbxxxu)", f.handle, std::string(physics::to_string(f.kind)).c_str(),
                                    std::string(physics::to_string(f.channel)).c_str(), int(f.active),
                                    std::int64_t(f.first_start), std::int64_t(f.duration_us), std::int64_t(f.period_us),
                                    f.count);
    return r < 0 ? r : sd_bus_message_close_container(reply);
  });
}

int node_start_recording(sd_bus_message* m, void* userdata, sd_bus_error* e) {
  NodeContext& n = NodeContext::of(userdata);
  const char* path = nullptr;
  int r = sd_bus_message_read(m, "s", &path);
  if (r < 0) return r;
  if (!n.sensor) return fail(e, kErrorNotSupported, n.handle->key + " has no measurement channels");
  if (!*path) return fail(e, kErrorInvalidArgument, "expected a file path");
  std::string error;
  if (!n.sensor->start_recording(n.node(), path, &error, n.service->host().now())) return fail(e, kErrorRefused, error);
  n.service->touched(n);
  return sd_bus_reply_method_return(m, "");
}

int node_stop_recording(sd_bus_message* m, void* userdata, sd_bus_error* e) {
  NodeContext& n = NodeContext::of(userdata);
  if (!n.sensor) return fail(e, kErrorNotSupported, n.handle->key + " has no measurement channels");
  n.sensor->stop_recording();
  return sd_bus_reply_method_return(m, "");
}

int node_get_channel(sd_bus*, const char*, const char*, const char* property, sd_bus_message* reply, void* userdata,
                     sd_bus_error*) {
  NodeContext& n = NodeContext::of(userdata);
  const Channel ch = std::string_view(property) == "Pressure" ? Channel::Pressure : Channel::Temperature;
  if (!n.sensor || !n.sensor->has_channel(ch))
    return sd_bus_message_append(reply, "(ddsy)", std::nan(""), std::nan(""), "", std::uint8_t(0));
  // No run_due() here: getters also run while a signal is being emitted.
  const auto v = n.sensor->view(n.node(), ch, n.service->host().now());
  return sd_bus_message_append(reply, "(ddsy)", v.true_value, v.reported, std::string(v.unit).c_str(), v.status);
}

int node_get_channel_counts(sd_bus*, const char*, const char*, const char* property, sd_bus_message* reply,
                            void* userdata, sd_bus_error*) {
  NodeContext& n = NodeContext::of(userdata);
  const Channel ch = std::string_view(property) == "PressureCounts" ? Channel::Pressure : Channel::Temperature;
  if (!n.sensor || !n.sensor->has_channel(ch)) return sd_bus_message_append(reply, "d", std::nan(""));
  return sd_bus_message_append(reply, "d", n.sensor->view(n.node(), ch, n.service->host().now()).counts);
}

int node_get_overrides(sd_bus*, const char*, const char*, const char*, sd_bus_message* reply, void* userdata,
                       sd_bus_error*) {
  NodeContext& n = NodeContext::of(userdata);
  int r = sd_bus_message_open_container(reply, 'a', "(sds)");
  if (n.sensor)
    for (const auto& o : n.sensor->overrides())
      if (r >= 0)
        r = sd_bus_message_append(reply, "(sds)", std::string(physics::channel_name(o.channel)).c_str(), o.value,
                                  std::string(o.unit).c_str());
  return r < 0 ? r : sd_bus_message_close_container(reply);
}

int node_get_faults(sd_bus*, const char*, const char*, const char*, sd_bus_message* reply, void* userdata,
                    sd_bus_error*) {
  NodeContext& n = NodeContext::of(userdata);
  int r = sd_bus_message_open_container(reply, 'a', "(usb)");
  if (n.sensor)
    for (const physics::FaultInfo& f : n.sensor->faults(n.service->host().now()))
      if (r >= 0)
        r = sd_bus_message_append(reply, "(usb)", f.handle, std::string(physics::to_string(f.kind)).c_str(),
                                  int(f.active));
  return r < 0 ? r : sd_bus_message_close_container(reply);
}

int node_get_recording(sd_bus*, const char*, const char*, const char*, sd_bus_message* reply, void* userdata,
                       sd_bus_error*) {
  NodeContext& n = NodeContext::of(userdata);
  return sd_bus_message_append(reply, "s", n.sensor ? n.sensor->recording().c_str() : "");
}

}  // namespace cansim::control
