#include "core/emcy.hpp"

#include <algorithm>
#include <cstring>

#include "core/protocol.hpp"
#include "core/node.hpp"

namespace cansim {

namespace {
using cob::kFrame29Bit;
using cob::kInvalid;
constexpr std::uint16_t kErrorReset = 0x0000;
constexpr std::uint8_t kGenericBit = 0x01;
constexpr std::uint8_t kNoMfr[5] = {};

}  // namespace

std::uint8_t Emcy::class_bits(std::uint16_t code) {
  switch (code >> 12) {
    case 0x1: return 0x01;  // generic
    case 0x2: return 0x02;  // current
    case 0x3: return 0x04;  // voltage
    case 0x4: return 0x08;  // temperature
    case 0x8:               // 81xx communication, 82xx protocol error
      return (code >> 8) == 0x81 || (code >> 8) == 0x82 ? 0x10 : 0x00;
    case 0xF: return (code >> 8) == 0xFF ? 0x80 : 0x00;  // device specific
    default: return 0x00;
  }
}

void Emcy::reset(TimeUs) {
  active_n_ = 0;
  queue_n_ = queue_head_ = 0;
  last_sent_ = kNever;
  next_ = kNever;
  register_ = 0;
  const OdObject* h = node_.od().object(0x1003);
  history_depth_ = h && h->count > 1 ? std::uint8_t(std::min<int>(h->count - 1, 254)) : 0;
  read_config();
}

void Emcy::read_config() {
  const OdEntry* c = node_.od().find(0x1014, 0);
  std::uint32_t v = c ? std::uint32_t(node_.values().get_u(*c)) : cob::kEmcyBase + node_.node_id();
  valid_ = !(v & kInvalid);
  extended_ = v & kFrame29Bit;
  can_id_ = cob::can_id(v);
  const OdEntry* i = node_.od().find(0x1015, 0);
  inhibit_us_ = i ? TimeUs(node_.values().get_u(*i)) * 100 : 0;
}

bool Emcy::active(std::uint16_t code) const {
  for (std::size_t i = 0; i < active_n_; ++i)
    if (active_[i].code == code) return true;
  return false;
}

void Emcy::update_register() {
  const NodeOptions& o = node_.options();
  std::uint8_t reg = 0;
  for (std::size_t i = 0; i < active_n_; ++i) {
    reg |= active_[i].reg;
    if (o.emcy_register_class_bits) reg |= class_bits(active_[i].code);
  }
  if (active_n_ && o.emcy_register_generic_bit) reg |= kGenericBit;
  register_ = reg;
  if (const OdEntry* e = node_.od().find(0x1001, 0)) node_.values().set_u(*e, reg);
}

void Emcy::raise(std::uint16_t code, std::uint8_t reg_bits, const std::uint8_t mfr[5], TimeUs now) {
  if (!mfr) mfr = kNoMfr;
  bool known = false;
  for (std::size_t i = 0; i < active_n_; ++i) {
    if (active_[i].code != code) continue;
    active_[i].reg |= reg_bits;
    known = true;
  }
  if (!known && active_n_ < kMaxActive) active_[active_n_++] = Active{code, reg_bits};
  update_register();
  record(code, register_, mfr);
  emit(code, register_, mfr, now);
  node_.wake_app(now);  // an application may react to the error state (CMP: PRE-OPERATIONAL)
}

void Emcy::report(std::uint16_t code, std::uint8_t reg_bits, const std::uint8_t mfr[5], TimeUs now) {
  if (!mfr) mfr = kNoMfr;
  const NodeOptions& o = node_.options();
  std::uint8_t reg = std::uint8_t(register_ | reg_bits);
  if (o.emcy_register_class_bits) reg |= class_bits(code);
  if (o.emcy_register_generic_bit) reg |= kGenericBit;
  record(code, reg, mfr);
  emit(code, reg, mfr, now);
}

void Emcy::restore_active(std::uint16_t code, std::uint8_t reg_bits) {
  if (!active(code) && active_n_ < kMaxActive) active_[active_n_++] = Active{code, reg_bits};
  update_register();
}

void Emcy::clear(std::uint16_t code, TimeUs now) {
  std::size_t i = 0;
  while (i < active_n_ && active_[i].code != code) ++i;
  if (i == active_n_) return;
  std::copy(active_ + i + 1, active_ + active_n_, active_ + i);
  --active_n_;
  update_register();
  if (active_n_ == 0 || node_.options().emcy_on_partial_clear == PartialClearEmcy::kReset)
    emit(kErrorReset, register_, kNoMfr, now);
  else if (node_.options().emcy_on_partial_clear == PartialClearEmcy::kLatest)
    emit(active_[active_n_ - 1].code, register_, kNoMfr, now);
  node_.wake_app(now);
}

void Emcy::clear_all(TimeUs now) {
  if (active_n_ == 0) return;
  active_n_ = 0;
  update_register();
  emit(kErrorReset, register_, kNoMfr, now);
  node_.wake_app(now);
}

// ---------------------------------------------------------------- 0x1003

std::uint8_t Emcy::history_count() const {
  const OdEntry* n = node_.od().find(0x1003, 0);
  return n ? std::uint8_t(std::min<std::uint64_t>(node_.values().get_u(*n), history_depth_)) : 0;
}

// Newest entry at sub 1, older ones shift up, the oldest falls off (CiA 301
// §7.5.2.4). Bits 0-15 code, bits 16-31 manufacturer info (mfr bytes 0-1).
void Emcy::record(std::uint16_t code, std::uint8_t reg, const std::uint8_t* mfr) {
  if (history_depth_ == 0) return;
  std::uint32_t info = node_.options().emcy_history_register_in_info ? reg : get_u16(mfr);
  std::uint8_t n = history_count();
  OdValues& v = node_.values();
  for (std::uint8_t sub = std::min<std::uint8_t>(n, std::uint8_t(history_depth_ - 1)); sub >= 1; --sub) {
    const OdEntry* from = node_.od().find(0x1003, sub);
    const OdEntry* to = node_.od().find(0x1003, std::uint8_t(sub + 1));
    if (from && to) v.set_u(*to, v.get_u(*from));
  }
  if (const OdEntry* first = node_.od().find(0x1003, 1)) v.set_u(*first, code | (info << 16));
  v.set_u(0x1003, 0, std::min<unsigned>(n + 1u, history_depth_));
}

void Emcy::clear_history() {
  for (std::uint8_t sub = 0; sub <= history_depth_; ++sub)
    if (const OdEntry* e = node_.od().find(0x1003, sub)) node_.values().set_u(*e, 0);
}

SdoAbort Emcy::check_read(const OdEntry& e) const {
  std::int64_t abort = node_.options().emcy_history_read_empty_abort;
  if (e.index != 0x1003 || e.sub == 0 || abort == 0) return SdoAbort::kNone;
  return e.sub > history_count() ? SdoAbort(std::uint32_t(abort)) : SdoAbort::kNone;
}

// ---------------------------------------------------------------- sending

void Emcy::emit(std::uint16_t code, std::uint8_t reg, const std::uint8_t* mfr, TimeUs now) {
  if (!valid_ || node_.state() == NmtState::kStopped) return;  // recorded only
  if (queue_n_ == kQueueSize) return;                          // ring full: dropped
  Pending& p = queue_[(queue_head_ + queue_n_++) % kQueueSize];
  put_u16(p.data, code);
  p.data[2] = reg;
  std::memcpy(p.data + 3, mfr, 5);
  while (queue_n_ && may_send_now(now)) send_front(now);
  update_deadline(now);
}

bool Emcy::may_send_now(TimeUs now) const {
  if (!node_.allowed(Service::kEmcy)) return false;
  return inhibit_us_ == 0 || last_sent_ == kNever || now >= last_sent_ + node_.local_duration(inhibit_us_);
}

void Emcy::send_front(TimeUs now) {
  Pending& p = queue_[queue_head_];
  queue_head_ = std::uint8_t((queue_head_ + 1) % kQueueSize);
  --queue_n_;
  if (!valid_) return;
  CanFrame f;
  f.id = can_id_;
  f.flags = extended_ ? CanFrame::kExtended : 0;
  f.dlc = 8;
  std::memcpy(f.data, p.data, 8);
  const bool sent = node_.send(f);
  last_sent_ = now;
  if (sent) note_sent(f.data, now);
}

// Frame layout [code lo, code hi, 0x1001, mfr0..mfr4] (CiA 301 §7.2.7).
void Emcy::note_sent(const std::uint8_t data[8], TimeUs now) {
  ++sent_count_;
  last_emcy_.time = now;
  last_emcy_.code = get_u16(data);
  last_emcy_.reg = data[2];
  std::memcpy(last_emcy_.vendor, data + 3, 5);
  if (NodeObserver* o = node_.observer()) o->on_emcy(node_, last_emcy_.code, last_emcy_.reg, last_emcy_.vendor, now);
}

void Emcy::update_deadline(TimeUs) {
  bool waiting = queue_n_ && node_.allowed(Service::kEmcy) && inhibit_us_ && last_sent_ != kNever;
  next_ = waiting ? last_sent_ + node_.local_duration(inhibit_us_) : kNever;
}

void Emcy::process(TimeUs now) {
  if (queue_n_ && may_send_now(now)) send_front(now);
  update_deadline(now);
}

void Emcy::on_nmt_state(NmtState old, TimeUs now) {
  NmtState s = node_.state();
  if (s == NmtState::kStopped) {
    queue_n_ = 0;  // not sent in STOPPED
  } else if (old == NmtState::kStopped && node_.allowed(Service::kEmcy) && node_.options().emcy_resend_after_stopped) {
    for (std::size_t i = 0; i < active_n_; ++i) emit(active_[i].code, register_, kNoMfr, now);
  }
  while (queue_n_ && may_send_now(now)) send_front(now);  // e.g. raised before the boot-up
  update_deadline(now);
}

bool Emcy::on_frame(const CanFrame&, TimeUs) { return false; }
void Emcy::collect_rx_ids(std::vector<std::uint32_t>&) const {}

// ---------------------------------------------------------------- OD writes

bool Emcy::owns(std::uint16_t index) const { return index == 0x1003 || index == 0x1014 || index == 0x1015; }

SdoAbort Emcy::write(const OdEntry& e, std::span<const std::uint8_t> data, TimeUs now) {
  std::uint64_t v = decode_u(e.type, data.data());
  switch (e.index) {
    case 0x1003:
      if (e.sub != 0) return SdoAbort::kReadOnly;
      if (v != 0) return SdoAbort(std::uint32_t(node_.options().emcy_history_bad_write_abort));
      clear_history();
      return SdoAbort::kNone;
    case 0x1014: return write_cob_id(e, std::uint32_t(v));
    default:  // 0x1015, changeable at any time (CiA 301 §7.5.2.18)
      node_.values().set_bytes(e, data);
      read_config();
      update_deadline(now);
      return SdoAbort::kNone;
  }
}

// The CAN-ID may change only while bit 31 marks the EMCY invalid (CiA 301
// §7.5.2.17); bit 30 is reserved.
SdoAbort Emcy::write_cob_id(const OdEntry& e, std::uint32_t v) {
  if (v & cob::kEmcyReserved) return SdoAbort::kInvalidValue;
  if (!cob::format_ok(v)) return SdoAbort::kInvalidValue;
  std::uint32_t current = std::uint32_t(node_.values().get_u(e));
  if (!(current & kInvalid) && !(v & kInvalid) && cob::frame_id(current) != cob::frame_id(v))
    return SdoAbort::kInvalidValue;
  node_.values().set_u(e, v);
  read_config();
  return SdoAbort::kNone;
}

}  // namespace cansim
