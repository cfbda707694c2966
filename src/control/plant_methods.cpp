// io.cansim.Plant1 on /io/cansim/Cansimd1/plant/<name> (docs/control-api.md
// "Plants"): a plant's variables and inputs in units, the inputs' overrides,
// the plant's faults. Every read first brings the plant to now (what it
// would compute anyway for a reader), so values are those of this instant.
#include <cmath>
#include <cstring>

#include "config/limits.hpp"
#include "config/plant_config.hpp"
#include "control/service_internal.hpp"
#include "physics/plant_units.hpp"

namespace cansim::control {

namespace {

using PlantContext = ControlService::PlantContext;

// The plant behind a context, or an error (it was removed by a reload).
physics::Plant* plant_of(PlantContext& p, sd_bus_error* e, int* r) {
  physics::PlantSet* set = p.service->host().plants();
  physics::Plant* plant = set ? set->find(p.name) : nullptr;
  if (!plant) *r = fail(e, kErrorUnknownPlant, "no plant '" + p.name + "'");
  return plant;
}

physics::Unit unit_of(const physics::Plant& plant, physics::PlantVar var) {
  const auto& v = plant.variables()[var];
  if (v.is_input) {
    const std::string& configured = plant.spec().inputs[var].unit;
    if (!configured.empty())
      if (auto u = physics::find_unit(configured, plant.spec().medium)) return *u;
  }
  return physics::display_unit(v.kind);
}

// `unit` ("" : the variable's own) for a variable of `kind`; false with the error.
bool resolve_unit(const physics::Plant& plant, physics::PlantVar var, const char* unit, physics::Unit& out,
                  sd_bus_error* e, int* r) {
  out = unit_of(plant, var);
  if (!*unit) return true;
  const physics::QuantityKind kind = plant.variables()[var].kind;
  const std::optional<physics::Unit> u = physics::find_unit(unit, plant.spec().medium);
  if (u && u->kind == kind) {
    out = *u;
    return true;
  }
  *r = fail(
      e, kErrorUnknownUnit,
      "unit '" + std::string(unit) + "' is not one of a " + std::string(physics::kind_name(kind)) + " (" +
          (kind == physics::QuantityKind::kNumber ? std::string("a plain number: \"\"") : physics::unit_names(kind)) +
          ")");
  return false;
}

// A variable now: an input as the next step takes it (an override just set
// shows at once), a block output as the latest step computed it.
double current(physics::Plant& plant, physics::PlantVar v, TimeUs t) {
  if (plant.variables()[v].is_input) return plant.input_state(v, t).current;
  return plant.value(v, t);
}

physics::PlantVar variable(const physics::Plant& plant, const char* name, sd_bus_error* e, int* r) {
  std::string why;
  const physics::PlantVar v = plant.find(name, &why);
  if (v == physics::kNoVar) *r = fail(e, kErrorUnknownVariable, why);
  return v;
}

std::optional<std::size_t> input(const physics::Plant& plant, const char* name, sd_bus_error* e, int* r) {
  const std::optional<std::size_t> i = plant.find_input(name);
  if (!i) {
    std::string names;
    for (const auto& in : plant.spec().inputs) names += (names.empty() ? "" : ", ") + in.name;
    *r = fail(e, kErrorUnknownVariable,
              "plant " + plant.name() + " has no input '" + std::string(name) + "' (" +
                  (names.empty() ? "none" : names) + ")");
  }
  return i;
}

// (s input, d value, s unit) -> the input and the value in SI.
bool read_input_value(sd_bus_message* m, physics::Plant& plant, std::size_t& in, double& si, sd_bus_error* e, int* r) {
  const char *name = nullptr, *unit = nullptr;
  double value = 0;
  if ((*r = sd_bus_message_read(m, "sds", &name, &value, &unit)) < 0) return false;
  const std::optional<std::size_t> i = input(plant, name, e, r);
  if (!i) return false;
  physics::Unit u;
  if (!resolve_unit(plant, physics::PlantVar(*i), unit, u, e, r)) return false;
  si = physics::from_unit(value, u);
  if (!std::isfinite(value) || !std::isfinite(si)) {
    *r = fail(e, kErrorOutOfRange, "expected a finite value");
    return false;
  }
  in = *i;
  return true;
}

int plant_get(sd_bus_message* m, void* userdata, sd_bus_error* e) {
  PlantContext& p = PlantContext::of(userdata);
  const char *name = nullptr, *unit = nullptr;
  int r = sd_bus_message_read(m, "ss", &name, &unit);
  if (r < 0) return r;
  physics::Plant* plant = plant_of(p, e, &r);
  if (!plant) return r;
  const physics::PlantVar v = variable(*plant, name, e, &r);
  physics::Unit u;
  if (v == physics::kNoVar || !resolve_unit(*plant, v, unit, u, e, &r)) return r;
  const TimeUs t = p.act_now();
  plant->advance_to(t);
  return sd_bus_reply_method_return(m, "ds", physics::to_unit(current(*plant, v, t), u), std::string(u.name).c_str());
}

// The empty reply of a call that changed `property` (PropertiesChanged first).
int reply_changed(PlantContext& p, sd_bus_message* m, const char* property) {
  p.service->emit_properties_changed(p.path, kPlantInterface, {property});
  return sd_bus_reply_method_return(m, "");
}

// Set (as the input's source would; `override` false) or Override.
int set_input(sd_bus_message* m, void* userdata, sd_bus_error* e, bool override) {
  PlantContext& p = PlantContext::of(userdata);
  int r = 0;
  physics::Plant* plant = plant_of(p, e, &r);
  std::size_t in = 0;
  double si = 0;
  if (!plant || !read_input_value(m, *plant, in, si, e, &r)) return r;
  const physics::PlantInputSpec& spec = plant->spec().inputs[in];
  if (override) {
    plant->override_input(in, si, p.act_now());
  } else {
    if (spec.source != physics::PlantInputSpec::Source::kPush)
      return fail(e, kErrorInvalidArgument,
                  "input " + spec.name + " reads " + spec.description +
                      ": its next value would replace this one (Override sets it for good)");
    plant->set_input(in, si, p.act_now());
  }
  return reply_changed(p, m, "Inputs");
}

int plant_set(sd_bus_message* m, void* userdata, sd_bus_error* e) { return set_input(m, userdata, e, false); }
int plant_override(sd_bus_message* m, void* userdata, sd_bus_error* e) { return set_input(m, userdata, e, true); }

int plant_clear_override(sd_bus_message* m, void* userdata, sd_bus_error* e) {
  PlantContext& p = PlantContext::of(userdata);
  const char* name = nullptr;
  int r = sd_bus_message_read(m, "s", &name);
  if (r < 0) return r;
  physics::Plant* plant = plant_of(p, e, &r);
  if (!plant) return r;
  const std::optional<std::size_t> in = input(*plant, name, e, &r);
  if (!in) return r;
  plant->clear_override(*in, p.act_now());
  return reply_changed(p, m, "Inputs");
}

int plant_arm_fault(sd_bus_message* m, void* userdata, sd_bus_error* e) {
  PlantContext& p = PlantContext::of(userdata);
  const char* kind = nullptr;
  int r = sd_bus_message_read(m, "s", &kind);
  std::vector<std::pair<std::string, std::string>> keys;
  if (r < 0 || (r = read_fault_params(m, e, keys)) < 0) return r;
  physics::Plant* plant = plant_of(p, e, &r);
  if (!plant) return r;
  physics::PlantFaultSpec spec;
  try {
    spec = config::parse_plant_fault_text("<ArmFault>", kind, keys, plant->spec().medium);
  } catch (const config::TooLarge& ex) {
    return fail(e, kErrorTooLarge, ex.what());
  } catch (const std::exception& ex) {
    const auto k = physics::parse_fault_kind(kind);
    return fail(e, k && physics::is_plant_fault(*k) ? kErrorInvalidArgument : kErrorUnknownFault, ex.what());
  }
  physics::FaultHandle id = 0;
  try {
    id = plant->arm_fault(spec, p.act_now());
  } catch (const physics::PlantError& ex) {
    return fail(e, kErrorInvalidArgument, ex.reason);
  }
  p.service->emit_properties_changed(p.path, kPlantInterface, {"Faults"});
  return sd_bus_reply_method_return(m, "u", std::uint32_t(id));
}

int plant_cancel_fault(sd_bus_message* m, void* userdata, sd_bus_error* e) {
  PlantContext& p = PlantContext::of(userdata);
  std::uint32_t id = 0;
  int r = sd_bus_message_read(m, "u", &id);
  if (r < 0) return r;
  physics::Plant* plant = plant_of(p, e, &r);
  if (!plant) return r;
  const TimeUs t = p.act_now();
  bool armed = false;
  for (const physics::FaultInfo& f : plant->armed_faults(t)) armed |= f.handle == id;
  if (!armed || !plant->cancel_fault(id, t))
    return fail(e, kErrorUnknownFault, "no armed fault " + std::to_string(id) + " on plant " + p.name);
  return reply_changed(p, m, "Faults");
}

// ---------------------------------------------------------------- properties

using PropertyGetter = int (*)(sd_bus*, const char*, const char*, const char*, sd_bus_message*, void*, sd_bus_error*);

// A property (or a reply) of a plant as it is now (the plant brought to now first).
template <typename Fill>
int plant_property(sd_bus_message* reply, void* userdata, sd_bus_error* e, Fill&& fill) {
  PlantContext& p = PlantContext::of(userdata);
  int r = 0;
  physics::Plant* plant = plant_of(p, e, &r);
  if (!plant) return r;
  const TimeUs t = p.act_now();
  plant->advance_to(t);
  return fill(reply, *plant, t);
}

int plant_list_faults(sd_bus_message* m, void* userdata, sd_bus_error* e) {
  return plant_property(m, userdata, e, [&](sd_bus_message*, physics::Plant& plant, TimeUs t) {
    return reply_with(m, [&](sd_bus_message* reply) {
      int r = sd_bus_message_open_container(reply, 'a', "(ussbxxxu)");
      for (const physics::FaultInfo& f : plant.armed_faults(t))
        if (r >= 0)
          r = sd_bus_message_append(reply, "(ussbxxxu)", f.handle, std::string(physics::to_string(f.kind)).c_str(),
                                    plant.fault_target(f.handle).c_str(), int(f.active), std::int64_t(f.first_start),
                                    std::int64_t(f.duration_us), std::int64_t(f.period_us), f.count);
      return r < 0 ? r : sd_bus_message_close_container(reply);
    });
  });
}

int get_name(sd_bus*, const char*, const char*, const char*, sd_bus_message* reply, void* userdata, sd_bus_error*) {
  return sd_bus_message_append(reply, "s", PlantContext::of(userdata).name.c_str());
}

int get_step(sd_bus*, const char*, const char*, const char*, sd_bus_message* reply, void* userdata, sd_bus_error* e) {
  return plant_property(reply, userdata, e, [](sd_bus_message* m, physics::Plant& plant, TimeUs) {
    return sd_bus_message_append(m, "x", std::int64_t(plant.step_us()));
  });
}

int get_time(sd_bus*, const char*, const char*, const char*, sd_bus_message* reply, void* userdata, sd_bus_error* e) {
  return plant_property(reply, userdata, e, [](sd_bus_message* m, physics::Plant& plant, TimeUs) {
    return sd_bus_message_append(m, "x", std::int64_t(plant.time()));
  });
}

int get_variables(sd_bus*, const char*, const char*, const char*, sd_bus_message* reply, void* userdata,
                  sd_bus_error* e) {
  return plant_property(reply, userdata, e, [](sd_bus_message* m, physics::Plant& plant, TimeUs t) {
    int r = sd_bus_message_open_container(m, 'a', "(ssds)");
    const auto& vars = plant.variables();
    for (physics::PlantVar v = 0; v < vars.size() && r >= 0; ++v) {
      const physics::Unit u = unit_of(plant, v);
      r = sd_bus_message_append(m, "(ssds)", vars[v].name.c_str(),
                                std::string(physics::kind_name(vars[v].kind)).c_str(),
                                physics::to_unit(current(plant, v, t), u), std::string(u.name).c_str());
    }
    return r < 0 ? r : sd_bus_message_close_container(m);
  });
}

int get_inputs(sd_bus*, const char*, const char*, const char*, sd_bus_message* reply, void* userdata, sd_bus_error* e) {
  return plant_property(reply, userdata, e, [](sd_bus_message* m, physics::Plant& plant, TimeUs t) {
    int r = sd_bus_message_open_container(m, 'a', "(sdsxsbbbb)");
    for (std::size_t i = 0; i < plant.input_count() && r >= 0; ++i) {
      const physics::PlantInputSpec& spec = plant.spec().inputs[i];
      const physics::Plant::InputState s = plant.input_state(i, t);
      const physics::Unit u = unit_of(plant, physics::PlantVar(i));
      r = sd_bus_message_append(m, "(sdsxsbbbb)", spec.name.c_str(), physics::to_unit(s.current, u),
                                std::string(u.name).c_str(), std::int64_t(s.updated), spec.description.c_str(),
                                int(s.overridden), int(s.stuck), int(s.lost), int(s.timed_out));
    }
    return r < 0 ? r : sd_bus_message_close_container(m);
  });
}

int get_faults(sd_bus*, const char*, const char*, const char*, sd_bus_message* reply, void* userdata, sd_bus_error* e) {
  return plant_property(reply, userdata, e, [](sd_bus_message* m, physics::Plant& plant, TimeUs t) {
    int r = sd_bus_message_open_container(m, 'a', "(ussb)");
    for (const physics::FaultInfo& f : plant.armed_faults(t))
      if (r >= 0)
        r = sd_bus_message_append(m, "(ussb)", f.handle, std::string(physics::to_string(f.kind)).c_str(),
                                  plant.fault_target(f.handle).c_str(), int(f.active));
    return r < 0 ? r : sd_bus_message_close_container(m);
  });
}

int get_health(sd_bus*, const char*, const char*, const char*, sd_bus_message* reply, void* userdata, sd_bus_error* e) {
  return plant_property(reply, userdata, e, [](sd_bus_message* m, physics::Plant& plant, TimeUs) {
    int r = sd_bus_message_open_container(m, 'a', "(st)");
    for (const auto& h : plant.health())
      if (r >= 0) r = sd_bus_message_append(m, "(st)", h.name.c_str(), std::uint64_t(h.non_finite));
    return r < 0 ? r : sd_bus_message_close_container(m);
  });
}

constexpr std::uint64_t kCall = SD_BUS_VTABLE_UNPRIVILEGED;

}  // namespace

const sd_bus_vtable kPlantVtable[] = {
    SD_BUS_VTABLE_START(0),
    SD_BUS_PROPERTY("Name", "s", get_name, 0, SD_BUS_VTABLE_PROPERTY_CONST),
    SD_BUS_PROPERTY("Step", "x", get_step, 0, 0),
    SD_BUS_PROPERTY("Time", "x", get_time, 0, 0),
    SD_BUS_PROPERTY("Variables", "a(ssds)", get_variables, 0, 0),
    SD_BUS_PROPERTY("Inputs", "a(sdsxsbbbb)", get_inputs, 0, SD_BUS_VTABLE_PROPERTY_EMITS_CHANGE),
    SD_BUS_PROPERTY("Faults", "a(ussb)", get_faults, 0, SD_BUS_VTABLE_PROPERTY_EMITS_CHANGE),
    SD_BUS_PROPERTY("Health", "a(st)", get_health, 0, 0),
    SD_BUS_METHOD_WITH_NAMES("Get", "ss", SD_BUS_PARAM(variable) SD_BUS_PARAM(unit), "ds",
                             SD_BUS_PARAM(value) SD_BUS_PARAM(unit), plant_get, kCall),
    SD_BUS_METHOD_WITH_NAMES("Set", "sds", SD_BUS_PARAM(input) SD_BUS_PARAM(value) SD_BUS_PARAM(unit), "", ,
                             audited_plant<plant_set>, kCall),
    SD_BUS_METHOD_WITH_NAMES("Override", "sds", SD_BUS_PARAM(input) SD_BUS_PARAM(value) SD_BUS_PARAM(unit), "", ,
                             audited_plant<plant_override>, kCall),
    SD_BUS_METHOD_WITH_NAMES("ClearOverride", "s", SD_BUS_PARAM(input), "", , audited_plant<plant_clear_override>,
                             kCall),
    SD_BUS_METHOD_WITH_NAMES("ArmFault", "sa{ss}", SD_BUS_PARAM(kind) SD_BUS_PARAM(params), "u", SD_BUS_PARAM(id),
                             audited_plant<plant_arm_fault>, kCall),
    SD_BUS_METHOD_WITH_NAMES("CancelFault", "u", SD_BUS_PARAM(id), "", , audited_plant<plant_cancel_fault>, kCall),
    SD_BUS_METHOD_WITH_NAMES("ListFaults", "", , "a(ussbxxxu)", SD_BUS_PARAM(faults), plant_list_faults, kCall),
    SD_BUS_SIGNAL_WITH_NAMES("FaultStarted", "xuss",
                             SD_BUS_PARAM(t) SD_BUS_PARAM(id) SD_BUS_PARAM(kind) SD_BUS_PARAM(target), 0),
    SD_BUS_SIGNAL_WITH_NAMES("FaultEnded", "xuss",
                             SD_BUS_PARAM(t) SD_BUS_PARAM(id) SD_BUS_PARAM(kind) SD_BUS_PARAM(target), 0),
    SD_BUS_VTABLE_END,
};

}  // namespace cansim::control
