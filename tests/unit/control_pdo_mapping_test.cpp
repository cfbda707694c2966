// Node1.GetPdoMapping, ListObjects and the PdoMappingChanged signal (what the
// decoded bus monitor reads) over a real sd-bus peer connection on the fake
// clock: the PDOs as the engine runs them, with each mapped object's type,
// unit and scale, following SDO writes of the mapping, unit and digits.
#include <gtest/gtest.h>

#include <cstring>
#include <map>

#include "control/service.hpp"
#include "support/control_fleet.hpp"

namespace cansim::test {
namespace {

constexpr const char* kFleet = R"(
interfaces: {vcan0: {bit_rate: 250}}
nodes:
  - {profile: generic-404, interface: vcan0, node_id: 0x10, name: generic}
  - {profile: dps, interface: vcan0, bit_rate: 250, name: dps}
)";

constexpr TimeUs kMs = 1000;

struct Entry {
  std::uint16_t index;
  std::uint8_t sub, bits;
  std::string name, type;
  double scale;
  std::string unit;
};

struct Pdo {
  std::string name;
  std::uint32_t cob_id;
  bool valid;
  std::uint8_t type;
  std::vector<Entry> entries;
};

class ControlPdoMappingTest : public ::testing::Test {
 protected:
  ControlFleet fleet{kFleet};
  BusPair bus{fleet.service()};

  void SetUp() override {
    fleet.run_until(5 * kMs);
    fleet.take("vcan0");
  }

  std::string path_of(const std::string& node) { return bus.node_path(node); }

  static Entry read_entry(sd_bus_message* r) {
    Entry e{};
    const char *name = "", *type = "", *unit = "";
    EXPECT_GT(sd_bus_message_read(r, "(qyyssds)", &e.index, &e.sub, &e.bits, &name, &type, &e.scale, &unit), 0);
    e.name = name, e.type = type, e.unit = unit;
    return e;
  }

  std::vector<Pdo> mapping(const std::string& node) {
    sd_bus_message* r = bus.call(bus.node_call(path_of(node), "GetPdoMapping"));
    std::vector<Pdo> out;
    if (!r) return out;
    EXPECT_GT(sd_bus_message_enter_container(r, 'a', "(subya(qyyssds))"), 0);
    while (sd_bus_message_enter_container(r, 'r', "subya(qyyssds)") > 0) {
      Pdo p{};
      const char* name = "";
      int valid = 0;
      sd_bus_message_read(r, "suby", &name, &p.cob_id, &valid, &p.type);
      p.name = name, p.valid = valid;
      sd_bus_message_enter_container(r, 'a', "(qyyssds)");
      while (sd_bus_message_at_end(r, 0) == 0) p.entries.push_back(read_entry(r));
      sd_bus_message_exit_container(r);
      sd_bus_message_exit_container(r);
      out.push_back(std::move(p));
    }
    sd_bus_message_unref(r);
    return out;
  }

  // A master's expedited SDO download of up to 4 bytes.
  void sdo_write(std::uint8_t node_id, std::uint16_t index, std::uint8_t sub, std::uint32_t value, int size) {
    CanFrame f{};
    f.id = 0x600 + node_id;
    f.dlc = 8;
    const std::uint8_t cmd = std::uint8_t(0x23 | ((4 - size) << 2));
    const std::uint8_t bytes[8] = {cmd, std::uint8_t(index), std::uint8_t(index >> 8), sub, std::uint8_t(value),
                                   std::uint8_t(value >> 8), std::uint8_t(value >> 16), std::uint8_t(value >> 24)};
    std::memcpy(f.data, bytes, 8);
    fleet.receive("vcan0", f);
    bus.pump();
  }

  int count_signals(const char* member, const std::string& path) {
    int n = 0;
    for (auto& [name, m] : bus.take_signals()) {
      if (name == member && path == sd_bus_message_get_path(m)) ++n;
      sd_bus_message_unref(m);
    }
    return n;
  }
};

TEST_F(ControlPdoMappingTest, GetPdoMappingGivesEachPdoWithTypedScaledEntries) {
  std::vector<Pdo> pdos = mapping("generic");
  ASSERT_EQ(pdos.size(), 5u);  // TPDO1-4, RPDO1
  EXPECT_EQ(pdos[0].name, "TPDO1");
  EXPECT_EQ(pdos[0].cob_id, 0x190u);
  EXPECT_TRUE(pdos[0].valid);
  EXPECT_EQ(pdos[0].type, 255);
  ASSERT_EQ(pdos[0].entries.size(), 2u);
  const Entry& pv = pdos[0].entries[0];
  EXPECT_EQ(pv.index, 0x6130);
  EXPECT_EQ(pv.sub, 1);
  EXPECT_EQ(pv.bits, 32);
  EXPECT_EQ(pv.type, "REAL32");
  EXPECT_EQ(pv.scale, 1.0);
  EXPECT_EQ(pv.unit, "bar");
  EXPECT_EQ(pdos[0].entries[1].type, "UNSIGNED8");
  EXPECT_EQ(pdos[0].entries[1].unit, "");  // status: no unit
  // TPDO2: the INTEGER16 PVs, value x 10^digits (0x6132: 2 for bar, 1 for degC).
  ASSERT_EQ(pdos[1].entries.size(), 2u);
  EXPECT_EQ(pdos[1].entries[0].type, "INTEGER16");
  EXPECT_DOUBLE_EQ(pdos[1].entries[0].scale, 0.01);
  EXPECT_EQ(pdos[1].entries[0].unit, "bar");
  EXPECT_DOUBLE_EQ(pdos[1].entries[1].scale, 0.1);
  EXPECT_EQ(pdos[1].entries[1].unit, "degC");
  EXPECT_FALSE(pdos[3].valid) << "TPDO4's COB-ID has bit 31 set";
  EXPECT_EQ(pdos[4].name, "RPDO1");
  EXPECT_EQ(pdos[4].cob_id, 0x210u);

  std::vector<Pdo> dps = mapping("dps");
  ASSERT_EQ(dps.size(), 1u);
  EXPECT_EQ(dps[0].cob_id, 0x1FFu);
  ASSERT_EQ(dps[0].entries.size(), 1u);
  EXPECT_EQ(dps[0].entries[0].type, "INTEGER32");
  EXPECT_DOUBLE_EQ(dps[0].entries[0].scale, 0.001);  // 0x6132 = 3
  EXPECT_EQ(dps[0].entries[0].unit, "psi");
}

TEST_F(ControlPdoMappingTest, ListObjectsNamesTypesAndUnitsEveryEntry) {
  sd_bus_message* r = bus.call(bus.node_call(path_of("generic"), "ListObjects"));
  ASSERT_NE(r, nullptr);
  ASSERT_GT(sd_bus_message_enter_container(r, 'a', "(qyssds)"), 0);
  std::map<int, Entry> by_address;  // index << 8 | sub
  std::uint16_t index;
  std::uint8_t sub;
  const char *name, *type, *unit;
  double scale;
  while (sd_bus_message_read(r, "(qyssds)", &index, &sub, &name, &type, &scale, &unit) > 0)
    by_address[index << 8 | sub] = Entry{index, sub, 0, name, type, scale, unit};
  sd_bus_message_unref(r);
  ASSERT_TRUE(by_address.count(0x101804));
  EXPECT_EQ(by_address[0x101804].type, "UNSIGNED32");
  EXPECT_EQ(by_address[0x101804].unit, "");
  EXPECT_EQ(by_address[0x613002].unit, "degC");
  EXPECT_EQ(by_address[0x913001].type, "INTEGER32");
  EXPECT_DOUBLE_EQ(by_address[0x913001].scale, 0.01);
  EXPECT_EQ(by_address[0x614901].unit, "bar");  // span end: a valued object
}

TEST_F(ControlPdoMappingTest, ListEmcyCodesGivesTheManualsMeanings) {
  auto codes = [&](const std::string& node) {
    std::map<int, std::string> out;
    sd_bus_message* r = bus.call(bus.node_call(path_of(node), "ListEmcyCodes"));
    if (!r) return out;
    std::uint16_t code = 0;
    const char* meaning = nullptr;
    EXPECT_GT(sd_bus_message_enter_container(r, 'a', "(qs)"), 0);
    while (sd_bus_message_read(r, "(qs)", &code, &meaning) > 0) out[code] = meaning;
    sd_bus_message_unref(r);
    return out;
  };
  const std::map<int, std::string> dps = codes("dps");
  EXPECT_EQ(dps.size(), 5u);
  EXPECT_EQ(dps.at(0x3201), "Over flow / under flow (PV outside the span)");
  EXPECT_TRUE(codes("generic").empty()) << "generic-404 names no codes of its own";
}

// A unit change (0x6131), a digits change (0x6132) and a mapping change by
// SDO each signal PdoMappingChanged, and GetPdoMapping then says what the
// PDOs carry now.
TEST_F(ControlPdoMappingTest, MappingUnitAndDigitsChangesAreSignalled) {
  sd_bus_message_unref(bus.call(bus.fleet_call("Subscribe")));
  const std::string path = path_of("generic");
  sdo_write(0x10, 0x6131, 1, 0xFD4E0000, 4);  // mbar
  EXPECT_EQ(count_signals("PdoMappingChanged", path), 1);
  EXPECT_EQ(mapping("generic")[0].entries[0].unit, "mbar");
  sdo_write(0x10, 0x6132, 1, 0, 1);
  EXPECT_EQ(count_signals("PdoMappingChanged", path), 1);
  EXPECT_DOUBLE_EQ(mapping("generic")[1].entries[0].scale, 1.0);
  // Remap TPDO1 to the temperature PV alone (CiA 301 §7.5.2.36 procedure).
  sdo_write(0x10, 0x1800, 1, 0x80000190, 4);
  sdo_write(0x10, 0x1A00, 0, 0, 1);
  sdo_write(0x10, 0x1A00, 1, 0x61300220, 4);
  sdo_write(0x10, 0x1A00, 0, 1, 1);
  sdo_write(0x10, 0x1800, 1, 0x190, 4);
  EXPECT_GE(count_signals("PdoMappingChanged", path), 3);
  std::vector<Pdo> now = mapping("generic");
  ASSERT_EQ(now[0].entries.size(), 1u);
  EXPECT_EQ(now[0].entries[0].sub, 2);
  EXPECT_EQ(now[0].entries[0].unit, "degC");
  EXPECT_TRUE(now[0].valid);
  // Nothing else signals it.
  sdo_write(0x10, 0x1017, 0, 100, 2);
  EXPECT_EQ(count_signals("PdoMappingChanged", path), 0);
}

}  // namespace
}  // namespace cansim::test
