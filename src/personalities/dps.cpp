#include "personalities/dps.hpp"

#include <algorithm>


namespace cansim::personalities::dps {

namespace {

// Manual Table 24: code and error register. The register's class bits come
// from the code (0x2xxx current, 0x3xxx voltage); EEPROM adds the manufacturer bit.
constexpr std::uint16_t kEmcySensorFailure = 0x2201;
constexpr std::uint16_t kEmcySpanOverflow = 0x3201;
constexpr std::uint16_t kEmcyEeprom = 0x5000;
constexpr std::uint8_t kManufacturerBit = 0x80;

}  // namespace

DpsApplication::DpsApplication(std::shared_ptr<const Cia404Profile> profile, std::unique_ptr<MeasurementSource> source,
                               const Settings& settings, IdentitySettings identity, std::uint32_t node_index)
    : Cia404Application(std::move(profile), std::move(source), identity, node_index), settings_(settings) {}

void DpsApplication::on_reset(Node& node, ResetKind kind, TimeUs now) {
  Cia404Application::on_reset(node, kind, now);
  serial_ = node.od().find(0x1018, 4);
  serial_copy_ = node.od().find(0x200E, 0);
  overflows_ = node.od().find(0x2004, 0);
  underflows_ = node.od().find(0x2005, 0);
  if (serial_ && serial_copy_) node.values().set_u(*serial_copy_, node.values().get_u(*serial_));
  span_ = Span::kInside;
  sensor_failed_ = false;
  const bool eeprom_bad = node.store().corrupt() || fault_active(physics::FaultKind::EepromError, now);
  if (kind != ResetKind::kCommunication && eeprom_bad) node.emcy().raise(kEmcyEeprom, kManufacturerBit, now);
  node.wake_app(now);
}

// Manual §10.5: autozero changes "all the objects associated with process
// value" (Table 18), so span start / end move with the offset.
void DpsApplication::after_write(Node& node, const OdEntry& e, TimeUs now) {
  const Cia404Profile::Binding& b = profile().binding(e);
  if (b.role != Role::kAutozero || !settings_.autozero_shifts_span) {
    Cia404Application::after_write(node, e, now);
    return;
  }
  const double before = get(node, b.channel, Role::kOffset);
  Cia404Application::after_write(node, e, now);
  const double delta = get(node, b.channel, Role::kOffset) - before;
  for (Role r : {Role::kSpanStart, Role::kSpanEnd}) set(node, b.channel, r, get(node, b.channel, r) + delta);
}


void DpsApplication::count(Node& node, const OdEntry* counter) {
  if (!counter) return;
  const std::uint64_t n = node.values().get_u(*counter);
  if (n < 0xFFFFFFFFu) node.values().set_u(*counter, n + 1);
}

// 0x2004 / 0x2005 count crossings of span end / start (appendix); EMCY 0x3201
// once per excursion and its reset when back inside (manual §9: "or a source
// of error is removed").
void DpsApplication::check_span(Node& node, TimeUs now) {
  const Measurement m = measure(node, 0, now);
  const bool failed = m.status & physics::kStatusInvalid;
  if (failed != sensor_failed_) {
    if (failed) node.emcy().raise(kEmcySensorFailure, 0, now);
    else node.emcy().clear(kEmcySensorFailure, now);
    sensor_failed_ = failed;
  }
  const Span s = (m.status & physics::kStatusPositiveOverload)   ? Span::kOver
                 : (m.status & physics::kStatusNegativeOverload) ? Span::kUnder
                                                                 : Span::kInside;
  if (s == span_) return;
  if (s == Span::kOver) count(node, overflows_);
  if (s == Span::kUnder) count(node, underflows_);
  if (settings_.span_overflow_emcy) {
    if (span_ == Span::kInside) node.emcy().raise(kEmcySpanOverflow, 0, now);
    else if (s == Span::kInside) node.emcy().clear(kEmcySpanOverflow, now);
  }
  span_ = s;
}

Requirements requirements() {
  return {{}, 1, "its span and sensor supervision (§5.4)"};
}

std::unique_ptr<Application> make(const model::Profile& profile, const Settings& settings, const NodeContext& ctx) {
  return std::make_unique<DpsApplication>(profile.cia404, make_sensor_source(profile, ctx), settings, profile.identity,
                                          ctx.index);
}

}  // namespace cansim::personalities::dps
