#include "config/eds_writer.hpp"

#include <algorithm>
#include <cinttypes>
#include <cstdio>
#include <ctime>
#include <filesystem>
#include <set>
#include <sstream>
#include <vector>

#include "config/profile.hpp"

namespace cansim::config {

namespace {

std::string hex(std::uint64_t v, int digits = 0) {
  char buf[32];
  std::snprintf(buf, sizeof buf, "0x%0*" PRIX64, digits, v);
  return buf;
}

std::string section_name(std::uint16_t index) {
  char buf[8];
  std::snprintf(buf, sizeof buf, "%04X", index);
  return buf;
}

std::string sub_section_name(std::uint16_t index, std::uint8_t sub) {
  char buf[16];
  std::snprintf(buf, sizeof buf, "%04Xsub%X", index, sub);
  return buf;
}

std::string real_text(DataType t, const std::uint8_t* p) {
  char buf[40];
  std::snprintf(buf, sizeof buf, t == DataType::kReal32 ? "%.9g" : "%.17g", decode_f(t, p));
  return buf;
}

// A value as CiA 306 writes it: unsigned in hex, signed in decimal, REAL as a
// decimal number, strings as text, OCTET_STRING and DOMAIN as hex bytes.
// `node_id_term`: the stored number is relative to the node-ID ("$NODEID+0x180").
std::string value_text(DataType t, std::span<const std::uint8_t> bytes, bool node_id_term) {
  if (t == DataType::kOctetString || t == DataType::kDomain) {
    std::string out;
    for (std::uint8_t b : bytes) out += hex(b, 2).substr(2);
    return out;
  }
  if (is_variable_size(t)) {
    std::string text(bytes.begin(), bytes.end());
    for (char& c : text)
      if (c == '\n' || c == '\r') c = ' ';  // a line break would end the key
    return text;
  }
  if (bytes.size() < type_size(t)) return "0";
  if (is_real(t)) return real_text(t, bytes.data());
  const std::string number = is_signed(t) ? std::to_string(decode_i(t, bytes.data())) : hex(decode_u(t, bytes.data()));
  return node_id_term ? "$NODEID+" + number : number;
}

// CiA 306 §4.6.1: 0x1000, 0x1001 and 0x1018 are mandatory; the
// manufacturer-specific range is 0x2000-0x5FFF; the rest are optional.
enum class ObjectList { kMandatory, kOptional, kManufacturer };
ObjectList list_of(std::uint16_t index) {
  if (index == 0x1000 || index == 0x1001 || index == 0x1018) return ObjectList::kMandatory;
  if (index >= 0x2000 && index <= 0x5FFF) return ObjectList::kManufacturer;
  return ObjectList::kOptional;
}

// An object's own name: its first entry's, without the " - number of
// entries" part the sub 0 of an array or record carries.
std::string object_name(const OdLayout& layout, const OdObject& o) {
  std::string name = layout.entry(o.first).name;
  if (o.kind == ObjectKind::kVar) return name;
  if (const auto dash = name.find(" - "); dash != std::string::npos) name.erase(dash);
  return name;
}

std::uint64_t default_u(const OdLayout& layout, std::uint16_t index, std::uint8_t sub) {
  const OdEntry* e = layout.find(index, sub);
  return e && !is_variable_size(e->type) && e->default_bytes.size() >= type_size(e->type)
             ? decode_u(e->type, e->default_bytes.data())
             : 0;
}

std::string default_string(const OdLayout& layout, std::uint16_t index) {
  const OdEntry* e = layout.find(index, 0);
  return e && e->type == DataType::kVisibleString ? std::string(e->default_bytes.begin(), e->default_bytes.end())
                                                  : std::string();
}

unsigned count_objects(const OdLayout& layout, std::uint16_t first, std::uint16_t last) {
  unsigned n = 0;
  for (const OdObject& o : layout.objects()) n += o.index >= first && o.index <= last;
  return n;
}

// CiA 306 Granularity: 0 when no PDO mapping can be changed, else 1 (the
// core packs mapped objects bit by bit, a BOOLEAN may be mapped as 1 bit).
int granularity(const OdLayout& layout) {
  for (const OdEntry& e : layout.entries())
    if (((e.index >= 0x1600 && e.index <= 0x17FF) || (e.index >= 0x1A00 && e.index <= 0x1BFF)) && writable(e.access))
      return 1;
  return 0;
}

class Writer {
 public:
  Writer(const OdLayout& layout, const NodeOptions& options, const EdsIdentity& id, const DcfValues* dcf)
      : layout_(layout), options_(options), id_(id), dcf_(dcf) {}

  std::string run() {
    file_info();
    device_info();
    dummy_usage();
    comments();
    object_lists();
    if (dcf_) commissioning();
    for (const OdObject& o : layout_.objects()) object(o);
    return out_.str();
  }

 private:
  void section(const std::string& name) { out_ << "\n[" << name << "]\n"; }
  template <typename V>
  void key(const char* name, const V& value) {
    out_ << name << "=" << value << "\n";
  }
  // Text from the profile: a line break would end the key.
  void key(const char* name, const std::string& value) {
    std::string line = value;
    for (char& c : line)
      if (c == '\n' || c == '\r') c = ' ';
    out_ << name << "=" << line << "\n";
  }

  void file_info() {
    out_ << "; " << (dcf_ ? "DCF" : "EDS") << " written by cansimd from profile " << id_.name << "\n";
    section("FileInfo");
    key("FileName", id_.file_name);
    key("FileVersion", 1);
    key("FileRevision", 0);
    key("EDSVersion", "4.0");
    key("Description", id_.description);
    if (!id_.created.empty()) {
      const auto space = id_.created.find(' ');
      key("CreationTime", id_.created.substr(0, space));
      key("CreationDate", id_.created.substr(space + 1));
    }
    key("CreatedBy", "cansimd");
  }

  void device_info() {
    section("DeviceInfo");
    key("VendorName", "cansimd (simulated device)");
    if (layout_.find(0x1018, 1)) key("VendorNumber", hex(default_u(layout_, 0x1018, 1), 8));
    const std::string product = default_string(layout_, 0x1008);
    key("ProductName", product.empty() ? id_.name : product);
    if (layout_.find(0x1018, 2)) key("ProductNumber", hex(default_u(layout_, 0x1018, 2), 8));
    if (layout_.find(0x1018, 3)) key("RevisionNumber", hex(default_u(layout_, 0x1018, 3), 8));
    key("OrderCode", id_.name);
    bit_rates();
    key("SimpleBootUpMaster", 0);
    key("SimpleBootUpSlave", 1);
    key("Granularity", granularity(layout_));
    key("DynamicChannelsSupported", 0);
    key("GroupMessaging", 0);
    key("NrOfRXPDO", count_objects(layout_, 0x1400, 0x15FF));
    key("NrOfTXPDO", count_objects(layout_, 0x1800, 0x19FF));
    key("LSS_Supported", int(options_.lss_supported));
  }

  // The profile's own rate, and with LSS the lss_bit_rates table indices.
  void bit_rates() {
    const ByteSet indices = options_.lss_supported ? options_.lss_bit_rates : ByteSet{};
    for (std::uint32_t kbit : {10u, 20u, 50u, 125u, 250u, 500u, 800u, 1000u}) {
      const bool on = kbit == id_.bit_rate_kbit || indices.has(std::uint8_t(bit_rate_index(kbit)));
      const std::string name = "BaudRate_" + std::to_string(kbit);
      key(name.c_str(), int(on));
    }
  }

  // Dummy entries 0x0001..0x0007 in RPDO mappings (CiA 301 §7.4.7.1).
  void dummy_usage() {
    section("DummyUsage");
    for (int i = 1; i <= 7; ++i) {
      const std::string name = "Dummy000" + std::to_string(i);
      key(name.c_str(), int(options_.rpdo_dummy_mapping));
    }
  }

  void comments() {
    std::vector<std::string> lines = {
        "Simulated by cansimd, profile " + id_.name + ".",
        "Node behaviour beyond this file: the profile's options (docs/profiles.md, Profile options)."};
    section("Comments");
    key("Lines", lines.size());
    for (std::size_t i = 0; i < lines.size(); ++i) {
      const std::string name = "Line" + std::to_string(i + 1);
      key(name.c_str(), lines[i]);
    }
  }

  void object_lists() {
    static constexpr struct {
      ObjectList list;
      const char* name;
    } kLists[] = {{ObjectList::kMandatory, "MandatoryObjects"},
                  {ObjectList::kOptional, "OptionalObjects"},
                  {ObjectList::kManufacturer, "ManufacturerObjects"}};
    for (const auto& l : kLists) {
      std::vector<std::uint16_t> indices;
      for (const OdObject& o : layout_.objects())
        if (list_of(o.index) == l.list) indices.push_back(o.index);
      section(l.name);
      key("SupportedObjects", indices.size());
      for (std::size_t i = 0; i < indices.size(); ++i) {
        const std::string name = std::to_string(i + 1);
        key(name.c_str(), hex(indices[i], 4));
      }
    }
  }

  void commissioning() {
    std::uint64_t serial = default_u(layout_, 0x1018, 4);
    if (const OdEntry* e = layout_.find(0x1018, 4); e && !is_variable_size(e->type)) {
      const auto bytes = dcf_->value(*e);
      if (bytes.size() >= type_size(e->type)) serial = decode_u(e->type, bytes.data());
    }
    section("DeviceComissioning");  // CiA 306 spelling
    key("NodeID", hex(dcf_->node_id, 2));
    key("NodeName", dcf_->node_name);
    key("Baudrate", dcf_->bit_rate_kbit);
    key("NetNumber", 0);
    key("LSS_SerialNumber", hex(serial, 8));
  }

  void object(const OdObject& o) {
    const std::string name = section_name(o.index);
    if (o.kind == ObjectKind::kVar && o.count == 1 && layout_.entry(o.first).sub == 0) {
      section(name);
      entry(layout_.entry(o.first), ObjectKind::kVar);
      return;
    }
    section(name);
    key("ParameterName", object_name(layout_, o));
    key("ObjectType", hex(unsigned(o.kind == ObjectKind::kVar ? ObjectKind::kRecord : o.kind)));
    key("SubNumber", o.count);
    // CiA 306 tools look sub-objects up by name: a name an earlier sub-index
    // of the object has (an imported file's) gets its sub-index.
    std::set<std::string> names;
    for (std::uint16_t slot = o.first; slot < o.first + o.count; ++slot) {
      const OdEntry& e = layout_.entry(slot);
      section(sub_section_name(e.index, e.sub));
      const bool taken = !names.insert(e.name).second;
      entry(e, ObjectKind::kVar, taken ? e.name + " (sub " + std::to_string(e.sub) + ")" : e.name);
    }
  }

  void entry(const OdEntry& e, ObjectKind kind) { entry(e, kind, e.name); }

  void entry(const OdEntry& e, ObjectKind kind, const std::string& name) {
    key("ParameterName", name);
    key("ObjectType", hex(unsigned(kind)));
    key("DataType", hex(unsigned(e.type), 4));
    key("AccessType", access_name(e.access));
    // A variable-size default longer than the entry holds is answered cut short.
    std::span<const std::uint8_t> preset(e.default_bytes);
    if (is_variable_size(e.type)) preset = preset.first(std::min<std::size_t>(preset.size(), e.capacity));
    key("DefaultValue", value_text(e.type, preset, e.default_plus_node_id));
    if (e.has_low) key("LowLimit", value_text(e.type, {e.low, type_size(e.type)}, false));
    if (e.has_high) key("HighLimit", value_text(e.type, {e.high, type_size(e.type)}, false));
    key("PDOMapping", int(e.pdo_mappable));
    if (dcf_) key("ParameterValue", parameter_value(e));
  }

  // The current value; "$NODEID+x" when it is still the default relative to
  // the node-ID, so the DCF keeps following a new node-ID.
  std::string parameter_value(const OdEntry& e) {
    const auto bytes = dcf_->value(e);
    if (e.default_plus_node_id && bytes.size() == type_size(e.type) && e.default_bytes.size() == bytes.size()) {
      const std::uint64_t base = decode_u(e.type, e.default_bytes.data());
      if (decode_u(e.type, bytes.data()) == base + dcf_->node_id) return value_text(e.type, e.default_bytes, true);
    }
    return value_text(e.type, bytes, false);
  }

  const OdLayout& layout_;
  const NodeOptions& options_;
  const EdsIdentity& id_;
  const DcfValues* dcf_;
  std::ostringstream out_;
};

}  // namespace

EdsIdentity identity_of(const Profile& profile) {
  EdsIdentity id;
  id.name = profile.name.empty() ? std::filesystem::path(profile.file).stem().string() : profile.name;
  id.file_name = id.name + ".eds";
  id.description = profile.description;
  id.bit_rate_kbit = profile.bit_rate_kbit;
  return id;
}

std::string write_eds(const OdLayout& layout, const NodeOptions& options, const EdsIdentity& identity,
                      const DcfValues* dcf) {
  return Writer(layout, options, identity, dcf).run();
}

std::string write_default_dcf(const Profile& profile, std::uint8_t node_id) {
  OdValues values(profile.layout);
  values.reset(node_id);
  DcfValues dcf;
  dcf.node_id = node_id;
  dcf.node_name = profile.name;
  dcf.bit_rate_kbit = profile.bit_rate_kbit;
  dcf.value = [&](const OdEntry& e) { return values.bytes(e); };
  EdsIdentity id = identity_of(profile);
  id.file_name = id.name + ".dcf";
  return write_eds(*profile.layout, *profile.options, id, &dcf);
}

std::string eds_time_now() {
  const std::time_t now = std::time(nullptr);
  std::tm tm{};
  localtime_r(&now, &tm);
  char buf[32];
  std::strftime(buf, sizeof buf, "%I:%M%p %m-%d-%Y", &tm);
  return buf;
}

}  // namespace cansim::config
