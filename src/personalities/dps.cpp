#include "personalities/dps.hpp"

#include <algorithm>

#include "personalities/vendor_params.hpp"

namespace cansim::personalities::dps {

namespace {

// Manual Table 24: code and error register. The register's class bits come
// from the code (0x2xxx current, 0x3xxx voltage); EEPROM adds the manufacturer bit.
constexpr std::uint16_t kEmcySensorFailure = 0x2201;
constexpr std::uint16_t kEmcySpanOverflow = 0x3201;
constexpr std::uint16_t kEmcyEeprom = 0x5000;
constexpr std::uint8_t kManufacturerBit = 0x80;

Settings parse_settings(const config::Profile& profile) {
  Settings s;
  const VendorParams v(profile);
  v.flags({{"span_overflow_emcy", &s.span_overflow_emcy}, {"autozero_shifts_span", &s.autozero_shifts_span}});
  v.time_us("span_check_period", s.span_check_period_us, VendorParams::kPositive, VendorParams::kForever, "a time > 0");
  v.reject_unknown_keys();
  return s;
}

}  // namespace

DpsApplication::DpsApplication(const PreparedProfile& prepared, std::unique_ptr<MeasurementSource> source,
                               std::uint32_t node_index)
    : Cia404Application(prepared.cia404, std::move(source), prepared.identity, node_index),
      settings_(prepared.device ? device_settings<Settings>(prepared) : Settings{}) {}

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

void prepare(config::Profile& profile, PreparedProfile& prepared) {
  require_channels(profile, prepared, 1, "its span and sensor supervision (§5.4)");
  prepared.device = std::make_shared<const Settings>(parse_settings(profile));
}

std::unique_ptr<Application> make(const config::Profile&, const PreparedProfile& prepared, const NodeContext& ctx) {
  return std::make_unique<DpsApplication>(prepared, make_sensor_source(prepared, ctx), ctx.index);
}

}  // namespace cansim::personalities::dps
