// LSS slave (CiA 305) services, frame by frame on a SimBus: switch state
// global / selective, configure node-ID and bit timing, activate bit timing,
// store configuration, inquire, unconfigured nodes, vendor options.
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
constexpr std::uint32_t kRevision = 0x00010002;
constexpr std::uint32_t kSerial = 0x12345678;

// A small node: identity, one $NODEID object, no heartbeat (so the log only
// holds LSS and boot-up frames). Bit rate 250 kbit/s = CiA index 3.
config::Profile lss_profile(std::uint32_t serial, const std::string& options) {
  char text[1024];
  std::snprintf(text, sizeof text, R"(
name: lss-test
node_id: 5
bit_rate: 250
options: %s
objects:
  - {index: 0x1000, type: UNSIGNED32, access: ro, default: 0x00020194}
  - {index: 0x1014, type: UNSIGNED32, access: rw, default: $NODEID+0x80}
  - {index: 0x1018, sub: 0, kind: record, type: UNSIGNED8, access: ro, default: 4}
  - {index: 0x1018, sub: 1, kind: record, type: UNSIGNED32, access: ro, default: 0x%08X}
  - {index: 0x1018, sub: 2, kind: record, type: UNSIGNED32, access: ro, default: 0x%08X}
  - {index: 0x1018, sub: 3, kind: record, type: UNSIGNED32, access: ro, default: 0x%08X}
  - {index: 0x1018, sub: 4, kind: record, type: UNSIGNED32, access: ro, default: 0x%08X}
)",
                options.c_str(), kVendor, kProduct, kRevision, serial);
  return config::parse_profile(std::string(text));
}

std::string S(std::initializer_list<Sent> frames) { return test::to_string(std::vector<Sent>(frames)); }

class Lss : public ::testing::Test {
 protected:
  // A node with the given node-ID (0xFF = unconfigured), powered on; the log is cleared.
  SimNode& add(std::uint8_t id, const std::string& options = "{}", std::uint32_t serial = kSerial) {
    profiles_.push_back(lss_profile(serial, options));
    SimNode& n = bus.add(profiles_.back(), id);
    return n;
  }
  void start() {
    bus.power_on_all();
    bus.take();
  }
  // Master request on 0x7E5 (8 bytes, zero padded); returns what the nodes sent.
  std::string req(std::initializer_list<std::uint8_t> bytes) {
    CanFrame f = F(0x7E5, {0, 0, 0, 0, 0, 0, 0, 0});
    std::size_t i = 0;
    for (std::uint8_t b : bytes) f.data[i++] = b;
    bus.inject(f);
    return test::to_string(bus.take());
  }
  std::string nmt(std::uint8_t cs, std::uint8_t id) {
    bus.inject(F(0x000, {cs, id}));
    return test::to_string(bus.take());
  }
  TimeUs t() const { return bus.now(); }

  std::deque<config::Profile> profiles_;  // outlives the bus
  SimBus bus;
};

// ---------------------------------------------------------------- switch state global

TEST_F(Lss, SwitchGlobalGatesConfigurationServices) {
  SimNode& n = add(5);
  start();
  bus.run_for(ms(1));
  EXPECT_EQ(req({0x5E}), "");  // inquire node-ID: configuration state only
  EXPECT_EQ(req({0x11, 0x07}), "");
  EXPECT_EQ(req({0x04, 0x01}), "");  // no reply
  EXPECT_TRUE(n->lss().configuring());
  EXPECT_EQ(req({0x5E}), S({{t(), F(0x7E4, {0x5E, 0x05, 0, 0, 0, 0, 0, 0})}}));
  bus.run_for(ms(1));
  EXPECT_EQ(req({0x04, 0x00}), "");
  EXPECT_FALSE(n->lss().configuring());
  EXPECT_EQ(req({0x5E}), "");
  // Modes other than 0 / 1 change nothing.
  EXPECT_EQ(req({0x04, 0x02}), "");
  EXPECT_FALSE(n->lss().configuring());
}

TEST_F(Lss, InquireIdentityAndNodeId) {
  add(5);
  start();
  req({0x04, 0x01});
  bus.run_for(ms(2));
  EXPECT_EQ(req({0x5A}), S({{t(), F(0x7E4, {0x5A, 0x00, 0x5D, 0xCA, 0x00, 0, 0, 0})}}));
  EXPECT_EQ(req({0x5B}), S({{t(), F(0x7E4, {0x5B, 0x04, 0x04, 0x00, 0x00, 0, 0, 0})}}));
  EXPECT_EQ(req({0x5C}), S({{t(), F(0x7E4, {0x5C, 0x02, 0x00, 0x01, 0x00, 0, 0, 0})}}));
  EXPECT_EQ(req({0x5D}), S({{t(), F(0x7E4, {0x5D, 0x78, 0x56, 0x34, 0x12, 0, 0, 0})}}));
  EXPECT_EQ(req({0x5E}), S({{t(), F(0x7E4, {0x5E, 0x05, 0, 0, 0, 0, 0, 0})}}));
  EXPECT_EQ(req({0x5F}), "");  // unknown command specifier
}

TEST_F(Lss, FramesWithOtherDlcOrRtrAreIgnored) {
  SimNode& n = add(5);
  start();
  bus.inject(F(0x7E5, {0x04, 0x01}));  // DLC 2
  EXPECT_FALSE(n->lss().configuring());
  bus.inject(CanFrame::remote(0x7E5, 8));
  EXPECT_FALSE(n->lss().configuring());
  CanFrame ext = F(0x7E5, {0x04, 0x01, 0, 0, 0, 0, 0, 0});
  ext.flags = CanFrame::kExtended;
  bus.inject(ext);
  EXPECT_FALSE(n->lss().configuring());
  EXPECT_EQ(req({0x04, 0x01}), "");
  bus.inject(F(0x7E5, {0x5E, 0, 0, 0, 0, 0, 0}));  // DLC 7
  EXPECT_EQ(test::to_string(bus.take()), "");
}

// ---------------------------------------------------------------- switch state selective

TEST_F(Lss, SelectiveSwitchNeedsAllFourInOrder) {
  SimNode& a = add(5, "{}", kSerial);
  SimNode& b = add(6, "{}", kSerial + 1);
  start();
  bus.run_for(ms(3));
  EXPECT_EQ(req({0x40, 0x00, 0x5D, 0xCA, 0x00}), "");
  EXPECT_EQ(req({0x41, 0x04, 0x04, 0x00, 0x00}), "");
  EXPECT_EQ(req({0x42, 0x02, 0x00, 0x01, 0x00}), "");
  EXPECT_EQ(req({0x43, 0x78, 0x56, 0x34, 0x12}), S({{t(), F(0x7E4, {0x44, 0, 0, 0, 0, 0, 0, 0})}}));
  EXPECT_TRUE(a->lss().configuring());
  EXPECT_FALSE(b->lss().configuring());
  // Only the selected node answers configuration services.
  EXPECT_EQ(req({0x5E}), S({{t(), F(0x7E4, {0x5E, 0x05, 0, 0, 0, 0, 0, 0})}}));
}

TEST_F(Lss, SelectiveSwitchWrongValuesOrOrderDoNotSelect) {
  SimNode& n = add(5);
  start();
  auto full = [&](std::uint32_t vendor, std::uint32_t product, std::uint32_t rev, std::uint32_t serial) {
    std::string out;
    const std::uint32_t v[4] = {vendor, product, rev, serial};
    for (std::uint8_t i = 0; i < 4; ++i)
      out += req({std::uint8_t(0x40 + i), std::uint8_t(v[i]), std::uint8_t(v[i] >> 8), std::uint8_t(v[i] >> 16),
                  std::uint8_t(v[i] >> 24)});
    return out;
  };
  EXPECT_EQ(full(kVendor + 1, kProduct, kRevision, kSerial), "");
  EXPECT_EQ(full(kVendor, kProduct + 1, kRevision, kSerial), "");
  EXPECT_EQ(full(kVendor, kProduct, kRevision + 1, kSerial), "");
  EXPECT_EQ(full(kVendor, kProduct, 0, kSerial), "");  // no wildcard by default
  EXPECT_EQ(full(kVendor, kProduct, kRevision, kSerial - 1), "");
  EXPECT_FALSE(n->lss().configuring());
  // Out of order: product before vendor, then the rest -> no match.
  req({0x41, 0x04, 0x04, 0x00, 0x00});
  req({0x40, 0x00, 0x5D, 0xCA, 0x00});
  req({0x42, 0x02, 0x00, 0x01, 0x00});
  EXPECT_EQ(req({0x43, 0x78, 0x56, 0x34, 0x12}), "");
  // Skipping the revision -> no match.
  req({0x40, 0x00, 0x5D, 0xCA, 0x00});
  req({0x41, 0x04, 0x04, 0x00, 0x00});
  EXPECT_EQ(req({0x43, 0x78, 0x56, 0x34, 0x12}), "");
  EXPECT_FALSE(n->lss().configuring());
  // A mismatch in the middle restarts matching; a fresh complete sequence works.
  req({0x40, 0x00, 0x5D, 0xCA, 0x00});
  req({0x41, 0x05, 0x04, 0x00, 0x00});
  req({0x42, 0x02, 0x00, 0x01, 0x00});
  EXPECT_EQ(req({0x43, 0x78, 0x56, 0x34, 0x12}), "");
  bus.run_for(ms(1));
  EXPECT_EQ(full(kVendor, kProduct, kRevision, kSerial), S({{t(), F(0x7E4, {0x44, 0, 0, 0, 0, 0, 0, 0})}}));
  // In configuration state a selective sequence is not a service any more.
  EXPECT_EQ(full(kVendor, kProduct, kRevision, kSerial), "");
}

TEST_F(Lss, RevisionZeroWildcardOption) {
  SimNode& n = add(5, "{lss_revision_zero_wildcard: true}");
  start();
  req({0x40, 0x00, 0x5D, 0xCA, 0x00});
  req({0x41, 0x04, 0x04, 0x00, 0x00});
  req({0x42, 0x00, 0x00, 0x00, 0x00});
  EXPECT_EQ(req({0x43, 0x78, 0x56, 0x34, 0x12}), S({{t(), F(0x7E4, {0x44, 0, 0, 0, 0, 0, 0, 0})}}));
  EXPECT_TRUE(n->lss().configuring());
}

// ---------------------------------------------------------------- configure node-ID

TEST_F(Lss, ConfigureNodeIdRangeAndErrors) {
  SimNode& n = add(5);
  start();
  req({0x04, 0x01});
  const std::string ok = "0us 7E4 [8] 11 00 00 00 00 00 00 00\n";
  const std::string out_of_range = "0us 7E4 [8] 11 01 00 00 00 00 00 00\n";
  EXPECT_EQ(req({0x11, 0x00}), out_of_range);
  EXPECT_EQ(req({0x11, 0x80}), out_of_range);
  EXPECT_EQ(req({0x11, 0xFE}), out_of_range);
  EXPECT_EQ(n->lss().pending_node_id(), 5);
  EXPECT_EQ(req({0x11, 0x01}), ok);
  EXPECT_EQ(req({0x11, 0x7F}), ok);
  EXPECT_EQ(req({0x11, 0xFF}), ok);  // back to unconfigured is allowed
  EXPECT_EQ(n->lss().pending_node_id(), 0xFF);
  EXPECT_EQ(req({0x11, 0x0A}), ok);
  EXPECT_EQ(n->lss().pending_node_id(), 0x0A);
  // Pending only: the active node-ID is unchanged.
  EXPECT_EQ(n->node_id(), 5);
  EXPECT_EQ(req({0x5E}), "0us 7E4 [8] 5E 05 00 00 00 00 00 00\n");
}

TEST_F(Lss, ConfigureNodeIdFfRefusedByOption) {
  add(5, "{lss_node_id_ff_allowed: false}");
  start();
  req({0x04, 0x01});
  EXPECT_EQ(req({0x11, 0xFF}), "0us 7E4 [8] 11 01 00 00 00 00 00 00\n");
}

// Configured node: the new ID waits for NMT reset communication (CiA 305).
TEST_F(Lss, PendingNodeIdBecomesActiveAtResetCommunication) {
  SimNode& n = add(5);
  start();
  req({0x04, 0x01});
  req({0x11, 0x0A});
  bus.run_for(ms(5));
  EXPECT_EQ(req({0x04, 0x00}), "");  // configured node: no reset of its own
  EXPECT_EQ(n->node_id(), 5);
  EXPECT_EQ(n->state(), NmtState::kPreOperational);
  bus.run_for(ms(5));
  EXPECT_EQ(nmt(0x82, 0x05), S({{t(), F(0x70A, {0x00})}}));
  EXPECT_EQ(n->node_id(), 0x0A);
  EXPECT_EQ(n->values().u(0x1014, 0), 0x8Au);  // $NODEID defaults follow
  EXPECT_EQ(n->lss().pending_node_id(), 0x0A);
  EXPECT_FALSE(n->lss().configuring());  // reset communication -> LSS waiting
  // The node now answers NMT on its new ID only.
  bus.run_for(ms(1));
  EXPECT_EQ(nmt(0x82, 0x05), "");
  EXPECT_EQ(nmt(0x82, 0x0A), S({{t(), F(0x70A, {0x00})}}));
}

TEST_F(Lss, PendingNodeIdBecomesActiveAtResetNode) {
  SimNode& n = add(5);
  start();
  req({0x04, 0x01});
  req({0x11, 0x30});
  bus.run_for(ms(2));
  EXPECT_EQ(nmt(0x81, 0x05), S({{t(), F(0x730, {0x00})}}));
  EXPECT_EQ(n->node_id(), 0x30);
}

// Configure node-ID 0xFF + reset communication: the node becomes unconfigured,
// falls silent and is found again by identify non-configured.
TEST_F(Lss, ConfiguringFfMakesTheNodeUnconfiguredAtReset) {
  SimNode& n = add(5);
  start();
  req({0x04, 0x01});
  req({0x11, 0xFF});
  req({0x04, 0x00});
  EXPECT_EQ(nmt(0x82, 0x05), "");  // no boot-up
  EXPECT_EQ(n->node_id(), 0xFF);
  EXPECT_EQ(n->state(), NmtState::kInitialising);
  EXPECT_EQ(req({0x4C}), "0us 7E4 [8] 50 00 00 00 00 00 00 00\n");
}

// ---------------------------------------------------------------- unconfigured node

TEST_F(Lss, UnconfiguredNodeBootsWithNewIdWhenSwitchedToWaiting) {
  SimNode& n = add(0xFF);
  bus.power_on_all();
  EXPECT_EQ(test::to_string(bus.take()), "");  // boots silent, waits for LSS
  EXPECT_EQ(n->state(), NmtState::kInitialising);
  bus.run_for(ms(10));
  EXPECT_EQ(req({0x4C}), S({{t(), F(0x7E4, {0x50, 0, 0, 0, 0, 0, 0, 0})}}));
  EXPECT_EQ(req({0x04, 0x01}), "");
  EXPECT_EQ(req({0x5E}), S({{t(), F(0x7E4, {0x5E, 0xFF, 0, 0, 0, 0, 0, 0})}}));
  EXPECT_EQ(req({0x11, 0x03}), S({{t(), F(0x7E4, {0x11, 0x00, 0, 0, 0, 0, 0, 0})}}));
  // A pending node-ID makes it "configured" for identify non-configured.
  EXPECT_EQ(req({0x4C}), "");
  bus.run_for(ms(10));
  EXPECT_EQ(req({0x04, 0x00}), S({{t(), F(0x703, {0x00})}}));
  EXPECT_EQ(n->node_id(), 3);
  EXPECT_EQ(n->state(), NmtState::kPreOperational);
  EXPECT_EQ(n->values().u(0x1014, 0), 0x83u);
  EXPECT_EQ(nmt(0x01, 0x03), "");
  EXPECT_EQ(n->state(), NmtState::kOperational);
}

TEST_F(Lss, UnconfiguredNodeSwitchedToWaitingWithoutIdStaysSilent) {
  SimNode& n = add(0xFF);
  bus.power_on_all();
  bus.take();
  req({0x04, 0x01});
  EXPECT_EQ(req({0x04, 0x00}), "");
  EXPECT_EQ(n->node_id(), 0xFF);
  EXPECT_EQ(n->state(), NmtState::kInitialising);
}

// ---------------------------------------------------------------- bit timing

TEST_F(Lss, ConfigureBitTimingTableAndErrors) {
  SimNode& n = add(5);  // lss_bit_rates default "0-4,6-8"
  start();
  EXPECT_EQ(req({0x13, 0x00, 0x02}), "");  // waiting state: ignored
  req({0x04, 0x01});
  const std::string ok = "0us 7E4 [8] 13 00 00 00 00 00 00 00\n";
  const std::string unsupported = "0us 7E4 [8] 13 01 00 00 00 00 00 00\n";
  EXPECT_EQ(req({0x13, 0x00, 0x05}), unsupported);  // reserved
  EXPECT_EQ(req({0x13, 0x00, 0x09}), unsupported);  // auto bit rate
  EXPECT_EQ(req({0x13, 0x00, 0x0A}), unsupported);
  EXPECT_EQ(req({0x13, 0x01, 0x02}), unsupported);  // table selector 1
  EXPECT_EQ(req({0x13, 0x04, 0x00}), unsupported);  // manual layout not on by default
  EXPECT_EQ(n->lss().pending_bit_rate_index(), 3);
  EXPECT_EQ(req({0x13, 0x00, 0x08}), ok);
  EXPECT_EQ(req({0x13, 0x00, 0x02}), ok);
  EXPECT_EQ(n->lss().pending_bit_rate_index(), 2);
  EXPECT_EQ(n->bit_rate_index(), 3);  // pending until activated
}

TEST_F(Lss, BitTimingVendorLayoutsAndRateSet) {
  SimNode& n =
      add(5, "{lss_bit_rates: '0,2-7', lss_bit_timing_manual_layout: true, lss_table_selector_1_is_cia: true}");
  start();
  req({0x04, 0x01});
  EXPECT_EQ(req({0x13, 0x04, 0x00}), "0us 7E4 [8] 13 00 00 00 00 00 00 00\n");  // "13 04": index 4
  EXPECT_EQ(n->lss().pending_bit_rate_index(), 4);
  EXPECT_EQ(req({0x13, 0x01, 0x05}), "0us 7E4 [8] 13 00 00 00 00 00 00 00\n");  // selector 1, index 5
  EXPECT_EQ(n->lss().pending_bit_rate_index(), 5);
  EXPECT_EQ(req({0x13, 0x00, 0x01}), "0us 7E4 [8] 13 01 00 00 00 00 00 00\n");  // 800k not in the set
  EXPECT_EQ(req({0x13, 0x02, 0x03}), "0us 7E4 [8] 13 01 00 00 00 00 00 00\n");  // selector 2
}

TEST_F(Lss, ActivateBitTimingSilenceSwitchSilence) {
  SimNode& n = add(5);
  start();
  req({0x04, 0x01});
  req({0x13, 0x00, 0x04});  // 125 kbit/s
  bus.run_for(ms(10));
  const TimeUs t0 = t();
  EXPECT_EQ(req({0x15, 0x64, 0x00}), "");  // switch delay 100 ms, no reply
  EXPECT_TRUE(n->lss().switching_bit_rate());
  // First delay: still at the old rate and hears frames, but sends nothing.
  bus.run_until(t0 + ms(50));
  EXPECT_EQ(req({0x5E}), "");
  bus.run_until(t0 + ms(100) - 1);
  EXPECT_EQ(n->bit_rate_index(), 3);
  bus.run_until(t0 + ms(100));
  EXPECT_EQ(n->bit_rate_index(), 4);
  // Off the 250 kbit/s bus: frames to it are ignored.
  bus.run_until(t0 + ms(110));
  req({0x04, 0x00});
  EXPECT_TRUE(n->lss().configuring());
  // The bus changes to 125 kbit/s during the second delay: it hears but stays silent.
  n->set_bus_bit_rate(4);
  bus.run_until(t0 + ms(150));
  EXPECT_EQ(req({0x5E}), "");
  bus.run_until(t0 + ms(200) - 1);
  EXPECT_EQ(req({0x5E}), "");
  EXPECT_TRUE(n->lss().switching_bit_rate());
  bus.run_until(t0 + ms(200));
  EXPECT_FALSE(n->lss().switching_bit_rate());
  EXPECT_EQ(test::to_string(bus.take()), "");  // nothing of its own either
  EXPECT_EQ(req({0x5E}), S({{t0 + ms(200), F(0x7E4, {0x5E, 0x05, 0, 0, 0, 0, 0, 0})}}));
}

TEST_F(Lss, ActivatedRateOffTheBusUntilTheBusMatches) {
  SimNode& n = add(5);
  start();
  req({0x04, 0x01});
  req({0x13, 0x00, 0x02});
  const TimeUs t0 = t();
  req({0x15, 0x0A, 0x00});  // 10 ms
  bus.run_until(t0 + ms(30));
  EXPECT_FALSE(n->lss().switching_bit_rate());
  EXPECT_EQ(n->bit_rate_index(), 2);
  EXPECT_EQ(req({0x5E}), "");  // bus still at 250 kbit/s
  EXPECT_EQ(nmt(0x81, 0x05), "");
  n->set_bus_bit_rate(2);
  EXPECT_EQ(req({0x5E}), S({{t(), F(0x7E4, {0x5E, 0x05, 0, 0, 0, 0, 0, 0})}}));
}

TEST_F(Lss, ActivateBitTimingIgnoredInWaitingState) {
  SimNode& n = add(5);
  start();
  req({0x15, 0x0A, 0x00});
  EXPECT_FALSE(n->lss().switching_bit_rate());
  EXPECT_EQ(n->next_deadline(), kNever);
}

// ---------------------------------------------------------------- store configuration

TEST_F(Lss, StoredNodeIdSurvivesPowerCycle) {
  SimNode& n = add(5);
  start();
  req({0x04, 0x01});
  req({0x11, 0x21});
  bus.run_for(ms(1));
  EXPECT_EQ(req({0x17}), S({{t(), F(0x7E4, {0x17, 0x00, 0, 0, 0, 0, 0, 0})}}));
  EXPECT_GE(n.storage.saves, 1);
  n.replace(5);  // power loss; the profile still says node-ID 5
  bus.run_for(ms(1));
  bus.power_on_all();
  EXPECT_EQ(test::to_string(bus.take()), S({{t(), F(0x721, {0x00})}}));
  EXPECT_EQ(n->node_id(), 0x21);
  EXPECT_EQ(n->values().u(0x1014, 0), 0xA1u);
}

TEST_F(Lss, StoredBitRateUsedAfterPowerCycle) {
  SimNode& n = add(5);
  start();
  req({0x04, 0x01});
  req({0x13, 0x00, 0x04});
  EXPECT_EQ(req({0x17}), "0us 7E4 [8] 17 00 00 00 00 00 00 00\n");
  n.replace(5);
  bus.power_on_all();
  EXPECT_EQ(n->bit_rate_index(), 4);
  EXPECT_EQ(test::to_string(bus.take()), "");  // boot-up lost: bus at 250 kbit/s
  n->set_bus_bit_rate(4);
  req({0x04, 0x01});
  EXPECT_EQ(req({0x5E}), "0us 7E4 [8] 5E 05 00 00 00 00 00 00\n");
}

TEST_F(Lss, StoreErrors) {
  SimNode& n = add(5);
  start();
  req({0x17});
  EXPECT_EQ(n.storage.saves, 0);  // waiting state: ignored
  req({0x04, 0x01});
  n.storage.fail_saves = true;
  EXPECT_EQ(req({0x17}), "0us 7E4 [8] 17 02 00 00 00 00 00 00\n");  // storage access error
}

TEST_F(Lss, StoreNotSupportedOption) {
  SimNode& n = add(5, "{lss_store_supported: false}");
  start();
  req({0x04, 0x01});
  EXPECT_EQ(req({0x17}), "0us 7E4 [8] 17 01 00 00 00 00 00 00\n");
  EXPECT_EQ(n.storage.saves, 0);
}

TEST_F(Lss, NothingToStoreAndReplyCsOptions) {
  SimNode& n = add(5, "{lss_nothing_to_store_error: true, lss_store_reply_cs: 0}");
  start();
  req({0x04, 0x01});
  EXPECT_EQ(req({0x17}), "0us 7E4 [8] 00 FF 01 00 00 00 00 00\n");
  req({0x11, 0x09});
  EXPECT_EQ(req({0x17}), "0us 7E4 [8] 00 00 00 00 00 00 00 00\n");
  EXPECT_EQ(req({0x17}), "0us 7E4 [8] 00 FF 01 00 00 00 00 00\n");
  EXPECT_GE(n.storage.saves, 1);
}

// ---------------------------------------------------------------- vendor options

TEST_F(Lss, OnlyInStoppedOption) {
  SimNode& n = add(5, "{lss_only_in_stopped: true}");
  start();
  EXPECT_EQ(n->state(), NmtState::kPreOperational);
  req({0x04, 0x01});
  EXPECT_FALSE(n->lss().configuring());
  EXPECT_EQ(req({0x5E}), "");
  nmt(0x02, 0x05);
  ASSERT_EQ(n->state(), NmtState::kStopped);
  req({0x04, 0x01});
  EXPECT_TRUE(n->lss().configuring());
  EXPECT_EQ(req({0x5E}), "0us 7E4 [8] 5E 05 00 00 00 00 00 00\n");
  // Once in configuration it stays reachable, e.g. to be switched back.
  nmt(0x01, 0x05);
  EXPECT_EQ(req({0x5E}), "0us 7E4 [8] 5E 05 00 00 00 00 00 00\n");
  req({0x04, 0x00});
  EXPECT_FALSE(n->lss().configuring());
  req({0x04, 0x01});
  EXPECT_FALSE(n->lss().configuring());  // OPERATIONAL now
}

TEST_F(Lss, DisabledLssAnswersNothing) {
  SimNode& n = add(5, "{lss_supported: false}");
  start();
  req({0x04, 0x01});
  EXPECT_FALSE(n->lss().configuring());
  EXPECT_EQ(req({0x5E}), "");
  std::vector<std::uint32_t> ids;
  n->lss().collect_rx_ids(ids);
  EXPECT_TRUE(ids.empty());
}

TEST_F(Lss, RxIdsIncludeLssRequestId) {
  SimNode& n = add(5);
  std::vector<std::uint32_t> ids;
  n->lss().collect_rx_ids(ids);
  EXPECT_EQ(ids, std::vector<std::uint32_t>{0x7E5});
}

TEST_F(Lss, InquireServicesCanBeDisabled) {
  add(5, "{lss_inquire_services: false}");
  start();
  req({0x04, 0x01});
  EXPECT_EQ(req({0x5A}), "");
  EXPECT_EQ(req({0x5E}), "");
  EXPECT_EQ(req({0x11, 0x07}), "0us 7E4 [8] 11 00 00 00 00 00 00 00\n");
}

TEST_F(Lss, InquireNodeIdStoredOption) {
  add(5, "{lss_inquire_node_id_stored: true}");
  start();
  req({0x04, 0x01});
  EXPECT_EQ(req({0x5E}), "0us 7E4 [8] 5E 05 00 00 00 00 00 00\n");  // nothing stored: active
  req({0x11, 0x0C});
  req({0x17});
  EXPECT_EQ(req({0x5E}), "0us 7E4 [8] 5E 0C 00 00 00 00 00 00\n");
}

// Danfoss-style: a stored node-ID takes effect when leaving configuration.
TEST_F(Lss, WaitingAppliesStoredNodeIdOption) {
  SimNode& n = add(5, "{lss_waiting_applies_stored_node_id: true}");
  start();
  req({0x04, 0x01});
  req({0x11, 0x0C});
  EXPECT_EQ(req({0x04, 0x00}), "");  // not stored: dropped, no reset
  EXPECT_EQ(n->lss().pending_node_id(), 5);
  req({0x04, 0x01});
  req({0x11, 0x0C});
  req({0x17});
  bus.run_for(ms(3));
  EXPECT_EQ(req({0x04, 0x00}), S({{t(), F(0x70C, {0x00})}}));
  EXPECT_EQ(n->node_id(), 0x0C);
  EXPECT_EQ(n->state(), NmtState::kPreOperational);
}

TEST_F(Lss, ConfigurationBlocksNmtOption) {
  SimNode& n = add(5, "{lss_configuration_blocks_nmt: true}");
  start();
  req({0x04, 0x01});
  EXPECT_EQ(nmt(0x81, 0x05), "");
  EXPECT_EQ(nmt(0x02, 0x00), "");
  EXPECT_EQ(n->state(), NmtState::kPreOperational);
  req({0x04, 0x00});
  EXPECT_EQ(nmt(0x02, 0x00), "");
  EXPECT_EQ(n->state(), NmtState::kStopped);
}

TEST_F(Lss, StoredBitRateAndBootUpAfterSwitchOptions) {
  SimNode& n = add(5, "{lss_activate_stored_bit_rate: true, lss_boot_up_after_bit_rate_switch: true}");
  start();
  req({0x04, 0x01});
  req({0x13, 0x00, 0x02});  // pending 500k, not stored: activation keeps 250k
  const TimeUs t0 = t();
  req({0x15, 0x0A, 0x00});
  bus.run_until(t0 + ms(20));
  EXPECT_EQ(n->bit_rate_index(), 3);
  EXPECT_EQ(test::to_string(bus.take()), S({{t0 + ms(20), F(0x705, {0x00})}}));
  EXPECT_TRUE(n->lss().configuring());
  req({0x17});
  const TimeUs t1 = t();
  req({0x15, 0x0A, 0x00});
  n->set_bus_bit_rate(2);
  bus.run_until(t1 + ms(20));
  EXPECT_EQ(n->bit_rate_index(), 2);
  EXPECT_EQ(test::to_string(bus.take()), S({{t1 + ms(20), F(0x705, {0x00})}}));
}

}  // namespace
}  // namespace cansim
