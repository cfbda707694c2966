#include "personalities/p92c.hpp"

#include "core/pdo.hpp"

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

constexpr std::uint16_t kMapping = 0x1A00;
constexpr std::uint16_t kBitRate = 0x4F00;
constexpr std::uint16_t kSerial = 0x4E00;

}  // namespace

P92cApplication::P92cApplication(std::shared_ptr<const Cia404Profile> profile,
                                 std::unique_ptr<MeasurementSource> source, const Settings& settings,
                                 IdentitySettings identity, std::uint32_t node_index)
    : Cia404Application(std::move(profile), std::move(source), identity, node_index), settings_(settings) {}

void P92cApplication::on_reset(Node& node, ResetKind kind, TimeUs now) {
  Cia404Application::on_reset(node, kind, now);
  fill_serial(node);
  for (int ch = 0; ch < 2; ++ch) {
    last_status_[ch] = 0;
    error_[ch] = false;  // the EMCY producer forgot them too
  }
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
  if (fault_active(physics::FaultKind::EepromError, now)) node.emcy().report(kEmcyStartUp, 0, nullptr, now);
}

// 0x4F00: the index table of §3.3 (index 5 blank, 8 and 9 not listed) is the
// LSS bit-rate set of the profile.
SdoAbort P92cApplication::check_write(Node& node, const OdEntry& e, std::span<const std::uint8_t> data, TimeUs now) {
  if (e.index != kBitRate) return Cia404Application::check_write(node, e, data, now);
  return node.options().lss_bit_rates.has(data[0]) ? SdoAbort::kNone : SdoAbort::kInvalidValue;
}

void P92cApplication::count_edge(Node& node, std::uint16_t counter) {
  const std::uint64_t n = node.values().u(counter, 0);
  if (n < 0xFFFF) node.values().set_u(counter, 0, n + 1);
}

// Status supervision in every NMT state: counters count each rising edge into
// an overload (saturating), the channel's EMCY follows its error state.
void P92cApplication::supervise(Node& node, TimeUs now) {
  const std::size_t channels = std::min<std::size_t>(2, profile().channels.size());
  for (std::size_t ch = 0; ch < channels; ++ch) {
    const std::uint8_t status = measure(node, ch, now).status;
    const std::uint8_t rising = std::uint8_t(status & ~last_status_[ch]);
    last_status_[ch] = status;
    if (settings_.overload_counters) {
      if (rising & kPositiveOverload) count_edge(node, kOverflowCounter[ch]);
      if (rising & kNegativeOverload) count_edge(node, kUnderflowCounter[ch]);
    }
    std::uint8_t error_bits = settings_.sensor_fault_emcy ? kInvalid : 0;
    if (settings_.overload_emcy) error_bits |= kPositiveOverload | kNegativeOverload;
    const bool error = (status & error_bits) != 0;
    if (error == error_[ch]) continue;
    error_[ch] = error;
    if (error) node.emcy().raise(kChannelEmcy[ch], 0, now);
    else node.emcy().clear(kChannelEmcy[ch], now);
  }
}

// ---- registry


std::unique_ptr<Application> make(const model::Profile& profile, const Settings& settings, const NodeContext& ctx) {
  return std::make_unique<P92cApplication>(profile.cia404, make_sensor_source(profile, ctx), settings, profile.identity,
                                           ctx.index);
}

}  // namespace cansim::personalities::p92c
