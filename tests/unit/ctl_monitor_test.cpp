// cansimctl monitor's decoder (src/ctl/frame_decoder.hpp): one frame -> one
// decoded line, text and JSON, with node knowledge as the daemon gives it
// (GetPdoMapping, ListObjects). Frames written by hand from CiA 301 / 305.
#include <gtest/gtest.h>

#include <sstream>

#include "ctl/canopen_text.hpp"
#include "ctl/frame_decoder.hpp"
#include "ctl/json.hpp"

namespace cansim::ctl {
namespace {

ObjectInfo object(std::uint16_t index, std::uint8_t sub, std::string name, std::string type, double scale = 1.0,
                  std::string unit = "") {
  return {index, sub, std::move(name), std::move(type), scale, std::move(unit)};
}

// generic-404 at 0x10 (TPDO1 REAL32 PV + status, TPDO2 two INTEGER16 PVs,
// RPDO1 two vendor objects) and a DPS at 0x7F (TPDO1 INTEGER32 PV, 3 digits, psi).
NodeInfo generic() {
  NodeInfo n;
  n.key = "vcan0/generic/0";
  n.label = "generic/0";
  n.interface = "vcan0";
  n.node_id = 0x10;
  n.pdos = {
      {"TPDO1",
       0x190,
       true,
       255,
       {{object(0x6130, 1, "AI input PV (pressure)", "REAL32", 1.0, "bar"), 32},
        {object(0x6150, 1, "AI status (pressure)", "UNSIGNED8"), 8}}},
      {"TPDO2",
       0x290,
       true,
       1,
       {{object(0x7130, 1, "AI input PV INTEGER16 (pressure)", "INTEGER16", 0.01, "bar"), 16},
        {object(0x7130, 2, "AI input PV INTEGER16 (temperature)", "INTEGER16", 0.1, "degC"), 16}}},
      {"TPDO4", 0x490, false, 254, {{object(0x6130, 2, "AI input PV (temperature)", "REAL32", 1.0, "degC"), 32}}},
      {"RPDO1",
       0x210,
       true,
       255,
       {{object(0x2100, 1, "Setpoint", "INTEGER32"), 32}, {object(0x2100, 2, "Mode", "UNSIGNED16"), 16}}},
  };
  n.objects = std::vector<ObjectInfo>{
      object(0x1008, 0, "Manufacturer device name", "VISIBLE_STRING"),
      object(0x1017, 0, "Producer heartbeat time", "UNSIGNED16"),
      object(0x1018, 4, "Serial number", "UNSIGNED32"),
      object(0x6130, 1, "AI input PV (pressure)", "REAL32", 1.0, "bar"),
  };
  return n;
}

NodeInfo dps() {
  NodeInfo n;
  n.key = "vcan0/dps/0";
  n.label = "dps";
  n.interface = "vcan0";
  n.node_id = 0x7F;
  n.pdos = {{"TPDO1",
             0x1FF,
             true,
             255,
             {{object(0x6130, 1, "AI input process value (INTEGER32)", "INTEGER32", 0.001, "psi"), 32}}}};
  return n;
}

RawFrame frame(std::uint32_t id, std::initializer_list<std::uint8_t> bytes, const std::string& iface = "vcan0") {
  RawFrame f;
  f.time = 1700000000.25;
  f.interface = iface;
  f.id = id;
  f.dlc = std::uint8_t(bytes.size());
  std::copy(bytes.begin(), bytes.end(), f.data);
  return f;
}

// The text line without its time of day (local time zone).
std::string text(const DecodedFrame& d) {
  std::string line = format_decoded(d);
  return line.substr(line.find(' ') + 1);
}

std::string json(const DecodedFrame& d) { return decoded_json(d).dump(); }

class MonitorDecoderTest : public ::testing::Test {
 protected:
  FrameDecoder decoder;
  void SetUp() override {
    decoder.set_node(generic());
    decoder.set_node(dps());
  }
  DecodedFrame decode(std::uint32_t id, std::initializer_list<std::uint8_t> bytes) {
    return decoder.decode(frame(id, bytes));
  }
};

TEST_F(MonitorDecoderTest, Real32TpdoIsEngineeringValuesWithUnits) {
  // 3.5f = 0x40600000, status 0.
  DecodedFrame d = decode(0x190, {0x00, 0x00, 0x60, 0x40, 0x00});
  EXPECT_EQ(d.kind, "TPDO1");
  EXPECT_EQ(d.node, "vcan0/generic/0");
  EXPECT_EQ(text(d), "vcan0 190 generic/0 TPDO1 AI input PV (pressure) = 3.5 bar, AI status (pressure) = 0");
  EXPECT_EQ(json(d),
            R"j({"time":null,"wall_time":1700000000.25,"interface":"vcan0","id":400,"extended":false,"rtr":false,)j"
            R"j("dlc":5,"data":"0000604000","node":"vcan0/generic/0","kind":"TPDO1","fields":[)j"
            R"j({"name":"AI input PV (pressure)","index":24880,"sub":1,"value":3.5,"unit":"bar","raw":3.5,)j"
            R"j("counts":null},{"name":"AI status (pressure)","index":24912,"sub":1,"value":0,"unit":null,"raw":0,)j"
            R"j("counts":null}]})j");
}

TEST_F(MonitorDecoderTest, IntegerPvsAreScaledByTheirDecimalDigits) {
  // DPS: 49664 x 10^-3 psi (its TPDO1 "i32=49664").
  DecodedFrame d = decode(0x1FF, {0x00, 0xC2, 0x00, 0x00});
  EXPECT_EQ(text(d), "vcan0 1FF dps TPDO1 AI input process value (INTEGER32) = 49.664 psi");
  EXPECT_NE(json(d).find(R"j("value":49.664,"unit":"psi")j"), std::string::npos) << json(d);
  // generic TPDO2: 350 x 0.01 bar, -125 x 0.1 degC (exact, no 3.5000000000000004).
  d = decode(0x290, {0x5E, 0x01, 0x83, 0xFF});
  EXPECT_EQ(text(d),
            "vcan0 290 generic/0 TPDO2 AI input PV INTEGER16 (pressure) = 3.50 bar, "
            "AI input PV INTEGER16 (temperature) = -12.5 degC");
  EXPECT_NE(json(d).find(R"j("value":3.5,"unit":"bar")j"), std::string::npos) << json(d);
  EXPECT_NE(json(d).find(R"j("value":-12.5,"unit":"degC")j"), std::string::npos) << json(d);
}

TEST_F(MonitorDecoderTest, RpdosDecodeByTheNodesMappingAndInvalidPdosAreRaw) {
  DecodedFrame d = decode(0x210, {0xFE, 0xFF, 0xFF, 0xFF, 0x02, 0x00});
  EXPECT_EQ(d.kind, "RPDO1");
  EXPECT_EQ(text(d), "vcan0 210 generic/0 RPDO1 Setpoint = -2, Mode = 2");
  // TPDO4 is not valid: its COB-ID is nobody's frame.
  d = decode(0x490, {0, 0, 0, 0});
  EXPECT_EQ(d.kind, "raw");
  EXPECT_EQ(d.node, "");
  EXPECT_EQ(json(d), R"j({"time":null,"wall_time":1700000000.25,"interface":"vcan0","id":1168,"extended":false,)j"
                     R"j("rtr":false,"dlc":4,"data":"00000000","node":null,"kind":"raw","fields":[)j"
                     R"j({"name":"data","index":null,"sub":null,"value":"00000000","unit":null,"raw":null,)j"
                     R"j("counts":null}]})j");
  // A mapping longer than the frame says so.
  d = decode(0x190, {0x00, 0x00});
  EXPECT_EQ(text(d), "vcan0 190 generic/0 TPDO1 error = frame too short for the mapping (DLC 2)");
}

TEST_F(MonitorDecoderTest, SameIdOnAnotherInterfaceIsAnotherNode) {
  DecodedFrame d = decoder.decode(frame(0x190, {0, 0, 0x60, 0x40, 0}, "vcan1"));
  EXPECT_EQ(d.kind, "raw");
  EXPECT_EQ(text(d), "vcan1 190 - raw data = 00 00 60 40 00");
}

TEST_F(MonitorDecoderTest, MappingChangesTakeEffectWhenTheNodeIsReplaced) {
  NodeInfo n = generic();
  n.pdos[0].entries = {{object(0x6130, 2, "AI input PV (temperature)", "REAL32", 1.0, "degC"), 32}};
  decoder.set_node(n);
  EXPECT_EQ(text(decode(0x190, {0x00, 0x00, 0xC8, 0x41})),
            "vcan0 190 generic/0 TPDO1 AI input PV (temperature) = 25 degC");
  decoder.remove_node("vcan0/generic/0");
  EXPECT_EQ(decode(0x190, {0x00, 0x00, 0xC8, 0x41}).kind, "raw");
}

// Two nodes on one node-ID and one COB-ID (a misconfigured bench): the
// lowest key decodes, the other once it left; a node's new node-ID moves it.
TEST_F(MonitorDecoderTest, ACollisionDecodesAsTheLowestKeyUntilItLeaves) {
  NodeInfo twin = generic();
  twin.key = "vcan0/a-twin/0";
  twin.label = "a-twin";
  decoder.set_node(twin);
  EXPECT_EQ(decode(0x190, {0x00, 0x00, 0x60, 0x40, 0x00}).node, "vcan0/a-twin/0");
  EXPECT_EQ(decode(0x710, {0x05}).node, "vcan0/a-twin/0");
  decoder.remove_node("vcan0/a-twin/0");
  EXPECT_EQ(decode(0x190, {0x00, 0x00, 0x60, 0x40, 0x00}).node, "vcan0/generic/0");
  EXPECT_EQ(decode(0x710, {0x05}).node, "vcan0/generic/0");
  NodeInfo moved = generic();
  moved.node_id = 0x11;
  moved.pdos[0].cob_id = 0x191;
  decoder.set_node(moved);
  EXPECT_EQ(decode(0x710, {0x05}).kind, "raw");
  EXPECT_EQ(decode(0x190, {0x00, 0x00, 0x60, 0x40, 0x00}).kind, "raw");
  EXPECT_EQ(decode(0x711, {0x05}).node, "vcan0/generic/0");
  EXPECT_EQ(decode(0x191, {0x00, 0x00, 0x60, 0x40, 0x00}).kind, "TPDO1");
}

TEST_F(MonitorDecoderTest, NmtHeartbeatBootUpAndSync) {
  EXPECT_EQ(text(decode(0x000, {0x01, 0x00})), "vcan0 000 - NMT start, node-ID = all");
  DecodedFrame d = decode(0x000, {0x81, 0x10});
  EXPECT_EQ(d.node, "vcan0/generic/0");
  EXPECT_EQ(text(d), "vcan0 000 generic/0 NMT reset-node, node-ID = 0x10");
  d = decode(0x710, {0x05});
  EXPECT_EQ(d.kind, "heartbeat");
  EXPECT_EQ(text(d), "vcan0 710 generic/0 heartbeat operational");
  EXPECT_EQ(json(d), R"j({"time":null,"wall_time":1700000000.25,"interface":"vcan0","id":1808,"extended":false,)j"
                     R"j("rtr":false,"dlc":1,"data":"05","node":"vcan0/generic/0","kind":"heartbeat","fields":[)j"
                     R"j({"name":"state","index":null,"sub":null,"value":"operational","unit":null,"raw":null,)j"
                     R"j("counts":null}]})j");
  d = decode(0x77F, {0x00});
  EXPECT_EQ(d.kind, "boot-up");
  EXPECT_EQ(text(d), "vcan0 77F dps boot-up");
  EXPECT_EQ(text(decode(0x080, {})), "vcan0 080 - SYNC");
  EXPECT_EQ(text(decode(0x080, {0x07})), "vcan0 080 - SYNC counter = 7");
  // A heartbeat of a node-ID that is not in the fleet.
  EXPECT_EQ(decode(0x733, {0x05}).kind, "raw");
}

TEST_F(MonitorDecoderTest, EmcyNamesTheCodeAndKeepsTheVendorBytes) {
  DecodedFrame d = decode(0x090, {0x10, 0x82, 0x11, 1, 2, 3, 4, 5});
  EXPECT_EQ(d.kind, "EMCY");
  EXPECT_EQ(text(d),
            "vcan0 090 generic/0 EMCY code = 0x8210, meaning = PDO not processed due to length error, "
            "register = 0x11, vendor = 01 02 03 04 05");
  EXPECT_NE(text(decode(0x090, {0, 0, 0, 0, 0, 0, 0, 0})).find("meaning = error reset / no error"), std::string::npos);
  EXPECT_EQ(emcy_meaning(0x2310), "current, device output side");
  EXPECT_EQ(emcy_meaning(0x4201), "device temperature");
  EXPECT_EQ(emcy_meaning(0xFF42), "device specific");
}

TEST_F(MonitorDecoderTest, EmcyCodesAsTheDevicesManualNamesThem) {
  NodeInfo n = dps();
  n.objects = std::vector<ObjectInfo>{};
  n.emcy_codes = std::map<std::uint16_t, std::string>{{0x3201, "Over flow / under flow (PV outside the span)"}};
  decoder.set_node(n);
  EXPECT_EQ(text(decode(0x0FF, {0x01, 0x32, 0x05, 0, 0, 0, 0, 0})),
            "vcan0 0FF dps EMCY code = 0x3201, meaning = Over flow / under flow (PV outside the span), "
            "register = 0x05, vendor = 00 00 00 00 00");
  // A code the manual does not list: CiA 301's meaning.
  EXPECT_NE(text(decode(0x0FF, {0x40, 0x81, 0x11, 0, 0, 0, 0, 0})).find("meaning = recovered from bus off"),
            std::string::npos);
}

TEST_F(MonitorDecoderTest, SdoIsTypedByTheObjectDictionary) {
  EXPECT_EQ(text(decode(0x610, {0x40, 0x18, 0x10, 0x04, 0, 0, 0, 0})),
            "vcan0 610 generic/0 SDO upload request 0x1018:04 Serial number");
  DecodedFrame d = decode(0x590, {0x43, 0x18, 0x10, 0x04, 0x01, 0x00, 0x01, 0x00});
  EXPECT_EQ(text(d), "vcan0 590 generic/0 SDO upload response 0x1018:04 Serial number = 65537");
  EXPECT_NE(json(d).find(R"j({"name":"Serial number","index":4120,"sub":4,"value":65537,"unit":null,"raw":65537,)j"
                         R"j("counts":null})j"),
            std::string::npos)
      << json(d);
  EXPECT_EQ(text(decode(0x610, {0x2B, 0x17, 0x10, 0x00, 0xF4, 0x01, 0, 0})),
            "vcan0 610 generic/0 SDO download request 0x1017:00 Producer heartbeat time = 500");
  EXPECT_EQ(text(decode(0x590, {0x60, 0x17, 0x10, 0x00, 0, 0, 0, 0})),
            "vcan0 590 generic/0 SDO download response 0x1017:00 Producer heartbeat time");
  // A REAL32 PV read carries its unit.
  EXPECT_EQ(text(decode(0x590, {0x43, 0x30, 0x61, 0x01, 0x00, 0x00, 0x60, 0x40})),
            "vcan0 590 generic/0 SDO upload response 0x6130:01 AI input PV (pressure) = 3.5 bar");
  // Abort codes by name.
  d = decode(0x590, {0x80, 0x00, 0x50, 0x00, 0x00, 0x00, 0x02, 0x06});
  EXPECT_EQ(text(d),
            "vcan0 590 generic/0 SDO abort 0x5000:00 object, code = 0x06020000, abort = object does not exist");
}

TEST_F(MonitorDecoderTest, SegmentedUploadIsShownWholeAtItsLastSegment) {
  decode(0x610, {0x40, 0x08, 0x10, 0x00, 0, 0, 0, 0});
  EXPECT_EQ(text(decode(0x590, {0x41, 0x08, 0x10, 0x00, 10, 0, 0, 0})),
            "vcan0 590 generic/0 SDO upload response 0x1008:00 Manufacturer device name, size = 10");
  decode(0x610, {0x60, 0, 0, 0, 0, 0, 0, 0});
  EXPECT_EQ(text(decode(0x590, {0x00, 'c', 'a', 'n', 's', 'i', 'm', '-'})),
            "vcan0 590 generic/0 SDO upload segment, bytes so far = 7");
  decode(0x610, {0x70, 0, 0, 0, 0, 0, 0, 0});
  EXPECT_EQ(text(decode(0x590, {0x19, '4', '0', '4', 0, 0, 0, 0})),
            "vcan0 590 generic/0 SDO upload segment 0x1008:00 Manufacturer device name = cansim-404");
}

TEST_F(MonitorDecoderTest, ObjectsAreLoadedOnlyWhenAnSdoNeedsThem) {
  int loads = 0;
  FrameDecoder lazy([&loads](NodeInfo& n) {
    ++loads;
    n.objects = std::vector<ObjectInfo>{object(0x1017, 0, "Producer heartbeat time", "UNSIGNED16")};
    n.emcy_codes = std::map<std::uint16_t, std::string>{};
  });
  NodeInfo n = generic();
  n.objects.reset();
  lazy.set_node(n);
  lazy.decode(frame(0x190, {0, 0, 0x60, 0x40, 0}));
  lazy.decode(frame(0x710, {0x05}));
  EXPECT_EQ(loads, 0);
  EXPECT_EQ(text(lazy.decode(frame(0x610, {0x2B, 0x17, 0x10, 0x00, 0x64, 0, 0, 0}))),
            "vcan0 610 generic/0 SDO download request 0x1017:00 Producer heartbeat time = 100");
  lazy.decode(frame(0x610, {0x2B, 0x17, 0x10, 0x00, 0x64, 0, 0, 0}));
  EXPECT_EQ(loads, 1);
}

TEST_F(MonitorDecoderTest, LssCommandsByName) {
  EXPECT_EQ(text(decode(0x7E5, {0x04, 0x01, 0, 0, 0, 0, 0, 0})),
            "vcan0 7E5 - LSS switch state global, mode = configuration");
  EXPECT_EQ(text(decode(0x7E5, {0x11, 0x22, 0, 0, 0, 0, 0, 0})), "vcan0 7E5 - LSS configure node-ID, node-ID = 0x22");
  EXPECT_EQ(text(decode(0x7E4, {0x11, 0x00, 0, 0, 0, 0, 0, 0})),
            "vcan0 7E4 - LSS configure node-ID (response), error = 0");
  EXPECT_EQ(text(decode(0x7E4, {0x5D, 0x01, 0x00, 0x01, 0x00, 0, 0, 0})),
            "vcan0 7E4 - LSS inquire serial number (response), value = 0x00010001");
}

TEST(MonitorValues, TypedBytesFollowTheCiATypes) {
  EXPECT_EQ(typed_bytes("INTEGER16", {0xFE, 0xFF}), Value(std::int64_t(-2)));
  EXPECT_EQ(typed_bytes("UNSIGNED24", {1, 2, 3}), Value(std::uint64_t(0x030201)));
  EXPECT_EQ(typed_bytes("REAL32", {0, 0, 0x60, 0x40}), Value(3.5));
  EXPECT_EQ(typed_bytes("BOOLEAN", {1}), Value(true));
  EXPECT_EQ(typed_bytes("VISIBLE_STRING", {'a', 'b'}), Value(std::string("ab")));
  EXPECT_EQ(typed_bytes("OCTET_STRING", {1, 2}), Value(Bytes{1, 2}));
  EXPECT_EQ(typed_bytes("UNSIGNED32", {1, 2}), Value(Bytes{1, 2})) << "too short for the type: bytes";
}

TEST_F(MonitorDecoderTest, JsonCarriesTheInterfaceTheRawDataAndTheSimulatedTime) {
  RawFrame f = frame(0x190, {0x00, 0x00, 0x60, 0x40, 0x00});
  f.simulated_time = 12.5;
  const Json j = decoded_json(decoder.decode(f));
  EXPECT_EQ(j["time"], 12.5);
  EXPECT_EQ(j["wall_time"], 1700000000.25);
  EXPECT_EQ(j["interface"], "vcan0");
  EXPECT_EQ(j["data"], "0000604000");
  EXPECT_EQ(j["dlc"], 5);
  // An RTR carries no data.
  RawFrame rtr = frame(0x710, {});
  rtr.rtr = true;
  rtr.dlc = 1;
  EXPECT_EQ(decoded_json(decoder.decode(rtr))["data"], "");
}

TEST_F(MonitorDecoderTest, CobIdsMappingsAndCodesInHexWhereCiaWritesHex) {
  NodeInfo n = generic();
  n.objects->push_back(object(0x1800, 1, "TPDO1 COB-ID", "UNSIGNED32"));
  n.objects->push_back(object(0x1A00, 1, "TPDO1 mapping entry 1", "UNSIGNED32"));
  n.objects->push_back(object(0x1A00, 0, "TPDO1 mapping - number of entries", "UNSIGNED8"));
  decoder.set_node(n);
  EXPECT_EQ(text(decode(0x590, {0x43, 0x00, 0x18, 0x01, 0x90, 0x01, 0x00, 0x40})),
            "vcan0 590 generic/0 SDO upload response 0x1800:01 TPDO1 COB-ID = 0x40000190");
  EXPECT_EQ(text(decode(0x610, {0x23, 0x00, 0x1A, 0x01, 0x20, 0x01, 0x30, 0x61})),
            "vcan0 610 generic/0 SDO download request 0x1A00:01 TPDO1 mapping entry 1 = 0x61300120");
  EXPECT_EQ(text(decode(0x610, {0x2F, 0x00, 0x1A, 0x00, 0x02, 0, 0, 0})),
            "vcan0 610 generic/0 SDO download request 0x1A00:00 TPDO1 mapping - number of entries = 2");
  // JSON keeps numbers.
  EXPECT_NE(json(decode(0x590, {0x43, 0x00, 0x18, 0x01, 0x90, 0x01, 0x00, 0x40})).find(R"j("value":1073742224)j"),
            std::string::npos);
  EXPECT_TRUE(written_in_hex(0x1014, 0));
  EXPECT_TRUE(written_in_hex(0x1003, 1));
  EXPECT_FALSE(written_in_hex(0x1003, 0));
  EXPECT_FALSE(written_in_hex(0x1018, 4));
  EXPECT_FALSE(written_in_hex(0x1017, 0));
}

// A P92C reports Pa: readable at that magnitude, not 9.99044e+06.
TEST_F(MonitorDecoderTest, LargeValuesReadWell) {
  NodeInfo n = dps();
  n.pdos = {{"TPDO1", 0x1FF, true, 255, {{object(0x6130, 1, "Pressure", "REAL32", 1.0, "Pa"), 32}}}};
  decoder.set_node(n);
  // 9990440.0f = 0x4B187128
  EXPECT_EQ(text(decode(0x1FF, {0x28, 0x71, 0x18, 0x4B})), "vcan0 1FF dps TPDO1 Pressure = 9 990 440 Pa");
}

// The SMC reports field counts (its 0x6131 is informational): counts named
// as counts, what they mean beside them (ListCountScaling: 0..20000 over
// 0..5 bar), and JSON's value in bar.
TEST_F(MonitorDecoderTest, CountsAreNamedCountsWithTheirEngineeringValue) {
  NodeInfo n;
  n.key = "vcan0/smc/0";
  n.label = "smc";
  n.interface = "vcan0";
  n.node_id = 0x20;
  ObjectInfo pv = object(0x6130, 1, "Process value (REAL32)", "REAL32", 1.0, "counts");
  pv.engineering = CountScaling{0.00025, 0.0, "bar"};
  n.pdos = {{"TPDO1", 0x1A0, true, 254, {{pv, 32}}}};
  decoder.set_node(n);
  const DecodedFrame d = decode(0x1A0, {0x00, 0x5C, 0x1C, 0x46});  // 10007.0f
  EXPECT_EQ(text(d), "vcan0 1A0 smc TPDO1 Process value (REAL32) = 10 007 counts (2.50175 bar)");
  const Json f = decoded_json(d)["fields"][0];
  EXPECT_EQ(f["unit"], "bar");
  EXPECT_NEAR(f["value"].get<double>(), 2.50175, 1e-9);
  EXPECT_EQ(f["counts"], 10007.0);
  EXPECT_EQ(f["raw"], 10007.0);
  // Without the daemon's scaling: counts, and no unit it does not have.
  n.pdos[0].entries[0].object.engineering.reset();
  decoder.set_node(n);
  EXPECT_EQ(text(decode(0x1A0, {0x00, 0x5C, 0x1C, 0x46})),
            "vcan0 1A0 smc TPDO1 Process value (REAL32) = 10 007 counts");
}

}  // namespace
}  // namespace cansim::ctl
