// Store / restore parameters 0x1010 / 0x1011 (CiA 301 §7.5.2.13-14) and the
// persistence blob shared with LSS store configuration.
#include "nmt_support.hpp"

#include "core/crc32.hpp"

namespace cansim::nmt_test {
namespace {

constexpr std::uint32_t kSave = StoreRestore::kSave;
constexpr std::uint32_t kLoad = StoreRestore::kLoad;

class Store : public Harness {
 protected:
  SimNode& start(const std::string& options = "{}") {
    SimNode& n = add(5, options);
    bus.power_on_all();
    take();
    return n;
  }
  // Power loss: a new Node object with the same storage, powered on.
  void power_cycle(SimNode& n) {
    n.replace(5);
    n->power_on(now());
  }
  SdoAbort set_string(SimNode& n, const std::string& s) {
    return n->write(0x2002, 0, {reinterpret_cast<const std::uint8_t*>(s.data()), s.size()}, now());
  }
  std::string get_string(SimNode& n) { return std::string(n->values().get_string(*n->od().find(0x2002, 0))); }
};

TEST_F(Store, SaveAllSurvivesPowerLoss) {
  SimNode& n = start();
  ASSERT_EQ(wr16(n, 0x1017, 0, 250), SdoAbort::kNone);
  ASSERT_EQ(wr32(n, 0x2000, 0, 0xDEADBEEF), SdoAbort::kNone);
  ASSERT_EQ(wr16(n, 0x2001, 0, 77), SdoAbort::kNone);  // not persistent
  ASSERT_EQ(set_string(n, "hello world"), SdoAbort::kNone);
  ASSERT_EQ(wr8(n, 0x3000, 0, 42), SdoAbort::kNone);
  ASSERT_EQ(wr32(n, 0x1010, 1, kSave), SdoAbort::kNone);
  EXPECT_EQ(n.storage.saves, 1);
  EXPECT_EQ(rd(n, 0x1010, 1), 1u);  // reads keep the capability bits
  power_cycle(n);
  EXPECT_EQ(rd(n, 0x1017, 0), 250u);
  EXPECT_EQ(rd(n, 0x2000, 0), 0xDEADBEEFu);
  EXPECT_EQ(rd(n, 0x2001, 0), 9u);
  EXPECT_EQ(get_string(n), "hello world");
  EXPECT_EQ(rd(n, 0x3000, 0), 42u);
  bus.run_until(ms(250));
  EXPECT_EQ(take(), S({{0, F(0x705, {0x00})}, {ms(250), F(0x705, {0x7F})}}));
}

TEST_F(Store, GroupsSaveOnlyTheirEntriesAndKeepTheOthers) {
  SimNode& n = start();
  ASSERT_EQ(wr16(n, 0x1017, 0, 250), SdoAbort::kNone);
  ASSERT_EQ(wr32(n, 0x2000, 0, 1), SdoAbort::kNone);
  ASSERT_EQ(wr8(n, 0x3000, 0, 11), SdoAbort::kNone);
  ASSERT_EQ(wr32(n, 0x1010, 3, kSave), SdoAbort::kNone);  // application: 0x2000
  ASSERT_EQ(wr16(n, 0x1017, 0, 500), SdoAbort::kNone);
  ASSERT_EQ(wr32(n, 0x2000, 0, 2), SdoAbort::kNone);
  ASSERT_EQ(wr32(n, 0x1010, 2, kSave), SdoAbort::kNone);  // communication: 0x1017 = 500
  ASSERT_EQ(wr32(n, 0x1010, 4, kSave), SdoAbort::kNone);  // manufacturer group 4: 0x3000
  power_cycle(n);
  EXPECT_EQ(rd(n, 0x1017, 0), 500u);
  EXPECT_EQ(rd(n, 0x2000, 0), 1u);  // the application save, not the later value
  EXPECT_EQ(rd(n, 0x3000, 0), 11u);
}

TEST_F(Store, WrongSignatureAndSubZero) {
  SimNode& n = start();
  EXPECT_EQ(wr32(n, 0x1010, 1, kLoad), SdoAbort::kDataTransfer);
  EXPECT_EQ(wr32(n, 0x1011, 1, kSave), SdoAbort::kDataTransfer);
  EXPECT_EQ(wr32(n, 0x1010, 1, 0), SdoAbort::kDataTransfer);
  EXPECT_EQ(wr8(n, 0x1010, 0, 1), SdoAbort::kReadOnly);
  EXPECT_EQ(wr16(n, 0x1010, 1, 0x6173), SdoAbort::kLengthTooLow);
  SdoAbort why = SdoAbort::kNone;
  rd(n, 0x1010, 5, &why);
  EXPECT_EQ(why, SdoAbort::kNoSubIndex);
  EXPECT_EQ(n.storage.saves, 0);
  SimNode& m = add(6, "{store_bad_signature_abort: 0x08000000}");
  m->power_on(now());
  EXPECT_EQ(wr32(m, 0x1010, 1, 1), SdoAbort::kGeneral);
}

TEST_F(Store, StorageFailureIsAHardwareError) {
  SimNode& n = start();
  ASSERT_EQ(wr32(n, 0x2000, 0, 5), SdoAbort::kNone);
  ASSERT_EQ(wr32(n, 0x1010, 1, kSave), SdoAbort::kNone);
  n.storage.fail_saves = true;
  ASSERT_EQ(wr32(n, 0x2000, 0, 6), SdoAbort::kNone);
  EXPECT_EQ(wr32(n, 0x1010, 1, kSave), SdoAbort::kHardware);
  EXPECT_EQ(wr32(n, 0x1011, 1, kLoad), SdoAbort::kHardware);
  n.storage.fail_saves = false;
  power_cycle(n);
  EXPECT_EQ(rd(n, 0x2000, 0), 5u);
}

TEST_F(Store, NoStorageIsAHardwareError) {
  config::Profile p = config::parse_profile(profile_text("{}", ""));
  FrameSink* sink = nullptr;
  struct Null : FrameSink {
    void send(const CanFrame&) override {}
  } null;
  sink = &null;
  Node node(config::node_setup(p, 5), *sink);
  node.power_on(0);
  std::uint8_t save[4] = {0x73, 0x61, 0x76, 0x65};
  EXPECT_EQ(node.write(0x1010, 1, save, 0), SdoAbort::kHardware);
}

// CiA 301: restore only invalidates the stored values; RAM is unchanged
// until a reset (reset communication suffices for the communication group).
TEST_F(Store, RestoreTakesEffectAtTheNextReset) {
  SimNode& n = start();
  ASSERT_EQ(wr16(n, 0x1017, 0, 250), SdoAbort::kNone);
  ASSERT_EQ(wr32(n, 0x2000, 0, 1234), SdoAbort::kNone);
  ASSERT_EQ(wr32(n, 0x1010, 1, kSave), SdoAbort::kNone);
  ASSERT_EQ(wr32(n, 0x1011, 1, kLoad), SdoAbort::kNone);
  EXPECT_EQ(rd(n, 0x1011, 1), 1u);
  EXPECT_EQ(rd(n, 0x1017, 0), 250u);
  EXPECT_EQ(rd(n, 0x2000, 0), 1234u);
  nmt(0x82, 5);
  EXPECT_EQ(rd(n, 0x1017, 0), 0u);
  EXPECT_EQ(rd(n, 0x2000, 0), 1234u);
  nmt(0x81, 5);
  EXPECT_EQ(rd(n, 0x2000, 0), 7u);
}

TEST_F(Store, RestoreOneGroupKeepsTheOther) {
  SimNode& n = start();
  ASSERT_EQ(wr16(n, 0x1017, 0, 250), SdoAbort::kNone);
  ASSERT_EQ(wr32(n, 0x2000, 0, 1234), SdoAbort::kNone);
  ASSERT_EQ(wr32(n, 0x1010, 1, kSave), SdoAbort::kNone);
  ASSERT_EQ(wr32(n, 0x1011, 3, kLoad), SdoAbort::kNone);
  power_cycle(n);
  EXPECT_EQ(rd(n, 0x1017, 0), 250u);
  EXPECT_EQ(rd(n, 0x2000, 0), 7u);
}

TEST_F(Store, RestoreModeImmediateAndRam) {
  SimNode& n = start("{restore_mode: immediate}");
  ASSERT_EQ(wr32(n, 0x2000, 0, 1234), SdoAbort::kNone);
  ASSERT_EQ(wr32(n, 0x1010, 1, kSave), SdoAbort::kNone);
  ASSERT_EQ(wr32(n, 0x1011, 1, kLoad), SdoAbort::kNone);
  EXPECT_EQ(rd(n, 0x2000, 0), 7u);
  power_cycle(n);
  EXPECT_EQ(rd(n, 0x2000, 0), 7u);

  SimNode& m = add(6, "{restore_mode: ram}");
  m->power_on(now());
  ASSERT_EQ(wr32(m, 0x2000, 0, 1234), SdoAbort::kNone);
  ASSERT_EQ(wr32(m, 0x1010, 1, kSave), SdoAbort::kNone);
  ASSERT_EQ(wr32(m, 0x1011, 1, kLoad), SdoAbort::kNone);
  EXPECT_EQ(rd(m, 0x2000, 0), 7u);
  m.replace(6);
  m->power_on(now());
  EXPECT_EQ(rd(m, 0x2000, 0), 1234u);  // not saved afterwards: the stored value stays
}

TEST_F(Store, LssAndParametersShareTheBlob) {
  SimNode& n = start();
  ASSERT_EQ(wr32(n, 0x2000, 0, 99), SdoAbort::kNone);
  ASSERT_EQ(wr32(n, 0x1010, 1, kSave), SdoAbort::kNone);
  ASSERT_TRUE(n->store().save_lss({true, 0x33, 2}));
  ASSERT_EQ(wr32(n, 0x2000, 0, 100), SdoAbort::kNone);
  ASSERT_EQ(wr32(n, 0x1010, 3, kSave), SdoAbort::kNone);
  power_cycle(n);
  EXPECT_EQ(rd(n, 0x2000, 0), 100u);
  LssStored lss = n->store().stored_lss();
  EXPECT_TRUE(lss.valid);
  EXPECT_EQ(lss.node_id, 0x33);
  EXPECT_EQ(lss.bit_rate_index, 2);
  n.storage.fail_saves = true;
  EXPECT_FALSE(n->store().save_lss({true, 0x44, 2}));
  EXPECT_EQ(n->store().stored_lss().node_id, 0x33);
}

// The CRC-32 of IEEE 802.3 ("check" value of the CRC catalogue).
TEST(StoreBlob, Crc32OfTheCatalogueCheckString) {
  const std::string check = "123456789";
  EXPECT_EQ(crc32({reinterpret_cast<const std::uint8_t*>(check.data()), check.size()}), 0xCBF43926u);
  EXPECT_EQ(crc32({}), 0u);
}

TEST_F(Store, CorruptBlobIsIgnored) {
  SimNode& n = start();
  ASSERT_EQ(wr32(n, 0x2000, 0, 99), SdoAbort::kNone);
  ASSERT_EQ(wr32(n, 0x1010, 1, kSave), SdoAbort::kNone);
  n.storage.data[12] ^= 0x01;
  power_cycle(n);
  EXPECT_TRUE(n->store().corrupt());
  EXPECT_EQ(rd(n, 0x2000, 0), 7u);
  ASSERT_EQ(n.storage.rejections.size(), 1u);  // the owner can log it
  EXPECT_NE(n.storage.rejections[0].find("CRC"), std::string::npos);
  n.storage.data.resize(7);
  power_cycle(n);
  EXPECT_TRUE(n->store().corrupt());
}

// A CRC-valid blob with LSS node-ID 0 (CiA 305 stores 1..127 or 0xFF): the
// node would send on 0x700 and answer SDOs on 0x600. It is dropped as a
// whole, reported, and the configured node-ID applies.
TEST_F(Store, ImpossibleLssNodeIdDropsTheBlob) {
  SimNode& n = start();
  ASSERT_EQ(wr32(n, 0x2000, 0, 99), SdoAbort::kNone);
  ASSERT_EQ(wr32(n, 0x1010, 1, kSave), SdoAbort::kNone);
  ASSERT_TRUE(n->store().save_lss({true, 0, 2}));
  power_cycle(n);
  EXPECT_EQ(n->node_id(), 5);
  EXPECT_TRUE(n->store().corrupt());
  EXPECT_EQ(rd(n, 0x2000, 0), 7u);
  ASSERT_EQ(n.storage.rejections.size(), 1u);
  EXPECT_NE(n.storage.rejections[0].find("node-ID"), std::string::npos);
  ASSERT_TRUE(n->store().save_lss({true, 0x7F, 2}));  // the highest valid one is kept
  power_cycle(n);
  EXPECT_EQ(n->node_id(), 0x7F);
  EXPECT_EQ(n.storage.rejections.size(), 1u);
}

// A profile that changed since the save: vanished entries, entries that
// stopped being persistent or changed size are skipped; the rest applies.
TEST_F(Store, RobustToAChangedProfile) {
  SimNode& n = start();
  ASSERT_EQ(wr32(n, 0x2000, 0, 99), SdoAbort::kNone);
  ASSERT_EQ(wr16(n, 0x1017, 0, 333), SdoAbort::kNone);
  ASSERT_EQ(wr8(n, 0x3000, 0, 5), SdoAbort::kNone);
  ASSERT_EQ(set_string(n, "kept"), SdoAbort::kNone);
  ASSERT_EQ(wr32(n, 0x1010, 1, kSave), SdoAbort::kNone);
  std::string text = profile_text("{}", "");
  auto swap = [&](const std::string& from, const std::string& to) { text.replace(text.find(from), from.size(), to); };
  swap("{index: 0x2000, type: UNSIGNED32", "{index: 0x2000, type: UNSIGNED16");  // other size
  swap("default: 3, persistent: 4}", "default: 3}");                             // no longer stored
  swap("  - {index: 0x1017, type: UNSIGNED16, access: rw, default: 0, persistent: yes}\n", "");
  config::Profile changed = config::parse_profile(text);
  SimNode& m = add_profile(std::move(changed), 5);
  m.storage.data = n.storage.data;
  m.replace(5);
  m->power_on(now());
  EXPECT_FALSE(m->store().corrupt());
  EXPECT_EQ(rd(m, 0x2000, 0), 7u);
  EXPECT_EQ(rd(m, 0x3000, 0), 3u);
  EXPECT_EQ(get_string(m), "kept");
}

}  // namespace
}  // namespace cansim::nmt_test
