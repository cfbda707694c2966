// `cansimctl plant [NAME]` and the plant targets of fault / faults / cancel
// (docs/plants.md): a plant's variables and inputs in units, each input's
// age and source, its faults; setting and overriding an input. A plant is
// named `plant:NAME` where a verb takes a NODE.
#pragma once

#include <cstdint>
#include <ostream>
#include <string>
#include <vector>

#include "ctl/connection.hpp"
#include "ctl/request.hpp"

namespace cansim::ctl {

inline constexpr const char* kPlantTargetPrefix = "plant:";

// "plant:vessel" -> "vessel"; "" for a node's name.
std::string plant_target(const std::string& node);

// Io.cansim.Plant1 as cansimctl prints it (the properties of one plant).
struct PlantVariableRow {
  std::string name, kind;
  double value = 0;
  std::string unit;
};
struct PlantInputRow {
  std::string name;
  double value = 0;
  std::string unit;
  std::int64_t updated_us = -1;  // -1: never
  std::string source;
  bool overridden = false, stuck = false, lost = false, timed_out = false;
};
struct PlantFaultBrief {
  std::uint32_t id = 0;
  std::string kind, target;
  bool active = false;
};
struct PlantView {
  std::string name;
  std::int64_t step_us = 0, time_us = 0;
  std::vector<PlantVariableRow> variables;
  std::vector<PlantInputRow> inputs;
  std::vector<PlantFaultBrief> faults;
};

// The text of one plant: variables, inputs with their age at `now_us`, faults.
void print_plant_text(std::ostream& out, const PlantView& p, std::int64_t now_us);
void print_plants_json(std::ostream& out, const std::vector<PlantView>& plants, std::int64_t now_us);

// Output::kPlant: shows every plant or Request::node's, or sets / overrides
// an input (Request::call is the Plant1 method, its path the plant's).
int run_plant(Connection& connection, const Request& request, bool json, std::ostream& out);

// The object path of a plant (Fleet1.GetPlant).
std::string plant_path(Connection& connection, const std::string& name);

}  // namespace cansim::ctl
