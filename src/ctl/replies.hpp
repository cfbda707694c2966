// The control API's replies and signals as plain data (docs/control-api.md),
// decoded by decode.hpp and printed by output.hpp.
#pragma once

#include <cmath>
#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include "ctl/values.hpp"

namespace cansim::ctl {

// ListNodes: a(osssysss).
struct NodeRow {
  std::string path, key, name, interface;
  std::uint8_t node_id = 0;
  std::string profile, personality, nmt_state;
};

// What an acting verb did on one node of a group.
struct GroupResult {
  std::string key;
  bool ok = false;
  std::optional<std::uint32_t> fault_id{};  // fault: the id armed on this node
  std::string error{};                      // refused: the reason
};

// A node object and its fleet key (AddNodes).
struct NodeRef {
  std::string path, key;
};

// ListFaults: a(ussbxxxu). Times in µs; duration -1: until cancelled.
struct FaultRow {
  std::uint32_t id = 0;
  std::string kind, channel;  // a plant's fault: channel is its target (a block or an input)
  bool active = false;
  std::int64_t start_us = -1, duration_us = -1, period_us = 0;
  std::uint32_t count = 0;
  bool plant = false;  // a fault of a plant (Plant1.ListFaults): JSON names channel "target"
};

// GetBusStatistics: a(sbuttttdd). Loads are fractions of the bit rate.
struct BusStats {
  std::string name;
  bool up = false;
  std::uint32_t bit_rate_kbit = 0;
  std::uint64_t frames_in = 0, frames_out = 0, frames_dropped = 0, frames_offline = 0;
  double offered_load = 0, measured_load = 0;
  // Fleet1.BusLoad a(ssddddxxxxxuut) and BusStates a{ss} of the same interface.
  std::string model, state;
  double offered_1s = 0, offered_10s = 0, carried_1s = 0, carried_10s = 0;
  std::int64_t delay_p50_us = 0, delay_p99_us = 0, delay_max_us = 0;
  std::int64_t slip_p99_us = 0, slip_max_us = 0;
  std::uint32_t queued = 0, queue_capacity = 0;
  std::uint64_t queue_dropped = 0;
  // Fleet1.SocketcandBuses a(ssqu): a socketcand bus's address and clients
  // (docs/socketcand.md); transport "socketcan" for a kernel interface.
  std::string transport = "socketcan";
  std::string listen_host = "";
  std::uint16_t listen_port = 0;
  std::uint32_t clients = 0;
};

// Node1.Pressure / Temperature: (ddsy), both values in `unit` (the reported
// one as the device means it). NaN and "" without such a channel.
struct Reading {
  double true_value = NAN, reported = NAN;
  std::string unit;
  std::uint8_t status = 0;
  double counts = NAN;  // Node1.PressureCounts / TemperatureCounts: the PV when it is in counts
};

struct OverrideRow {  // Node1.Overrides: a(sds)
  std::string channel;
  double value = 0;
  std::string unit;
};

struct FaultBrief {  // Node1.Faults: a(usb)
  std::uint32_t id = 0;
  std::string kind;
  bool active = false;
};

struct EmcyRecord {  // Node1.LastEmcy: (xqyay); time -1: none yet
  std::int64_t time_us = -1;
  std::uint16_t code = 0;
  std::uint8_t error_register = 0;
  Bytes vendor;
};

// Properties.GetAll of a node (io.cansim.Node1).
struct NodeStatus {
  std::string path;
  std::string key, name;
  std::uint32_t index = 0;
  std::string profile, personality, interface;
  std::uint8_t node_id = 0;
  std::string nmt_state;
  bool powered = false, on_bus = false;
  Reading pressure, temperature;
  std::vector<OverrideRow> overrides;
  std::vector<FaultBrief> faults;
  std::uint32_t emcy_count = 0;
  EmcyRecord last_emcy;
  std::string recording;
  std::uint64_t frames_sent = 0;
};

// One argument of a signal, or one changed property.
struct Field {
  std::string name;
  Value value;
  IntegerStyle style = IntegerStyle::kDecimal;      // human output; JSON always prints numbers
  std::optional<std::vector<FaultBrief>> faults{};  // the Faults property: value is its text, JSON a list
};

// A signal as watch prints it.
struct Event {
  std::optional<std::int64_t> time_us;  // simulated time
  std::string source;                   // node key, "fleet", or the object path
  std::string name;                     // signal name, or PropertiesChanged
  std::vector<Field> fields;
};

}  // namespace cansim::ctl
