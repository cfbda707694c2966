// Strict mode of the chain and device settings (docs/profiles.md "Strict mode and
// quirks"): plain functions on the settings structs, called by the loader
// (config/strict_mode.cpp). A setting strict mode changes is a quirk named
// `cia404.<name>` / `vendor.<name>` in the profile's `quirks:` map.
#pragma once

#include <string>
#include <vector>

#include "model/profile.hpp"
#include "personalities/cia404.hpp"
#include "personalities/dps.hpp"
#include "personalities/smc.hpp"

namespace cansim::personalities {

// CiA 404 behaviour and CiA 301 abort codes (the Cia404Settings defaults)
// for the settings that are vendor deviations; feature choices (which TPDO
// types get events, check periods, filters) stay.
void make_strict(Cia404Settings& s);
// DPS 10.5: autozero moves the span too; CiA 404 0x6125 corrects the offset only.
void make_strict(dps::Settings& s);
// SMC §6.1.2: 0x1001 survives reset node; CiA 301 re-evaluates it on a reset.
void make_strict(smc::Settings& s);

// A name strict_changes can report (the `quirks:` keys a profile may use).
bool is_strict_setting(const std::string& name);
// The settings strict mode changes, as inventory rows without reference.
std::vector<model::Quirk> strict_changes(const Cia404Settings& faithful);
std::vector<model::Quirk> strict_changes(const dps::Settings& faithful);
std::vector<model::Quirk> strict_changes(const smc::Settings& faithful);

}  // namespace cansim::personalities
