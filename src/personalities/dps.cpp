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
constexpr std::uint64_t kCounterMax = 0xFFFFFFFF;  // UNSIGNED32 counters 0x2004 / 0x2005

}  // namespace

void DpsApplication::on_reset(Node& node, ResetKind kind, TimeUs now) {
  SensorApplication::on_reset(node, kind, now);
  OdValues& v = node.values();
  const OdEntry* serial = node.od().find(0x1018, 4);
  if (const OdEntry* copy = node.od().find(0x200E, 0); serial && copy) v.set_u(*copy, v.get_u(*serial));
  state_ = State{};
  state_.overflows = node.od().find(0x2004, 0);
  state_.underflows = node.od().find(0x2005, 0);
  if (kind != ResetKind::kCommunication && DevicePart::boot_data_error(node, chain_.fault_set(), now))
    node.emcy().raise(kEmcyEeprom, kManufacturerBit, now);
  node.wake_app(now);
}

// Manual §10.5: autozero changes "all the objects associated with process
// value" (Table 18), so span start / end move with the offset.
void DpsApplication::after_write(Node& node, const OdEntry& e, TimeUs now) {
  const Cia404Profile::Binding& b = chain_.profile().binding(e);
  if (b.role != Role::kAutozero || !settings_.autozero_shifts_span) {
    chain_.after_write(node, e, now);
    return;
  }
  const double before = chain_.get(node, b.channel, Role::kOffset);
  chain_.after_write(node, e, now);
  const double delta = chain_.get(node, b.channel, Role::kOffset) - before;
  for (Role r : {Role::kSpanStart, Role::kSpanEnd})
    chain_.set(node, b.channel, r, chain_.get(node, b.channel, r) + delta);
}

// Span over/underflow: EMCY 0x3201 and the counters 0x2004 / 0x2005.
TimeUs DpsApplication::process(Node& node, TimeUs now) {
  const TimeUs next = chain_.process(node, now);
  return std::min(next, device_.supervise(now, settings_.span_check_period_us, [&] { check_span(node, now); }));
}

// 0x2004 / 0x2005 count crossings of span end / start (appendix); EMCY 0x3201
// once per excursion and its reset when back inside (manual §9: "or a source
// of error is removed").
void DpsApplication::check_span(Node& node, TimeUs now) {
  const Cia404Chain::Measurement m = chain_.measure(node, 0, now);
  node.emcy().follow(kEmcySensorFailure, m.status & physics::kStatusInvalid, 0, now);
  if (!state_.span.move_to(SpanMonitor::of_status(m.status))) return;
  const Span s = state_.span.span;
  if (s == Span::kOver) saturating_count(node, state_.overflows, kCounterMax);
  if (s == Span::kUnder) saturating_count(node, state_.underflows, kCounterMax);
  if (settings_.span_overflow_emcy) node.emcy().follow(kEmcySpanOverflow, s != Span::kInside, 0, now);
}

Requirements requirements() { return {{}, 1, "its span and sensor supervision (§5.4)"}; }

}  // namespace cansim::personalities::dps
