// Node1.GetPdoMapping, ListObjects and the PdoMappingChanged signal (what the
// decoded bus monitor reads) over a real sd-bus peer connection on the fake
// clock: the PDOs as the engine runs them, with each mapped object's type,
// unit and scale, following SDO writes of the mapping, unit and digits.
#include <gtest/gtest.h>

#include <cmath>
#include <cstring>
#include <map>
#include <string_view>
#include <tuple>

#include "control/service.hpp"
#include "support/control_fleet.hpp"

namespace cansim::test {
namespace {

constexpr const char* kFleet = R"(
interfaces: {vcan0: {bit_rate: 250}}
nodes:
  - {profile: generic-404, interface: vcan0, node_id: 0x10, name: generic}
  - {profile: dps, interface: vcan0, bit_rate: 250, name: dps}
  - {profile: smc, interface: vcan0, bit_rate: 250, name: smc}
)";

constexpr TimeUs kMs = 1000;

struct Entry {
  std::uint16_t index;
  std::uint8_t sub, bits;
  std::string name, type;
  double scale;
  std::string unit;
  bool operator==(const Entry&) const = default;
};

struct Pdo {
  std::string name;
  std::uint32_t cob_id;
  bool valid;
  std::uint8_t type;
  std::vector<Entry> entries;
  bool operator==(const Pdo&) const = default;
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
    if (!r) return {};
    std::vector<Pdo> out = read_pdos(r);
    sd_bus_message_unref(r);
    return out;
  }

  // a(subya(qyyssds)) at the reader's position.
  static std::vector<Pdo> read_pdos(sd_bus_message* r) {
    std::vector<Pdo> out;
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
    sd_bus_message_exit_container(r);
    return out;
  }

  // A master's expedited SDO download of up to 4 bytes.
  void sdo_write(std::uint8_t node_id, std::uint16_t index, std::uint8_t sub, std::uint32_t value, int size) {
    CanFrame f{};
    f.id = 0x600 + node_id;
    f.dlc = 8;
    const std::uint8_t cmd = std::uint8_t(0x23 | ((4 - size) << 2));
    const std::uint8_t bytes[8] = {cmd,
                                   std::uint8_t(index),
                                   std::uint8_t(index >> 8),
                                   sub,
                                   std::uint8_t(value),
                                   std::uint8_t(value >> 8),
                                   std::uint8_t(value >> 16),
                                   std::uint8_t(value >> 24)};
    std::memcpy(f.data, bytes, 8);
    fleet.receive("vcan0", f);
    bus.pump();
  }

  struct Reading {
    double truth = NAN, reported = NAN, counts = NAN;
    std::string unit;
  };
  // Node1.Pressure and PressureCounts.
  Reading pressure(const std::string& node) {
    Reading out;
    for (const std::string_view prop : {"Pressure", "PressureCounts"}) {
      const bool counts = prop == "PressureCounts";
      sd_bus_message* m = nullptr;
      sd_bus_message_new_method_call(bus.client(), &m, nullptr, path_of(node).c_str(),
                                     "org.freedesktop.DBus.Properties", "Get");
      sd_bus_message_append(m, "ss", control::kNodeInterface, std::string(prop).c_str());
      sd_bus_message* r = bus.call(m);
      const char* unit = "";
      std::uint8_t status = 0;
      if (r && !counts && sd_bus_message_enter_container(r, 'v', "(ddsy)") > 0 &&
          sd_bus_message_read(r, "(ddsy)", &out.truth, &out.reported, &unit, &status) > 0)
        out.unit = unit;
      if (r && counts) {
        EXPECT_GT(sd_bus_message_read(r, "v", "d", &out.counts), 0);
      }
      if (r) sd_bus_message_unref(r);
    }
    return out;
  }

  using Scaling =
      std::map<int, std::tuple<double, double, std::string>>;  // (index << 8 | sub) -> (scale, offset, unit)

  // ListCountScaling.
  Scaling count_scaling(const std::string& node) {
    sd_bus_message* r = bus.call(bus.node_call(path_of(node), "ListCountScaling"));
    if (!r) return {};
    Scaling out = read_scaling(r);
    sd_bus_message_unref(r);
    return out;
  }

  // a(qydds) at the reader's position.
  static Scaling read_scaling(sd_bus_message* r) {
    Scaling out;
    EXPECT_GT(sd_bus_message_enter_container(r, 'a', "(qydds)"), 0);
    std::uint16_t index = 0;
    std::uint8_t sub = 0;
    double scale = 0, offset = 0;
    const char* unit = "";
    while (sd_bus_message_read(r, "(qydds)", &index, &sub, &scale, &offset, &unit) > 0)
      out[index << 8 | sub] = {scale, offset, unit};
    sd_bus_message_exit_container(r);
    return out;
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

// Fleet1.GetPdoMappings: the GetPdoMapping of every node of a bus in one
// call, with the ListCountScaling rows of the objects its PDOs map (the
// SMC's PVs in counts).
TEST_F(ControlPdoMappingTest, GetPdoMappingsGivesEveryNodesMappingAtOnce) {
  sd_bus_message* none = bus.fleet_call("GetPdoMappings");  // a bus without nodes: none
  sd_bus_message_append(none, "s", "vcan1");
  none = bus.call(none);
  ASSERT_NE(none, nullptr);
  ASSERT_GT(sd_bus_message_enter_container(none, 'a', "(sa(subya(qyyssds))a(qydds))"), 0);
  EXPECT_GT(sd_bus_message_at_end(none, 0), 0);
  sd_bus_message_unref(none);
  sd_bus_message* r = bus.fleet_call("GetPdoMappings");
  sd_bus_message_append(r, "s", "vcan0");
  r = bus.call(r);
  ASSERT_NE(r, nullptr);
  ASSERT_GT(sd_bus_message_enter_container(r, 'a', "(sa(subya(qyyssds))a(qydds))"), 0);
  std::map<std::string, std::vector<Pdo>> pdos;
  std::map<std::string, Scaling> scaling;
  while (sd_bus_message_enter_container(r, 'r', "sa(subya(qyyssds))a(qydds)") > 0) {
    const char* key = "";
    ASSERT_GT(sd_bus_message_read(r, "s", &key), 0);
    const std::string node = key;
    pdos[node] = read_pdos(r);
    scaling[node] = read_scaling(r);
    sd_bus_message_exit_container(r);
  }
  sd_bus_message_unref(r);
  ASSERT_EQ(pdos.size(), 3u);
  for (const char* node : {"vcan0/generic/0", "vcan0/dps/0", "vcan0/smc/0"}) {
    SCOPED_TRACE(node);
    ASSERT_TRUE(pdos.count(node));
    EXPECT_EQ(pdos[node], mapping(node));
    const auto all = count_scaling(node);
    for (const auto& [address, row] : scaling[node]) {
      ASSERT_TRUE(all.count(address)) << std::hex << address;
      EXPECT_EQ(all.at(address), row);
    }
  }
  EXPECT_TRUE(scaling["vcan0/generic/0"].empty());
  EXPECT_FALSE(scaling["vcan0/smc/0"].empty());  // its TPDO1 maps its PV, in counts
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
  const std::map<int, std::string> generic = codes("generic");
  EXPECT_EQ(generic.size(), 2u);  // its personality's sensor fault and range EMCYs
  EXPECT_TRUE(generic.count(0x5030) && generic.count(0xF001));
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

// The SMC reports field counts (0..20000 over its 0..5 bar, -55..125 degC
// ranges; manual §6.2.3: 0x6131 changes no calculation): its PV objects say
// counts, ListCountScaling what they mean with its own scaling, Pressure
// the engineering value beside PressureCounts. Scaled to its unit (PV1 0,
// PV2 5 bar: 0x6121 / 0x6123), the PV is in bar and says so, signalled.
TEST_F(ControlPdoMappingTest, ADeviceInCountsSaysCountsAndWhatTheyMean) {
  fleet.run_until(300 * kMs);  // the SMC boots 150 ms after power-on (its SDO server with it)
  bus.pump();
  const Entry pv = mapping("smc")[0].entries[0];
  EXPECT_EQ(pv.index, 0x6130);
  EXPECT_EQ(pv.unit, "counts");
  EXPECT_DOUBLE_EQ(pv.scale, 1.0);
  auto scaling = count_scaling("smc");
  ASSERT_TRUE(scaling.count(0x613001) && scaling.count(0x613002));
  EXPECT_NEAR(std::get<0>(scaling[0x613001]), 5.0 / 20000, 1e-12);
  EXPECT_NEAR(std::get<1>(scaling[0x613001]), 0.0, 1e-9);
  EXPECT_EQ(std::get<2>(scaling[0x613001]), "bar");
  EXPECT_NEAR(std::get<0>(scaling[0x613002]), 180.0 / 20000, 1e-12);
  EXPECT_NEAR(std::get<1>(scaling[0x613002]), -55.0, 1e-9);
  EXPECT_EQ(std::get<2>(scaling[0x613002]), "degC");
  EXPECT_TRUE(count_scaling("generic").empty());

  Reading p = pressure("smc");
  EXPECT_EQ(p.unit, "bar");
  EXPECT_NEAR(p.reported, p.truth, 0.01) << "the reported value compares with the true one";
  EXPECT_NEAR(p.counts, p.reported / (5.0 / 20000), 1e-3);
  EXPECT_TRUE(std::isnan(pressure("generic").counts));

  sd_bus_message_unref(bus.call(bus.fleet_call("Subscribe")));
  const std::string path = path_of("smc");
  sdo_write(0x20, 0x6121, 1, 0x00000000, 4);  // PV at FV 0: 0.0f
  sdo_write(0x20, 0x6123, 1, 0x40A00000, 4);  // PV at FV 20000: 5.0f
  fleet.run_until(fleet.now() + 20 * kMs);
  bus.pump();
  EXPECT_GE(count_signals("PdoMappingChanged", path), 1);
  EXPECT_EQ(mapping("smc")[0].entries[0].unit, "bar");
  EXPECT_FALSE(count_scaling("smc").count(0x613001));
  p = pressure("smc");
  EXPECT_TRUE(std::isnan(p.counts));
  EXPECT_NEAR(p.reported, p.truth, 0.01);
}

}  // namespace
}  // namespace cansim::test
