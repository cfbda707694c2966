// Typed options: every option's kind is declared once in
// core/node_options.hpp and parsed by the loader, so a misspelt or
// out-of-range value fails --check with file:line:column, the option and
// what its kind expects; the services read typed values.
#include <gtest/gtest.h>

#include <string>

#include "core/node_options.hpp"
#include "support/device.hpp"

namespace cansim::test {
namespace {

// A profile with one option line (line 2: `options: {<option>}`, column 12).
std::string with_option(const std::string& option) {
  return "name: t\noptions: {" + option + "}\nobjects:\n  - {index: 0x1000, type: UNSIGNED32, access: ro}\n";
}

TEST(TypedOptions, AMisspeltEnumerationNamesTheChoices) {
  EXPECT_EQ(load_error(with_option("restore_mode: immedate"), "p.yaml"),
            "p.yaml:2:25: options.restore_mode: expected one of on_reset, immediate, ram, got 'immedate'");
  EXPECT_EQ(load_error(with_option("emcy_on_partial_clear: last"), "p.yaml"),
            "p.yaml:2:34: options.emcy_on_partial_clear: expected one of reset, latest, none, got 'last'");
}

TEST(TypedOptions, EveryKindRefusesWhatItDoesNotHold) {
  struct Case {
    const char* option;
    const char* error;
  };
  const Case cases[] = {
      {"sdo_block_transfer: maybe", "options.sdo_block_transfer: expected true or false, got 'maybe'"},
      {"sdo_min_request_dlc: 9", "options.sdo_min_request_dlc: expected an integer in 0..8, got '9'"},
      {"boot_up_delay_ms: -5", "options.boot_up_delay_ms: expected an integer in 0..3600000, got '-5'"},
      {"sdo_refusal_abort: 0x100000000",
       "options.sdo_refusal_abort: expected an integer in 0..0xFFFFFFFF, got '0x100000000'"},
      {"tpdo_allowed_types: '0-300'",
       "options.tpdo_allowed_types: expected ranges of values 0..255 like '0-240,252-255', got '0-300'"},
      {"lss_bit_rates: '4,x'",
       "options.lss_bit_rates: expected ranges of values 0..255 like '0-240,252-255', got '4,x'"},
      {"sdo_segmented_download_indices: '0x4022-0x4020'",
       "options.sdo_segmented_download_indices: expected ranges of values 0..0xFFFF like '0x4020-0x4022' (empty: "
       "every value), got '0x4022-0x4020'"},
      {"nmt_startup_values: '4,256'",
       "options.nmt_startup_values: expected ranges of values 0..255 like '0,2,8' (empty: every value), got '4,256'"},
      {"sdo_abort_map: '0x06090031='",
       "options.sdo_abort_map: expected up to 16 abort code pairs 'from=to' like "
       "'0x06090031=0x06090030,0x06090032=0x06090030', got '0x06090031='"},
  };
  for (const Case& c : cases) EXPECT_THAT(load_error(with_option(c.option)), ::testing::HasSubstr(c.error)) << c.option;
}

TEST(TypedOptions, ValuesAreTypedOnceLoaded) {
  const config::Profile p = config::parse_profile(
      with_option("restore_mode: ram, emcy_on_partial_clear: latest, tpdo_allowed_types: '1, 255', "
                  "sdo_abort_map: '0x06090031=0x06090030', sdo_segmented_download_indices: '0x4020-0x4022'"),
      "p.yaml");
  const NodeOptions& o = *p.options;
  EXPECT_EQ(o.restore_mode, RestoreMode::kRam);
  EXPECT_EQ(o.emcy_on_partial_clear, PartialClearEmcy::kLatest);
  EXPECT_TRUE(o.tpdo_allowed_types.has(1));
  EXPECT_TRUE(o.tpdo_allowed_types.has(255));
  EXPECT_FALSE(o.tpdo_allowed_types.has(254));
  EXPECT_EQ(o.sdo_abort_map.apply(0x06090031), 0x06090030u);
  EXPECT_TRUE(o.sdo_segmented_download_indices.contains(0x4021));
  EXPECT_FALSE(o.sdo_segmented_download_indices.contains(0x4023));
  // Written back as a profile writes them (the quirk inventory's text).
  EXPECT_EQ(option_text(o, "restore_mode"), "\"ram\"");
  EXPECT_EQ(option_text(o, "tpdo_allowed_types"), "\"1,255\"");
  EXPECT_EQ(option_text(o, "sdo_segmented_download_indices"), "\"0x4020-0x4022\"");
  EXPECT_EQ(option_text(o, "sdo_abort_map"), "\"0x06090031=0x06090030\"");
}

// Every option's text, as option_text writes it, loads back to the same
// value: for the defaults, the strict values and every shipped profile.
TEST(TypedOptions, TheTextOfEveryOptionLoadsBack) {
  std::vector<NodeOptions> all(2);
  make_strict(all[1]);
  for (const char* name : {"dps", "p92c", "gems9000", "smc", "cmp", "generic-404"})
    all.push_back(*load_repo_profile(name).options);
  for (const NodeOptions& o : all) {
    std::string map;
    for (const OptionInfo& info : option_infos())
      map += std::string(map.empty() ? "" : ", ") + info.name + ": " + option_text(o, info.name);
    const config::Profile back = config::parse_profile(with_option(map), "p.yaml");
    EXPECT_EQ(differing_options(o, *back.options), std::vector<std::string>{});
  }
}

}  // namespace
}  // namespace cansim::test
