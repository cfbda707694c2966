#include "core/sync.hpp"

#include "core/protocol.hpp"
#include "core/node.hpp"

namespace cansim {

namespace {
using cob::kFrame29Bit;

// Validates the frame-format bits of a COB-ID (CiA 301 Table 50): with bit 29
// clear, bits 11..28 must be 0.
}  // namespace

void SyncConsumer::reset(TimeUs) {
  last_sync_ = kNever;
  next_ = kNever;
  read_config();
}

void SyncConsumer::read_config() {
  const OdEntry* c = node_.od().find(0x1005, 0);
  const std::int64_t fixed = node_.options().sync_cob_id_without_1005;
  present_ = c != nullptr || fixed > 0;
  std::uint32_t v = c ? std::uint32_t(node_.values().get_u(*c)) : std::uint32_t(fixed);
  extended_ = v & kFrame29Bit;
  cob_id_ = cob::can_id(v);
  const OdEntry* o = node_.od().find(0x1019, 0);
  overflow_ = o ? std::uint8_t(node_.values().get_u(*o)) : 0;
  const OdEntry* w = node_.od().find(0x1007, 0);
  window_us_ = w ? TimeUs(node_.values().get_u(*w)) : 0;
}

bool SyncConsumer::window_open(TimeUs now) const {
  if (window_us_ == 0) return true;
  return last_sync_ != kNever && now - last_sync_ <= node_.local_duration(window_us_);
}

bool SyncConsumer::on_frame(const CanFrame& f, TimeUs now) {
  if (!present_ || f.rtr() || f.id != cob_id_ || f.extended() != extended_) return false;
  if (!node_.allowed(Service::kSync)) return true;
  std::uint8_t expected = overflow_ ? 1 : 0;
  if (f.dlc != expected && !node_.options().sync_accept_any_dlc) {
    std::uint8_t info[5] = {f.dlc, 0, 0, 0, 0};
    node_.emcy().report(emcy::kSyncLength, 0, info, now);
    return true;
  }
  std::uint8_t counter = overflow_ && f.dlc >= 1 ? f.data[0] : 0;
  last_sync_ = now;
  node_.pdo().on_sync(counter, now);
  if (Application* app = node_.app()) app->on_sync(node_, counter, now);
  return true;
}

void SyncConsumer::process(TimeUs) { next_ = kNever; }

void SyncConsumer::collect_rx_ids(std::vector<std::uint32_t>& out) const {
  if (present_) out.push_back(cob_id_ | (extended_ ? cob::kRxIdExtended : 0));
}

bool SyncConsumer::owns(std::uint16_t index) const { return index == 0x1005 || index == 0x1007 || index == 0x1019; }

SdoAbort SyncConsumer::write(const OdEntry& e, std::span<const std::uint8_t> data, TimeUs) {
  std::uint64_t v = decode_u(e.type, data.data());
  if (e.index == 0x1005) return write_cob_id(e, std::uint32_t(v));
  if (e.index == 0x1019) return write_overflow(e, std::uint8_t(v));
  node_.values().set_bytes(e, data);  // 0x1007
  read_config();
  return SdoAbort::kNone;
}

SdoAbort SyncConsumer::write_cob_id(const OdEntry& e, std::uint32_t v) {
  std::int64_t generate_abort = node_.options().sync_generate_bit_abort;
  if ((v & cob::kGenerate) && generate_abort) return SdoAbort(std::uint32_t(generate_abort));
  if (!cob::format_ok(v)) return SdoAbort::kInvalidValue;
  node_.values().set_u(e, v);
  read_config();
  node_.rx_changed();
  return SdoAbort::kNone;
}

// 0x1019: 0 = no counter, 2..240 = counter overflow; 1 and 241..255 are
// reserved. Changeable only while the cycle period 0x1006 is 0 (CiA 301
// §7.5.2.40).
SdoAbort SyncConsumer::write_overflow(const OdEntry& e, std::uint8_t v) {
  if (v == 1 || v > 240) return SdoAbort::kInvalidValue;
  const OdEntry* period = node_.od().find(0x1006, 0);
  if (period && node_.values().get_u(*period) != 0) return SdoAbort::kDeviceState;
  node_.values().set_u(e, v);
  read_config();
  return SdoAbort::kNone;
}

}  // namespace cansim
