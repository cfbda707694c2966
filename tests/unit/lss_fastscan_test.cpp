// Several LSS slaves on one bus (CiA 305): identify remote slave ranges,
// identify non-configured remote slave, and a fastscan master (written here)
// that finds two unconfigured nodes one after the other, gives each a node-ID
// and lets them boot.
#include <gtest/gtest.h>

#include <cstdio>
#include <deque>
#include <string>

#include "config/profile.hpp"
#include "support/sim.hpp"

namespace cansim {
namespace {

using test::F;
using test::Sent;
using test::SimBus;
using test::SimNode;

constexpr std::uint32_t kVendor = 0x00CA5D00;
constexpr std::uint32_t kProduct = 0x00000404;

config::Profile lss_profile(std::uint32_t revision, std::uint32_t serial, const std::string& options) {
  char text[1024];
  std::snprintf(text, sizeof text, R"(
name: lss-multi
node_id: 5
bit_rate: 250
options: %s
objects:
  - {index: 0x1000, type: UNSIGNED32, access: ro, default: 0x00020194}
  - {index: 0x1018, sub: 0, kind: record, type: UNSIGNED8, access: ro, default: 4}
  - {index: 0x1018, sub: 1, kind: record, type: UNSIGNED32, access: ro, default: 0x%08X}
  - {index: 0x1018, sub: 2, kind: record, type: UNSIGNED32, access: ro, default: 0x%08X}
  - {index: 0x1018, sub: 3, kind: record, type: UNSIGNED32, access: ro, default: 0x%08X}
  - {index: 0x1018, sub: 4, kind: record, type: UNSIGNED32, access: ro, default: 0x%08X}
)",
                options.c_str(), kVendor, kProduct, revision, serial);
  return config::parse_profile(std::string(text));
}

class LssBus : public ::testing::Test {
 protected:
  SimNode& add(std::uint8_t id, std::uint32_t revision, std::uint32_t serial, const std::string& options = "{}") {
    profiles_.push_back(lss_profile(revision, serial, options));
    return bus.add(profiles_.back(), id);
  }
  void start() {
    bus.power_on_all();
    bus.take();
  }
  void send(std::uint8_t cs, std::uint32_t value, std::uint8_t b5 = 0, std::uint8_t b6 = 0, std::uint8_t b7 = 0) {
    CanFrame f = F(0x7E5, {cs, 0, 0, 0, 0, b5, b6, b7});
    put_u32(f.data + 1, value);
    bus.inject(f);
  }
  // Frames sent since the last call.
  std::vector<Sent> sent() { return bus.take(); }
  // Identify remote slave with the given ranges; returns the replies.
  std::string identify(std::uint32_t vendor, std::uint32_t product, std::uint32_t rev_lo, std::uint32_t rev_hi,
                       std::uint32_t ser_lo, std::uint32_t ser_hi) {
    bus.take();
    const std::uint32_t v[6] = {vendor, product, rev_lo, rev_hi, ser_lo, ser_hi};
    for (std::uint8_t i = 0; i < 6; ++i) send(std::uint8_t(0x46 + i), v[i]);
    return test::to_string(bus.take());
  }
  // One fastscan request; true when at least one slave answered 0x4F.
  bool fastscan(std::uint32_t id, std::uint8_t bit, std::uint8_t sub, std::uint8_t next) {
    bus.take();
    send(0x51, id, bit, sub, next);
    bus.run_for(ms(1));  // the master's response timeout
    int answers = 0;
    for (const Sent& s : bus.take()) {
      EXPECT_EQ(s.frame.id, 0x7E4u);
      if (s.frame.id == 0x7E4 && s.frame.data[0] == 0x4F) ++answers;
    }
    return answers > 0;
  }
  // The master side of CiA 305 Fig. 46: reset, then every LSS number bit by
  // bit from 31 down to 0 (a bit is 1 when nobody answers the guess 0), then
  // the confirmed number moving to the next one. Fills `found`; false if no
  // unconfigured slave is left.
  bool fastscan_one(std::uint32_t found[4]) {
    if (!fastscan(0, 0x80, 0, 0)) return false;
    for (std::uint8_t sub = 0; sub < 4; ++sub) {
      std::uint32_t id = 0;
      for (int bit = 31; bit >= 0; --bit)
        if (!fastscan(id, std::uint8_t(bit), sub, sub)) id |= 1u << bit;
      const std::uint8_t next = std::uint8_t((sub + 1) % 4);
      EXPECT_TRUE(fastscan(id, 0, sub, next)) << "sub " << int(sub);
      found[sub] = id;
    }
    return true;
  }

  std::deque<config::Profile> profiles_;
  SimBus bus;
};

std::string S(std::initializer_list<Sent> frames) { return test::to_string(std::vector<Sent>(frames)); }

// ---------------------------------------------------------------- identify remote slave

TEST_F(LssBus, IdentifyRemoteSlaveRanges) {
  add(1, 0x00010000, 0x100);
  add(2, 0x00010005, 0x200);
  add(3, 0x00020000, 0x300);
  start();
  bus.run_for(ms(7));
  const CanFrame reply = F(0x7E4, {0x4F, 0, 0, 0, 0, 0, 0, 0});
  // Every slave inside all ranges answers (nodes 2 and 3 here: two frames).
  EXPECT_EQ(identify(kVendor, kProduct, 0, 0xFFFFFFFF, 0x150, 0x300), S({{ms(7), reply}, {ms(7), reply}}));
  EXPECT_EQ(identify(kVendor, kProduct, 0x00010000, 0x00010005, 0x100, 0x300), S({{ms(7), reply}, {ms(7), reply}}));
  EXPECT_EQ(identify(kVendor, kProduct, 0x00010001, 0x00010005, 0x100, 0x300), S({{ms(7), reply}}));
  EXPECT_EQ(identify(kVendor, kProduct, 0, 0xFFFFFFFF, 0x300, 0x300), S({{ms(7), reply}}));
  // Bounds that contain nobody, wrong vendor / product.
  EXPECT_EQ(identify(kVendor, kProduct, 0, 0xFFFFFFFF, 0x301, 0x400), "");
  EXPECT_EQ(identify(kVendor, kProduct, 0, 0xFFFF, 0, 0xFFFFFFFF), "");
  EXPECT_EQ(identify(kVendor, kProduct, 0x00030000, 0xFFFFFFFF, 0, 0xFFFFFFFF), "");
  EXPECT_EQ(identify(kVendor + 1, kProduct, 0, 0xFFFFFFFF, 0, 0xFFFFFFFF), "");
  EXPECT_EQ(identify(kVendor, kProduct + 1, 0, 0xFFFFFFFF, 0, 0xFFFFFFFF), "");
  // The order must be kept: skipping revision-low yields nothing.
  bus.take();
  send(0x46, kVendor);
  send(0x47, kProduct);
  send(0x49, 0xFFFFFFFF);
  send(0x4A, 0);
  send(0x4B, 0xFFFFFFFF);
  EXPECT_EQ(test::to_string(bus.take()), "");
}

TEST_F(LssBus, IdentifyRemoteSlaveInConfigurationStateToo) {
  SimNode& n = add(1, 0x00010000, 0x100);
  start();
  send(0x04, 1);
  ASSERT_TRUE(n->lss().configuring());
  EXPECT_EQ(identify(kVendor, kProduct, 0, 0xFFFFFFFF, 0, 0xFFFFFFFF), S({{0, F(0x7E4, {0x4F, 0, 0, 0, 0, 0, 0, 0})}}));
}

TEST_F(LssBus, IdentifyRevisionWildcardOption) {
  add(1, 0x00010000, 0x100, "{lss_identify_revision_zero_wildcard: true}");
  add(2, 0x00010000, 0x100);
  start();
  // low = high = 0: any revision for the first node, revision 0 only for the second.
  EXPECT_EQ(identify(kVendor, kProduct, 0, 0, 0x100, 0x100), S({{0, F(0x7E4, {0x4F, 0, 0, 0, 0, 0, 0, 0})}}));
}

TEST_F(LssBus, IdentifyServicesCanBeDisabled) {
  add(0xFF, 1, 0x100, "{lss_identify_services: false}");
  start();
  EXPECT_EQ(identify(kVendor, kProduct, 0, 0xFFFFFFFF, 0, 0xFFFFFFFF), "");
  send(0x4C, 0);
  EXPECT_EQ(test::to_string(bus.take()), "");
}

// ---------------------------------------------------------------- identify non-configured

TEST_F(LssBus, IdentifyNonConfiguredOnlyUnconfiguredNodesAnswer) {
  add(0xFF, 1, 0x100);
  add(4, 1, 0x200);
  add(0xFF, 1, 0x300);
  start();
  bus.run_for(ms(2));
  send(0x4C, 0);
  const CanFrame reply = F(0x7E4, {0x50, 0, 0, 0, 0, 0, 0, 0});
  EXPECT_EQ(test::to_string(bus.take()), S({{ms(2), reply}, {ms(2), reply}}));
}

// ---------------------------------------------------------------- fastscan

TEST_F(LssBus, FastscanIgnoredByConfiguredNodesAndWhenDisabled) {
  add(4, 1, 0x100);
  add(0xFF, 1, 0x200, "{lss_fastscan: false}");
  start();
  EXPECT_FALSE(fastscan(0, 0x80, 0, 0));
}

TEST_F(LssBus, FastscanResetConfirmsPresenceAndChecksBits) {
  SimNode& n = add(0xFF, 0x00010000, 0x000000A5);
  start();
  EXPECT_TRUE(fastscan(0, 0x80, 0, 0));
  // Vendor 0x00CA5D00: bits 31..24 are 0.
  EXPECT_TRUE(fastscan(0x00000000, 24, 0, 0));
  EXPECT_FALSE(fastscan(0x01000000, 24, 0, 0));
  EXPECT_TRUE(fastscan(0x00CA5D00, 0, 0, 0));
  EXPECT_FALSE(fastscan(0x00CA5D01, 0, 0, 0));
  // Wrong LSSSub for its position (still at the vendor-ID): no answer.
  EXPECT_FALSE(fastscan(kProduct, 0, 1, 2));
  // Invalid BitChecked / LSSSub / LSSNext are ignored.
  EXPECT_FALSE(fastscan(0x00CA5D00, 32, 0, 0));
  EXPECT_FALSE(fastscan(0x00CA5D00, 0, 4, 0));
  EXPECT_FALSE(fastscan(0x00CA5D00, 0, 0, 4));
  // Complete match of every number, the last one wrapping to the vendor-ID.
  EXPECT_TRUE(fastscan(0x00CA5D00, 0, 0, 1));
  EXPECT_TRUE(fastscan(kProduct, 0, 1, 2));
  EXPECT_TRUE(fastscan(0x00010000, 0, 2, 3));
  EXPECT_FALSE(n->lss().configuring());
  EXPECT_TRUE(fastscan(0x000000A5, 0, 3, 0));
  EXPECT_TRUE(n->lss().configuring());
  // In configuration state fastscan is not served.
  EXPECT_FALSE(fastscan(0, 0x80, 0, 0));
}

TEST_F(LssBus, FastscanSerialCheckedWithoutWrapDoesNotSelect) {
  SimNode& n = add(0xFF, 0x00010000, 0x000000A5);
  start();
  EXPECT_TRUE(fastscan(0, 0x80, 0, 0));
  EXPECT_TRUE(fastscan(0x00CA5D00, 0, 0, 1));
  EXPECT_TRUE(fastscan(kProduct, 0, 1, 2));
  EXPECT_TRUE(fastscan(0x00010000, 0, 2, 3));
  EXPECT_TRUE(fastscan(0x000000A5, 0, 3, 3));  // LSSNext = serial: not complete
  EXPECT_FALSE(n->lss().configuring());
}

// A slave that did not match when the master moved on stays silent until the
// next reset.
TEST_F(LssBus, FastscanSlaveLeftBehindStaysSilentUntilReset) {
  SimNode& a = add(0xFF, 1, 0x10);
  SimNode& b = add(0xFF, 2, 0x10);
  start();
  EXPECT_TRUE(fastscan(0, 0x80, 0, 0));
  EXPECT_TRUE(fastscan(kVendor, 0, 0, 1));
  EXPECT_TRUE(fastscan(kProduct, 0, 1, 2));
  EXPECT_TRUE(fastscan(1, 0, 2, 3));  // only a has revision 1
  EXPECT_EQ(a->lss().configuring(), false);
  // b is left at the revision: serial requests do not reach it.
  bus.take();
  send(0x51, 0x10, 0, 3, 0);
  std::vector<Sent> got = bus.take();
  ASSERT_EQ(got.size(), 1u);
  EXPECT_TRUE(a->lss().configuring());
  EXPECT_FALSE(b->lss().configuring());
  // After a reset, b takes part again (a is in configuration state now).
  EXPECT_TRUE(fastscan(0, 0x80, 0, 0));
  EXPECT_TRUE(fastscan(kVendor, 0, 0, 1));
  EXPECT_TRUE(fastscan(kProduct, 0, 1, 2));
  EXPECT_TRUE(fastscan(2, 0, 2, 3));
  EXPECT_TRUE(fastscan(0x10, 0, 3, 0));
  EXPECT_TRUE(b->lss().configuring());
}

// The full procedure: fastscan separates two unconfigured nodes that differ
// only in their serial numbers; each gets a node-ID and boots.
TEST_F(LssBus, FastscanSeparatesTwoUnconfiguredNodes) {
  SimNode& a = add(0xFF, 0x00010002, 0x0001A5A5);
  SimNode& b = add(0xFF, 0x00010002, 0x0000A5A5);
  start();
  EXPECT_EQ(a->state(), NmtState::kInitialising);
  EXPECT_EQ(b->state(), NmtState::kInitialising);

  std::uint32_t found[4] = {};
  ASSERT_TRUE(fastscan_one(found));
  // The scan finds the lower serial number first: node b.
  EXPECT_EQ(found[0], kVendor);
  EXPECT_EQ(found[1], kProduct);
  EXPECT_EQ(found[2], 0x00010002u);
  EXPECT_EQ(found[3], 0x0000A5A5u);
  EXPECT_TRUE(b->lss().configuring());
  EXPECT_FALSE(a->lss().configuring());

  send(0x11, 0x21);  // configure node-ID 0x21 (only b is in configuration state)
  EXPECT_EQ(test::to_string(sent()), S({{bus.now(), F(0x7E4, {0x11, 0, 0, 0, 0, 0, 0, 0})}}));
  bus.run_for(ms(5));
  send(0x04, 0);  // back to waiting: b resets communication and boots as 0x21
  EXPECT_EQ(test::to_string(sent()), S({{bus.now(), F(0x721, {0x00})}}));
  EXPECT_EQ(b->node_id(), 0x21);
  EXPECT_EQ(b->state(), NmtState::kPreOperational);
  EXPECT_EQ(a->node_id(), 0xFF);

  ASSERT_TRUE(fastscan_one(found));
  EXPECT_EQ(found[3], 0x0001A5A5u);
  EXPECT_TRUE(a->lss().configuring());
  send(0x11, 0x22);
  EXPECT_EQ(test::to_string(sent()), S({{bus.now(), F(0x7E4, {0x11, 0, 0, 0, 0, 0, 0, 0})}}));
  bus.run_for(ms(5));
  send(0x04, 0);
  EXPECT_EQ(test::to_string(sent()), S({{bus.now(), F(0x722, {0x00})}}));
  EXPECT_EQ(a->node_id(), 0x22);
  EXPECT_EQ(a->state(), NmtState::kPreOperational);

  // Nobody is left.
  EXPECT_FALSE(fastscan(0, 0x80, 0, 0));
  send(0x4C, 0);
  EXPECT_EQ(test::to_string(sent()), "");
}

}  // namespace
}  // namespace cansim
