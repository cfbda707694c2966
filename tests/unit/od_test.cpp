#include <gtest/gtest.h>

#include "config/profile.hpp"
#include "support/sim.hpp"

namespace cansim {
namespace {

const char* kProfile = R"(
name: t
node_id: 5
objects:
  - {index: 0x1000, type: UNSIGNED32, access: ro, default: 0x00020194}
  - {index: 0x1014, type: UNSIGNED32, access: rw, default: $NODEID+0x80}
  - {index: 0x1016, sub: 0, kind: array, type: UNSIGNED8, access: ro, default: 2}
  - {index: 0x1016, sub: 1..2, kind: array, type: UNSIGNED32, access: rw, default: 0}
  - {index: 0x2000, type: VISIBLE_STRING, access: rw, max_length: 10, default: "abc"}
  - {index: 0x2001, type: INTEGER16, access: rw, default: -5, low: -10, high: 100}
  - {index: 0x2002, type: REAL32, access: rw, default: 1.5}
  - {index: 0x2003, type: UNSIGNED8, access: wo}
)";

TEST(Od, LookupDistinguishesMissingObjectAndSub) {
  auto p = config::parse_profile(kProfile);
  SdoAbort why = SdoAbort::kNone;
  EXPECT_EQ(p.layout->lookup(0x1234, 0, why), nullptr);
  EXPECT_EQ(why, SdoAbort::kNoObject);
  EXPECT_EQ(p.layout->lookup(0x1016, 3, why), nullptr);
  EXPECT_EQ(why, SdoAbort::kNoSubIndex);
  ASSERT_NE(p.layout->lookup(0x1016, 2, why), nullptr);
}

TEST(Od, FindWithinAnObjectWithGapsInItsSubIndices) {
  auto p = config::parse_profile(R"(
name: t
objects:
  - {index: 0x1400, sub: 0, kind: record, type: UNSIGNED8, access: ro, default: 5}
  - {index: 0x1400, sub: 1, kind: record, type: UNSIGNED32, access: rw, default: 0x201}
  - {index: 0x1400, sub: 2, kind: record, type: UNSIGNED8, access: rw, default: 255}
  - {index: 0x1400, sub: 5, kind: record, type: UNSIGNED16, access: rw, default: 0}
  - {index: 0x1401, sub: 1, kind: record, type: UNSIGNED32, access: rw, default: 0x301}
)");
  const OdLayout& od = *p.layout;
  const OdObject& rpdo1 = *od.object(0x1400);
  for (std::uint8_t sub : {0, 1, 2, 5}) EXPECT_EQ(od.find(rpdo1, sub), od.find(0x1400, sub)) << int(sub);
  EXPECT_EQ(od.find(rpdo1, 3), nullptr);
  EXPECT_EQ(od.find(rpdo1, 6), nullptr);
  const OdObject& rpdo2 = *od.object(0x1401);  // no sub 0: entry 0 is sub 1
  EXPECT_EQ(od.find(rpdo2, 0), nullptr);
  EXPECT_EQ(od.find(rpdo2, 1), od.find(0x1401, 1));
}

TEST(Od, DefaultsWithNodeIdAndTypes) {
  auto p = config::parse_profile(kProfile);
  OdValues v(p.layout);
  v.reset(5);
  EXPECT_EQ(v.u(0x1000, 0), 0x00020194u);
  EXPECT_EQ(v.u(0x1014, 0), 0x85u);
  EXPECT_EQ(v.get_i(*p.layout->find(0x2001, 0)), -5);
  EXPECT_FLOAT_EQ(v.get_f(*p.layout->find(0x2002, 0)), 1.5f);
  EXPECT_EQ(v.get_string(*p.layout->find(0x2000, 0)), "abc");
}

// A reset communication reloads 0x1000-0x1FFF only (CiA 301 §7.3.2.2.1);
// values and string lengths outside the range stay as written.
TEST(Od, ResetOfAnIndexRangeLeavesTheRestAlone) {
  auto p = config::parse_profile(kProfile);
  const OdLayout& od = *p.layout;
  OdValues v(p.layout);
  v.reset(5);
  v.set_u(*od.find(0x1014, 0), 0x99);
  v.set_u(*od.find(0x1016, 1), 0x00050064);
  v.set_string(*od.find(0x2000, 0), "written!");
  v.set_i(*od.find(0x2001, 0), 42);
  v.set_f(*od.find(0x2002, 0), 2.5);
  v.reset(7, 0x1000, 0x1FFF);
  EXPECT_EQ(v.u(0x1014, 0), 0x87u);
  EXPECT_EQ(v.u(0x1016, 1), 0u);
  EXPECT_EQ(v.u(0x1016, 0), 2u);
  EXPECT_EQ(v.get_string(*od.find(0x2000, 0)), "written!");
  EXPECT_EQ(v.get_i(*od.find(0x2001, 0)), 42);
  v.reset(7, 0x2000, 0x2001);
  EXPECT_EQ(v.get_string(*od.find(0x2000, 0)), "abc");
  EXPECT_EQ(v.get_i(*od.find(0x2001, 0)), -5);
  EXPECT_FLOAT_EQ(v.get_f(*od.find(0x2002, 0)), 2.5f);
  v.reset(7, 0x3000, 0x3FFF);  // no entry in the range
  EXPECT_FLOAT_EQ(v.get_f(*od.find(0x2002, 0)), 2.5f);
}

TEST(Od, WriteChecksLengthLimitsAndAccess) {
  auto p = config::parse_profile(kProfile);
  const OdEntry& i16 = *p.layout->find(0x2001, 0);
  std::uint8_t too_low[2] = {0xF5, 0xFF};  // -11
  std::uint8_t ok_val[2] = {100, 0};
  std::uint8_t too_high[2] = {101, 0};
  EXPECT_EQ(check_value(i16, too_low), SdoAbort::kValueTooLow);
  EXPECT_EQ(check_value(i16, too_high), SdoAbort::kValueTooHigh);
  EXPECT_EQ(check_value(i16, ok_val), SdoAbort::kNone);
  EXPECT_EQ(check_value(i16, std::span<const std::uint8_t>(ok_val, 1)), SdoAbort::kLengthTooLow);
  std::uint8_t three[3] = {};
  EXPECT_EQ(check_value(i16, three), SdoAbort::kLengthTooHigh);
  const OdEntry& str = *p.layout->find(0x2000, 0);
  std::uint8_t eleven[11] = {};
  EXPECT_EQ(check_value(str, eleven), SdoAbort::kLengthTooHigh);
}

TEST(Profile, ErrorsNameFileLineAndKey) {
  try {
    config::parse_profile("objects:\n  - {index: 0x1000, type: UNSIGNED32, access: rx}\n", "p.yaml");
    FAIL() << "no error";
  } catch (const config::ConfigError& e) {
    std::string m = e.what();
    EXPECT_NE(m.find("p.yaml:2:"), std::string::npos) << m;
    EXPECT_NE(m.find("objects[0].access"), std::string::npos) << m;
    EXPECT_NE(m.find("'rx'"), std::string::npos) << m;
  }
  try {
    config::parse_profile("options: {no_such_option: 1}\nobjects: []\n", "q.yaml");
    FAIL() << "no error";
  } catch (const config::ConfigError& e) {
    EXPECT_NE(std::string(e.what()).find("q.yaml:1:"), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("options.no_such_option"), std::string::npos) << e.what();
  }
}

TEST(Profile, GenericProfileLoads) {
  auto p = test::load_repo_profile("generic-404");
  EXPECT_EQ(p.node_id, 0x10);
  EXPECT_EQ(config::bit_rate_index(p.bit_rate_kbit), 3);
  ASSERT_NE(p.layout->find(0x1018, 4), nullptr);
  EXPECT_TRUE(p.layout->find(0x6130, 1)->pdo_mappable);
  EXPECT_EQ(p.layout->find(0x1017, 0)->persist, kPersistCommunication);
  EXPECT_EQ(p.layout->find(0x6124, 1)->persist, kPersistApplication);
}

}  // namespace
}  // namespace cansim

namespace cansim {
namespace {
TEST(Profile, NodeIdExpressions) {
  auto p = config::parse_profile(R"(
node_id: 3
objects:
  - {index: 0x1800, sub: 1, type: UNSIGNED32, access: rw, default: 0x80000000+0x280+$NODEID}
  - {index: 0x1801, sub: 1, type: UNSIGNED32, access: rw, default: "$NODEID + 0x200"}
  - {index: 0x1802, sub: 1, type: UNSIGNED32, access: rw, default: 0x180+NodeID}
)");
  OdValues v(p.layout);
  v.reset(3);
  EXPECT_EQ(v.u(0x1800, 1), 0x80000283u);
  EXPECT_EQ(v.u(0x1801, 1), 0x203u);
  EXPECT_EQ(v.u(0x1802, 1), 0x183u);
}
}  // namespace
}  // namespace cansim
