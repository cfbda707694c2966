// PDO parameter rules (CiA 301 §7.5.2.33-36): COB-ID, transmission type,
// inhibit time, event timer, mapping; exact abort codes and dispatch updates.
#include <algorithm>

#include "unit/pdo_fixture.hpp"

namespace cansim::pdo_test {
namespace {

bool listens(Node& n, std::uint32_t id) {
  std::vector<std::uint32_t> ids;
  n.collect_rx_ids(ids);
  return std::find(ids.begin(), ids.end(), id) != ids.end();
}

TEST(PdoConfig, DiscoversEveryDeclaredPdo) {
  PdoBus b;
  EXPECT_EQ(b.node().pdo().tpdo_count(), 2u);
  EXPECT_EQ(b.node().pdo().rpdo_count(), 1u);
  EXPECT_TRUE(b.node().pdo().owns(0x1801));
  EXPECT_TRUE(b.node().pdo().owns(0x1A01));
  EXPECT_FALSE(b.node().pdo().owns(0x1802));
  EXPECT_FALSE(b.node().pdo().owns(0x1601));
}

TEST(PdoConfig, CanIdChangesOnlyWhileInvalid) {
  PdoBus b;
  EXPECT_EQ(b.write(0x1800, 1, 0x195), SdoAbort::kInvalidValue);
  EXPECT_EQ(b.write(0x1800, 1, 0x185), SdoAbort::kNone);       // same value
  EXPECT_EQ(b.write(0x1800, 1, 0x40000185), SdoAbort::kNone);  // bit 30 may change
  // Invalidating may carry a new ID (as CANopenNode and Lely accept).
  EXPECT_EQ(b.write(0x1800, 1, 0x800001A5), SdoAbort::kNone);
  EXPECT_EQ(b.write(0x1800, 1, 0x195), SdoAbort::kNone);  // invalid -> valid with a new ID
  EXPECT_EQ(b.value(0x1800, 1), 0x195u);
  b.start();
  b.node().pdo().raise_event(1, b.now());
  EXPECT_EQ(b.sent(0x195).size(), 1u);
}

TEST(PdoConfig, CobIdFormatAndRestrictedIds) {
  PdoBus b;
  ASSERT_EQ(b.write(0x1800, 1, 0x80000185), SdoAbort::kNone);
  EXPECT_EQ(b.write(0x1800, 1, 0x00000985), SdoAbort::kInvalidValue);  // 11-bit with bit 11
  for (std::uint32_t id :
       {0x000u, 0x07Fu, 0x101u, 0x180u, 0x581u, 0x5FFu, 0x601u, 0x67Fu, 0x6E0u, 0x6FFu, 0x701u, 0x77Fu, 0x780u, 0x7FFu})
    EXPECT_EQ(b.write(0x1800, 1, id), SdoAbort::kInvalidValue) << std::hex << id;
  EXPECT_EQ(b.write(0x1800, 1, 0x80000601), SdoAbort::kNone);  // invalid: not checked
  EXPECT_EQ(b.write(0x1800, 1, 0x181), SdoAbort::kNone);
  EXPECT_EQ(b.write(0x1800, 1, 0x80000000), SdoAbort::kNone);
  EXPECT_EQ(b.write(0x1800, 1, 0x080), SdoAbort::kNone);
  EXPECT_EQ(b.write(0x1800, 1, 0x80000000), SdoAbort::kNone);
  EXPECT_EQ(b.write(0x1800, 1, 0x20000601), SdoAbort::kNone);  // 29-bit IDs are not restricted
}

TEST(PdoConfig, TwentyNineBitIdsCanBeRefused) {
  PdoBus b("{pdo_29bit_ids: false}");
  ASSERT_EQ(b.write(0x1800, 1, 0x80000185), SdoAbort::kNone);
  EXPECT_EQ(b.write(0x1800, 1, 0x20000185), SdoAbort::kInvalidValue);
}

TEST(PdoConfig, ReservedTransmissionTypes) {
  PdoBus b;
  for (unsigned t = 241; t <= 251; ++t) EXPECT_EQ(b.write(0x1800, 2, t), SdoAbort::kInvalidValue) << t;
  for (unsigned t : {0u, 1u, 240u, 252u, 253u, 254u, 255u})
    EXPECT_EQ(b.write(0x1800, 2, t), SdoAbort::kNone) << t;  // allowed while valid
  for (unsigned t = 241; t <= 253; ++t) EXPECT_EQ(b.write(0x1400, 2, t), SdoAbort::kInvalidValue) << t;
  EXPECT_EQ(b.write(0x1400, 2, 0), SdoAbort::kNone);
  EXPECT_EQ(b.write(0x1400, 2, 254), SdoAbort::kNone);
}

TEST(PdoConfig, AllowedTypesOptionWithVendorAbort) {
  PdoBus b("{tpdo_allowed_types: \"0-240,254-255\", tpdo_bad_type_abort: 0x06090031}");
  EXPECT_EQ(b.write(0x1800, 2, 252), SdoAbort::kValueTooHigh);
  EXPECT_EQ(b.write(0x1800, 2, 253), SdoAbort::kValueTooHigh);
  EXPECT_EQ(b.write(0x1800, 2, 245), SdoAbort::kValueTooHigh);
  EXPECT_EQ(b.write(0x1800, 2, 254), SdoAbort::kNone);
  EXPECT_EQ(b.value(0x1800, 2), 254u);
}

TEST(PdoConfig, EventTimerMinimumOption) {
  PdoBus b("{tpdo_min_event_timer_ms: 4, tpdo_event_timer_low_abort: 0x06090031}");
  EXPECT_EQ(b.write(0x1800, 5, 3), SdoAbort::kValueTooHigh);
  EXPECT_EQ(b.write(0x1800, 5, 4), SdoAbort::kNone);
  EXPECT_EQ(b.write(0x1800, 5, 0), SdoAbort::kNone);  // 0 = timer off
}

TEST(PdoConfig, EventTimerWriteRestartsTheTimer) {
  PdoBus b;
  b.start();
  const TimeUs t0 = b.now();
  ASSERT_EQ(b.write(0x1800, 5, 20), SdoAbort::kNone);
  b.bus().run_for(ms(45));
  auto frames = b.sent(0x185);
  ASSERT_EQ(frames.size(), 2u);
  EXPECT_EQ(frames[0].time, t0 + ms(20));
  EXPECT_EQ(frames[1].time, t0 + ms(40));
  ASSERT_EQ(b.write(0x1800, 5, 0), SdoAbort::kNone);
  b.bus().run_for(ms(100));
  EXPECT_TRUE(b.sent(0x185).empty());
}

TEST(PdoConfig, InhibitTimeAndSyncStartOnlyWhileInvalid) {
  PdoBus b;
  EXPECT_EQ(b.write(0x1800, 3, 10), SdoAbort::kInvalidValue);
  EXPECT_EQ(b.write(0x1800, 6, 1), SdoAbort::kInvalidValue);
  EXPECT_EQ(b.write(0x1800, 3, 0), SdoAbort::kNone);  // unchanged value
  ASSERT_EQ(b.write(0x1800, 1, 0x80000185), SdoAbort::kNone);
  EXPECT_EQ(b.write(0x1800, 3, 10), SdoAbort::kNone);
  EXPECT_EQ(b.write(0x1800, 6, 240), SdoAbort::kNone);
  EXPECT_EQ(b.write(0x1800, 6, 241), SdoAbort::kInvalidValue);
}

TEST(PdoConfig, MappingLockedWhileValidOrEnabled) {
  PdoBus b;
  EXPECT_EQ(b.write(0x1A00, 0, 0), SdoAbort::kInvalidValue);           // PDO exists
  EXPECT_EQ(b.write(0x1A00, 3, 0x20030008), SdoAbort::kInvalidValue);  // PDO exists
  ASSERT_EQ(b.write(0x1800, 1, 0x80000185), SdoAbort::kNone);
  EXPECT_EQ(b.write(0x1A00, 3, 0x20030008), SdoAbort::kInvalidValue);  // sub 0 != 0
  ASSERT_EQ(b.write(0x1A00, 0, 0), SdoAbort::kNone);
  EXPECT_EQ(b.write(0x1A00, 3, 0x20030008), SdoAbort::kNone);
  EXPECT_EQ(b.write(0x1A00, 0, 3), SdoAbort::kNone);
  ASSERT_EQ(b.write(0x1800, 1, 0x185), SdoAbort::kNone);
  b.start();
  b.node().pdo().raise_event(1, b.now());
  auto frames = b.sent(0x185);
  ASSERT_EQ(frames.size(), 1u);
  EXPECT_EQ(frames[0].frame, F(0x185, {0x44, 0x33, 0x22, 0x11, 0x66, 0x55, 0x88}));
}

TEST(PdoConfig, VendorMappingProcedureAndAbortOption) {
  PdoBus b("{pdo_mapping_needs_invalid: false, pdo_mapping_locked_abort: 0x06040043}");
  EXPECT_EQ(b.write(0x1A00, 1, 0x20030008), SdoAbort::kParamIncompatible);  // sub 0 != 0
  ASSERT_EQ(b.write(0x1A00, 0, 0), SdoAbort::kNone);                        // while valid
  EXPECT_EQ(b.write(0x1A00, 1, 0x20030008), SdoAbort::kNone);
  EXPECT_EQ(b.write(0x1A00, 0, 1), SdoAbort::kNone);
  b.start();
  b.node().pdo().raise_event(1, b.now());
  auto frames = b.sent(0x185);
  ASSERT_EQ(frames.size(), 1u);
  EXPECT_EQ(frames[0].frame, F(0x185, {0x88}));
}

TEST(PdoConfig, MappingEntryChecks) {
  PdoBus b;
  ASSERT_EQ(b.write(0x1800, 1, 0x80000185), SdoAbort::kNone);
  ASSERT_EQ(b.write(0x1A00, 0, 0), SdoAbort::kNone);
  EXPECT_EQ(b.write(0x1A00, 1, 0x30000008), SdoAbort::kNoObject);
  EXPECT_EQ(b.write(0x1A00, 1, 0x20000120), SdoAbort::kNoSubIndex);
  EXPECT_EQ(b.write(0x1A00, 1, 0x20020008), SdoAbort::kNotMappable);  // not PDO-mappable
  EXPECT_EQ(b.write(0x1A00, 1, 0x20060008), SdoAbort::kNotMappable);  // write-only: not for TPDO
  EXPECT_EQ(b.write(0x1A00, 1, 0x20000010), SdoAbort::kNotMappable);  // 16 bits of a U32
  EXPECT_EQ(b.write(0x1A00, 1, 0x20000000), SdoAbort::kNotMappable);  // length 0
  EXPECT_EQ(b.write(0x1A00, 1, 0x00050008), SdoAbort::kNotMappable);  // dummy in a TPDO
  EXPECT_EQ(b.write(0x1A00, 1, 0x20040001), SdoAbort::kNone);         // BOOLEAN as 1 bit
  EXPECT_EQ(b.write(0x1A00, 1, 0x20040008), SdoAbort::kNone);         // or as a byte
  EXPECT_EQ(b.write(0x1A00, 1, 0), SdoAbort::kNone);                  // clearing is fine
  ASSERT_EQ(b.write(0x1400, 1, 0x80000205), SdoAbort::kNone);
  ASSERT_EQ(b.write(0x1600, 0, 0), SdoAbort::kNone);
  EXPECT_EQ(b.write(0x1600, 1, 0x20030008), SdoAbort::kNotMappable);  // read-only: not for RPDO
  EXPECT_EQ(b.write(0x1600, 1, 0x20060008), SdoAbort::kNone);         // write-only is fine
  EXPECT_EQ(b.write(0x1600, 2, 0x00050008), SdoAbort::kNone);         // dummy U8
  EXPECT_EQ(b.write(0x1600, 2, 0x00050010), SdoAbort::kNotMappable);  // dummy with wrong length
}

TEST(PdoConfig, MappingCountChecksLengthAndEntries) {
  PdoBus b;
  ASSERT_EQ(b.write(0x1800, 1, 0x80000185), SdoAbort::kNone);
  ASSERT_EQ(b.write(0x1A00, 0, 0), SdoAbort::kNone);
  ASSERT_EQ(b.write(0x1A00, 3, 0x20050040), SdoAbort::kNone);  // U64
  EXPECT_EQ(b.write(0x1A00, 0, 3), SdoAbort::kPdoLength);      // 32 + 16 + 64 bits
  EXPECT_EQ(b.write(0x1A00, 0, 4), SdoAbort::kPdoLength);
  EXPECT_EQ(b.write(0x1A00, 0, 9), SdoAbort::kValueTooHigh);  // only subs 1..8 exist
  EXPECT_EQ(b.value(0x1A00, 0), 0u);
  ASSERT_EQ(b.write(0x1A00, 3, 0), SdoAbort::kNone);
  EXPECT_EQ(b.write(0x1A00, 0, 3), SdoAbort::kNotMappable);  // entry 3 is empty
  EXPECT_EQ(b.write(0x1A00, 0, 2), SdoAbort::kNone);
  // A bad entry stored behind the engine's back (old storage) is caught at sub 0.
  ASSERT_EQ(b.write(0x1A00, 0, 0), SdoAbort::kNone);
  b.set(0x1A00, 1, 0x20020008);
  EXPECT_EQ(b.write(0x1A00, 0, 1), SdoAbort::kNotMappable);
}

TEST(PdoConfig, EmptyMappingSendsNothing) {
  PdoBus b;
  ASSERT_EQ(b.write(0x1800, 1, 0x80000185), SdoAbort::kNone);
  ASSERT_EQ(b.write(0x1A00, 0, 0), SdoAbort::kNone);
  ASSERT_EQ(b.write(0x1800, 1, 0x185), SdoAbort::kNone);  // valid with no objects (Lely, CiA)
  ASSERT_EQ(b.write(0x1800, 5, 10), SdoAbort::kNone);
  b.start();
  b.node().pdo().raise_event(1, b.now());
  b.bus().run_for(ms(50));
  EXPECT_TRUE(b.sent(0x185).empty());
}

TEST(PdoConfig, DispatchFollowsCobIdsAndMapping) {
  PdoBus b;
  EXPECT_TRUE(listens(b.node(), 0x205));  // RPDO1
  EXPECT_TRUE(listens(b.node(), 0x185));  // TPDO1 accepts RTR
  std::uint32_t epoch = b.node().rx_epoch();
  ASSERT_EQ(b.write(0x1800, 1, 0x40000185), SdoAbort::kNone);
  EXPECT_NE(b.node().rx_epoch(), epoch);
  EXPECT_FALSE(listens(b.node(), 0x185));
  epoch = b.node().rx_epoch();
  ASSERT_EQ(b.write(0x1400, 1, 0x80000205), SdoAbort::kNone);
  EXPECT_NE(b.node().rx_epoch(), epoch);
  EXPECT_FALSE(listens(b.node(), 0x205));
  ASSERT_EQ(b.write(0x1400, 1, 0x20001234), SdoAbort::kNone);
  EXPECT_TRUE(listens(b.node(), 0x1234u | kRxIdExtended));
  epoch = b.node().rx_epoch();
  ASSERT_EQ(b.write(0x1800, 1, 0xC0000185), SdoAbort::kNone);
  epoch = b.node().rx_epoch();
  ASSERT_EQ(b.write(0x1A00, 0, 1), SdoAbort::kNone);
  EXPECT_NE(b.node().rx_epoch(), epoch);
}

TEST(PdoConfig, IgnoreValidBitOption) {
  PdoBus b("{pdo_ignore_valid_bit: true}");
  ASSERT_EQ(b.write(0x1801, 1, 0x80000285), SdoAbort::kNone);  // GEMS: "make the PDO valid"
  ASSERT_EQ(b.write(0x1801, 1, 0x80000295), SdoAbort::kNone);  // ID changes are free
  b.start();
  b.sync();
  EXPECT_EQ(b.sent(0x295).size(), 1u);
}

class HookApp : public Application {
 public:
  SdoAbort check_write(Node&, const OdEntry& e, std::span<const std::uint8_t> d, TimeUs) override {
    // A personality restricting its mapping table: only 0x2003 may be mapped.
    if (e.index == 0x1A00 && e.sub != 0 && d[2] != 0x03 && get_u32(d.data()) != 0) return SdoAbort::kNotMappable;
    return SdoAbort::kNone;
  }
};

TEST(PdoConfig, ApplicationHookMayRestrictMappings) {
  // Personalities flag the objects they police with hook: write.
  std::string text = pdo_profile("{}");
  const std::string plain = "{index: 0x1A00, sub: 1, kind: record, type: UNSIGNED32, access: rw, default: 0x20000020}";
  ASSERT_NE(text.find(plain), std::string::npos);
  text.replace(text.find(plain), plain.size(),
               "{index: 0x1A00, sub: 1, kind: record, type: UNSIGNED32, access: rw, default: 0x20000020, hook: write}");
  config::Profile p = config::parse_profile(text, "x.yaml");
  HookApp app;
  test::SimBus bus;
  test::SimNode& sim = bus.add(p, 5, &app);
  bus.power_on_all();
  Node& n = sim.node();
  std::uint8_t v[4];
  put_u32(v, 0x80000185);
  ASSERT_EQ(n.write(0x1800, 1, v, bus.now()), SdoAbort::kNone);
  put_u32(v, 0);
  ASSERT_EQ(n.write(0x1A00, 0, std::span<const std::uint8_t>(v, 1), bus.now()), SdoAbort::kNone);
  put_u32(v, 0x20010010);
  EXPECT_EQ(n.write(0x1A00, 1, v, bus.now()), SdoAbort::kNotMappable);
  put_u32(v, 0x20030008);
  EXPECT_EQ(n.write(0x1A00, 1, v, bus.now()), SdoAbort::kNone);
}

// ---- the public mapping decoder and the configuration notification

TEST(PdoMapEntry, DecodesIndexSubAndLength) {
  constexpr PdoMapEntry m = PdoMapEntry::decode(0x61300120);
  static_assert(m.index == 0x6130 && m.sub == 0x01 && m.bits == 0x20);
  EXPECT_FALSE(m.dummy());
  EXPECT_TRUE(PdoMapEntry::decode(0x00050008).dummy());  // UNSIGNED8 dummy
  EXPECT_FALSE(PdoMapEntry::decode(0x00080020).dummy());
}

TEST(PdoMapEntry, ChecksAgainstTheLayoutAsAMappingWriteDoes) {
  const config::Profile p = config::parse_profile(pdo_profile("{}"), "pdo-test.yaml");
  const OdLayout& od = *p.layout;
  const OdEntry* mapped = nullptr;
  EXPECT_EQ(check_pdo_map_entry(od, 0x20000020, true, false, &mapped), SdoAbort::kNone);
  EXPECT_EQ(mapped, od.find(0x2000, 0));
  EXPECT_EQ(check_pdo_map_entry(od, 0x20000010, true, false), SdoAbort::kNotMappable);  // 16 bits of a U32
  EXPECT_EQ(check_pdo_map_entry(od, 0x20020008, true, false), SdoAbort::kNotMappable);  // not mappable
  EXPECT_EQ(check_pdo_map_entry(od, 0x20060008, true, false), SdoAbort::kNotMappable);  // wo in a TPDO
  EXPECT_EQ(check_pdo_map_entry(od, 0x20060008, false, false), SdoAbort::kNone);        // ... fine in an RPDO
  EXPECT_EQ(check_pdo_map_entry(od, 0x20040001, true, false), SdoAbort::kNone);         // BOOLEAN as one bit
  EXPECT_EQ(check_pdo_map_entry(od, 0x30000008, true, false), SdoAbort::kNoObject);
  EXPECT_EQ(check_pdo_map_entry(od, 0x20000108, true, false), SdoAbort::kNoSubIndex);
  EXPECT_EQ(check_pdo_map_entry(od, 0x00050008, false, false), SdoAbort::kNotMappable);  // dummies off
  EXPECT_EQ(check_pdo_map_entry(od, 0x00050008, false, true, &mapped), SdoAbort::kNone);
  EXPECT_EQ(mapped, nullptr);
  EXPECT_EQ(check_pdo_map_entry(od, 0x00050008, true, true), SdoAbort::kNotMappable);  // never in a TPDO
}

class ConfigWatcher : public Application {
 public:
  void on_pdo_config(Node& node, TimeUs) override {
    ++calls;
    const Tpdo& t1 = node.pdo().tpdos()[0];
    valid = node.pdo().valid(t1.cfg);
    type = t1.cfg.type;
    items = t1.cfg.item_count;
  }
  int calls = 0;
  bool valid = false;
  int type = -1;
  int items = -1;
};

TEST(PdoConfig, ApplicationIsToldOfEveryConfigurationChange) {
  ConfigWatcher app;
  PdoBus b("{}", &app);
  EXPECT_GE(app.calls, 1);  // the power-on reset loaded the PDOs
  EXPECT_TRUE(app.valid);
  EXPECT_EQ(app.type, 255);
  EXPECT_EQ(app.items, 2);
  app.calls = 0;
  ASSERT_EQ(b.write(0x1800, 2, 1), SdoAbort::kNone);
  EXPECT_EQ(app.calls, 1);
  EXPECT_EQ(app.type, 1);
  ASSERT_EQ(b.write(0x1800, 1, 0x80000185), SdoAbort::kNone);
  EXPECT_EQ(app.calls, 2);
  EXPECT_FALSE(app.valid);
  ASSERT_EQ(b.write(0x1A00, 0, 0), SdoAbort::kNone);
  EXPECT_EQ(app.calls, 3);
  EXPECT_EQ(app.items, 0);
  b.nmt(0x81);  // reset node: back to the defaults, told again
  EXPECT_EQ(app.calls, 4);
  EXPECT_TRUE(app.valid);
  EXPECT_EQ(app.items, 2);
}

}  // namespace
}  // namespace cansim::pdo_test
