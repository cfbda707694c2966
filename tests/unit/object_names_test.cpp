// Object names are unique within each object: every shipped profile's
// sub-indices carry distinct names (a range `sub: a..b` numbers them), and an
// exported EDS gives each sub-object a distinct ParameterName even when the
// profile does not (CiA 306 tools such as python-canopen look sub-objects up
// by name: od[0x6130]["AI input PV 1"]).
#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <map>
#include <set>
#include <sstream>

#include "config/eds_writer.hpp"
#include "config/profile.hpp"
#include "support/device.hpp"

namespace cansim::test {
namespace {

const char* const kProfiles[] = {"cmp", "dps", "gems9000", "generic-404", "p92c", "smc"};

// "[6130sub2]" -> 0x6130; "" for other lines.
std::optional<unsigned> sub_section_index(const std::string& line) {
  const auto sub = line.find("sub");
  if (line.size() < 8 || line[0] != '[' || sub != 5) return std::nullopt;
  return std::stoul(line.substr(1, 4), nullptr, 16);
}

// ParameterName of every sub-object section, by object index.
std::map<unsigned, std::vector<std::string>> eds_sub_names(const std::string& eds) {
  std::map<unsigned, std::vector<std::string>> out;
  std::istringstream in(eds);
  std::optional<unsigned> object;
  for (std::string line; std::getline(in, line);) {
    if (!line.empty() && line[0] == '[') object = sub_section_index(line);
    if (object && line.rfind("ParameterName=", 0) == 0) out[*object].push_back(line.substr(14));
  }
  return out;
}

std::vector<std::string> duplicates(const std::vector<std::string>& names) {
  std::set<std::string> seen;
  std::vector<std::string> twice;
  for (const std::string& n : names)
    if (!seen.insert(n).second) twice.push_back(n);
  return twice;
}

class ObjectNames : public ::testing::TestWithParam<const char*> {};

TEST_P(ObjectNames, EveryProfileNamesEachSubIndexOfAnObjectDistinctly) {
  const config::Profile p = prepared_repo_profile(GetParam());
  for (const OdObject& o : p.layout->objects()) {
    std::vector<std::string> names;
    for (std::uint16_t slot = o.first; slot < o.first + o.count; ++slot) names.push_back(p.layout->entry(slot).name);
    EXPECT_THAT(duplicates(names), ::testing::IsEmpty()) << GetParam() << " object 0x" << std::hex << o.index;
  }
}

TEST_P(ObjectNames, ExportedEdsHasDistinctParameterNamesPerObject) {
  const config::Profile p = prepared_repo_profile(GetParam());
  const std::string eds = config::write_eds(*p.layout, *p.options, config::identity_of(p));
  const auto names = eds_sub_names(eds);
  ASSERT_FALSE(names.empty());
  for (const auto& [index, list] : names)
    EXPECT_THAT(duplicates(list), ::testing::IsEmpty()) << GetParam() << " object 0x" << std::hex << index;
}

INSTANTIATE_TEST_SUITE_P(Shipped, ObjectNames, ::testing::ValuesIn(kProfiles), [](const auto& info) {
  return std::string(info.param) == "generic-404" ? "generic_404" : info.param;
});

TEST(ObjectNamesLoader, ARangeNumbersItsSubIndices) {
  const config::Profile p = prepared_repo_profile("generic-404");
  EXPECT_EQ(p.layout->find(0x6130, 1)->name, "AI input PV 1");
  EXPECT_EQ(p.layout->find(0x6130, 2)->name, "AI input PV 2");
  EXPECT_EQ(p.layout->find(0x1A00, 3)->name, "TPDO1 mapping entry 3");
}

TEST(ObjectNamesWriter, DuplicateNamesOfAnImportedProfileBecomeDistinct) {
  config::Profile p = prepared_repo_profile("generic-404");
  auto layout = std::make_shared<OdLayout>();
  for (const OdEntry& e : p.layout->entries()) {
    OdEntry copy = e;
    if (copy.index == 0x6130 && copy.sub > 0) copy.name = "AI input PV";  // as an EDS might say
    layout->add(copy);
  }
  layout->finalize();
  const auto names = eds_sub_names(config::write_eds(*layout, *p.options, config::identity_of(p)));
  EXPECT_THAT(names.at(0x6130),
              ::testing::ElementsAre("AI input PV - number of channels", "AI input PV", "AI input PV (sub 2)"));
}

TEST(ProfileEmcyCodes, TheManualsMeaningsLoadAndBadCodesNameTheLine) {
  EXPECT_EQ(prepared_repo_profile("p92c").emcy_codes.at(0xF011), "Error pressure");
  // The reference node names its personality's own codes (the DBC, the monitor).
  EXPECT_EQ(prepared_repo_profile("generic-404").emcy_codes.size(), 2u);
  EXPECT_TRUE(prepared_repo_profile("generic-404").emcy_codes.count(0x5030));
  const std::string error = repo_yaml_error("dps", [](YAML::Node& root) { root["emcy"]["0x12345"] = "too big"; });
  EXPECT_THAT(error, ::testing::HasSubstr("emcy"));
  EXPECT_THAT(error, ::testing::HasSubstr("expected an EMCY error code 0x0000..0xFFFF, got '0x12345'"));
}

}  // namespace
}  // namespace cansim::test
