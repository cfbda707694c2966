// The device personalities' own `vendor:` keys: values land in the device
// settings, and a bad value fails with file:line:column: vendor.<key> and the
// personality's wording of what is expected.
#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <fstream>
#include <ostream>
#include <sstream>

#include "personalities/dps.hpp"
#include "personalities/gems9000.hpp"
#include "personalities/p92c.hpp"
#include "personalities/registry.hpp"
#include "personalities/smc.hpp"
#include "support/device.hpp"

namespace cansim::test {
namespace {

using Edits = std::initializer_list<std::pair<std::string, std::string>>;

// profiles/<name>.yaml with each `from` replaced by its `to` (the file's own line numbers).
std::string edited_text(const std::string& name, Edits edits) {
  std::ifstream in(std::string(CANSIM_SOURCE_DIR) + "/profiles/" + name + ".yaml");
  std::stringstream text;
  text << in.rdbuf();
  std::string s = text.str();
  for (const auto& [from, to] : edits) {
    const std::size_t at = s.find(from);
    EXPECT_NE(at, std::string::npos) << from;
    if (at != std::string::npos) s.replace(at, from.size(), to);
  }
  return s;
}
std::string file_of(const std::string& name) { return "profiles/" + name + ".yaml"; }
config::Profile edited(const std::string& name, Edits edits) {
  return config::parse_profile(edited_text(name, edits), file_of(name));
}
config::Profile edited(const std::string& name, const std::string& from, const std::string& to) {
  return edited(name, {{from, to}});
}
std::string edited_error(const std::string& name, const std::string& from, const std::string& to) {
  return load_error(edited_text(name, {{from, to}}), file_of(name));
}

template <class Settings>
Settings prepared_settings(const config::Profile& p) {
  return std::get<Settings>(p.device);
}

TEST(VendorParams, P92c) {
  auto s = prepared_settings<personalities::p92c::Settings>(
      edited("p92c", {{"serial_part1: 11", "serial_part1: 7"},
                      {"serial_part3: 5566", "serial_part3: 12"},
                      {"overload_counters: true", "overload_counters: no"},
                      {"sensor_fault_emcy: true", "sensor_fault_emcy: false"},
                      {"overload_emcy: false", "overload_emcy: yes"},
                      {"boot_emcys: true", "boot_emcys: off"},
                      {"monitor_period: 10 ms", "monitor_period: 20 ms"}}));
  EXPECT_EQ(s.serial_part1, 7);
  EXPECT_EQ(s.serial_part3, 12);
  EXPECT_FALSE(s.overload_counters);
  EXPECT_TRUE(s.overload_emcy);
  EXPECT_FALSE(s.boot_emcys);
  EXPECT_FALSE(s.sensor_fault_emcy);
  EXPECT_EQ(s.monitor_period_us, 20000);
}

TEST(VendorParams, Gems9000) {
  auto s = prepared_settings<personalities::gems9000::Settings>(
      edited("gems9000", {{"pin: 0x00001234", "pin: 0x4321"},
                          {"experienced_area_direct_nvm: true", "experienced_area_direct_nvm: no"},
                          {"autostart_on_nmt_reset: false", "autostart_on_nmt_reset: yes"},
                          {"boot_alias_2813: false",
                           "boot_alias_2813: true\n  emcy_register_mode: cia301\n  supervision_period: 2.5 ms"}}));
  EXPECT_EQ(s.pin, 0x4321u);
  EXPECT_TRUE(s.boot_alias_2813);
  EXPECT_FALSE(s.direct_nvm);
  EXPECT_TRUE(s.autostart_on_nmt_reset);
  EXPECT_FALSE(s.manual_error_register);
  EXPECT_EQ(s.supervision_period_us, 2500);
}

TEST(VendorParams, Smc) {
  auto s = prepared_settings<personalities::smc::Settings>(
      edited("smc", {{"stay_set_period: 10 ms", "stay_set_period: 5 ms"},
                     {"ad_fault_info: 0xC555", "ad_fault_info: 0x1234"},
                     {"reset_node_clears_error_register: false", "reset_node_clears_error_register: true"},
                     {"analog_error_reaction: true", "analog_error_reaction: false"}}));
  EXPECT_EQ(s.stay_set_period_us, 5000);
  EXPECT_EQ(s.ad_fault_info, 0x1234);
  EXPECT_TRUE(s.reset_node_clears_error_register);
  EXPECT_FALSE(s.analog_error_reaction);
}

TEST(VendorParams, Dps) {
  auto s = prepared_settings<personalities::dps::Settings>(
      edited("dps", {{"span_check_period: 1 ms", "span_check_period: 0.1 us"},
                     {"span_overflow_emcy: true", "span_overflow_emcy: false"},
                     {"autozero_shifts_span: true", "autozero_shifts_span: false"}}));
  EXPECT_EQ(s.span_check_period_us, 1);  // a positive period is at least 1 us
  EXPECT_FALSE(s.span_overflow_emcy);
  EXPECT_FALSE(s.autozero_shifts_span);
  EXPECT_EQ(prepared_settings<personalities::dps::Settings>(
                edited("dps", "span_check_period: 1 ms", "span_check_period: 2.6 ms"))
                .span_check_period_us,
            2600);
}

TEST(VendorParams, CmpAcceptsAZeroStartIndicationDelay) {
  EXPECT_EQ(edited_error("cmp", "mapping_modes:", "start_indication_delay: 0 s\n  mapping_modes:"), "no error");
}

// A bad value per key kind and device: the whole message, file:line:column included.
struct BadValue {
  const char* profile;
  const char* from;
  const char* to;
  const char* error;
};
void PrintTo(const BadValue& b, std::ostream* os) { *os << b.profile << ": " << b.to; }

const BadValue kBadValues[] = {
    {"p92c", "monitor_period: 10 ms", "monitor_period: 20 s",
     "profiles/p92c.yaml:63:19: vendor.monitor_period: expected 1 ms .. 10 s, got '20 s'"},
    {"p92c", "monitor_period: 10 ms", "monitor_period: 0.5 ms",
     "profiles/p92c.yaml:63:19: vendor.monitor_period: expected 1 ms .. 10 s, got '0.5 ms'"},
    {"p92c", "serial_part3: 5566", "serial_part3: 10000",
     "profiles/p92c.yaml:58:17: vendor.serial_part3: expected an integer in 0..9999, got '10000'"},
    {"p92c", "serial_number_base: 223344", "serial_number_base: -1",
     "profiles/p92c.yaml:56:23: vendor.serial_number_base: expected an integer in 0..4294967295, got '-1'"},
    {"p92c", "boot_emcys: true", "boot_emcys: maybe",
     "profiles/p92c.yaml:62:15: vendor.boot_emcys: expected true or false, got 'maybe'"},
    {"gems9000", "boot_alias_2813: false", "boot_alias_2813: false\n  supervision_period: 11 s",
     "profiles/gems9000.yaml:55:23: vendor.supervision_period: expected 1 ms .. 10 s, got '11 s'"},
    {"gems9000", "boot_alias_2813: false", "boot_alias_2813: false\n  emcy_register_mode: auto",
     "profiles/gems9000.yaml:55:23: vendor.emcy_register_mode: expected manual or cia301, got 'auto'"},
    {"gems9000", "pin: 0x00001234", "pin: -1",
     "profiles/gems9000.yaml:51:8: vendor.pin: expected an integer in 0..4294967295, got '-1'"},
    {"gems9000", "autostart_on_nmt_reset: false", "autostart_on_nmt_reset: 2",
     "profiles/gems9000.yaml:53:27: vendor.autostart_on_nmt_reset: expected true or false, got '2'"},
    {"smc", "stay_set_period: 10 ms", "stay_set_period: 2 s",
     "profiles/smc.yaml:48:20: vendor.stay_set_period: expected 1 ms .. 1 s, got '2 s'"},
    {"smc", "ad_fault_info: 0xC555", "ad_fault_info: 0x10000",
     "profiles/smc.yaml:45:18: vendor.ad_fault_info: expected an integer in 0..65535, got '0x10000'"},
    {"smc", "analog_error_reaction: true", "analog_error_reaction: [1]",
     "profiles/smc.yaml:47:26: vendor.analog_error_reaction: expected true or false"},
    {"dps", "span_check_period: 1 ms", "span_check_period: 0 s",
     "profiles/dps.yaml:42:22: vendor.span_check_period: expected a time > 0, got '0 s'"},
    {"dps", "span_overflow_emcy: true", "span_overflow_emcy: 1",
     "profiles/dps.yaml:40:23: vendor.span_overflow_emcy: expected true or false, got '1'"},
    {"cmp", "mapping_modes:", "start_indication_delay: -1 ms\n  mapping_modes:",
     "profiles/cmp.yaml:30:27: vendor.start_indication_delay: expected a time >= 0, got '-1 ms'"},
    {"cmp", "mapping_modes:", "start_indication_node_id: 128\n  mapping_modes:",
     "profiles/cmp.yaml:30:29: vendor.start_indication_node_id: expected an integer in 0..127, got '128'"},
};

class VendorParamsErrors : public ::testing::TestWithParam<BadValue> {};

TEST_P(VendorParamsErrors, NameFileLineColumnAndKey) {
  const BadValue& b = GetParam();
  EXPECT_EQ(edited_error(b.profile, b.from, b.to), b.error);
}

INSTANTIATE_TEST_SUITE_P(Devices, VendorParamsErrors, ::testing::ValuesIn(kBadValues));

}  // namespace
}  // namespace cansim::test
