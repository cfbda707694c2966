// Shared fixture of the SDO server tests: one generic-404 node (node-ID 0x10,
// SDO 0x610 -> 0x590) on a SimBus, pre-operational, log cleared. Replies are
// the frames the node sent on its SDO response COB-ID (heartbeats etc. are
// filtered out so the tests hold while other services land).
#pragma once

#include <gtest/gtest.h>

#include <fstream>
#include <map>
#include <sstream>
#include <string>
#include <vector>

#include "config/profile.hpp"
#include "support/sim.hpp"

namespace cansim::test {

constexpr std::uint32_t kSdoRx = 0x610;
constexpr std::uint32_t kSdoTx = 0x590;

// generic-404 with its `options: {}` line replaced; parsed once per options
// text (layouts are immutable and shared, as in the daemon).
inline config::Profile parse_generic_with_options(const std::string& options) {
  std::ifstream in(std::string(CANSIM_SOURCE_DIR) + "/profiles/generic-404.yaml");
  std::stringstream ss;
  ss << in.rdbuf();
  std::string text = ss.str();
  std::size_t at = text.find("options: {}");
  if (at != std::string::npos) text.replace(at, 11, "options: {" + options + "}");
  return config::parse_profile(text, "generic-404+options");
}
inline const config::Profile& generic_with_options(const std::string& options) {
  static std::map<std::string, config::Profile> cache;
  auto it = cache.find(options);
  if (it == cache.end()) it = cache.emplace(options, parse_generic_with_options(options)).first;
  return it->second;
}

inline std::vector<std::uint8_t> bytes_of(const std::string& s) { return {s.begin(), s.end()}; }

class SdoFixture : public ::testing::Test {
 protected:
  explicit SdoFixture(const std::string& options = "") : profile_(generic_with_options(options)) {}

  void SetUp() override {
    node_ = &bus_.add(profile_, 0x10);
    bus_.power_on_all();
    bus_.run_for(ms(1));
    ASSERT_EQ(node().state(), NmtState::kPreOperational);
    bus_.take();
  }

  Node& node() { return node_->node(); }

  // Sends a master request and returns the SDO replies it caused.
  std::vector<CanFrame> req(std::initializer_list<std::uint8_t> bytes) {
    bus_.inject(F(kSdoRx, bytes));
    return replies();
  }
  std::vector<CanFrame> req(const CanFrame& f) {
    bus_.inject(f);
    return replies();
  }
  // The SDO frames sent since the last take().
  std::vector<CanFrame> replies() {
    std::vector<CanFrame> out;
    for (const Sent& s : bus_.take())
      if (s.frame.id == kSdoTx) out.push_back(s.frame);
    return out;
  }
  std::vector<Sent> timed_replies() {
    std::vector<Sent> out;
    for (const Sent& s : bus_.take())
      if (s.frame.id == kSdoTx) out.push_back(s);
    return out;
  }
  static std::vector<CanFrame> one(std::initializer_list<std::uint8_t> bytes) { return {F(kSdoTx, bytes)}; }
  static CanFrame abort_frame(std::uint16_t index, std::uint8_t sub, std::uint32_t code) {
    return F(kSdoTx, {0x80, std::uint8_t(index), std::uint8_t(index >> 8), sub, std::uint8_t(code),
                      std::uint8_t(code >> 8), std::uint8_t(code >> 16), std::uint8_t(code >> 24)});
  }
  static std::vector<CanFrame> aborted(std::uint16_t index, std::uint8_t sub, SdoAbort code) {
    return {abort_frame(index, sub, std::uint32_t(code))};
  }
  std::vector<std::uint8_t> value(std::uint16_t index, std::uint8_t sub) {
    auto b = node().values().bytes(*node().od().find(index, sub));
    return {b.begin(), b.end()};
  }
  void set_value(std::uint16_t index, std::uint8_t sub, const std::vector<std::uint8_t>& v) {
    node().values().set_bytes(*node().od().find(index, sub), v);
  }

  // Expected segmented-upload answers to alternating 0x60/0x70 requests.
  static std::vector<CanFrame> upload_segments(const std::vector<std::uint8_t>& data) {
    std::vector<CanFrame> out;
    std::uint8_t toggle = 0;
    for (std::size_t pos = 0; pos < data.size(); pos += 7, toggle ^= 0x10) {
      std::size_t n = std::min<std::size_t>(7, data.size() - pos);
      CanFrame f = F(kSdoTx, {0, 0, 0, 0, 0, 0, 0, 0});
      bool last = pos + n == data.size();
      f.data[0] = std::uint8_t(toggle | ((7 - n) << 1) | (last ? 1 : 0));
      for (std::size_t i = 0; i < n; ++i) f.data[1 + i] = data[pos + i];
      out.push_back(f);
    }
    return out;
  }
  // Block segment `seq` (client or server) carrying data[pos, pos+7).
  static CanFrame block_segment(std::uint32_t id, std::uint8_t seq, const std::vector<std::uint8_t>& data,
                                std::size_t pos, bool last) {
    CanFrame f = F(id, {0, 0, 0, 0, 0, 0, 0, 0});
    f.data[0] = std::uint8_t(seq | (last ? 0x80 : 0));
    for (std::size_t i = 0; i < 7 && pos + i < data.size(); ++i) f.data[1 + i] = data[pos + i];
    return f;
  }

  const config::Profile& profile_;
  SimBus bus_;
  SimNode* node_ = nullptr;
};

}  // namespace cansim::test
