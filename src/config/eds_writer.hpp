// CiA 306 v1.4 electronic data sheet (EDS) and device configuration file
// (DCF) of a profile's object dictionary. Only what the node answers is
// described: one section per object and sub-object of the layout, no other.
#pragma once

#include <cstdint>
#include <functional>
#include <optional>
#include <span>
#include <string>

#include "core/node_options.hpp"
#include "core/od.hpp"
#include "model/profile.hpp"

namespace cansim::config {

using Profile = model::Profile;

// What the file says about the device besides its object dictionary.
struct EdsIdentity {
  std::string file_name;              // [FileInfo] FileName, e.g. "p92c.eds"
  std::string name;                   // profile name ([DeviceInfo] OrderCode)
  std::string description;            // [FileInfo] Description
  std::uint32_t bit_rate_kbit = 250;  // the profile's own rate (always listed as supported)
  std::string created;                // "hh:mmAM mm-dd-yyyy"; empty: none written
};

// A DCF: the node's commissioning and its current values.
struct DcfValues {
  std::uint8_t node_id = 1;
  std::string node_name;
  std::uint32_t bit_rate_kbit = 250;
  // The entry's current value, as the node stores it.
  std::function<std::span<const std::uint8_t>(const OdEntry&)> value;
};

EdsIdentity identity_of(const Profile& profile);

// The EDS text; with `dcf`, the DCF (EDS + [DeviceComissioning] + ParameterValue).
std::string write_eds(const OdLayout& layout, const NodeOptions& options, const EdsIdentity& identity,
                      const DcfValues* dcf = nullptr);

// A DCF of a node at power-on: every ParameterValue its default, $NODEID
// resolved with `node_id` (cansimd --export-eds PROFILE --node-id N).
std::string write_default_dcf(const Profile& profile, std::uint8_t node_id);

// "hh:mmAM mm-dd-yyyy" (CiA 306 §4.3 time and date formats) of the current time.
std::string eds_time_now();

}  // namespace cansim::config
