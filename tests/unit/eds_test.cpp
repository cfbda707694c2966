// CiA 306 EDS / DCF: every shipped profile exports and reads back to the same
// object dictionary; the reader takes the messy forms real files use and
// rejects the ambiguous with file:line; a DCF's ParameterValue wins; nodes
// built from an exported EDS answer SDO uploads as the YAML-built ones do.
#include <unistd.h>

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <cmath>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <optional>
#include <sstream>

#include "config/eds_reader.hpp"
#include "config/fleet.hpp"
#include "config/eds_writer.hpp"
#include "daemon/daemon.hpp"
#include "personalities/registry.hpp"
#include "support/sim.hpp"

namespace cansim::test {
namespace {

using ::testing::HasSubstr;

const char* const kProfiles[] = {"cmp", "dps", "gems9000", "generic-404", "p92c", "smc"};

std::string export_eds(const config::Profile& p) {
  return config::write_eds(*p.layout, *p.options, config::identity_of(p));
}

config::Profile eds_profile(const std::string& text, const std::string& file = "t.eds", bool strict_eds = false) {
  return config::profile_from_eds(config::parse_eds(text, file), false, strict_eds);
}

std::string eds_error(const std::string& text, const std::string& file = "bad.eds", bool strict_eds = false) {
  try {
    eds_profile(text, file, strict_eds);
  } catch (const config::ConfigError& e) {
    return e.what();
  }
  return "no error";
}

// The bytes a node of this entry answers at its default.
std::vector<std::uint8_t> answered_default(const OdEntry& e) {
  std::vector<std::uint8_t> d = e.default_bytes;
  if (is_variable_size(e.type) && d.size() > e.capacity) d.resize(e.capacity);
  return d;
}

// ---------------------------------------------------------------- round trip

class EdsRoundTrip : public ::testing::TestWithParam<const char*> {};

TEST_P(EdsRoundTrip, ExportReadsBackEntryByEntry) {
  const config::Profile yaml = load_repo_profile(GetParam());
  const config::Profile eds = eds_profile(export_eds(yaml), std::string(GetParam()) + ".eds");
  const auto a = yaml.layout->entries();
  const auto b = eds.layout->entries();
  ASSERT_EQ(a.size(), b.size());
  for (std::size_t i = 0; i < a.size(); ++i) {
    SCOPED_TRACE(::testing::Message() << std::hex << a[i].index << "sub" << int(a[i].sub));
    EXPECT_EQ(a[i].index, b[i].index);
    EXPECT_EQ(a[i].sub, b[i].sub);
    EXPECT_EQ(a[i].type, b[i].type);
    EXPECT_EQ(a[i].access, b[i].access);
    EXPECT_EQ(answered_default(a[i]), b[i].default_bytes);
    EXPECT_EQ(a[i].default_plus_node_id, b[i].default_plus_node_id);
    EXPECT_EQ(a[i].pdo_mappable, b[i].pdo_mappable);
    EXPECT_EQ(a[i].has_low, b[i].has_low);
    EXPECT_EQ(a[i].has_high, b[i].has_high);
    const std::size_t n = type_size(a[i].type);
    if (a[i].has_low) {
      EXPECT_EQ(0, std::memcmp(a[i].low, b[i].low, n));
    }
    if (a[i].has_high) {
      EXPECT_EQ(0, std::memcmp(a[i].high, b[i].high, n));
    }
  }
  EXPECT_EQ(eds.personality, "generic");
  EXPECT_EQ(eds.options->lss_supported, yaml.options->lss_supported);
  EXPECT_EQ(eds.options->rpdo_dummy_mapping, yaml.options->rpdo_dummy_mapping);
}

TEST_P(EdsRoundTrip, DefaultDcfReadsBackWithItsNodeIdAndRate) {
  const config::Profile yaml = load_repo_profile(GetParam());
  const config::Profile dcf = eds_profile(config::write_default_dcf(yaml, 0x22), "x.dcf");
  EXPECT_EQ(dcf.node_id, 0x22);
  EXPECT_EQ(dcf.bit_rate_kbit, yaml.bit_rate_kbit);
  ASSERT_EQ(dcf.layout->entries().size(), yaml.layout->entries().size());
  OdValues a(yaml.layout), b(dcf.layout);
  a.reset(0x22);
  b.reset(0x22);
  for (const OdEntry& e : yaml.layout->entries()) {
    const OdEntry* f = dcf.layout->find(e.index, e.sub);
    ASSERT_TRUE(f);
    const auto x = a.bytes(e), y = b.bytes(*f);
    EXPECT_EQ(std::vector<std::uint8_t>(x.begin(), x.end()), std::vector<std::uint8_t>(y.begin(), y.end()))
        << std::hex << e.index << "sub" << int(e.sub);
  }
}

INSTANTIATE_TEST_SUITE_P(Profiles, EdsRoundTrip, ::testing::ValuesIn(kProfiles), [](const auto& info) {
  std::string n = info.param;
  for (char& c : n)
    if (c == '-') c = '_';
  return n;
});

TEST(EdsExport, DescribesTheDeviceAndItsObjects) {
  const std::string text = export_eds(load_repo_profile("generic-404"));
  for (const char* line : {"[FileInfo]", "EDSVersion=4.0", "VendorNumber=0x00CA5D00", "ProductNumber=0x00000404",
                           "RevisionNumber=0x00010000", "BaudRate_250=1", "LSS_Supported=1", "SimpleBootUpSlave=1",
                           "Granularity=1", "NrOfRXPDO=1", "NrOfTXPDO=4", "[DummyUsage]", "[Comments]",
                           "[MandatoryObjects]\nSupportedObjects=3\n1=0x1000\n2=0x1001\n3=0x1018", "[1018sub1]",
                           "[1A00sub8]", "DefaultValue=$NODEID+0x180", "PDOMapping=1", "[ManufacturerObjects]"})
    EXPECT_THAT(text, HasSubstr(line));
  EXPECT_THAT(text, ::testing::Not(HasSubstr("[DeviceComissioning]")));
  EXPECT_THAT(text, ::testing::Not(HasSubstr("ParameterValue")));
}

TEST(EdsExport, AnObjectTheDeviceLacksIsNotInItsEds) {
  const std::string dps = export_eds(load_repo_profile("dps"));
  const config::Profile p = load_repo_profile("dps");
  for (std::uint16_t index : {0x1003, 0x1016, 0x1029, 0x6130, 0x9130})
    if (!p.layout->object(index)) {
      char section[16];
      std::snprintf(section, sizeof section, "\n[%04X]", index);
      EXPECT_THAT(dps, ::testing::Not(HasSubstr(section)));
    }
}

TEST(EdsExport, BitRatesFollowLssOption) {
  config::Profile p = load_repo_profile("generic-404");
  auto options = std::make_shared<NodeOptions>(*p.options);
  ASSERT_TRUE(ByteSet::parse("3-4", options->lss_bit_rates));
  p.options = options;
  const std::string text = export_eds(p);
  EXPECT_THAT(text, HasSubstr("BaudRate_125=1\nBaudRate_250=1\nBaudRate_500=0"));
  EXPECT_THAT(text, HasSubstr("BaudRate_10=0"));
  const config::Profile back = eds_profile(text);
  EXPECT_EQ(back.options->lss_bit_rates.text(), "3-4");
  EXPECT_EQ(back.bit_rate_kbit, 250u);
}

// ---------------------------------------------------------------- messy files

// A minimal EDS around `objects` (sections text).
std::string eds(const std::string& objects, const std::string& device_info = "") {
  return "[DeviceInfo]\nVendorNumber=\n" + device_info + "\n" + objects;
}

std::uint64_t default_u(const config::Profile& p, std::uint16_t index, std::uint8_t sub) {
  const OdEntry* e = p.layout->find(index, sub);
  EXPECT_TRUE(e) << std::hex << index << "sub" << int(sub);
  return e ? decode_u(e->type, e->default_bytes.data()) : 0;
}

TEST(EdsReader, NodeIdInEverySpelling) {
  const config::Profile p =
      eds_profile(eds("[1400]\nObjectType=0x9\nSubNumber=4\n"
                      "[1400sub0]\nDataType=0x0005\nAccessType=ro\nDefaultValue=3\n"
                      "[1400sub1]\nDataType=0x0007\nAccessType=rw\nDefaultValue=$NODEID+0x200\n"
                      "[1400sub2]\nDataType=0x0007\nAccessType=rw\nDefaultValue=0x200+$NODEID\n"
                      "[1400sub3]\nDataType=0x0007\nAccessType=rw\nDefaultValue=$NodeID + 0x200\n"));
  for (std::uint8_t sub = 1; sub <= 3; ++sub) {
    EXPECT_EQ(default_u(p, 0x1400, sub), 0x200u);
    EXPECT_TRUE(p.layout->find(0x1400, sub)->default_plus_node_id);
  }
}

TEST(EdsReader, CaseSpacesCommentsCrlfAndBom) {
  const config::Profile p = eds_profile(
      "\xEF\xBB\xBF; written by hand\r\n[ deviceinfo ]\r\nLSS_Supported = 0\r\n# another comment\r\n"
      "[1017]\r\n  parametername = Producer heartbeat time \r\nDATATYPE=0x0006\r\naccess type=RW\r\n"
      "Default Value=1000\r\nPdoMapping=0\r\n");
  const OdEntry* e = p.layout->find(0x1017, 0);
  ASSERT_TRUE(e);
  EXPECT_EQ(e->name, "Producer heartbeat time");
  EXPECT_EQ(e->type, DataType::kUnsigned16);
  EXPECT_EQ(e->access, Access::kRw);
  EXPECT_EQ(default_u(p, 0x1017, 0), 1000u);
  EXPECT_FALSE(p.options->lss_supported);
}

TEST(EdsReader, DecimalHexAndOctalNumbers) {
  const config::Profile p =
      eds_profile(eds("[2000]\nDataType=0x0007\nAccessType=rw\nDefaultValue=010\nLowLimit=0x2\nHighLimit=100\n"
                      "[2001]\nDataType=0x0003\nAccessType=rw\nDefaultValue=0xFFFF\nLowLimit=-100\n"
                      "[2002]\nDataType=0x0008\nAccessType=rw\nDefaultValue=1.5\n"));
  EXPECT_EQ(default_u(p, 0x2000, 0), 8u);  // CiA 306 §4.2: a leading 0 is octal
  const OdEntry* e = p.layout->find(0x2000, 0);
  EXPECT_EQ(decode_u(e->type, e->low), 2u);
  EXPECT_EQ(decode_u(e->type, e->high), 100u);
  const OdEntry* s = p.layout->find(0x2001, 0);
  EXPECT_EQ(decode_i(s->type, s->default_bytes.data()), -1);  // hex gives the INTEGER16 bit pattern
  EXPECT_EQ(decode_i(s->type, s->low), -100);
  EXPECT_FLOAT_EQ(float(decode_f(DataType::kReal32, p.layout->find(0x2002, 0)->default_bytes.data())), 1.5f);
}

TEST(EdsReader, EmptyNumericFieldsAndDomainWithoutDefault) {
  const config::Profile p =
      eds_profile(eds("[1000]\nDataType=0x0007\nAccessType=ro\nDefaultValue=\nLowLimit=\nHighLimit=\nPDOMapping=\n"
                      "[2001]\nDataType=0x000F\nAccessType=rw\n"));
  EXPECT_EQ(default_u(p, 0x1000, 0), 0u);
  EXPECT_FALSE(p.layout->find(0x1000, 0)->has_low);
  EXPECT_TRUE(p.layout->find(0x2001, 0)->default_bytes.empty());
  EXPECT_EQ(p.layout->find(0x2001, 0)->type, DataType::kDomain);
}

TEST(EdsReader, CompactSubObjWithNamesAndValuesAndObjFlags) {
  const config::Profile p =
      eds_profile(eds("[1016]\nParameterName=Consumer heartbeat time\nObjectType=0x8\nDataType=0x0007\nAccessType=rw\n"
                      "CompactSubObj=3\nDefaultValue=0\nObjFlags=0x1\n"
                      "[1016Name]\nNrOfEntries=1\n2=Heartbeat of node 5\n"
                      "[1016Value]\nNrOfEntries=1\n2=0x000501F4\n"));
  EXPECT_EQ(default_u(p, 0x1016, 0), 3u);
  EXPECT_EQ(p.layout->find(0x1016, 0)->access, Access::kRo);
  EXPECT_EQ(default_u(p, 0x1016, 1), 0u);
  EXPECT_EQ(default_u(p, 0x1016, 2), 0x000501F4u);
  EXPECT_EQ(p.layout->find(0x1016, 2)->name, "Heartbeat of node 5");
  EXPECT_EQ(p.layout->find(0x1016, 3)->access, Access::kRw);
  EXPECT_EQ(p.layout->find(0x1016, 3)->kind, ObjectKind::kArray);
}

TEST(EdsReader, DcfParameterValueWinsOverDefaultValue) {
  const config::Profile p =
      eds_profile(eds("[1017]\nDataType=0x0006\nAccessType=rw\nDefaultValue=1000\nParameterValue=250\n"
                      "[1800]\nObjectType=0x9\nSubNumber=2\n[1800sub0]\nDataType=0x5\nAccessType=ro\nDefaultValue=1\n"
                      "[1800sub1]\nDataType=0x7\nAccessType=rw\nDefaultValue=$NODEID+0x180\nParameterValue=0x185\n"
                      "[DeviceComissioning]\nNodeID=5\nBaudrate=125\nNodeName=sensor\n"),
                  "node.dcf");
  EXPECT_EQ(default_u(p, 0x1017, 0), 250u);
  EXPECT_EQ(default_u(p, 0x1800, 1), 0x185u);
  EXPECT_FALSE(p.layout->find(0x1800, 1)->default_plus_node_id);
  EXPECT_EQ(p.node_id, 5);
  EXPECT_EQ(p.bit_rate_kbit, 125u);
  EXPECT_EQ(p.name, "node");
}

TEST(EdsReader, DeviceInfoGivesLssBitRatesAndDummies) {
  const config::Profile p =
      eds_profile(eds("[1000]\nDataType=0x7\nAccessType=ro\n[DummyUsage]\nDummy0001=0\nDummy0002=0\n",
                      "LSS_Supported=1\nBaudRate_125=1\nBaudRate_500=1\nBaudRate_250=0\n"));
  EXPECT_TRUE(p.options->lss_supported);
  EXPECT_EQ(p.options->lss_bit_rates.text(), "2,4");
  EXPECT_EQ(p.bit_rate_kbit, 125u);  // no 250: the first rate the file lists
  EXPECT_FALSE(p.options->rpdo_dummy_mapping);
}

TEST(EdsReader, PersistenceGroupsByRange) {
  const config::Profile p = eds_profile(
      eds("[1017]\nDataType=0x6\nAccessType=rw\n[2000]\nDataType=0x7\nAccessType=rww\n"
          "[2001]\nDataType=0x7\nAccessType=wo\n[1010]\nObjectType=0x8\nSubNumber=2\n"
          "[1010sub0]\nDataType=0x5\nAccessType=ro\nDefaultValue=1\n[1010sub1]\nDataType=0x7\nAccessType=rw\n"));
  EXPECT_EQ(p.layout->find(0x1017, 0)->persist, kPersistCommunication);
  EXPECT_EQ(p.layout->find(0x2000, 0)->persist, kPersistApplication);
  EXPECT_EQ(p.layout->find(0x2001, 0)->persist, kPersistNone);
  EXPECT_EQ(p.layout->find(0x1010, 1)->persist, kPersistNone);
}

// ---------------------------------------------------------------- rejections

TEST(EdsReader, RejectsTheAmbiguousWithFileAndLine) {
  struct Case {
    std::string text;
    std::string message;
  } cases[] = {
      {"[1000]\nDataType=0x7\nAccessType=ro\nDefaultValue=08\n",
       "bad.eds:4: [1000] DefaultValue: expected an integer, optionally plus $NODEID (e.g. $NODEID+0x180), got '08'"},
      {"[1000]\nDataType=0x7\nAccessType=rx\n",
       "bad.eds:3: [1000] AccessType: expected one of ro, wo, rw, rwr, rww, const, got 'rx'"},
      {"[1000]\nAccessType=ro\n", "bad.eds:1: [1000] DataType: missing required key"},
      {"[1000]\nDataType=0x0C\nAccessType=ro\n", "bad.eds:2: [1000] DataType: expected a CiA 301 basic data type"},
      {"[1000]\nDataType=0x5\nAccessType=ro\nDefaultValue=256\n",
       "bad.eds:4: [1000] DefaultValue: expected a value in the range of UNSIGNED8, got '256'"},
      {"[1000]\nDataType=0x7\nAccessType=ro\nDefaultValue=$NODEID+$NODEID\n",
       "bad.eds:4: [1000] DefaultValue: expected an integer"},
      {"[1000]\nDataType=0x7\nDataType=0x5\n",
       "bad.eds:3: [1000] DataType: expected each key once per section (first at line 2)"},
      {"[1000]\nDataType=0x7\nAccessType=ro\n[1000]\n",
       "bad.eds:4: [1000]: expected each section once (first at line 1)"},
      {"DataType=0x7\n",
       "bad.eds:1: (before the first section): expected a [section] before any key, got 'DataType=0x7'"},
      {"[1000]\nDataType 0x7\n", "bad.eds:2: [1000]: expected [section], key=value or a ; comment, got 'DataType 0x7'"},
      {"[1000\n", "bad.eds:1: (before the first section): expected a section header [name], got '[1000'"},
      {"[1018sub1]\nDataType=0x7\nAccessType=ro\n",
       "bad.eds:1: [1018sub1]: expected an object section [1018] for this sub-object"},
      {"[1018]\nObjectType=0x4\n", "bad.eds:2: [1018] ObjectType: expected ObjectType 0x7 (VAR)"},
      {"[1017]\nDataType=0x6\nAccessType=rw\n[1017sub1]\nDataType=0x6\nAccessType=rw\n",
       "bad.eds:4: [1017sub1]: expected no sub-object sections for a VAR object"},
      {"[1000x]\n", "bad.eds:1: [1000x]: expected an object section [xxxx], [xxxxsubN], [xxxxName] or [xxxxValue]"},
      {"[1000]\nDataType=0x7\nAccessType=ro\nPDOMapping=yes please\n",
       "bad.eds:4: [1000] PDOMapping: expected 0 or 1, got 'yes please'"},
      {"[1016]\nObjectType=0x8\nSubNumber=1\n[1016sub0]\nDataType=0x5\nAccessType=ro\n[1016Name]\n1=x\n",
       "bad.eds:7: [1016Name]: expected CompactSubObj in [1016] for this section"},
      {"[1000]\nDataType=0x7\nAccessType=ro\n[DeviceComissioning]\nNodeID=200\n",
       "bad.eds:5: [DeviceComissioning] NodeID: expected a node-ID 1..127 or 255 (LSS-unconfigured), got '200'"},
      {"[2000]\nDataType=0x9\nAccessType=ro\nLowLimit=1\n",
       "bad.eds:4: [2000] LowLimit: expected no limit for VISIBLE_STRING, got '1'"},
      {"[2000]\nDataType=0xA\nAccessType=ro\nDefaultValue=ABC\n",
       "bad.eds:4: [2000] DefaultValue: expected hex bytes, e.g. 0A1B2C, got 'ABC'"},
      {"[FileInfo]\n", "bad.eds:1: (top level): expected at least one object section [xxxx]"},
      {std::string("[1000\x01]\n"), "bad.eds:1: [1000\\x01]: expected an object section [xxxx]"},
      {"[2000]\nDataType=0x8\nAccessType=ro\nDefaultValue=1e39\n",
       "bad.eds:4: [2000] DefaultValue: expected a number in the range of REAL32, got '1e39'"},
      {"[2000]\nDataType=0x1B\nAccessType=ro\nDefaultValue=0x7FFFFFFFFFFFFFFF+0x7FFFFFFFFFFFFFFF\n",
       "bad.eds:4: [2000] DefaultValue: expected an integer"},
  };
  for (const Case& c : cases) EXPECT_THAT(eds_error(c.text), HasSubstr(c.message)) << c.text;
}

// ---------------------------------------------------------------- nodes

struct Upload {
  std::uint32_t abort = 0;
  std::vector<std::uint8_t> data;
  bool operator==(const Upload&) const = default;
};
void PrintTo(const Upload& u, std::ostream* os) {
  *os << "abort " << std::hex << u.abort << " data";
  for (std::uint8_t b : u.data) *os << ' ' << int(b);
}

// A master's SDO upload, expedited or segmented.
Upload upload(SimBus& bus, std::uint8_t id, const OdEntry& e) {
  const std::uint32_t rx = 0x600u + id, tx = 0x580u + id;
  auto ask = [&](CanFrame request) {
    request.dlc = 8;
    bus.take();
    bus.inject(request);
    bus.run_for(ms(1));
    for (const Sent& s : bus.take())
      if (s.frame.id == tx) return s.frame;
    ADD_FAILURE() << "no SDO answer for " << std::hex << e.index << "sub" << int(e.sub);
    return CanFrame{};
  };
  const auto lo = std::uint8_t(e.index), hi = std::uint8_t(e.index >> 8);
  CanFrame r = ask(F(rx, {0x40, lo, hi, e.sub, 0, 0, 0, 0}));
  Upload u;
  if (r.data[0] == 0x80) {
    u.abort = std::uint32_t(r.data[4] | r.data[5] << 8 | r.data[6] << 16 | std::uint32_t(r.data[7]) << 24);
    return u;
  }
  if (r.data[0] & 0x02) {  // expedited
    const int n = (r.data[0] & 0x01) ? 4 - ((r.data[0] >> 2) & 3) : 4;
    u.data.assign(r.data + 4, r.data + 4 + n);
    return u;
  }
  for (std::uint8_t toggle = 0;; toggle ^= 0x10) {
    r = ask(F(rx, {std::uint8_t(0x60 | toggle), 0, 0, 0, 0, 0, 0, 0}));
    if (r.data[0] == 0x80 || u.data.size() > 70000) return Upload{1, {}};
    const int n = 7 - ((r.data[0] >> 1) & 7);
    u.data.insert(u.data.end(), r.data + 1, r.data + 1 + n);
    if (r.data[0] & 0x01) return u;
  }
}

// The uploads of every object of a core node (no application) of `p`.
std::vector<Upload> uploads(const config::Profile& p, std::uint8_t id) {
  SimBus bus;
  bus.add(p, id);
  bus.power_on_all();
  bus.run_for(ms(500));  // past any boot_up_delay_ms
  std::vector<Upload> out;
  for (const OdEntry& e : p.layout->entries()) out.push_back(upload(bus, id, e));
  return out;
}

// ---------------------------------------------------------------- what masters tolerate

// A flag in any CiA 306 number form, as every number.
TEST(EdsTolerant, FlagsInAnyNumberForm) {
  const config::Profile p = eds_profile(
      eds("[2000]\nDataType=0x7\nAccessType=rw\nPDOMapping=0x1\n[2001]\nDataType=0x7\nAccessType=rw\nPDOMapping=0x0\n"
          "[2002]\nDataType=0x7\nAccessType=rw\nPDOMapping=01\n[2003]\nDataType=0x7\nAccessType=rw\nPDOMapping=TRUE\n"
          "[DummyUsage]\nDummy0005=0x1\n",
          "LSS_Supported=0x1\nBaudRate_500=0x1\nBaudRate_250=0x0\n"));
  EXPECT_TRUE(p.layout->find(0x2000, 0)->pdo_mappable);
  EXPECT_FALSE(p.layout->find(0x2001, 0)->pdo_mappable);
  EXPECT_TRUE(p.layout->find(0x2002, 0)->pdo_mappable);
  EXPECT_TRUE(p.layout->find(0x2003, 0)->pdo_mappable);
  EXPECT_TRUE(p.options->lss_supported);
  EXPECT_EQ(p.options->lss_bit_rates.text(), "2");
  EXPECT_EQ(p.bit_rate_kbit, 500u);
  EXPECT_TRUE(p.options->rpdo_dummy_mapping);
  EXPECT_TRUE(p.warnings.empty());
  EXPECT_THAT(eds_error("[1000]\nDataType=0x7\nAccessType=ro\nPDOMapping=0x2\n"),
              HasSubstr("bad.eds:4: [1000] PDOMapping: expected 0 or 1, got '0x2'"));
}

// "ParameterValue=" (CANopenEditor's unset value) is not
// given: DefaultValue counts, $NODEID included; "2=" in [xxxxValue] too.
TEST(EdsTolerant, EmptyKeysAreNotGiven) {
  const config::Profile p =
      eds_profile(eds("[1017]\nDataType=0x0006\nAccessType=rw\nDefaultValue=1000\nParameterValue=\n"
                      "[1008]\nDataType=0x0009\nAccessType=const\nDefaultValue=Gripper GX-2\nParameterValue=\n"
                      "[1014]\nDataType=0x0007\nAccessType=rw\nDefaultValue=$NODEID+0x80\nParameterValue=\n"
                      "[1015]\nDataType=0x0006\nAccessType=rw\nDefaultValue=\nParameterValue=\n"
                      "[1016]\nObjectType=0x8\nDataType=0x0007\nAccessType=rw\nCompactSubObj=2\nDefaultValue=0x10064\n"
                      "[1016Value]\nNrOfEntries=2\n2=\n0x1=0x50064\n"
                      "[DeviceComissioning]\nNodeID=\nBaudrate=\n"),
                  "editor.dcf");
  EXPECT_EQ(default_u(p, 0x1017, 0), 1000u);
  const auto& name = p.layout->find(0x1008, 0)->default_bytes;
  EXPECT_EQ(std::string(name.begin(), name.end()), "Gripper GX-2");
  EXPECT_EQ(default_u(p, 0x1014, 0), 0x80u);
  EXPECT_TRUE(p.layout->find(0x1014, 0)->default_plus_node_id);
  EXPECT_EQ(default_u(p, 0x1015, 0), 0u);
  EXPECT_EQ(default_u(p, 0x1016, 2), 0x10064u);
  EXPECT_EQ(default_u(p, 0x1016, 1), 0x50064u);  // "0x1=": sub 1 in hex
  EXPECT_EQ(p.node_id, 1);
  EXPECT_TRUE(p.warnings.empty());
}

const char* const kSdoServer =
    "[1200]\nObjectType=0x9\nSubNumber=3\n"
    "[1200sub0]\nDataType=0x0005\nAccessType=ro\nDefaultValue=2\n"
    "[1200sub1]\nDataType=0x0007\nAccessType=ro\nDefaultValue=%s\nParameterValue=%s\n"
    "[1200sub2]\nDataType=0x0007\nAccessType=ro\nDefaultValue=%s\nParameterValue=%s\n";

std::string sdo_server(const char* rx, const char* rx_pv, const char* tx, const char* tx_pv) {
  char buf[512];
  std::snprintf(buf, sizeof buf, kSdoServer, rx, rx_pv, tx, tx_pv);
  return buf;
}

// CiA 301 fixes the default SDO server at 600h / 580h +
// node-ID. Line 14 is [1200sub1] DefaultValue, 15 its ParameterValue.
TEST(EdsTolerant, DefaultSdoServerAtItsPredefinedCobIds) {
  struct Case {
    std::string text;
    std::string warning;  // empty: none
  } cases[] = {
      {sdo_server("$NODEID+0x600", "", "$NODEID+0x580", ""), ""},
      {sdo_server("0x610", "", "0x590", ""),
       "t.dcf:14: [1200sub1] DefaultValue: expected $NODEID+0x600 (the default SDO server's COB-ID), got '0x610'; "
       "the node uses 0x600 + its node-ID (and 1 more like it in this file)"},
      {sdo_server("$NODEID+0x600", "0x620", "$NODEID+0x580", ""),
       "t.dcf:15: [1200sub1] ParameterValue: expected $NODEID+0x600 (the default SDO server's COB-ID), got '0x620'; "
       "the node uses 0x600 + its node-ID"},
      {sdo_server("0x80000000", "", "0x80000000", ""),
       "t.dcf:14: [1200sub1] DefaultValue: expected $NODEID+0x600 (the default SDO server's COB-ID), got '0x80000000'; "
       "the node uses 0x600 + its node-ID (and 1 more like it in this file)"},
      // A DCF's own node: 0x605 is 600h + its NodeID.
      {sdo_server("$NODEID+0x600", "0x605", "$NODEID+0x580", "0x585") + "[DeviceComissioning]\nNodeID=5\n", ""},
  };
  for (const Case& c : cases) {
    SCOPED_TRACE(c.text);
    const config::Profile p = eds_profile("[DeviceInfo]\nProductName=x\n\n" + c.text, "t.dcf");
    if (c.warning.empty()) EXPECT_THAT(p.warnings, ::testing::IsEmpty());
    else EXPECT_THAT(p.warnings, ::testing::ElementsAre(c.warning));
    for (std::uint8_t sub : {1, 2}) {
      EXPECT_TRUE(p.layout->find(0x1200, sub)->default_plus_node_id);
      EXPECT_EQ(default_u(p, 0x1200, sub), sub == 1 ? 0x600u : 0x580u);
    }
    // Reachable at any node-ID: 0x1200:01 read back through 0x605 -> 0x585.
    SimBus bus;
    bus.add(p, 5);
    bus.power_on_all();
    bus.run_for(ms(10));
    const Upload u = upload(bus, 5, *p.layout->find(0x1200, 1));
    EXPECT_EQ(u.data, (std::vector<std::uint8_t>{0x05, 0x06, 0, 0}));
  }
}

// DOMAIN "0", NodeID=0 / Baudrate=0 (not set).
TEST(EdsTolerant, DomainZeroAndUnsetCommissioning) {
  const config::Profile p = eds_profile(eds("[1F50]\nDataType=0x000F\nAccessType=rw\nDefaultValue=0\n"
                                            "[2000]\nDataType=0x000F\nAccessType=rw\nDefaultValue=0x0\n"
                                            "[DeviceComissioning]\nNodeID=0\nNodeName=\nBaudrate=0\nNetNumber=0\n",
                                            "BaudRate_125=1\n"),
                                        "editor.dcf");
  EXPECT_TRUE(p.layout->find(0x1F50, 0)->default_bytes.empty());
  EXPECT_TRUE(p.layout->find(0x2000, 0)->default_bytes.empty());
  EXPECT_EQ(p.node_id, 1);
  EXPECT_EQ(p.bit_rate_kbit, 125u);  // from [DeviceInfo]
  EXPECT_THAT(p.warnings,
              ::testing::ElementsAre(
                  "editor.dcf:8: [1F50] DefaultValue: expected hex bytes, e.g. 0A1B2C, got '0'; read as an empty "
                  "DOMAIN (and 1 more like it in this file)",
                  "editor.dcf:14: [DeviceComissioning] NodeID: expected a node-ID 1..127 or 255 (LSS-unconfigured), "
                  "got '0'; taken as not set (node-ID 1) (and 1 more like it in this file)"));
}

// What every master tolerates.
TEST(EdsTolerant, InconsistenciesLoadWithOneWarningEach) {
  const std::string text =
      "[MandatoryObjects]\nSupportedObjects=3\n1=0x1000\n2=0x1001\n"    // lines 2-5
      "[OptionalObjects]\nSupportedObjects=2\n1=0x1017\n2=0x1800\n"     // 6-9
      "[1000]\nDataType=0x7\nAccessType=ro\n"                           // 10-12
      "[1001]\nDataType=0x5\nAccessType=ro\n"                           // 13-15
      "[1018]\nObjectType=0x9\nSubNumber=5\n"                           // 16-18
      "[1018sub0]\nDataType=0x5\nAccessType=ro\nDefaultValue=1\n"       // 19-22
      "[1018sub1]\nDataType=0x7\nAccessType=ro\nDefaultValue=0x1234\n"  // 23-26
      "[6130]\nObjectType=0x8\nSubNumber=2\n"                           // 27-29
      "[6130sub0]\nDataType=0x5\nAccessType=ro\nDefaultValue=1\n"       // 30-33
      "[2100]\nDataType=0x8\nAccessType=rw\nDefaultValue=0x3e6b851f\n"  // 34-37
      "[2101]\nDataType=0x11\nAccessType=rw\nDefaultValue=0x3FF8000000000000\n"
      "[2102]\nDataType=0x7\nAccessType=rw\nLowLimit=$NODEID+0x180\nHighLimit=0x1FF\n";  // 42-46
  const config::Profile p = eds_profile("[DeviceInfo]\n" + text, "vendor.eds");
  EXPECT_EQ(default_u(p, 0x1018, 1), 0x1234u);
  EXPECT_FLOAT_EQ(float(decode_f(DataType::kReal32, p.layout->find(0x2100, 0)->default_bytes.data())), 0.23f);
  EXPECT_EQ(decode_f(DataType::kReal64, p.layout->find(0x2101, 0)->default_bytes.data()), 1.5);
  // Bits of a subnormal: exported in decimal, read back to the same bits.
  const config::Profile tiny = eds_profile(eds("[2000]\nDataType=0x11\nAccessType=rw\nDefaultValue=0x85\n"));
  const config::Profile back = eds_profile(export_eds(tiny));
  EXPECT_EQ(back.layout->find(0x2000, 0)->default_bytes, tiny.layout->find(0x2000, 0)->default_bytes);
  EXPECT_EQ(back.layout->find(0x2000, 0)->default_bytes, (std::vector<std::uint8_t>{0x85, 0, 0, 0, 0, 0, 0, 0}));
  EXPECT_FALSE(p.layout->find(0x2102, 0)->has_low);
  EXPECT_TRUE(p.layout->find(0x2102, 0)->has_high);
  EXPECT_THAT(
      p.warnings,
      ::testing::ElementsAre(
          "vendor.eds:3: [MandatoryObjects] SupportedObjects: expected the number of object keys (2), got '3'; the 2 "
          "keys are read",
          "vendor.eds:8: [OptionalObjects] 1: expected a section [1017] for this listed object, got '0x1017'; the "
          "entry is ignored (and 1 more like it in this file)",
          "vendor.eds:18: [1018] SubNumber: expected the number of [1018subN] sections (2), got '5'; the 2 sections "
          "are read (and 1 more like it in this file)",
          "vendor.eds:37: [2100] DefaultValue: expected a decimal floating-point number, got '0x3e6b851f'; read as the "
          "IEEE 754 bits of 0.230000004 (and 1 more like it in this file)",
          "vendor.eds:45: [2102] LowLimit: expected an integer, got '$NODEID+0x180'; the limit is not applied"));
}

// `cansimd --strict-eds`: each repair is the error it was before.
TEST(EdsTolerant, StrictEdsRefusesWhatItWouldRepair) {
  struct Case {
    std::string text;
    std::string message;
  } cases[] = {
      {"[1000]\nDataType=0x7\nAccessType=ro\nLowLimit=$NODEID+1\n",
       "bad.eds:4: [1000] LowLimit: expected an integer, got '$NODEID+1'"},
      {"[2000]\nDataType=0x8\nAccessType=ro\nDefaultValue=0x3F800000\n",
       "bad.eds:4: [2000] DefaultValue: expected a decimal floating-point number, got '0x3F800000'"},
      {"[1018]\nObjectType=0x9\nSubNumber=3\n[1018sub0]\nDataType=0x5\nAccessType=ro\n",
       "bad.eds:3: [1018] SubNumber: expected the number of [1018subN] sections (1), got '3'"},
      {"[OptionalObjects]\nSupportedObjects=1\n1=0x1017\n[1000]\nDataType=0x7\nAccessType=ro\n",
       "bad.eds:3: [OptionalObjects] 1: expected a section [1017] for this listed object, got '0x1017'"},
      {"[OptionalObjects]\nSupportedObjects=2\n1=0x1000\n[1000]\nDataType=0x7\nAccessType=ro\n",
       "bad.eds:2: [OptionalObjects] SupportedObjects: expected the number of object keys (1), got '2'"},
      {"[1000]\nDataType=0xF\nAccessType=ro\nDefaultValue=0\n", "bad.eds:4: [1000] DefaultValue: expected hex bytes"},
      {"[1000]\nDataType=0x7\nAccessType=ro\n[DeviceComissioning]\nBaudrate=0\n",
       "bad.eds:5: [DeviceComissioning] Baudrate: expected a CiA bit rate in kbit/s"},
      {sdo_server("0x610", "", "0x590", ""),
       "bad.eds:11: [1200sub1] DefaultValue: expected $NODEID+0x600 (the default SDO server's COB-ID), got '0x610'"},
  };
  for (const Case& c : cases) {
    EXPECT_THAT(eds_error(c.text, "bad.eds", true), HasSubstr(c.message)) << c.text;
    EXPECT_EQ(eds_error(c.text, "bad.eds", false), "no error") << c.text;
  }
}

// ---------------------------------------------------------------- foreign files

// Device descriptions as other tools and vendors write them (tests/data/eds,
// also seeds of eds_fuzz): a CANopenEditor DCF (every unset value an empty
// key, Baudrate=0, a DOMAIN "0"), a commercial editor's EDS (every number in
// hex, flags included) and a vendor's hand-written CiA 404 EDS (spaces, comments,
// miscounts, the SDO server written for node 1, a REAL as bits, $NODEID in
// a limit).
const char* const kForeignFiles[] = {"editor-gripper.dcf", "vector-drive.eds", "vendor-transmitter.eds"};

std::string foreign_file(const std::string& name) { return std::string(CANSIM_SOURCE_DIR) + "/tests/data/eds/" + name; }

// The entries as the npm package `canopen` reads the file
// (tests/master/eds_values.js); nullopt without node or the package.
std::optional<std::vector<std::string>> npm_reading(const std::string& path) {
  const std::string master = std::string(CANSIM_SOURCE_DIR) + "/tests/master";
  if (!std::filesystem::exists(master + "/node_modules/canopen")) return std::nullopt;
  const std::string command = "node '" + master + "/eds_values.js' '" + path + "' 2>&1";
  FILE* pipe = popen(command.c_str(), "r");
  if (!pipe) return std::nullopt;
  std::vector<std::string> lines;
  char buf[4096];
  while (std::fgets(buf, sizeof buf, pipe)) {
    std::string l(buf);
    while (!l.empty() && (l.back() == '\n' || l.back() == '\r')) l.pop_back();
    lines.push_back(l);
  }
  if (pclose(pipe) != 0) return std::nullopt;
  return lines;
}

std::vector<std::uint8_t> hex_bytes(const std::string& hex) {
  std::vector<std::uint8_t> out;
  if (hex == "-") return out;
  for (std::size_t i = 0; i + 1 < hex.size(); i += 2)
    out.push_back(std::uint8_t(std::stoul(hex.substr(i, 2), nullptr, 16)));
  return out;
}

// A DCF's configured value (the package reads DefaultValue only).
bool configured_in_dcf(const config::EdsDocument& doc, std::uint16_t index, std::uint8_t sub) {
  char name[16];
  std::snprintf(name, sizeof name, "%04Xsub%X", index, sub);
  const config::EdsSection* s = doc.find(name);
  if (!s && sub == 0) {
    std::snprintf(name, sizeof name, "%04X", index);
    s = doc.find(name);
  }
  const config::EdsKey* k = s ? s->find("ParameterValue") : nullptr;
  return k && !k->value.empty();
}

class EdsForeign : public ::testing::TestWithParam<const char*> {};

// Every entry the package evaluates: the node built from the file (at the
// file's node-ID) answers an SDO upload with the package's bytes.
TEST_P(EdsForeign, NodeAnswersWhatAnIndependentReaderReads) {
  const std::string path = foreign_file(GetParam());
  const config::Profile p = config::load_eds_profile(path);
  const config::EdsDocument doc = config::load_eds_file(path);
  const auto reading = npm_reading(path);
  if (!reading) GTEST_SKIP() << "node or tests/master/node_modules missing (scripts/install-deps)";
  SimBus bus;
  bus.add(p, p.node_id);
  bus.power_on_all();
  bus.run_for(ms(500));
  int compared = 0, skipped = 0;
  for (const std::string& l : *reading) {
    ASSERT_NE(l.rfind("ERROR", 0), 0u) << l;
    std::istringstream in(l);
    std::string index, sub, type, bytes;
    in >> index >> sub >> type >> bytes;
    if (index == "SKIP") {
      ++skipped;
      continue;
    }
    const auto i = std::uint16_t(std::stoul(index, nullptr, 16));
    const auto si = std::uint8_t(std::stoul(sub, nullptr, 16));
    const OdEntry* e = p.layout->find(i, si);
    ASSERT_TRUE(e) << l;
    if (configured_in_dcf(doc, i, si)) {
      ++skipped;
      continue;
    }
    EXPECT_EQ(int(e->type), std::stoi(type, nullptr, 16)) << l;
    const Upload u = upload(bus, p.node_id, *e);
    if (u.abort == 0x06010001) continue;  // write-only
    EXPECT_EQ(u, (Upload{0, hex_bytes(bytes)})) << l;
    ++compared;
  }
  std::printf("%s: %d entries compared with the npm canopen reading, %d skipped\n", GetParam(), compared, skipped);
  EXPECT_GE(compared, 15);
}

INSTANTIATE_TEST_SUITE_P(Files, EdsForeign, ::testing::ValuesIn(kForeignFiles), [](const auto& info) {
  std::string n = info.param;
  for (char& c : n)
    if (!std::isalnum(static_cast<unsigned char>(c))) c = '_';
  return n;
});

std::uint32_t uploaded_u32(SimBus& bus, const config::Profile& p, std::uint8_t id, std::uint16_t index,
                           std::uint8_t sub) {
  const OdEntry* e = p.layout->find(index, sub);
  EXPECT_TRUE(e) << std::hex << index << "sub" << int(sub);
  if (!e) return 0;
  const Upload u = upload(bus, id, *e);
  EXPECT_EQ(u.abort, 0u);
  std::uint32_t v = 0;
  for (std::size_t b = 0; b < u.data.size() && b < 4; ++b) v |= std::uint32_t(u.data[b]) << (8 * b);
  return v;
}

// A CANopenEditor DCF in small (a real one had 181 objects wrong): what an
// empty ParameterValue hid, and the configured values that are there.
TEST(EdsForeign, EditorDcfAnswersItsValues) {
  const config::Profile p = config::load_eds_profile(foreign_file("editor-gripper.dcf"));
  EXPECT_EQ(p.node_id, 10);
  EXPECT_EQ(p.bit_rate_kbit, 250u);  // Baudrate=0: [DeviceInfo]'s 250
  EXPECT_THAT(p.warnings, ::testing::ElementsAre(HasSubstr("editor-gripper.dcf:345: [1F50] DefaultValue: expected hex "
                                                           "bytes, e.g. 0A1B2C, got '0'; read as an empty DOMAIN"),
                                                 HasSubstr("editor-gripper.dcf:387: [DeviceComissioning] Baudrate: "
                                                           "expected a CiA bit rate in kbit/s")));
  SimBus bus;
  bus.add(p, 10);
  bus.power_on_all();
  bus.run_for(ms(10));
  EXPECT_EQ(uploaded_u32(bus, p, 10, 0x1017, 0), 1000u);
  EXPECT_EQ(uploaded_u32(bus, p, 10, 0x1014, 0), 0x8Au);
  EXPECT_EQ(uploaded_u32(bus, p, 10, 0x1800, 1), 0x18Au);
  EXPECT_EQ(uploaded_u32(bus, p, 10, 0x1400, 1), 0x20Au);
  EXPECT_EQ(uploaded_u32(bus, p, 10, 0x1018, 4), 0x0012D687u);  // ParameterValue
  EXPECT_EQ(uploaded_u32(bus, p, 10, 0x1800, 2), 1u);           // ParameterValue
  const Upload name = upload(bus, 10, *p.layout->find(0x1008, 0));
  EXPECT_EQ(std::string(name.data.begin(), name.data.end()), "GX-2 gripper");
}

TEST(EdsForeign, HexFlagsOfAVectorStyleEds) {
  const config::Profile p = config::load_eds_profile(foreign_file("vector-drive.eds"));
  EXPECT_THAT(p.warnings, ::testing::IsEmpty());
  EXPECT_TRUE(p.layout->find(0x2100, 0)->pdo_mappable);
  EXPECT_TRUE(p.layout->find(0x1001, 0)->pdo_mappable);
  EXPECT_FALSE(p.layout->find(0x1000, 0)->pdo_mappable);
  EXPECT_FALSE(p.options->lss_supported);
  EXPECT_TRUE(p.options->rpdo_dummy_mapping);
  EXPECT_EQ(p.options->lss_bit_rates.text(), "0,2-4");  // 1000, 500, 250, 125 kbit/s
  // A compact 0x1003: sub 0 counts the errors (none at boot), rw to clear them.
  EXPECT_EQ(default_u(p, 0x1003, 0), 0u);
  EXPECT_EQ(p.layout->find(0x1003, 0)->access, Access::kRw);
  EXPECT_EQ(p.layout->find(0x1003, 4)->access, Access::kRo);
}

TEST(EdsForeign, VendorEdsLoadsWithOneWarningPerKind) {
  const config::Profile p = config::load_eds_profile(foreign_file("vendor-transmitter.eds"));
  const char* const expected[] = {
      ":24: [MandatoryObjects] SupportedObjects: expected the number of object keys (3), got '4'",
      ":35: [OptionalObjects] 5: expected a section [1010] for this listed object, got '0x1010'",
      ":65: [1018] SubNumber: expected the number of [1018subN] sections (4), got '5'; the 4 sections are read (and 1 "
      "more like it in this file)",
      ":106: [1200sub1] DefaultValue: expected $NODEID+0x600 (the default SDO server's COB-ID), got '0x601'; the node "
      "uses 0x600 + its node-ID (and 1 more like it in this file)",
      ":175: [6130sub1] DefaultValue: expected a decimal floating-point number, got '0x3e6b851f'; read as the IEEE 754 "
      "bits of 0.230000004",
      ":212: [2F00] DefaultValue: expected hex bytes, e.g. 0A1B2C, got '0'; read as an empty DOMAIN",
      ":219: [2F01] LowLimit: expected an integer, got '$NODEID+0x300'; the limit is not applied"};
  ASSERT_EQ(p.warnings.size(), std::size(expected));
  for (std::size_t i = 0; i < p.warnings.size(); ++i) {
    EXPECT_THAT(p.warnings[i], ::testing::StartsWith(foreign_file("vendor-transmitter.eds") + ":"));
    EXPECT_THAT(p.warnings[i], HasSubstr(expected[i]));
  }
  // At node-ID 5, not at the 0x601 the file wrote for its node 1.
  SimBus bus;
  bus.add(p, 5);
  bus.power_on_all();
  bus.run_for(ms(10));
  EXPECT_EQ(uploaded_u32(bus, p, 5, 0x1200, 1), 0x605u);
  EXPECT_EQ(uploaded_u32(bus, p, 5, 0x1200, 2), 0x585u);
  EXPECT_EQ(uploaded_u32(bus, p, 5, 0x1017, 0), 500u);
  EXPECT_EQ(uploaded_u32(bus, p, 5, 0x1000, 0), 0x00020194u);
  EXPECT_EQ(uploaded_u32(bus, p, 5, 0x2F01, 0), 0x305u);
  EXPECT_THROW(config::load_eds_profile(foreign_file("vendor-transmitter.eds"), false, true), config::ConfigError);
}

// python-canopen's own sample (tests/data/eds/python-canopen-sample.eds, as
// it ships it): object 0x2020 has a manufacturer complex data type (0x40),
// which loads as an empty DOMAIN with one warning naming its line, as
// python-canopen loads it; --strict-eds refuses it there.
TEST(EdsForeign, PythonCanopensSampleLoadsItsComplexTypeAsDomain) {
  const std::string path = foreign_file("python-canopen-sample.eds");
  const config::Profile p = config::load_eds_profile(path);
  std::vector<std::string> complex;
  for (const std::string& w : p.warnings)
    if (w.find("DataType") != std::string::npos) complex.push_back(w);
  ASSERT_EQ(complex.size(), 1u) << ::testing::PrintToString(p.warnings);
  EXPECT_EQ(complex[0], path +
                            ":896: [2020] DataType: expected a CiA 301 basic data type 0x0001..0x001B (BOOLEAN, "
                            "INTEGERn, UNSIGNEDn, REAL32/64, strings, DOMAIN), got '0x40'; read as an empty DOMAIN, "
                            "its value and limits not read");
  const OdEntry* e = p.layout->find(0x2020, 0);
  ASSERT_TRUE(e);
  EXPECT_EQ(e->type, DataType::kDomain);
  EXPECT_EQ(e->name, "Complex data type");
  EXPECT_EQ(p.node_id, 0x10);
  // The node runs and answers: the complex object as an empty DOMAIN, the others as written.
  SimBus bus;
  bus.add(p, p.node_id);
  bus.power_on_all();
  bus.run_for(ms(10));
  EXPECT_EQ(upload(bus, p.node_id, *e).abort, 0u);
  EXPECT_EQ(uploaded_u32(bus, p, p.node_id, 0x1800, 1), 0x190u);
  EXPECT_EQ(uploaded_u32(bus, p, p.node_id, 0x3003, 0), 0u);  // an ARRAY listing no entries
  // --strict-eds refuses the file (its first repair), and a complex type where it stands.
  EXPECT_THROW(config::load_eds_profile(path, false, true), config::ConfigError);
  const std::string complex_type =
      eds("[2020]\nParameterName=Complex data type\nObjectType=0x7\nAccessType=RW\n"
          "DataType=0x40\nDefaultValue=0x0\nLowLimit=0x3\nHighLimit=0x1\n");
  EXPECT_EQ(eds_profile(complex_type).layout->find(0x2020, 0)->type, DataType::kDomain);
  try {
    eds_profile(complex_type, "t.eds", true);
    FAIL() << "--strict-eds loaded a manufacturer complex type";
  } catch (const config::ConfigError& err) {
    EXPECT_THAT(err.what(), HasSubstr("t.eds:8: [2020] DataType: expected a CiA 301 basic data type"));
  }
  // Beyond the data type range (CiA 306 §4.6.3: 0x0001-0x025F): an error, strict or not.
  EXPECT_THROW(eds_profile(eds("[2000]\nDataType=0x0260\nAccessType=rw\n")), config::ConfigError);
  EXPECT_THROW(eds_profile(eds("[2000]\nDataType=0\nAccessType=rw\n")), config::ConfigError);
}

class EdsNodes : public ::testing::TestWithParam<const char*> {};

// Options (vendor quirks) and the default bit rate are not in an EDS: the
// EDS node gets the YAML's, as a fleet entry's `options:` and `bit_rate:`
// would give them (p92c's 0x4F00 answers the node's bit rate).
TEST_P(EdsNodes, EdsNodeAnswersEveryUploadAsTheYamlNode) {
  const config::Profile yaml = load_repo_profile(GetParam());
  config::Profile eds = eds_profile(export_eds(yaml), std::string(GetParam()) + ".eds");
  eds.options = yaml.options;
  eds.bit_rate_kbit = yaml.bit_rate_kbit;
  // The profile's node-ID: p92c takes its node-ID from its object 0x4F01.
  const std::vector<Upload> a = uploads(yaml, yaml.node_id), b = uploads(eds, yaml.node_id);
  ASSERT_EQ(a.size(), b.size());
  const auto entries = yaml.layout->entries();
  for (std::size_t i = 0; i < a.size(); ++i)
    EXPECT_EQ(a[i], b[i]) << std::hex << entries[i].index << "sub" << int(entries[i].sub) << " abort " << a[i].abort
                          << " vs " << b[i].abort;
}

INSTANTIATE_TEST_SUITE_P(Profiles, EdsNodes, ::testing::ValuesIn(kProfiles), [](const auto& info) {
  std::string n = info.param;
  for (char& c : n)
    if (c == '-') c = '_';
  return n;
});

TEST(EdsNodes, GenericEdsAsImportedAnswersAsTheYamlNode) {
  const config::Profile yaml = load_repo_profile("generic-404");
  const config::Profile eds = eds_profile(export_eds(yaml), "generic-404.eds");
  EXPECT_EQ(uploads(yaml, 0x10), uploads(eds, 0x10));
}

// LSS_Supported decides whether the node answers LSS (CiA 305 inquire node-ID).
TEST(EdsNodes, LssAsTheEdsSays) {
  for (const bool lss : {true, false}) {
    std::string text = export_eds(load_repo_profile("generic-404"));
    const auto at = text.find("LSS_Supported=1");
    ASSERT_NE(at, std::string::npos);
    if (!lss) text.replace(at, 16, "LSS_Supported=0");
    const config::Profile p = eds_profile(text, "g.eds");
    SimBus bus;
    bus.add(p, 0x12);
    bus.power_on_all();
    bus.run_for(ms(10));
    bus.take();
    CanFrame global = F(0x7E5, {0x04, 0x01, 0, 0, 0, 0, 0, 0}), inquire = F(0x7E5, {0x5E, 0, 0, 0, 0, 0, 0, 0});
    bus.inject(global);
    bus.inject(inquire);
    bus.run_for(ms(10));
    std::vector<CanFrame> replies;
    for (const Sent& s : bus.take())
      if (s.frame.id == 0x7E4) replies.push_back(s.frame);
    if (lss) {
      ASSERT_EQ(replies.size(), 1u);
      EXPECT_EQ(replies[0].data[0], 0x5E);
      EXPECT_EQ(replies[0].data[1], 0x12);
    } else {
      EXPECT_TRUE(replies.empty());
    }
  }
}

TEST(EdsNodes, Cia404ObjectsOfAnEdsGetTheMeasurementChain) {
  config::Profile p = eds_profile(export_eds(load_repo_profile("generic-404")), "generic-404.eds");
  ASSERT_EQ(p.cia404->channels.size(), 2u);
  EXPECT_EQ(p.cia404->channels[1].source, physics::Channel::Temperature);  // from 0x6131:02's default
  EXPECT_EQ(p.layout->find(0x6130, 1)->hooks, kHookRead);
  EXPECT_EQ(p.layout->find(0x6130, 2)->hooks, kHookRead);
  auto app = personalities::make_application(p, {7, 0, "vcan0/eds", {}});
  ASSERT_TRUE(app);
  SimBus bus;
  SimNode& n = bus.add(p, 0x10, app.get());
  bus.power_on_all();
  bus.run_until(ms(2000));
  std::span<const std::uint8_t> out;
  ASSERT_EQ(n->read(0x6130, 1, bus.now(), out), SdoAbort::kNone);
  const float pv = float(decode_f(DataType::kReal32, out.data()));
  EXPECT_TRUE(std::isfinite(pv));
  ASSERT_EQ(n->read(0x6130, 2, bus.now(), out), SdoAbort::kNone);
  EXPECT_TRUE(std::isfinite(decode_f(DataType::kReal32, out.data())));
}

// A folder of this test process's own under the system's temporary folder
// (never the source tree, whatever the working directory).
std::filesystem::path eds_fleet_dir() {
  const std::filesystem::path dir =
      std::filesystem::temp_directory_path() / ("cansim-eds-test-fleet-" + std::to_string(::getpid()));
  std::filesystem::create_directories(dir);
  return dir;
}

// A fleet entry names an EDS like a profile and overrides it as usual.
TEST(EdsFleet, EntryTakesAnEdsWithOverrides) {
  const std::filesystem::path dir = eds_fleet_dir();
  std::ofstream(dir / "g404.eds") << export_eds(load_repo_profile("generic-404"));
  const std::string fleet =
      "interfaces: {vcan0: {bit_rate: 125}}\n"
      "nodes:\n"
      "  - {profile: g404.eds, interface: vcan0, node_id: 5, bit_rate: 125, options: {sdo_expedited_only: true}}\n"
      "  - {profile: g404.eds, interface: vcan0, node_id: 6, count: 2, vendor: {serial_number_base: 100}}\n";
  const config::FleetConfig f = config::parse_fleet(fleet, (dir / "fleet.yaml").string(), config::ProfileSearch{});
  ASSERT_EQ(f.nodes.size(), 3u);
  EXPECT_EQ(f.nodes[0].name, "g404-5");
  EXPECT_EQ(f.nodes[0].profile->personality, "generic");
  EXPECT_EQ(f.nodes[0].bit_rate_kbit, 125u);
  EXPECT_TRUE(f.nodes[0].profile->options->sdo_expedited_only);
  EXPECT_FALSE(f.nodes[1].profile->options->sdo_expedited_only);
  EXPECT_EQ(f.nodes[2].node_id, 7);
  EXPECT_EQ(f.nodes[1].profile->identity.serial_base, 100u);
  EXPECT_TRUE(f.nodes[1].profile->identity.serial_per_node);
  EXPECT_NE(f.nodes[0].profile->layout->find(0x6130, 1), nullptr);
  std::filesystem::remove_all(dir);
}

TEST(EdsFleet, ErrorsInTheEdsNameTheEdsFile) {
  const std::filesystem::path dir = eds_fleet_dir();
  std::ofstream(dir / "broken.eds") << "[1000]\nDataType=0x7\nAccessType=rx\n";
  const std::string fleet = "interfaces: {vcan0: {}}\nnodes:\n  - {profile: broken.eds, interface: vcan0}\n";
  try {
    config::parse_fleet(fleet, (dir / "fleet.yaml").string(), config::ProfileSearch{});
    ADD_FAILURE() << "no error";
  } catch (const config::ConfigError& e) {
    EXPECT_THAT(e.what(),
                HasSubstr("broken.eds:3: [1000] AccessType: expected one of ro, wo, rw, rwr, rww, const, got 'rx'"));
  }
  std::filesystem::remove_all(dir);
}

// `cansimd --check` lists a file's warnings once, however many entries
// (and variants) use it; --strict-eds refuses the file.
TEST(EdsFleet, CheckListsTheFileWarningsOnce) {
  const std::string dcf = foreign_file("editor-gripper.dcf");
  const std::string fleet = "interfaces: {vcan0: {}}\nnodes:\n  - {profile: " + dcf +
                            ", interface: vcan0, node_id: 5}\n  - {profile: " + dcf +
                            ", interface: vcan0, node_id: 6, options: {sdo_expedited_only: true}}\n";
  config::FleetConfig f = config::parse_fleet(fleet, "fleet.yaml", config::ProfileSearch{});
  std::vector<std::string> warnings;
  daemon::check_fleet(f, &warnings);
  EXPECT_THAT(warnings, ::testing::ElementsAre(::testing::StartsWith(dcf + ":345: [1F50] DefaultValue:"),
                                               ::testing::StartsWith(dcf + ":387: [DeviceComissioning] Baudrate:")));
  config::ProfileSearch strict;
  strict.strict_eds = true;
  try {
    config::parse_fleet(fleet, "fleet.yaml", strict);
    ADD_FAILURE() << "no error";
  } catch (const config::ConfigError& e) {
    EXPECT_THAT(e.what(), ::testing::StartsWith(dcf + ":387: [DeviceComissioning] Baudrate: expected a CiA bit rate"));
  }
}

TEST(EdsDcf, CurrentValuesBecomeParameterValues) {
  const config::Profile p = load_repo_profile("generic-404");
  SimBus bus;
  SimNode& n = bus.add(p, 0x10);
  bus.power_on_all();
  bus.run_for(ms(10));
  ASSERT_TRUE(n->values().set_u(0x1017, 0, 250));
  config::DcfValues dcf;
  dcf.node_id = 0x10;
  dcf.node_name = "g";
  dcf.bit_rate_kbit = 250;
  dcf.value = [&](const OdEntry& e) { return n->values().bytes(e); };
  const std::string text = config::write_eds(*p.layout, *p.options, config::identity_of(p), &dcf);
  EXPECT_THAT(text, HasSubstr("[DeviceComissioning]\nNodeID=0x10\nNodeName=g\nBaudrate=250"));
  EXPECT_THAT(text, HasSubstr("DefaultValue=0x3E8\nPDOMapping=0\nParameterValue=0xFA"));
  const config::Profile back = eds_profile(text, "g.dcf");
  EXPECT_EQ(default_u(back, 0x1017, 0), 250u);
  EXPECT_EQ(default_u(back, 0x1800, 1), 0x180u);  // still "$NODEID+0x180"
  EXPECT_TRUE(back.layout->find(0x1800, 1)->default_plus_node_id);
  EXPECT_EQ(back.node_id, 0x10);
}

}  // namespace
}  // namespace cansim::test
