// The two measured quantities, named once: every layer that takes a channel
// by name (profiles, the control API, cansimctl, fault schedules) parses and
// prints it here. A CiA 404 channel measures one of them; a unit belongs to
// one (model/units.hpp); a fault acts on one or both (physics/fault.hpp).
#pragma once

#include <array>
#include <cstdint>
#include <optional>
#include <string_view>

namespace cansim::physics {

enum class Channel : std::uint8_t { Pressure = 0, Temperature = 1 };

// The names in Channel order, as profiles and the control API write them.
inline constexpr std::array<std::string_view, 2> kChannelNames = {"pressure", "temperature"};

constexpr std::string_view channel_name(Channel c) { return kChannelNames[std::size_t(c)]; }

// nullopt for any other word.
constexpr std::optional<Channel> parse_channel(std::string_view word) {
  for (std::size_t i = 0; i < kChannelNames.size(); ++i)
    if (word == kChannelNames[i]) return Channel(i);
  return std::nullopt;
}

}  // namespace cansim::physics
