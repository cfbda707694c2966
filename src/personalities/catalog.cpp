#include "personalities/catalog.hpp"

#include "personalities/analog_output.hpp"
#include "personalities/cmp.hpp"
#include "personalities/dps.hpp"
#include "personalities/gems9000.hpp"
#include "personalities/generic.hpp"
#include "personalities/p92c.hpp"
#include "personalities/smc.hpp"

namespace cansim::personalities {

namespace {

template <class Settings>
model::DeviceSettings defaults() {
  return Settings{};
}

Requirements nothing() { return {}; }

// Device personalities add one line each (and a make() in registry.cpp).
const PersonalityInfo kPersonalities[] = {
    {"generic", defaults<model::GenericSettings>, nothing},
    {"trafag-cmp", defaults<model::CmpSettings>, nothing},
    {"gems-9000", defaults<model::GemsSettings>, nothing},
    {"danfoss-p92c", defaults<model::P92cSettings>, nothing},
    {"adz-smc", defaults<model::SmcSettings>, smc::requirements},
    {"honeywell-dps", defaults<model::DpsSettings>, dps::requirements},
    {"cia401-analog-output", defaults<model::AnalogOutputSettings>, analog_output::requirements},
};

}  // namespace

const PersonalityInfo* find_personality(std::string_view name) {
  for (const PersonalityInfo& p : kPersonalities)
    if (name == p.name) return &p;
  return nullptr;
}

std::string personality_names() {
  std::string s;
  for (const PersonalityInfo& p : kPersonalities) s += (s.empty() ? "" : ", ") + std::string(p.name);
  return s;
}

}  // namespace cansim::personalities
