// What each personality is to a loader: its name, its settings type (the
// DeviceSettings alternative a profile of it carries) and what its behaviour
// needs from the object dictionary, declared once per personality. Loaders
// (config/) check every profile against it and say which line lacks what.
#pragma once

#include <cstdint>
#include <span>
#include <string>
#include <string_view>

#include "model/device_settings.hpp"

namespace cansim::personalities {

// Numeric objects the behaviour reads or writes: index, subs first..last.
struct RequiredObject {
  std::uint16_t index;
  std::uint8_t first_sub, last_sub;
  const char* purpose;     // "the input scaling (§5)"
  std::uint8_t hooks = 0;  // kHookRead / kHookWrite the behaviour needs on it
};

struct Requirements {
  std::span<const RequiredObject> objects;
  std::size_t channels = 0;           // CiA 404 channels at least
  const char* channels_purpose = "";  // what they are for
};

struct PersonalityInfo {
  const char* name;  // `personality:` in a profile
  model::DeviceSettings (*default_settings)();
  Requirements (*requirements)();
};

// Null for an unknown name.
const PersonalityInfo* find_personality(std::string_view name);
// "generic, trafag-cmp, ..." for error messages.
std::string personality_names();

}  // namespace cansim::personalities
