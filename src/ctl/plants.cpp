#include "ctl/plants.hpp"

#include <cmath>
#include <cstdio>
#include <cstring>

#include "ctl/json.hpp"
#include "ctl/output.hpp"
#include "ctl/values.hpp"

namespace cansim::ctl {

namespace {

void check(int r, const char* what) {
  if (r < 0) throw Failure(std::string("unexpected reply from cansimd: ") + what + ": " + std::strerror(-r));
}

MessagePtr property(Connection& c, const std::string& path, const char* name) {
  return c.call(path, kPropertiesInterface, "Get",
                {Value(std::string(control::kPlantInterface)), Value(std::string(name))});
}

template <typename ReadOne>
void read_list(sd_bus_message* m, const char* element, ReadOne&& read_one) {
  const std::string array = std::string("a") + element;
  check(sd_bus_message_enter_container(m, 'v', array.c_str()), "variant");
  check(sd_bus_message_enter_container(m, 'a', element), "array");
  int r;
  while ((r = read_one(m)) > 0) {
  }
  check(r, element);
}

PlantView read_plant(Connection& c, const std::string& name) {
  const std::string path = plant_path(c, name);
  PlantView p;
  p.name = name;
  MessagePtr step = property(c, path, "Step"), time = property(c, path, "Time");
  check(sd_bus_message_read(step.get(), "v", "x", &p.step_us), "Step");
  check(sd_bus_message_read(time.get(), "v", "x", &p.time_us), "Time");
  MessagePtr vars = property(c, path, "Variables");
  read_list(vars.get(), "(ssds)", [&](sd_bus_message* m) {
    const char *n = nullptr, *k = nullptr, *u = nullptr;
    double v = 0;
    const int r = sd_bus_message_read(m, "(ssds)", &n, &k, &v, &u);
    if (r > 0) p.variables.push_back({n, k, v, u});
    return r;
  });
  MessagePtr ins = property(c, path, "Inputs");
  read_list(ins.get(), "(sdsxsbbbb)", [&](sd_bus_message* m) {
    const char *n = nullptr, *u = nullptr, *src = nullptr;
    PlantInputRow in;
    int o = 0, s = 0, l = 0, t = 0;
    const int r = sd_bus_message_read(m, "(sdsxsbbbb)", &n, &in.value, &u, &in.updated_us, &src, &o, &s, &l, &t);
    if (r > 0) {
      in.name = n, in.unit = u, in.source = src;
      in.overridden = o, in.stuck = s, in.lost = l, in.timed_out = t;
      p.inputs.push_back(in);
    }
    return r;
  });
  MessagePtr faults = property(c, path, "Faults");
  read_list(faults.get(), "(ussb)", [&](sd_bus_message* m) {
    const char *k = nullptr, *target = nullptr;
    PlantFaultBrief f;
    int active = 0;
    const int r = sd_bus_message_read(m, "(ussb)", &f.id, &k, &target, &active);
    if (r > 0) {
      f.kind = k, f.target = target, f.active = active;
      p.faults.push_back(f);
    }
    return r;
  });
  return p;
}

std::vector<std::string> plant_names(Connection& c) {
  MessagePtr reply = c.call(kFleetPath, kFleetInterface, "ListPlants");
  std::vector<std::string> names;
  check(sd_bus_message_enter_container(reply.get(), 'a', "(os)"), "ListPlants");
  const char *path = nullptr, *name = nullptr;
  int r;
  while ((r = sd_bus_message_read(reply.get(), "(os)", &path, &name)) > 0) names.emplace_back(name);
  check(r, "ListPlants");
  return names;
}

std::string input_state(const PlantInputRow& in) {
  std::string s;
  auto add = [&](bool on, const char* what) {
    if (on) s += (s.empty() ? "" : ", ") + std::string(what);
  };
  add(in.overridden, "overridden");
  add(in.stuck, "stuck");
  add(in.lost, "lost");
  add(in.timed_out, "timed out");
  return s.empty() ? "-" : s;
}

std::string age_text(std::int64_t updated, std::int64_t now) {
  return updated < 0 ? "never" : format_seconds(std::max<std::int64_t>(0, now - updated)) + " s";
}

}  // namespace

std::string plant_target(const std::string& node) {
  const std::string prefix(kPlantTargetPrefix);
  return node.compare(0, prefix.size(), prefix) == 0 ? node.substr(prefix.size()) : "";
}

std::string plant_path(Connection& connection, const std::string& name) {
  MessagePtr reply = connection.call(kFleetPath, kFleetInterface, "GetPlant", {Value(name)});
  const char* path = nullptr;
  check(sd_bus_message_read(reply.get(), "o", &path), "GetPlant");
  return path;
}

void print_plant_text(std::ostream& out, const PlantView& p, std::int64_t now_us) {
  out << p.name << " (step " << format_seconds(p.step_us) << " s, at " << format_seconds(p.time_us) << " s)\n";
  Table vars({"VARIABLE", "KIND", "VALUE", "UNIT"});
  for (const PlantVariableRow& v : p.variables)
    vars.add({v.name, v.kind, format_measure(v.value), v.unit.empty() ? "-" : v.unit});
  vars.print(out);
  if (!p.inputs.empty()) {
    Table ins({"INPUT", "VALUE", "UNIT", "AGE", "STATE", "SOURCE"});
    for (const PlantInputRow& in : p.inputs)
      ins.add({in.name, format_measure(in.value), in.unit.empty() ? "-" : in.unit, age_text(in.updated_us, now_us),
               input_state(in), in.source});
    ins.print(out);
  }
  std::string faults;
  for (const PlantFaultBrief& f : p.faults)
    faults += (faults.empty() ? "" : ", ") + std::to_string(f.id) + " " + f.kind + " on " + f.target +
              (f.active ? " (active)" : "");
  out << "faults: " << (faults.empty() ? "none" : faults) << '\n';
}

void print_plants_json(std::ostream& out, const std::vector<PlantView>& plants, std::int64_t now_us) {
  Json list = Json::array();
  for (const PlantView& p : plants) {
    Json vars = Json::array(), ins = Json::array(), faults = Json::array();
    for (const PlantVariableRow& v : p.variables)
      vars.push_back(
          {{"name", v.name}, {"kind", v.kind}, {"value", json_number(v.value)}, {"unit", json_text_or_null(v.unit)}});
    for (const PlantInputRow& in : p.inputs)
      ins.push_back(
          {{"name", in.name},
           {"value", json_number(in.value)},
           {"unit", json_text_or_null(in.unit)},
           {"updated", json_seconds(in.updated_us)},
           {"age", in.updated_us < 0 ? Json(nullptr) : json_seconds(std::max<std::int64_t>(0, now_us - in.updated_us))},
           {"source", in.source},
           {"overridden", in.overridden},
           {"stuck", in.stuck},
           {"lost", in.lost},
           {"timed_out", in.timed_out}});
    for (const PlantFaultBrief& f : p.faults)
      faults.push_back({{"id", f.id}, {"kind", f.kind}, {"target", f.target}, {"active", f.active}});
    list.push_back({{"plant", p.name},
                    {"step", json_seconds(p.step_us)},
                    {"time", json_seconds(p.time_us)},
                    {"variables", vars},
                    {"inputs", ins},
                    {"faults", faults}});
  }
  print_json(out, {{"time", json_seconds(now_us)}, {"plants", list}});
}

int run_plant(Connection& connection, const Request& request, bool json, std::ostream& out) {
  if (!request.call.method.empty()) {  // set / override / clear
    connection.call(plant_path(connection, request.node), control::kPlantInterface, request.call.method,
                    request.call.args);
    return 0;
  }
  const std::vector<std::string> names = request.node.empty() ? plant_names(connection) : std::vector{request.node};
  std::vector<PlantView> plants;
  for (const std::string& n : names) plants.push_back(read_plant(connection, n));
  const std::int64_t now = connection.simulated_time_us();
  if (json) {
    print_plants_json(out, plants, now);
    return 0;
  }
  if (plants.empty()) out << "no plants\n";
  for (std::size_t i = 0; i < plants.size(); ++i) {
    if (i) out << '\n';
    print_plant_text(out, plants[i], now);
  }
  return 0;
}

}  // namespace cansim::ctl
