// Strict mode (docs/profiles.md "Strict mode and quirks"): `strict` flips exactly the
// quirk inventory of every profile, the loader keeps `quirks:` and the
// deviations in step, and every personality in strict mode passes the same
// frame-by-frame CiA 301 / 305 service checks as the generic node.
#include <gmock/gmock.h>
#include <gtest/gtest-spi.h>
#include <gtest/gtest.h>

#include <algorithm>
#include <map>
#include <memory>
#include <set>

#include "config/fleet.hpp"
#include "config/strict_mode.hpp"
#include "support/device.hpp"

namespace cansim::test {
namespace {

using ::testing::HasSubstr;

const char* const kDevices[] = {"dps", "p92c", "gems9000", "smc", "cmp"};

config::Profile strict_repo_profile(const std::string& name) {
  return config::load_profile(std::string(CANSIM_SOURCE_DIR) + "/profiles/" + name + ".yaml", true);
}

std::set<std::string> names_with_prefix(const std::vector<config::Quirk>& rows, bool settings) {
  std::set<std::string> out;
  for (const config::Quirk& q : rows) {
    const bool is_setting = q.name.rfind("cia404.", 0) == 0 || q.name.rfind("vendor.", 0) == 0;
    const bool is_object = q.name.rfind("object ", 0) == 0;
    if (settings ? is_setting : (!is_setting && !is_object)) out.insert(q.name);
  }
  return out;
}

std::set<std::string> changed_objects(const OdLayout& a, const OdLayout& b) {
  std::set<std::string> out;
  auto key = [](const OdEntry& e) {
    char buf[32];
    std::snprintf(buf, sizeof buf, "object 0x%04X:%02X", e.index, e.sub);
    return std::string(buf);
  };
  for (const OdEntry& e : b.entries()) {
    const OdEntry* f = a.find(e.index, e.sub);
    if (!f || f->type != e.type || f->access != e.access || f->default_bytes != e.default_bytes ||
        f->default_plus_node_id != e.default_plus_node_id)
      out.insert(key(e));
  }
  for (const OdEntry& e : a.entries())
    if (!b.find(e.index, e.sub)) out.insert(key(e));
  return out;
}

std::set<std::string> object_rows(const std::vector<config::Quirk>& rows) {
  std::set<std::string> out;
  for (const config::Quirk& q : rows)
    if (q.name.rfind("object ", 0) == 0) out.insert(q.name);
  return out;
}

// ---- strict flips exactly the inventory

class Inventory : public ::testing::TestWithParam<const char*> {};

TEST_P(Inventory, StrictChangesExactlyTheInventory) {
  config::Profile faithful = prepared_repo_profile(GetParam());
  config::Profile strict = strict_repo_profile(GetParam());
  const std::vector<config::Quirk> rows = config::quirk_inventory(faithful);
  for (const config::Quirk& q : rows) {
    EXPECT_FALSE(q.reference.empty()) << q.name;
    EXPECT_NE(q.faithful, q.strict) << q.name;
  }
  const std::vector<std::string> diff = differing_options(*faithful.options, *strict.options);
  EXPECT_EQ(std::set<std::string>(diff.begin(), diff.end()), names_with_prefix(rows, false));
  EXPECT_EQ(changed_objects(*faithful.layout, *strict.layout), object_rows(rows));
  EXPECT_EQ(names_with_prefix(strict.setting_quirks, true), names_with_prefix(rows, true));
  // Nothing left to make strict.
  NodeOptions again = *strict.options;
  make_strict(again);
  EXPECT_TRUE(differing_options(again, *strict.options).empty());
}

TEST_P(Inventory, FaithfulIsTheDefault) {
  const config::Profile p = load_repo_profile(GetParam());
  EXPECT_FALSE(p.strict);
  EXPECT_TRUE(differing_options(*p.options, *p.faithful_options).empty());
  EXPECT_EQ(p.layout.get(), p.faithful_layout.get());
}

// CiA 301 §7.5.2.17: 0x1014 is mandatory where EMCY is supported, and every
// device sends EMCYs (Gems: its profile lacks it; strict mode adds it).
TEST_P(Inventory, StrictModeHasTheEmcyCobIdObject) {
  EXPECT_NE(strict_repo_profile(GetParam()).layout->find(0x1014, 0), nullptr);
}

INSTANTIATE_TEST_SUITE_P(Profiles, Inventory, ::testing::ValuesIn(kDevices));

TEST(StrictMode, GenericProfileHasNoQuirks) {
  const config::Profile p = prepared_repo_profile("generic-404");
  EXPECT_TRUE(config::quirk_inventory(p).empty());
}

TEST(StrictMode, QuirkCountsPerProfile) {
  // The inventory printed by `cansimd --quirks` (kept in step with docs/devices).
  const std::pair<const char*, std::size_t> counts[] = {
      {"dps", 16}, {"p92c", 23}, {"gems9000", 28}, {"smc", 18}, {"cmp", 6}};
  for (const auto& [name, n] : counts)
    EXPECT_EQ(config::quirk_inventory(prepared_repo_profile(name)).size(), n) << name;
}

// ---- the loader keeps `quirks:` and the deviations in step

const char* const kMini =
    "name: t\n"
    "objects:\n"
    "  - {index: 0x1000, type: UNSIGNED32, access: ro}\n";

TEST(StrictMode, DeviationWithoutReferenceIsRefused) {
  EXPECT_THAT(load_error(std::string(kMini) + "options: {sdo_in_stopped: true}\nquirks: {}\n"),
              HasSubstr("option 'sdo_in_stopped' deviates from CiA: `quirks:` needs its manual reference"));
  EXPECT_EQ(load_error(std::string(kMini) + "options: {sdo_in_stopped: true}\nquirks: {sdo_in_stopped: \"p. 3\"}\n"),
            "no error");
}

TEST(StrictMode, ProfileWithoutQuirksMapListsUndocumentedDeviations) {
  const config::Profile p = config::parse_profile(std::string(kMini) + "options: {sdo_in_stopped: true}\n", "t.yaml");
  const std::vector<config::Quirk> rows = config::option_quirks(p);
  ASSERT_EQ(rows.size(), 1u);
  EXPECT_EQ(rows[0].name, "sdo_in_stopped");
  EXPECT_EQ(rows[0].reference, config::kUndocumented);
}

TEST(StrictMode, ReferenceMustNameADeviation) {
  EXPECT_THAT(load_error(std::string(kMini) + "quirks: {sdo_in_stopped: \"p. 3\"}\n"),
              HasSubstr("keeps the CiA value"));
  EXPECT_THAT(load_error(std::string(kMini) + "options: {sdo_block_transfer: false}\n"
                                              "quirks: {sdo_block_transfer: \"p. 3\"}\n"),
              HasSubstr("a setting, not a deviation"));
  EXPECT_THAT(load_error(std::string(kMini) + "quirks: {no_such_thing: \"p. 3\"}\n"), HasSubstr("unknown option"));
  EXPECT_THAT(load_error(std::string(kMini) + "quirks: {\"object 0x1000:00\": \"p. 3\"}\n"),
              HasSubstr("expected a `strict_objects:` entry"));
  EXPECT_THAT(load_error(std::string(kMini) + "options: {sdo_in_stopped: true}\nquirks: {sdo_in_stopped: \"\"}\n"),
              HasSubstr("expected the manual's page or table"));
}

TEST(StrictMode, SettingQuirksAreCheckedByTheLoader) {
  EXPECT_THAT(repo_yaml_error("dps", [](YAML::Node& root) { root["quirks"].remove("vendor.autozero_shifts_span"); }),
              HasSubstr("setting 'vendor.autozero_shifts_span' deviates from CiA"));
  EXPECT_THAT(repo_yaml_error("generic-404", [](YAML::Node& root) { root["quirks"]["cia404.colour"] = "p. 1"; }),
              HasSubstr("not a chain or device setting strict mode changes"));
}

TEST(StrictMode, ProfileKeyTurnsItOn) {
  config::Profile p = load_repo_profile("dps");
  config::Profile s = prepared_repo_yaml("dps", [](YAML::Node& root) { root["strict"] = true; });
  EXPECT_TRUE(s.strict);
  EXPECT_FALSE(s.options->sdo_upload_response_0x60);
  EXPECT_FALSE(s.options->sdo_expedited_only);
  EXPECT_EQ(s.options->sdo_abort_map.count, 0);
  EXPECT_EQ(s.options->lss_bit_rates, p.options->lss_bit_rates);  // a setting: kept
}

TEST(StrictMode, FleetEntryOptionsWinOverStrict) {
  config::ProfileSearch search;
  search.dirs.push_back(std::string(CANSIM_SOURCE_DIR) + "/profiles");
  const config::FleetConfig fleet = config::parse_fleet(
      "interfaces: {vcan0: {bit_rate: 125}}\n"
      "nodes:\n"
      "  - {profile: dps, interface: vcan0, node_id: 1, name: a, strict: true, options: {sdo_expedited_only: true}}\n"
      "  - {profile: dps, interface: vcan0, node_id: 2, name: b}\n",
      "f.yaml", search);
  ASSERT_EQ(fleet.nodes.size(), 2u);
  const config::Profile& a = *fleet.nodes[0].profile;
  const config::Profile& b = *fleet.nodes[1].profile;
  EXPECT_TRUE(a.strict);
  EXPECT_TRUE(a.options->sdo_expedited_only);         // the entry's override
  EXPECT_FALSE(a.options->sdo_upload_response_0x60);  // strict
  EXPECT_FALSE(b.strict);
  EXPECT_TRUE(b.options->sdo_upload_response_0x60);  // faithful
}

TEST(StrictMode, WholeFleetKeepsEntryOverrides) {
  config::ProfileSearch search;
  search.dirs.push_back(std::string(CANSIM_SOURCE_DIR) + "/profiles");
  search.strict = true;  // cansimd --strict
  config::FleetConfig fleet = config::parse_fleet(
      "interfaces: {vcan0: {bit_rate: 125}}\n"
      "nodes:\n"
      "  - {profile: smc, interface: vcan0, node_id: 1, name: a, options: {restore_mode: ram}}\n"
      "  - {profile: smc, interface: vcan0, node_id: 2, name: b}\n",
      "f.yaml", search);
  EXPECT_EQ(fleet.nodes[0].profile->options->restore_mode, RestoreMode::kRam);
  EXPECT_EQ(fleet.nodes[1].profile->options->restore_mode, RestoreMode::kOnReset);
  EXPECT_EQ(fleet.nodes[1].profile->layout->find(0x1003, 0)->type, DataType::kUnsigned8);
}

// ---- every personality in strict mode: the generic node's CiA services

// Which quirks may explain a check failing in faithful mode.
const std::map<std::string, std::vector<std::string>> kExplainedBy = {
    {"ExpeditedUploadIsCiA", {"sdo_upload_response_0x60"}},
    {"LengthErrorsHaveTheirOwnCodes", {"sdo_abort_map"}},
    {"WrongToggleAbortsASegmentedDownload",
     {"sdo_expedited_only", "sdo_segmented_download", "sdo_segmented_download_indices"}},
    {"StalledSegmentedDownloadTimesOut",
     {"sdo_expedited_only", "sdo_segmented_download", "sdo_segmented_download_indices"}},
    {"NoSdoInStopped", {"sdo_in_stopped"}},
    {"TpdoStopsWhileItsCobIdIsInvalid", {"pdo_ignore_valid_bit", "tpdo_event_timer_types"}},
    {"MappingChangesOnlyWhileThePdoIsInvalid", {"pdo_mapping_needs_invalid", "pdo_mapping_locked_abort"}},
    {"ErrorHistoryFollowsCiA", {"emcy_history_bad_write_abort", "emcy_history_read_empty_abort", "object 0x1003:00"}},
    {"RestoreDefaultsTakesEffectAtResetNode", {"restore_mode", "store_bad_signature_abort"}},
    {"LssConfiguresNodeIdAndBitTiming",
     {"lss_only_in_stopped", "lss_node_id_ff_allowed", "lss_bit_timing_manual_layout", "lss_table_selector_1_is_cia",
      "lss_configuration_blocks_nmt"}},
    {"SyncWithUnexpectedLengthRaisesEmcy", {"sync_accept_any_dlc"}},
};

// Param "dps": strict mode, every check must pass. "faithful:dps": a failing
// check must be explained by a quirk of the profile's inventory.
class Conformance : public ::testing::TestWithParam<const char*> {
 protected:
  bool faithful() const { return std::string(GetParam()).rfind("faithful:", 0) == 0; }

  void SetUp() override {
    const std::string name = faithful() ? std::string(GetParam()).substr(9) : GetParam();
    if (faithful())
      reporter_ = std::make_unique<::testing::ScopedFakeTestPartResultReporter>(
          ::testing::ScopedFakeTestPartResultReporter::INTERCEPT_ONLY_CURRENT_THREAD, &failures_);
    profile_ = name == "generic-404" || faithful() ? prepared_repo_profile(name) : strict_repo_profile(name);
    id_ = profile_.node_id;
    app_ = personalities::make_application(profile_, {1, 0, "vcan0/" + name, {}});
    node_ = &bus_.add(profile_, id_, app_.get());
    bus_.power_on_all();
    bus_.run_for(ms(500));
    bus_.take();
  }

  void TearDown() override {
    if (!reporter_) return;
    reporter_.reset();
    std::string what;
    for (int i = 0; i < failures_.size(); ++i)
      if (failures_.GetTestPartResult(i).failed()) what += failures_.GetTestPartResult(i).message() + std::string("\n");
    if (what.empty()) return;  // passed (or skipped)
    const std::string check = ::testing::UnitTest::GetInstance()->current_test_info()->name();
    const std::string base = check.substr(0, check.find('/'));
    std::set<std::string> inventory;
    for (const config::Quirk& q : config::quirk_inventory(profile_)) inventory.insert(q.name);
    const auto it = kExplainedBy.find(base);
    if (it != kExplainedBy.end())
      for (const std::string& q : it->second)
        if (inventory.count(q)) return;
    ADD_FAILURE() << "faithful " << GetParam() << ": " << base << " differs from CiA without an inventory entry:\n"
                  << what;
  }

  std::vector<CanFrame> sdo(std::initializer_list<std::uint8_t> bytes) {
    bus_.inject(F(0x600u + id_, bytes));
    bus_.run_for(ms(2));
    return frames(only(bus_.take(), 0x580u + id_));
  }
  static std::vector<std::uint8_t> le(std::uint32_t v) {
    return {std::uint8_t(v), std::uint8_t(v >> 8), std::uint8_t(v >> 16), std::uint8_t(v >> 24)};
  }
  std::vector<CanFrame> write(std::uint16_t index, std::uint8_t sub, std::uint32_t v, int size) {
    const auto b = le(v);
    const std::uint8_t cs = std::uint8_t(0x23 | ((4 - size) << 2));
    return sdo({cs, std::uint8_t(index), std::uint8_t(index >> 8), sub, b[0], b[1], b[2], b[3]});
  }
  bool confirmed(const std::vector<CanFrame>& r) const { return r.size() == 1 && r[0].data[0] == 0x60; }
  std::uint32_t abort_code(const std::vector<CanFrame>& r) const {
    if (r.size() != 1 || r[0].data[0] != 0x80) return 0;
    return std::uint32_t(r[0].data[4]) | std::uint32_t(r[0].data[5]) << 8 | std::uint32_t(r[0].data[6]) << 16 |
           std::uint32_t(r[0].data[7]) << 24;
  }
  // Expedited upload: the value, or nullopt on abort / silence.
  std::optional<std::uint32_t> read(std::uint16_t index, std::uint8_t sub) {
    auto r = sdo({0x40, std::uint8_t(index), std::uint8_t(index >> 8), sub, 0, 0, 0, 0});
    if (r.size() != 1 || (r[0].data[0] & 0xE2) != 0x42) return std::nullopt;
    return std::uint32_t(r[0].data[4]) | std::uint32_t(r[0].data[5]) << 8 | std::uint32_t(r[0].data[6]) << 16 |
           std::uint32_t(r[0].data[7]) << 24;
  }
  void nmt(std::uint8_t cs) {
    bus_.inject(F(0x000, {cs, id_}));
    bus_.run_for(ms(5));
  }
  std::uint32_t tpdo1_cob() const {
    const OdEntry* e = profile_.layout->find(0x1800, 1);
    std::uint32_t v = 0;
    for (std::size_t i = 0; i < 4; ++i) v |= std::uint32_t(e->default_bytes[i]) << (8 * i);
    return (v & 0x7FF) + (e->default_plus_node_id ? id_ : 0);
  }
  std::uint32_t default_u(std::uint16_t index, std::uint8_t sub) const {
    const OdEntry* e = profile_.layout->find(index, sub);
    std::uint32_t v = 0;
    for (std::size_t i = 0; i < e->default_bytes.size() && i < 4; ++i)
      v |= std::uint32_t(e->default_bytes[i]) << (8 * i);
    return v;
  }
  // Makes TPDO1 event-driven with a 20 ms event timer (type 255, else 254).
  void tpdo1_every_20ms() {
    if (!confirmed(write(0x1800, 2, 255, 1))) {
      ASSERT_TRUE(confirmed(write(0x1800, 2, 254, 1)));
    }
    ASSERT_TRUE(confirmed(write(0x1800, 5, 20, 2)));
  }

  ::testing::TestPartResultArray failures_;
  std::unique_ptr<::testing::ScopedFakeTestPartResultReporter> reporter_;
  config::Profile profile_;
  std::unique_ptr<Application> app_;
  SimBus bus_;
  SimNode* node_ = nullptr;
  std::uint8_t id_ = 1;
};

TEST_P(Conformance, ExpeditedUploadIsCiA) {
  auto r = sdo({0x40, 0x00, 0x10, 0x00, 0, 0, 0, 0});
  ASSERT_EQ(r.size(), 1u);
  EXPECT_EQ(r[0].data[0] & 0xF2, 0x42) << "0x1000 read answered " << int(r[0].data[0]);
}

TEST_P(Conformance, LengthErrorsHaveTheirOwnCodes) {  // CiA 301 §7.2.4.3.17
  EXPECT_EQ(abort_code(write(0x1017, 0, 100, 4)), 0x06070012u);
  EXPECT_EQ(abort_code(write(0x1017, 0, 100, 1)), 0x06070013u);
}

TEST_P(Conformance, WrongToggleAbortsASegmentedDownload) {
  ASSERT_TRUE(confirmed(sdo({0x21, 0x17, 0x10, 0x00, 2, 0, 0, 0})));
  EXPECT_EQ(abort_code(sdo({0x1B, 100, 0, 0, 0, 0, 0, 0})), 0x05030000u);
}

TEST_P(Conformance, StalledSegmentedDownloadTimesOut) {
  ASSERT_TRUE(confirmed(sdo({0x21, 0x17, 0x10, 0x00, 2, 0, 0, 0})));
  bus_.run_for(ms(1500));
  EXPECT_EQ(abort_code(frames(only(bus_.take(), 0x580u + id_))), 0x05040000u);
}

TEST_P(Conformance, NoSdoInStopped) {  // CiA 301 §7.3.2.2.4
  nmt(0x02);
  EXPECT_TRUE(sdo({0x40, 0x00, 0x10, 0x00, 0, 0, 0, 0}).empty());
  nmt(0x80);
  EXPECT_EQ(sdo({0x40, 0x00, 0x10, 0x00, 0, 0, 0, 0}).size(), 1u);
}

TEST_P(Conformance, HeartbeatReportsTheState) {
  ASSERT_TRUE(confirmed(write(0x1017, 0, 50, 2)));
  bus_.run_for(ms(120));
  auto hb = only(bus_.take(), 0x700u + id_);
  ASSERT_GE(hb.size(), 2u);
  EXPECT_EQ(hb.back().frame.data[0], 0x7F);
  nmt(0x02);
  bus_.run_for(ms(60));
  hb = only(bus_.take(), 0x700u + id_);
  ASSERT_FALSE(hb.empty());
  EXPECT_EQ(hb.back().frame.data[0], 0x04);
}

TEST_P(Conformance, TpdoStopsWhileItsCobIdIsInvalid) {  // CiA 301 §7.5.2.35 bit 31
  tpdo1_every_20ms();
  nmt(0x01);
  bus_.run_for(ms(100));
  const std::uint32_t cob = tpdo1_cob();
  EXPECT_FALSE(only(bus_.take(), cob).empty()) << "TPDO1 silent";
  ASSERT_TRUE(confirmed(write(0x1800, 1, 0x80000000u | 0x40000000u | cob, 4)));
  bus_.run_for(ms(100));
  EXPECT_TRUE(only(bus_.take(), cob).empty()) << "TPDO1 sent with COB-ID bit 31 set";
}

TEST_P(Conformance, MappingChangesOnlyWhileThePdoIsInvalid) {  // CiA 301 §7.5.2.36
  const Access access = profile_.layout->find(0x1A00, 0)->access;
  if (access == Access::kRo || access == Access::kConst) GTEST_SKIP() << "static mapping (0x1A00 read-only)";
  const std::uint32_t cob = tpdo1_cob();
  if (read(0x1800, 1).value_or(0x80000000u) & 0x80000000u) {
    ASSERT_TRUE(confirmed(write(0x1800, 1, 0x40000000u | cob, 4)));
  }
  EXPECT_EQ(abort_code(write(0x1A00, 0, 0, 1)), 0x06090030u);
  ASSERT_TRUE(confirmed(write(0x1800, 1, 0xC0000000u | cob, 4)));
  EXPECT_TRUE(confirmed(write(0x1A00, 0, 0, 1)));
  EXPECT_NE(abort_code(write(0x1A00, 0, 0x40, 1)), 0u);  // more entries than the record has
}

TEST_P(Conformance, ErrorHistoryFollowsCiA) {  // CiA 301 §7.5.2.6
  EXPECT_TRUE(confirmed(write(0x1003, 0, 0, 1)));
  EXPECT_EQ(abort_code(write(0x1003, 0, 1, 1)), 0x06090030u);
  EXPECT_EQ(read(0x1003, 0), 0u);
  EXPECT_EQ(abort_code(sdo({0x40, 0x03, 0x10, 0x01, 0, 0, 0, 0})), 0x08000024u);
}

TEST_P(Conformance, RestoreDefaultsTakesEffectAtResetNode) {  // CiA 301 §7.5.2.14
  const std::uint32_t def = default_u(0x1017, 0);
  ASSERT_TRUE(confirmed(write(0x1017, 0, 1234, 2)));
  ASSERT_TRUE(confirmed(write(0x1010, 1, 0x65766173, 4)));  // "save"
  nmt(0x81);
  bus_.run_for(ms(500));
  bus_.take();
  EXPECT_EQ(read(0x1017, 0), 1234u) << "saved value lost at reset node";
  ASSERT_TRUE(confirmed(write(0x1011, 1, 0x64616F6C, 4)));  // "load"
  EXPECT_EQ(read(0x1017, 0), 1234u) << "load changed the value before the reset";
  nmt(0x81);
  bus_.run_for(ms(500));
  bus_.take();
  EXPECT_EQ(read(0x1017, 0), def) << "restored default not in effect after reset node";
  EXPECT_EQ(abort_code(write(0x1010, 1, 0x12345678, 4)), 0x08000020u);
}

TEST_P(Conformance, LssConfiguresNodeIdAndBitTiming) {  // CiA 305 §5.x
  auto lss = [&](std::initializer_list<std::uint8_t> bytes) {
    bus_.inject(F(0x7E5, bytes));
    bus_.run_for(ms(5));
    return frames(only(bus_.take(), 0x7E4));
  };
  EXPECT_TRUE(lss({0x04, 0x01, 0, 0, 0, 0, 0, 0}).empty());  // switch state global: configuration
  auto r = lss({0x11, 0x22, 0, 0, 0, 0, 0, 0});
  ASSERT_EQ(r.size(), 1u);
  EXPECT_EQ(r[0].data[0], 0x11);
  EXPECT_EQ(r[0].data[1], 0x00);
  r = lss({0x11, 0xFF, 0, 0, 0, 0, 0, 0});  // back to unconfigured is allowed
  ASSERT_EQ(r.size(), 1u);
  EXPECT_EQ(r[0].data[1], 0x00);
  r = lss({0x13, 0x00, 0x03, 0, 0, 0, 0, 0});  // table 0, index 3 = 250 kbit/s
  ASSERT_EQ(r.size(), 1u);
  EXPECT_EQ(r[0].data[0], 0x13);
  EXPECT_EQ(r[0].data[1], 0x00);
  r = lss({0x13, 0x01, 0x03, 0, 0, 0, 0, 0});  // a user table the device does not have
  ASSERT_EQ(r.size(), 1u);
  EXPECT_NE(r[0].data[1], 0x00);
  r = lss({0x11, 0x22, 0, 0, 0, 0, 0, 0});
  EXPECT_TRUE(lss({0x04, 0x00, 0, 0, 0, 0, 0, 0}).empty());  // waiting: node-ID applies at reset comm.
}

TEST_P(Conformance, SyncWithUnexpectedLengthRaisesEmcy) {  // CiA 301 §7.2.5.3: 0x1019 = 0
  if (!profile_.layout->find(0x1005, 0)) GTEST_SKIP() << "no SYNC consumer";
  bus_.inject(F(0x080, {0x01}));
  bus_.run_for(ms(5));
  auto emcy = only(bus_.take(), 0x80u + id_);
  ASSERT_EQ(emcy.size(), 1u);
  EXPECT_EQ(emcy[0].frame.data[0], 0x40);
  EXPECT_EQ(emcy[0].frame.data[1], 0x82);
}

INSTANTIATE_TEST_SUITE_P(StrictDevices, Conformance,
                         ::testing::Values("generic-404", "dps", "p92c", "gems9000", "smc", "cmp"));
INSTANTIATE_TEST_SUITE_P(FaithfulDevices, Conformance,
                         ::testing::Values("faithful:dps", "faithful:p92c", "faithful:gems9000", "faithful:smc",
                                           "faithful:cmp"));

}  // namespace
}  // namespace cansim::test
