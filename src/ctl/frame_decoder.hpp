// The bus monitor's decoder: a CAN frame -> one decoded line, with what the
// daemon knows of each node (its current node-ID, its PDOs as the engine runs
// them, its objects' names, types and units: Node1.GetPdoMapping and
// ListObjects, docs/control-api.md). Pure: no sockets, no D-Bus, so each
// frame kind is unit-tested (tests/unit/ctl_monitor_test.cpp).
#pragma once

#include <cstdint>
#include <functional>
#include <map>
#include <optional>
#include <set>
#include <string>
#include <vector>

#include "control/can_signal.hpp"
#include "ctl/json.hpp"
#include "ctl/values.hpp"

namespace cansim::ctl {

// What a value in counts means (ListCountScaling): engineering value = raw x scale + offset, in unit.
struct CountScaling {
  double scale = 1.0, offset = 0.0;
  std::string unit;
};

inline constexpr const char* kCountsUnit = "counts";  // ListObjects' unit of a device value in counts

// An object of a node (ListObjects), or one mapped into a PDO (GetPdoMapping).
struct ObjectInfo {
  std::uint16_t index = 0;
  std::uint8_t sub = 0;
  std::string name;                           // "" for a dummy mapping entry
  std::string type;                           // CiA 301 type name: "REAL32", "INTEGER16", "VISIBLE_STRING", ...
  double scale = 1.0;                         // the device's value = raw x scale
  std::string unit;                           // "" for none, "counts" for a value in counts
  std::optional<CountScaling> engineering{};  // a value in counts: what it means
};

struct PdoEntryInfo {
  ObjectInfo object;
  std::uint8_t bits = 0;
};

struct PdoInfo {
  std::string name;          // "TPDO1", "RPDO2"
  std::uint32_t cob_id = 0;  // CAN-ID; bit 29 set: a 29-bit CAN-ID
  bool valid = false;
  std::uint8_t transmission_type = 0;
  std::vector<PdoEntryInfo> entries;
};

struct NodeInfo {
  std::string key;    // fleet key "vcan0/generic/0"
  std::string label;  // as people name it: "generic/0", "dps"
  std::string interface;
  std::uint8_t node_id = 0;
  std::vector<PdoInfo> pdos;
  std::optional<std::vector<ObjectInfo>> objects;  // loaded when an SDO frame needs them
  // What the device's manual says its EMCY codes mean (ListEmcyCodes);
  // loaded with the objects, when an EMCY or SDO frame needs them.
  std::optional<std::map<std::uint16_t, std::string>> emcy_codes;
};

struct RawFrame {
  double time = 0;                       // seconds since the Unix epoch (the socket's receive time)
  std::optional<double> simulated_time;  // the daemon's clock at that instant, when known
  std::string interface;
  std::uint32_t id = 0;  // CAN-ID (11 or 29 bits)
  bool extended = false;
  bool rtr = false;
  bool error = false;  // a controller's error frame: id holds its CAN_ERR_* class bits
  std::uint8_t dlc = 0;
  std::uint8_t data[8] = {};
};

// One field of a decoded frame. Object fields carry index and sub.
struct DecodedField {
  std::string name;
  std::optional<std::uint16_t> index;
  std::optional<std::uint8_t> sub;
  std::optional<Value> value;    // what it means, in `unit`; none: JSON null
  std::string unit;              // "" : JSON null
  std::optional<Value> raw;      // the value as the device sent it (JSON: "raw", the same as value when unscaled)
  std::optional<double> counts;  // the device's value when it is in counts (value: what they mean)
  int decimals = -1;             // a scaled integer: print this many decimals (text)
  IntegerStyle style = IntegerStyle::kDecimal;
  int hex_digits = 0;  // with kHex: at least this many digits (text)
  bool bare = false;   // text: the value only ("upload request"), no "name ="
};

struct DecodedFrame {
  double time = 0;  // wall clock, Unix seconds
  std::optional<double> simulated_time;
  std::string interface;
  std::uint32_t id = 0;
  bool extended = false;
  bool rtr = false;
  std::uint8_t dlc = 0;
  Bytes data;         // the frame's data bytes (none for an RTR)
  std::string node;   // fleet key, "" when the frame belongs to no node of the fleet
  std::string label;  // the node as people name it, "" with node
  std::string kind;   // "TPDO1", "RPDO1", "heartbeat", "boot-up", "NMT", "SDO", "EMCY", "SYNC", "LSS", "raw"
  std::vector<DecodedField> fields;
};

// A plant input read from frames (Fleet1.ListPlantSignals).
struct PlantSignalInfo {
  std::string plant, input, interface;
  CanSignal signal;  // raw x scale + offset is in `unit`
  std::string unit;
};

class FrameDecoder {
 public:
  // Called when an SDO or EMCY frame needs what the daemon says of a node
  // beyond its PDOs (node.objects or node.emcy_codes unset); it may fill
  // them. Without a loader SDO values print as bytes, EMCY codes by CiA.
  using ObjectLoader = std::function<void(NodeInfo& node)>;
  explicit FrameDecoder(ObjectLoader loader = {}) : loader_(std::move(loader)) {}

  void set_node(NodeInfo node);  // adds or replaces (by key)
  // Frames carrying plant inputs also decode as "PLANT.INPUT = value unit"
  // (a frame no node owns: kind "plant").
  void set_plant_signals(std::vector<PlantSignalInfo> signals) { plant_signals_ = std::move(signals); }
  void remove_node(const std::string& key);
  NodeInfo* node(const std::string& key);

  DecodedFrame decode(const RawFrame& frame);

 private:
  struct SdoTransfer {  // a segmented transfer in progress
    bool upload = false;
    std::uint16_t index = 0;
    std::uint8_t sub = 0;
    Bytes data;
    bool active = false;
  };
  NodeInfo* by_id(const std::string& interface, std::uint8_t node_id);
  const ObjectInfo* object(NodeInfo& n, std::uint16_t index, std::uint8_t sub);
  std::string emcy_text(NodeInfo& n, std::uint16_t code);
  void load(NodeInfo& n);
  void decode_pdo(NodeInfo& n, const PdoInfo& pdo, const RawFrame& f, DecodedFrame& out);
  void decode_sdo(NodeInfo& n, bool request, const RawFrame& f, DecodedFrame& out);
  void sdo_value(NodeInfo& n, std::uint16_t index, std::uint8_t sub, const Bytes& data, DecodedFrame& out);
  void index(const NodeInfo& n);
  void unindex(const NodeInfo& n);
  void add_plant_fields(const RawFrame& f, DecodedFrame& out) const;
  DecodedFrame decode_canopen(const RawFrame& f);

  ObjectLoader loader_;
  std::vector<PlantSignalInfo> plant_signals_;
  std::map<std::string, NodeInfo> nodes_;  // by key
  // Where a frame's node is found, by key within each (the lowest key wins a
  // collision): (interface, COB-ID) -> key -> which of its PDOs; (interface,
  // node-ID) -> keys.
  std::map<std::pair<std::string, std::uint32_t>, std::map<std::string, std::size_t>> pdo_by_id_;
  std::map<std::pair<std::string, std::uint8_t>, std::set<std::string>> key_by_id_;
  std::map<std::string, SdoTransfer> sdo_;  // by key
};

// "12:03:04.123456 vcan0 190 generic/0 TPDO1 AI input PV (pressure) = 3.50 bar, AI status (pressure) = 0".
std::string format_decoded(const DecodedFrame& f);
// {"time": simulated s|null, "wall_time": Unix s, "interface", "id": CAN-ID, "extended", "rtr", "dlc",
//  "data": hex, "node": key|null, "kind", "fields": [field_json...]}
Json decoded_json(const DecodedFrame& f);

// The field of an object's raw value: its name and address, the value it
// means (raw x scale, exact for 10^-d scales: 350 x 0.01 is 3.5) and unit.
DecodedField object_field(const ObjectInfo& o, const Value& raw);
// A field's value as text: "3.50" (a scaled integer's decimals), "9 990 440", "0x06020000", "01 02".
std::string format_field_value(const DecodedField& f);
// {"name", "index", "sub", "value", "unit", "raw", "counts"}; null where none.
Json field_json(const DecodedField& f);

// The typed value of little-endian bytes of a CiA 301 type name; bytes when
// the type is unknown or the length does not fit it.
Value typed_bytes(const std::string& type, const Bytes& data);

}  // namespace cansim::ctl
