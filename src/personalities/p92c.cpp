#include "personalities/p92c.hpp"

#include "core/pdo.hpp"

#include <algorithm>
#include <cstdio>

#include "physics/fault.hpp"

namespace cansim::personalities::p92c {

namespace {

// EMCY error codes (§3.6).
enum : std::uint16_t {
  kEmcyTemperature = 0x4000,
  kEmcyEepromInvalid = 0x6161,
  kEmcyStartUp = 0x6300,
  kEmcyMapping = 0x6363,
  kEmcyPressure = 0xF011,
};

// 0x6150 bits (§3.4).
enum : std::uint8_t { kInvalid = 0x01, kPositiveOverload = 0x02, kNegativeOverload = 0x04 };

// Per channel (0 pressure, 1 temperature): EMCY code and overflow / underflow counters (§3.3).
constexpr std::uint16_t kChannelEmcy[2] = {kEmcyPressure, kEmcyTemperature};
constexpr std::uint16_t kOverflowCounter[2] = {0x3000, 0x3002};
constexpr std::uint16_t kUnderflowCounter[2] = {0x3001, 0x3003};
constexpr std::uint64_t kCounterMax = 0xFFFF;  // UNSIGNED16 counters

constexpr std::uint16_t kMapping = 0x1A00;
constexpr std::uint16_t kBitRate = 0x4F00;
constexpr std::uint16_t kSerial = 0x4E00;

}  // namespace

void P92cApplication::on_reset(Node& node, ResetKind kind, TimeUs now) {
  SensorApplication::on_reset(node, kind, now);
  fill_serial(node);
  state_ = State{};
  if (settings_.boot_emcys) boot_checks(node, kind, now);
}

// 0x4E00: "11.223344.5566"; part 2 is the node's serial number 0x1018:04.
void P92cApplication::fill_serial(Node& node) {
  OdValues& v = node.values();
  const auto part2 = std::uint32_t(v.u(0x1018, 4));
  v.set_u(kSerial, 1, settings_.serial_part1);
  v.set_u(kSerial, 2, part2);
  v.set_u(kSerial, 3, settings_.serial_part3);
  char text[32];
  const int n = std::snprintf(text, sizeof text, "%02u.%06u.%04u", unsigned(settings_.serial_part1), unsigned(part2),
                              unsigned(settings_.serial_part3));
  if (const OdEntry* e = node.od().find(kSerial, 4)) v.set_string(*e, std::string_view(text, std::size_t(n)));
}

// Start-up errors (§3.6, §5.2): sent after the boot-up frame. A stored mapping
// the device cannot use falls back to the default one.
void P92cApplication::boot_checks(Node& node, ResetKind kind, TimeUs now) {
  if (kind == ResetKind::kCommunication) return;
  if (node.store().corrupt()) node.emcy().report(kEmcyEepromInvalid, 0, nullptr, now);
  if (!ok(node.pdo().tpdo_mapping_status(1))) {
    node.values().reset(node.node_id(), kMapping, kMapping);
    node.pdo().reset(now);
    node.emcy().report(kEmcyMapping, 0, nullptr, now);
  }
  if (DevicePart::fault_active(chain_.fault_set(), physics::FaultKind::EepromError, now))
    node.emcy().report(kEmcyStartUp, 0, nullptr, now);
}

// The vendor objects (p92c.hpp: kObjectHooks); the others are the chain's.
constexpr ObjectHook<P92cApplication> P92cApplication::kObjectRows[] = {
    object<P92cApplication>(kBitRate, nullptr, &P92cApplication::check_bit_rate),
};
constexpr ObjectHooks<P92cApplication> P92cApplication::kObjectHooks{kObjectRows};

// 0x4F00: the index table of §3.3 (index 5 blank, 8 and 9 not listed) is the
// LSS bit-rate set of the profile.
SdoAbort P92cApplication::check_bit_rate(Node& node, const OdEntry&, std::span<const std::uint8_t> data, TimeUs) {
  return node.options().lss_bit_rates.has(data[0]) ? SdoAbort::kNone : SdoAbort::kInvalidValue;
}

TimeUs P92cApplication::process(Node& node, TimeUs now) {
  const TimeUs next = chain_.process(node, now);
  return std::min(next, device_.supervise(now, settings_.monitor_period_us, [&] { supervise(node, now); }));
}

// Status supervision in every NMT state: counters count each rising edge into
// an overload (saturating), the channel's EMCY follows its error state.
void P92cApplication::supervise(Node& node, TimeUs now) {
  const std::size_t channels = std::min<std::size_t>(2, chain_.profile().channels.size());
  for (std::size_t ch = 0; ch < channels; ++ch) {
    const std::uint8_t status = chain_.measure(node, ch, now).status;
    const std::uint8_t rising = std::uint8_t(status & ~state_.last_status[ch]);
    state_.last_status[ch] = status;
    if (settings_.overload_counters) {
      if (rising & kPositiveOverload) saturating_count(node, node.od().find(kOverflowCounter[ch], 0), kCounterMax);
      if (rising & kNegativeOverload) saturating_count(node, node.od().find(kUnderflowCounter[ch], 0), kCounterMax);
    }
    std::uint8_t error_bits = settings_.sensor_fault_emcy ? kInvalid : 0;
    if (settings_.overload_emcy) error_bits |= kPositiveOverload | kNegativeOverload;
    node.emcy().follow(kChannelEmcy[ch], (status & error_bits) != 0, 0, now);
  }
}

}  // namespace cansim::personalities::p92c
