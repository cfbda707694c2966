#include "personalities/cia404.hpp"

#include <algorithm>
#include <cmath>
#include <cstring>
#include <limits>
#include <string>

#include "physics/quantize.hpp"
#include "physics/random.hpp"

namespace cansim::personalities {

namespace {

void integer_range(DataType t, std::int64_t& lo, std::int64_t& hi) {
  const std::size_t bits = 8 * type_size(t);
  if (bits >= 64) {
    lo = is_signed(t) ? std::numeric_limits<std::int64_t>::min() : 0;
    hi = std::numeric_limits<std::int64_t>::max();
  } else if (is_signed(t)) {
    lo = -(std::int64_t(1) << (bits - 1));
    hi = (std::int64_t(1) << (bits - 1)) - 1;
  } else {
    lo = 0;
    hi = (std::int64_t(1) << bits) - 1;
  }
}

double decode_view(const OdEntry& e, const std::uint8_t* p, int digits) {
  if (is_real(e.type)) return decode_f(e.type, p);
  return physics::from_decimal(decode_i(e.type, p), digits);
}

}  // namespace

// ---------------------------------------------------------------- values

float LinearInput::scale(double fv) const {
  const float x = float(fv) - offset;
  return std::clamp(gain * x + pv1, cmin, cmax);
}

SourceSlot::SourceSlot(std::unique_ptr<MeasurementSource> source)
    : source_(std::move(source)), sensor_(dynamic_cast<SensorSource*>(source_.get())) {}

SourceSlot::SourceSlot(const SourceSlot& other)
    : source_(other.source_ ? other.source_->snapshot() : nullptr),
      sensor_(dynamic_cast<SensorSource*>(source_.get())) {}

SourceSlot& SourceSlot::operator=(const SourceSlot& other) {
  if (this != &other && source_ && other.source_) source_->restore(*other.source_);
  return *this;
}

// ---------------------------------------------------------------- chain

Cia404Chain::Cia404Chain(std::shared_ptr<const Cia404Profile> profile, std::unique_ptr<MeasurementSource> source)
    : profile_(std::move(profile)), source_(std::move(source)) {
  state_.resize(profile_->channels.size());
  for (std::size_t ch = 0; ch < state_.size(); ++ch) {
    state_[ch].captured.assign(kRoleCount + profile_->channels[ch].extras.size(), 0.0);
    state_[ch].unit = profile_->channels[ch].fixed_unit;
  }
}

int Cia404Chain::digits(const Node& node, std::size_t ch) const {
  const OdEntry* d = profile_->channels[ch].param(Role::kDigits).views[0];
  return d ? int(std::min<std::uint64_t>(node.values().get_u(*d), 18)) : 0;
}

Cia404Chain::EntryScale Cia404Chain::entry_scale(const Node& node, const OdEntry& e) const {
  const Cia404Profile::Binding& b = profile_->binding(e);
  const bool in_unit = b.role == Role::kPv || model::is_valued(b.role);
  if (!in_unit || b.channel >= state_.size()) return {};
  const double scale = is_real(e.type) ? 1.0 : std::pow(10.0, -digits(node, b.channel));
  EntryScale out{scale, 0.0, unit(b.channel).name};
  if (const std::optional<CountScaling> c = count_scaling(b.channel)) {
    out.counts = true;
    out.count_scale = scale;
    out.scale = scale * c->factor;
    out.offset = model::role_info(b.role).difference ? 0.0 : c->offset;  // a delta or hysteresis has no zero
  }
  return out;
}

std::optional<Cia404Chain::CountScaling> Cia404Chain::count_scaling(std::size_t ch) const {
  const std::optional<LinearInput>& in = state_[ch].input;
  if (!in) return std::nullopt;
  // PV = gain x (FV - input offset) + pv1, FV = (si - si_min) / (si_max - si_min) x span
  // (clamping aside): the engineering value is affine in the PV.
  const UnitScale& u = unit(ch);
  const double si_per_count = (in->si_max - in->si_min) / in->field_span;
  const double factor = si_per_count / double(in->gain) / u.si_per_unit;
  const double at_pv1 = u.from_si(in->si_min + double(in->offset) * si_per_count);
  if (!std::isfinite(factor) || !std::isfinite(at_pv1)) return CountScaling{NAN, NAN};
  const CountScaling s{factor, at_pv1 - factor * double(in->pv1)};
  const double span = std::fabs(u.delta_from_si(in->si_max - in->si_min));
  constexpr double kFloatResolution = 1e-5;  // gain and pv1 are REAL32
  if (std::fabs(s.factor - 1.0) <= kFloatResolution && std::fabs(s.offset) <= kFloatResolution * span)
    return std::nullopt;
  return s;
}

double Cia404Chain::param_value(const Node& node, const Param& p, int dd) const {
  if (!p.present()) return 0.0;
  const OdEntry& e = *p.views[0];
  return is_real(e.type) ? node.values().get_f(e) : physics::from_decimal(node.values().get_i(e), dd);
}

void Cia404Chain::store_param(Node& node, const Param& p, double value, int dd) {
  // Integer twins are rendered from the REAL32 value the node reports
  // (float32(1.92) x 100 -> 192, round half away from zero, saturated).
  const bool has_real = p.present() && is_real(p.views[0]->type);
  const double v = has_real ? double(float(value)) : value;
  for (int i = 0; i < p.count; ++i) {
    const OdEntry& e = *p.views[i];
    if (is_real(e.type)) {
      node.values().set_f(e, value);
    } else {
      std::int64_t lo = 0, hi = 0;
      integer_range(e.type, lo, hi);
      node.values().set_i(e, physics::to_decimal(v, dd, lo, hi).value);
    }
  }
}

double Cia404Chain::get(const Node& node, std::size_t ch, Role role) const {
  return param_value(node, profile_->channels[ch].param(role), digits(node, ch));
}

void Cia404Chain::set(Node& node, std::size_t ch, Role role, double value) {
  invalidate();
  store_param(node, profile_->channels[ch].param(role), value, digits(node, ch));
}

UnitChoice Cia404Chain::resolve(const Node& node, const UnitChoice& u) const {
  UnitChoice r = u;
  if (u.scale_object) {
    r.scale.si_per_unit *= node.values().get_f(*u.scale_object);
    r.scale.name = {};  // no longer the named unit
  }
  return r;
}

const UnitChoice* Cia404Chain::find_unit(const ChannelConfig& c, std::uint32_t code) const {
  for (const UnitChoice& u : c.units)
    if (u.code == code) return &u;
  return nullptr;
}

const Cia404Chain::ChannelParams& Cia404Chain::params(const Node& node, std::size_t ch) {
  ChannelParams& p = state_[ch].params;
  if (p.epoch == config_epoch_) return p;
  const ChannelConfig& c = profile_->channels[ch];
  p.epoch = config_epoch_;
  p.digits = digits(node, ch);
  const auto value = [&](Role r) { return param_value(node, c.param(r), p.digits); };
  p.offset = value(Role::kOffset);
  p.span_start = value(Role::kSpanStart);
  p.span_end = value(Role::kSpanEnd);
  p.delta = value(Role::kDelta);
  p.upper = value(Role::kUpperLimit);
  p.lower = value(Role::kLowerLimit);
  return p;
}

Cia404Chain::Measurement Cia404Chain::measure(Node& node, std::size_t ch, TimeUs now) {
  if (meaning_changed_) {
    // What the PV means changed (counts or not, another scaling): what the
    // node's PDOs carry did too (the control API's PdoMappingChanged).
    meaning_changed_ = false;
    if (node.observer()) node.observer()->on_pdo_config(node, now);
  }
  ChannelState& st = state_[ch];
  if (st.measured_at != now || st.measured_epoch != config_epoch_) {
    note_read(node, now);
    st.measured = evaluate(node, ch, now);
    st.measured_at = now;
    st.measured_epoch = config_epoch_;
  } else if (st.rendered) {
    return st.measured;
  }
  // The live objects, rendered again when a personality rewrote them since
  // (live_objects_rewritten(), e.g. SMC's byte order).
  st.rendered = true;
  const Measurement& m = st.measured;
  const ChannelConfig& c = profile_->channels[ch];
  store_param(node, c.param(Role::kPv), m.pv, params(node, ch).digits);
  const Param& fv = c.param(Role::kFieldValue);
  for (int i = 0; i < fv.count; ++i) node.values().set_i(*fv.views[i], m.raw);  // raw counts, not scaled
  if (const OdEntry* e = c.param(Role::kStatus).views[0]) node.values().set_u(*e, m.status);
  return m;
}

Cia404Chain::Measurement Cia404Chain::evaluate(const Node& node, std::size_t ch, TimeUs now) {
  const ChannelConfig& c = profile_->channels[ch];
  const ChannelState& st = state_[ch];
  const MeasurementSource::Sample s = source_->sample(c.source, now);
  const ChannelParams& p = params(node, ch);
  Measurement m;
  m.raw = s.raw;
  if (const std::optional<double>& reported = override_si_[std::size_t(c.source)]) {
    // Reported as it is (through the device's input chain: in counts where
    // its PV is counts): the input is what gives that PV with the offset.
    m.pv = st.input ? st.input->scale(st.input->field_value(*reported)) : st.unit.scale.from_si(*reported);
    m.input = m.pv - p.offset;
    m.status = status_bits(ch, p, m, 0);
  } else {
    m.input = input_value(ch, s) + st.unit.scale.delta_from_si(st.zero_si);
    m.pv = m.input + p.offset;
    m.status = status_bits(ch, p, m, s.status);
  }
  return m;
}

void Cia404Chain::note_read(Node& node, TimeUs now) {
  if (!wake_on_read_) return;
  wake_on_read_ = false;
  node.wake_app(now);
}

TimeUs Cia404Chain::status_steady_until(const Node& node, std::size_t ch, TimeUs now, std::uint8_t& status) {
  const ChannelConfig& c = profile_->channels[ch];
  const ChannelState& st = state_[ch];
  const ChannelParams& p = params(node, ch);
  if (const std::optional<double>& reported = override_si_[std::size_t(c.source)]) {
    Measurement m;
    m.pv = st.unit.scale.from_si(*reported);
    m.input = m.pv - p.offset;
    status = status_bits(ch, p, m, 0);
    return kNever;  // until the override changes (a new epoch)
  }
  const physics::Steadiness s = source_->steady(c.source, now);
  if (s.until <= now) return now;
  // The chain's steps after the source are monotone in the value.
  Measurement lo, hi;
  const double zero = st.unit.scale.delta_from_si(st.zero_si);
  const double a = input_value(ch, {s.lo, 0, 0}) + zero, b = input_value(ch, {s.hi, 0, 0}) + zero;
  lo.input = std::min(a, b), hi.input = std::max(a, b);
  lo.pv = lo.input + p.offset, hi.pv = hi.input + p.offset;
  status = status_bits(ch, p, lo, s.status);
  return status_bits(ch, p, hi, s.status) == status ? s.until : now;
}

// 0x6150: bit 0 from the sensor; overload against the span objects when
// the profile has them, else the sensor's own range check.
std::uint8_t Cia404Chain::status_bits(std::size_t ch, const ChannelParams& p, const Measurement& m,
                                      std::uint8_t sensor_status) const {
  const ChannelConfig& c = profile_->channels[ch];
  std::uint8_t status = sensor_status & physics::kStatusInvalid;
  const bool start = c.param(Role::kSpanStart).present();
  const bool end = c.param(Role::kSpanEnd).present();
  if (start || end) {
    const double x = profile_->settings.span_compares_input ? m.input : m.pv;
    if (end && x > p.span_end) status |= physics::kStatusPositiveOverload;
    if (start && x < p.span_start) status |= physics::kStatusNegativeOverload;
  } else {
    status |= sensor_status & (physics::kStatusPositiveOverload | physics::kStatusNegativeOverload);
  }
  return status;
}

void Cia404Chain::apply_filter(Node& node, std::size_t ch) {
  const ChannelConfig& c = profile_->channels[ch];
  const OdEntry* type = c.param(Role::kFilterType).views[0];
  const auto fallback = std::uint64_t(profile_->settings.filter_type_without_object);
  if (!type && fallback == 0) return;
  const OdEntry* constant = c.param(Role::kFilterConstant).views[0];
  physics::FilterSpec f;
  // CiA 404 0x61A0: 0 none, 1 moving average, 2 repeating average.
  switch (type ? node.values().get_u(*type) : fallback) {
    case 1: f.type = physics::FilterType::MovingAverage; break;
    case 2: f.type = physics::FilterType::RepeatingAverage; break;
    default: f.type = physics::FilterType::None; break;
  }
  f.length = constant ? std::uint32_t(std::max<std::uint64_t>(1, node.values().get_u(*constant))) : 1;
  source_->set_filter(c.source, f);
}

void Cia404Chain::on_reset(Node& node, ResetKind kind, TimeUs now) {
  ++config_epoch_;
  if (kind != ResetKind::kCommunication) source_->reboot(now);
  for (std::size_t ch = 0; ch < state_.size(); ++ch) {
    const ChannelConfig& c = profile_->channels[ch];
    ChannelState& st = state_[ch];
    st.unit = c.fixed_unit;
    if (const OdEntry* u = c.param(Role::kUnit).views[0]; u && !profile_->settings.unit_informational) {
      if (const UnitChoice* found = find_unit(c, std::uint32_t(node.values().get_u(*u))))
        st.unit = resolve(node, *found);
    }
    if (c.zero_object) st.zero_si = c.fixed_unit.scale.delta_to_si(node.values().get_f(*c.zero_object));
    if (kind != ResetKind::kCommunication) {
      if (!c.zero_object) st.zero_si = 0.0;
      apply_filter(node, ch);
    }
    st.have_ref = false;
    st.upper_armed = st.lower_armed = true;
  }
  event_channels_ = change_channels_ = 0;
  rescan_ = true;
  next_check_ = now;
}

void Cia404Chain::on_nmt_state(Node& node, TimeUs now) {
  rescan_ = true;  // PDOs may have become allowed
  node.wake_app(now);
}

void Cia404Chain::on_pdo_config(Node& node, TimeUs now) {
  rescan_ = true;  // the event TPDO set may have changed
  node.wake_app(now);
}

void Cia404Chain::refresh(Node& node, const OdEntry& e, TimeUs now) {
  const Cia404Profile::Binding& b = profile_->binding(e);
  if (b.role == Role::kPv || b.role == Role::kFieldValue || b.role == Role::kStatus) measure(node, b.channel, now);
}

// ---- writes

void Cia404Chain::capture(const Node& node, std::size_t ch) {
  const ChannelConfig& c = profile_->channels[ch];
  ChannelState& st = state_[ch];
  const int dd = digits(node, ch);
  for (std::size_t r = 0; r < kRoleCount; ++r) st.captured[r] = param_value(node, c.params[r], dd);
  for (std::size_t x = 0; x < c.extras.size(); ++x) st.captured[kRoleCount + x] = param_value(node, c.extras[x], dd);
}

// Stores the captured values again with the current digits, converted
// between units for the unit-dependent ones when from/to are given.
void Cia404Chain::rerender(Node& node, std::size_t ch, const UnitScale* from, const UnitScale* to) {
  const ChannelConfig& c = profile_->channels[ch];
  const ChannelState& st = state_[ch];
  const int dd = digits(node, ch);
  for (std::size_t r = 0; r < kRoleCount; ++r) {
    if (!model::is_valued(Role(r)) || !c.params[r].present()) continue;
    double v = st.captured[r];
    if (from && (c.dependent_roles >> r) & 1) v = convert(v, *from, *to, c.params[r].difference);
    store_param(node, c.params[r], v, dd);
  }
  for (std::size_t x = 0; x < c.extras.size(); ++x) {
    double v = st.captured[kRoleCount + x];
    if (from) v = convert(v, *from, *to, c.extras[x].difference);
    store_param(node, c.extras[x], v, dd);
  }
}

namespace {
int unit_change_digits(DigitsOnUnitChange policy, int dd, int max, const UnitScale& from, const UnitScale& to) {
  switch (policy) {
    case DigitsOnUnitChange::kAdjust: {
      // Keep the resolution: one new unit is k old units (e.g. bar -> mbar: 3 digits fewer).
      double k = to.si_per_unit / from.si_per_unit;
      dd = std::clamp(dd + int(std::lround(std::log10(k))), 0, max >= 0 ? max : 9);
      return dd;
    }
    case DigitsOnUnitChange::kClamp: return max >= 0 ? std::min(dd, max) : dd;
    default: return dd;
  }
}

double decode_data(const OdEntry& e, std::span<const std::uint8_t> data, int dd) {
  return data.size() >= type_size(e.type) ? decode_view(e, data.data(), dd) : 0.0;
}
}  // namespace

SdoAbort Cia404Chain::check_write(Node& node, const OdEntry& e, std::span<const std::uint8_t> data, TimeUs) {
  ++config_epoch_;
  const Cia404Profile::Binding& b = profile_->binding(e);
  if (b.role == Role::kNone) return SdoAbort::kNone;
  const Cia404Settings& s = profile_->settings;
  const ChannelConfig& c = profile_->channels[b.channel];
  ChannelState& st = state_[b.channel];
  const int dd = digits(node, b.channel);
  switch (b.role) {
    case Role::kUnit: {
      if (s.unit_informational) return SdoAbort::kNone;
      const UnitChoice* u = find_unit(c, std::uint32_t(decode_u(e.type, data.data())));
      if (!u) return s.bad_unit_abort;
      if (s.digits_on_unit_change == DigitsOnUnitChange::kReject && u->max_digits >= 0 && dd > u->max_digits)
        return s.unit_digits_abort;
      st.pending_unit = resolve(node, *u);
      capture(node, b.channel);
      return SdoAbort::kNone;
    }
    case Role::kDigits: {
      if (st.unit.max_digits >= 0 && std::int64_t(decode_u(e.type, data.data())) > st.unit.max_digits)
        return s.digits_abort;
      capture(node, b.channel);
      return SdoAbort::kNone;
    }
    case Role::kAutozero:
      // CiA 404: only the signature "zero" (0x6F72657A) triggers the autozero.
      return decode_u(e.type, data.data()) == s.autozero_signature ? SdoAbort::kNone : s.bad_autozero_abort;
    case Role::kDelta:
    case Role::kHysteresis: return decode_data(e, data, dd) < 0 ? s.negative_abort : SdoAbort::kNone;
    case Role::kFilterType: return decode_u(e.type, data.data()) > 2 ? SdoAbort::kInvalidValue : SdoAbort::kNone;
    case Role::kFilterConstant: return decode_u(e.type, data.data()) == 0 ? SdoAbort::kValueTooLow : SdoAbort::kNone;
    default: return SdoAbort::kNone;
  }
}

void Cia404Chain::after_param_write(Node& node, std::size_t ch, const Param& p, const OdEntry& written) {
  // The written view is the truth; its twins follow.
  const int dd = digits(node, ch);
  const double v = decode_view(written, node.values().bytes(written).data(), dd);
  store_param(node, p, v, dd);
}

void Cia404Chain::autozero(Node& node, std::size_t ch, TimeUs now) {
  // CiA 404 0x6125: the offset is set so that the PV reads 0 now.
  // Autozero target "correction" (or no offset object): a hidden correction,
  // kept in SI so it survives unit changes.
  const Measurement m = measure(node, ch, now);
  const ChannelConfig& c = profile_->channels[ch];
  ChannelState& st = state_[ch];
  if (c.param(Role::kOffset).present() && !profile_->settings.autozero_to_correction) {
    set(node, ch, Role::kOffset, get(node, ch, Role::kOffset) - m.pv);
  } else {
    st.zero_si -= st.unit.scale.delta_to_si(m.pv);
    if (c.zero_object) node.values().set_f(*c.zero_object, c.fixed_unit.scale.delta_from_si(st.zero_si));
    invalidate();
  }
  measure(node, ch, now);
}

void Cia404Chain::after_write(Node& node, const OdEntry& e, TimeUs now) {
  ++config_epoch_;
  const Cia404Profile::Binding& b = profile_->binding(e);
  if (b.role == Role::kNone) return;
  const std::size_t ch = b.channel;
  const ChannelConfig& c = profile_->channels[ch];
  ChannelState& st = state_[ch];
  switch (b.role) {
    case Role::kUnit: {
      if (profile_->settings.unit_informational) return;
      const UnitChoice from = st.unit;
      st.unit = st.pending_unit;
      if (const OdEntry* d = c.param(Role::kDigits).views[0]; d && writable(d->access)) {
        int dd = unit_change_digits(profile_->settings.digits_on_unit_change, digits(node, ch), st.unit.max_digits,
                                    from.scale, st.unit.scale);
        node.values().set_u(*d, std::uint64_t(dd));
      }
      rerender(node, ch, &from.scale, &st.unit.scale);
      break;
    }
    case Role::kDigits: rerender(node, ch, nullptr, nullptr); break;
    case Role::kAutozero: autozero(node, ch, now); break;
    case Role::kFilterType:
    case Role::kFilterConstant: apply_filter(node, ch); break;
    case Role::kExtra: after_param_write(node, ch, c.extras[b.extra], e); break;
    default:
      if (model::is_valued(b.role)) after_param_write(node, ch, c.param(b.role), e);
      break;
  }
  if ((b.role == Role::kUnit || b.role == Role::kDigits) && node.observer()) node.observer()->on_pdo_config(node, now);
  if (b.role >= Role::kDelta && b.role <= Role::kHysteresis) {
    st.have_ref = false;
    st.upper_armed = st.lower_armed = true;
    node.wake_app(now);
  }
}

// ---- events (CiA 404 analogue-input interrupts, TPDO types 254/255)

// The channels whose PV a valid TPDO of one of `types` maps (CiA 404: the
// analogue-input interrupts act on mapped channels).
std::uint32_t Cia404Chain::scan_event_channels(const Node& node, const ByteSet& types) const {
  std::uint32_t mask = 0;
  const PdoEngine& pdo = node.pdo();
  for (const Tpdo& t : pdo.tpdos()) {
    if (!pdo.valid(t.cfg) || !types.has(t.cfg.type)) continue;
    for (const PdoMapItem& item : std::span(t.cfg.items).first(t.cfg.item_count)) {
      if (item.slot == PdoMapItem::kDummy) continue;
      const Cia404Profile::Binding& b = profile_->binding(node.od().entry(item.slot));
      if (b.role == Role::kPv && b.channel < 32) mask |= 1u << b.channel;
    }
  }
  return mask;
}

TimeUs Cia404Chain::check_period(std::size_t ch) const {
  const TimeUs p = profile_->settings.event_check_period_us;
  return p > 0 ? p : source_->sample_period_us(profile_->channels[ch].source);
}

// Change of state: the mapped PV or field value differs from the one of the
// last change event (the first check after arming always fires).
bool Cia404Chain::changed(Node& node, std::size_t ch) {
  const ChannelConfig& c = profile_->channels[ch];
  ChannelState& st = state_[ch];
  std::uint8_t bytes[8] = {};  // PV in bytes 0-3, field value in bytes 4-7
  for (int i = 0; i < 2; ++i) {
    if (const OdEntry* e = c.param(i ? Role::kFieldValue : Role::kPv).views[0]) {
      const auto v = node.values().bytes(*e);
      std::memcpy(bytes + 4 * i, v.data(), std::min<std::size_t>(4, v.size()));
    }
  }
  std::uint64_t key = 0;
  std::memcpy(&key, bytes, sizeof key);
  if (st.have_change_ref && key == st.change_ref) return false;
  st.change_ref = key;
  st.have_change_ref = true;
  return true;
}

// Limits: one event per crossing; re-armed once back inside by the hysteresis.
unsigned Cia404Chain::check_limits(std::size_t ch, const ChannelParams& p, double pv, double hyst) {
  const ChannelConfig& c = profile_->channels[ch];
  ChannelState& st = state_[ch];
  const bool level = profile_->settings.limit_level;
  unsigned events = 0;
  if (c.param(Role::kUpperLimit).present()) {
    if (pv > p.upper && (st.upper_armed || level)) {
      events |= kEventUpperUp;
      st.upper_armed = false;
    } else if (pv <= p.upper - hyst) {
      if (!st.upper_armed) events |= kEventUpperDown;
      st.upper_armed = true;
    }
  }
  if (c.param(Role::kLowerLimit).present()) {
    if (pv < p.lower && (st.lower_armed || level)) {
      events |= kEventLowerDown;
      st.lower_armed = false;
    } else if (pv >= p.lower + hyst) {
      if (!st.lower_armed) events |= kEventLowerUp;
      st.lower_armed = true;
    }
  }
  return events;
}

bool Cia404Chain::check_events(Node& node, std::size_t ch, TimeUs now, EventRoute route) {
  const ChannelConfig& c = profile_->channels[ch];
  ChannelState& st = state_[ch];
  const double pv = measure(node, ch, now).pv;
  const ChannelParams& p = params(node, ch);
  unsigned events = (change_channels_ >> ch) & 1 && changed(node, ch) ? kEventChange : 0u;
  // Delta: |PV - PV at the last event| > delta (delta 0 = off).
  if (c.param(Role::kDelta).present() && p.delta > 0) {
    if (!st.have_ref) {
      st.delta_ref = pv;
      st.have_ref = true;
    } else if (std::fabs(pv - st.delta_ref) > p.delta) {
      events |= kEventDelta;
    }
  }
  events |= check_limits(ch, p, pv, limit_hysteresis(node, ch));
  if (events & kEventsRaising) {
    st.delta_ref = pv;  // the TPDO carries this value
    st.have_ref = true;
  }
  if (events) {
    if (route) route(ch, events);
    else raise_events(node, ch, events);
  }
  return (events & kEventsRaising) != 0;
}

// Hysteresis of the limit interrupts: CiA 404 0x6136, or what the device set.
double Cia404Chain::limit_hysteresis(const Node& node, std::size_t ch) const {
  const std::optional<double>& h = state_[ch].hysteresis;
  return h ? *h : get(node, ch, Role::kHysteresis);
}

// Source value -> value in the current unit before the offset.
double Cia404Chain::input_value(std::size_t ch, const MeasurementSource::Sample& s) const {
  const ChannelState& st = state_[ch];
  return st.input ? st.input->scale(st.input->field_value(s.si)) : st.unit.scale.from_si(s.si);
}

void Cia404Chain::set_linear_input(std::size_t ch, const std::optional<LinearInput>& input) {
  if (state_[ch].input == input) return;
  state_[ch].input = input;
  invalidate();  // the PV of this instant changes too
  meaning_changed_ = true;
}

void Cia404Chain::raise_events(Node& node, std::size_t ch, unsigned events) {
  if (!(events & kEventsRaising)) return;
  for (Role r : {Role::kPv, Role::kFieldValue, Role::kStatus}) {
    const Param& p = profile_->channels[ch].param(r);
    for (int i = 0; i < p.count; ++i) node.pdo().raise_event_for(*p.views[i]);
  }
}

// Delta / limit / change events of the channels mapped into event TPDOs.
TimeUs Cia404Chain::process(Node& node, TimeUs now, EventRoute route) {
  if (!node.allowed(Service::kPdo)) {
    event_channels_ = change_channels_ = 0;
    rescan_ = true;  // once PDOs are allowed again
    return kNever;   // on_nmt_state wakes the application on the next state change
  }
  if (rescan_) rescan_event_channels(node);
  TimeUs period = kNever;
  for (std::size_t ch = 0; ch < state_.size() && ch < 32; ++ch) {
    if (!((event_channels_ >> ch) & 1)) continue;
    check_events(node, ch, now, route);
    period = std::min(period, check_period(ch));
  }
  if (period == kNever) return kNever;
  // The checks run on the device's own measurement grid, from its reset: a
  // wake-up between two grid points (a control call, an NMT command) checks
  // at once but does not move the grid.
  if (next_check_ <= now) next_check_ += ((now - next_check_) / period + 1) * period;
  return next_check_;
}

// A channel that joins the event set starts with fresh references.
void Cia404Chain::rescan_event_channels(const Node& node) {
  const Cia404Settings& s = profile_->settings;
  const std::uint32_t change = scan_event_channels(node, s.change_event_tpdo_types);
  const std::uint32_t all = state_.size() >= 32 ? ~0u : (1u << state_.size()) - 1u;
  const std::uint32_t mask = (s.events_all_channels ? all : scan_event_channels(node, s.event_tpdo_types)) | change;
  for (std::size_t ch = 0; ch < state_.size() && ch < 32; ++ch) {
    if ((mask >> ch) & 1 && !((event_channels_ >> ch) & 1)) {
      state_[ch].have_ref = false;
      state_[ch].upper_armed = state_[ch].lower_armed = true;
    }
    if ((change >> ch) & 1 && !((change_channels_ >> ch) & 1)) state_[ch].have_change_ref = false;
  }
  event_channels_ = mask;
  change_channels_ = change;
  rescan_ = false;
}

}  // namespace cansim::personalities
