#include "core/sdo_server.hpp"

#include <algorithm>
#include <cstring>

#include "core/crc16.hpp"
#include "core/node.hpp"
#include "core/protocol.hpp"

namespace cansim {

namespace {

using namespace sdo;

constexpr std::uint8_t ccs(const std::uint8_t* d) { return d[0] & kCsMask; }

}  // namespace

// ------------------------------------------------------------ configuration

void SdoServer::reset(TimeUs) {
  idle();
  delayed_n_ = 0;  // answers still in the pipe die with the reset
  delayed_changed();
  turnaround_end_ = 0;
  const NodeOptions& o = node_.options();
  timeout_ = ms(o.sdo_timeout_ms);  // 0: no timeout
  turnaround_.set(o.sdo_turnaround_us, o.sdo_turnaround_jitter_us);
  if (turnaround_.any()) reserve_pipe();

  // One buffer for the largest value plus a segment of slack (block download
  // stores whole 7-byte segments before the end frame says how many count).
  const std::size_t need = node_.od().max_capacity() + 7;
  if (buf_.size() < need) buf_.resize(need);

  load_cob_ids();
}

// CiA 301 §7.5.2.33: 0x1200:01/02, bit 31 = not valid, bit 29 = 29-bit ID.
// An LSS-unconfigured node (node-ID 0xFF) has no SDO server.
void SdoServer::load_cob_ids() {
  std::uint8_t id = node_.node_id();
  valid_ = id >= 1 && id <= 127;
  if (!valid_) return;
  std::uint32_t rx = cob::kSdoRxBase + id;
  std::uint32_t tx = cob::kSdoTxBase + id;
  if (const OdEntry* e = node_.od().find(0x1200, 1)) rx = std::uint32_t(node_.values().get_u(*e));
  if (const OdEntry* e = node_.od().find(0x1200, 2)) tx = std::uint32_t(node_.values().get_u(*e));
  valid_ = !(rx & cob::kInvalid) && !(tx & cob::kInvalid);
  rx_ext_ = rx & cob::kFrame29Bit;
  tx_ext_ = tx & cob::kFrame29Bit;
  rx_id_ = cob::can_id(rx);
  tx_id_ = cob::can_id(tx);
}

// 29-bit identifiers carry bit 31 (SocketCAN CAN_EFF_FLAG), as io/dispatch expects.
void SdoServer::collect_rx_ids(std::vector<std::uint32_t>& out) const {
  if (valid_) out.push_back(rx_ext_ ? (rx_id_ | cob::kRxIdExtended) : rx_id_);
}

bool SdoServer::owns(std::uint16_t index) const { return index == 0x1200; }

// 0x1200:01/02 when a profile makes them writable: the CAN-ID of a valid
// channel may only change while it is invalid (bit 31 set), as for PDOs.
SdoAbort SdoServer::write(const OdEntry& e, std::span<const std::uint8_t> data, TimeUs) {
  if (e.sub == 1 || e.sub == 2) {
    std::uint32_t v = get_u32(data.data());
    std::uint32_t old = std::uint32_t(node_.values().get_u(e));
    if (!cob::format_ok(v)) return SdoAbort::kInvalidValue;
    bool both_valid = !(v & cob::kInvalid) && !(old & cob::kInvalid);
    if (both_valid && cob::frame_id(v) != cob::frame_id(old)) return SdoAbort::kInvalidValue;
    node_.values().set_bytes(e, data);
    reload_pending_ = true;  // applied after the confirmation went out
    if (!in_frame_) apply_reload();
    return SdoAbort::kNone;
  }
  node_.values().set_bytes(e, data);
  return SdoAbort::kNone;
}

void SdoServer::apply_reload() {
  reload_pending_ = false;
  load_cob_ids();
  node_.rx_changed();
}

// ------------------------------------------------------------ frame entry

bool SdoServer::on_frame(const CanFrame& frame, TimeUs now) {
  if (!valid_ || frame.id != rx_id_ || frame.extended() != rx_ext_) return false;
  if (frame.rtr()) return true;
  // CiA 301 Table 82: no SDO in STOPPED (nor while initialising).
  if (!node_.allowed(Service::kSdo)) {
    idle();
    return true;
  }
  if (frame.dlc < node_.options().sdo_min_request_dlc) return true;
  std::uint8_t d[8] = {};
  std::memcpy(d, frame.data, std::min<std::size_t>(frame.dlc, 8));

  if (silenced(d)) return true;
  in_frame_ = true;
  now_ = now;
  answer_at_ = kNever;
  dispatch(d, now);
  in_frame_ = false;
  if (reload_pending_) apply_reload();
  return true;
}

void SdoServer::dispatch(Bytes d, TimeUs now) {
  // A client abort ends any transfer silently. Inside a block-download
  // sub-block byte 0 is c|seqno, where 0x80 (seqno 0) can only be an abort.
  bool client_abort = state_ == State::kBlockDownloadSub ? d[0] == kCsAbort : ccs(d) == kCsAbort;
  if (client_abort) {
    idle();
    return;
  }
  switch (state_) {
    case State::kIdle: return on_idle(d, now);
    case State::kDownloadSegment: return on_download_segment(d, now);
    case State::kUploadSegment: return on_upload_segment(d, now);
    case State::kBlockDownloadSub: return on_block_download_segment(d, now);
    case State::kBlockDownloadEnd: return on_block_download_end(d, now);
    case State::kBlockUploadStart: return on_block_upload_start(d, now);
    case State::kBlockUploadAck: return on_block_upload_ack(d, now);
    case State::kBlockUploadEnd: return on_block_upload_end(d, now);
  }
}

void SdoServer::process(TimeUs now) {
  while (delayed_n_ && delayed_[delayed_head_].at <= now) {
    if (node_.allowed(Service::kSdo)) send_now(delayed_[delayed_head_].data);
    delayed_head_ = (delayed_head_ + 1) % delayed_.size();
    --delayed_n_;
    delayed_changed();
  }
  now_ = now;
  answer_at_ = kNever;
  if (block_ack_at_ <= now) {
    block_ack_at_ = kNever;
    if (state_ == State::kBlockDownloadSub) send_block_download_ack();
  }
  if (state_ == State::kIdle || now < deadline_) return;
  if (node_.allowed(Service::kSdo)) abort(SdoAbort::kTimeout);
  else idle();
}

// ------------------------------------------------------------ idle: initiates

void SdoServer::on_idle(Bytes d, TimeUs now) {
  index_ = get_u16(d + 1);
  sub_ = d[3];
  for (std::size_t i = 0; i < faults_.abort_n; ++i)
    if (faults_.aborts[i].object.matches(index_, sub_)) return abort(faults_.aborts[i].code, index_, sub_);
  switch (ccs(d)) {
    case kCcsInitiateDownload: return initiate_download(d, now);
    case kCcsInitiateUpload: return initiate_upload(d, now);
    case kCcsBlockUpload:
      if ((d[0] & kScMask) == kScInitiate) return initiate_block_upload(d, now);
      break;
    case kCcsBlockDownload:
      if ((d[0] & kScEnd) == kScInitiate) return initiate_block_download(d, now);
      break;
    default: break;
  }
  // Not an initiate: bytes 1..3 are no multiplexer, answer with 0000:00.
  index_ = 0;
  sub_ = 0;
  abort(SdoAbort::kCommandSpecifier);
}

const OdEntry* SdoServer::find_entry() {
  SdoAbort why = SdoAbort::kNone;
  const OdEntry* e = node_.od().lookup(index_, sub_, why);
  if (!e) abort(why);
  return e;
}

bool SdoServer::refuse(bool allowed) {
  if (allowed) return false;
  abort(std::uint32_t(node_.options().sdo_refusal_abort), index_, sub_);
  return true;
}

bool SdoServer::segmented_download_allowed() const {
  const NodeOptions& o = node_.options();
  return o.sdo_segmented_download && !o.sdo_expedited_only;
}

bool SdoServer::block_allowed() const {
  const NodeOptions& o = node_.options();
  return o.sdo_block_transfer && !o.sdo_expedited_only;
}

// Checks before a segmented or block download is accepted.
const OdEntry* SdoServer::download_target() {
  const OdEntry* e = find_entry();
  if (!e) return nullptr;
  if (!writable(e->access)) {
    abort(SdoAbort::kReadOnly);
    return nullptr;
  }
  // Vendor quirk: multi-frame writes only to some objects (0x06010000).
  if (!node_.options().sdo_segmented_download_indices.contains(index_)) {
    abort(SdoAbort::kUnsupportedAccess);
    return nullptr;
  }
  return e;
}

SdoAbort SdoServer::check_download_size(const OdEntry& e, std::uint32_t size) {
  std::size_t fixed = type_size(e.type);
  std::size_t limit = fixed ? fixed : e.capacity;
  if (size > limit) return SdoAbort::kLengthTooHigh;
  if (fixed && size < fixed) return SdoAbort::kLengthTooLow;
  return SdoAbort::kNone;
}

// Expedited download without size indication: how many of the 4 bytes count.
static std::size_t unspecified_length(const OdEntry& e, const std::uint8_t* data) {
  std::size_t fixed = type_size(e.type);
  if (fixed) return std::min<std::size_t>(fixed, 4);
  if (e.type == DataType::kVisibleString) {
    std::size_t n = 0;
    while (n < 4 && data[n]) ++n;
    return std::min<std::size_t>(n, e.capacity);
  }
  return std::min<std::size_t>(4, e.capacity);
}

void SdoServer::initiate_download(Bytes d, TimeUs now) {
  if (!(d[0] & kExpedited) && refuse(segmented_download_allowed())) return;
  const OdEntry* e = (d[0] & kExpedited) ? find_entry() : download_target();
  if (!e) return;
  if (d[0] & kExpedited) {
    std::size_t n = (d[0] & kSizeIndicated) ? expedited_bytes(d[0]) : unspecified_length(*e, d + 4);
    const std::uint32_t resets = node_.nmt().reset_count();
    SdoAbort result = write_remote(*e, {d + 4, n}, now);
    if (!ok(result)) return abort(result);
    if (node_.nmt().reset_count() != resets) return;  // the write rebooted the node: no answer
    return send_initiate_response(kScsInitiateDownload);
  }
  entry_ = e;
  size_indicated_ = d[0] & kSizeIndicated;
  indicated_ = size_indicated_ ? get_u32(d + 4) : 0;
  if (size_indicated_) {
    if (SdoAbort a = check_download_size(*e, indicated_); !ok(a)) return abort(a);
  }
  size_ = 0;
  toggle_ = 0;
  start(State::kDownloadSegment, now);
  send_initiate_response(kScsInitiateDownload);
}

void SdoServer::initiate_upload(Bytes, TimeUs now) {
  const OdEntry* e = find_entry();
  if (!e || !snapshot(*e, now)) return;
  answer_upload(now);
}

bool SdoServer::snapshot(const OdEntry& e, TimeUs now) {
  std::span<const std::uint8_t> value;
  SdoAbort result = node_.read(e, now, value);
  if (!ok(result)) {
    abort(result);
    return false;
  }
  size_ = std::uint32_t(std::min(value.size(), buf_.size()));
  if (size_) std::memcpy(buf_.data(), value.data(), size_);
  entry_ = &e;
  return true;
}

// First answer to an upload: the value itself when it fits in 4 bytes
// (expedited), else the segmented initiate response with the size.
void SdoServer::answer_upload(TimeUs now) {
  const NodeOptions& o = node_.options();
  if (size_ <= 4) {
    std::uint8_t cs = kScsInitiateUpload | kExpedited;
    if (size_ > 0 && o.sdo_upload_size_indicated) cs |= kSizeIndicated | expedited_unused(size_);
    if (o.sdo_upload_response_0x60) cs = kScsInitiateDownload;  // vendor quirk: the byte 0x60 (not CiA 301)
    send_initiate_response(cs, buf_.data(), int(size_));
    return idle();
  }
  if (!o.sdo_segmented_upload || o.sdo_expedited_only)
    return abort(std::uint32_t(o.sdo_long_upload_abort), index_, sub_);
  std::uint8_t size[4] = {};
  std::uint8_t cs = kScsInitiateUpload;
  if (o.sdo_upload_size_indicated) {
    cs |= kSizeIndicated;
    put_u32(size, size_);
  }
  offset_ = 0;
  toggle_ = 0;
  start(State::kUploadSegment, now);
  send_initiate_response(cs, size, 4);
}

void SdoServer::initiate_block_download(Bytes d, TimeUs now) {
  if (refuse(block_allowed())) return;
  const OdEntry* e = download_target();
  if (!e) return;
  entry_ = e;
  size_indicated_ = d[0] & kBlockSizeIndicated;
  indicated_ = size_indicated_ ? get_u32(d + 4) : 0;
  if (size_indicated_) {
    if (SdoAbort a = check_download_size(*e, indicated_); !ok(a)) return abort(a);
  }
  crc_ = d[0] & kBlockCrc;
  blksize_ = kMaxBlockSize;
  seqno_ = 0;
  size_ = 0;
  last_segment_ = false;
  start(State::kBlockDownloadSub, now);
  arm_block_ack(now);
  std::uint8_t blk = blksize_;
  send_initiate_response(kScsBlockDownload | kScInitiate | kBlockCrc, &blk, 1);
}

void SdoServer::initiate_block_upload(Bytes d, TimeUs now) {
  if (refuse(block_allowed())) return;
  const OdEntry* e = find_entry();
  if (!e) return;
  std::uint8_t blk = d[4];
  std::uint8_t pst = d[5];
  if (blk == 0 || blk > kMaxBlockSize) return abort(SdoAbort::kBlockSize);
  if (!snapshot(*e, now)) return;
  // CiA 301 §7.2.4.3.13: protocol switch threshold, the server may answer
  // with a normal (expedited / segmented) upload instead.
  if (pst != 0 && size_ <= pst) return answer_upload(now);
  crc_ = d[0] & kBlockCrc;
  blksize_ = blk;
  offset_ = 0;
  std::uint8_t size[4] = {};
  std::uint8_t cs = kScsBlockUpload | kScInitiate | kBlockCrc;
  if (node_.options().sdo_upload_size_indicated) {
    cs |= kBlockSizeIndicated;
    put_u32(size, size_);
  }
  start(State::kBlockUploadStart, now);
  send_initiate_response(cs, size, 4);
}

// ------------------------------------------------------------ segmented

void SdoServer::on_download_segment(Bytes d, TimeUs now) {
  if (ccs(d) != kCcsDownloadSegment) return abort(SdoAbort::kCommandSpecifier);
  if ((d[0] & kToggle) != toggle_) return abort(SdoAbort::kToggleBit);
  std::uint32_t n = segment_bytes(d[0]);
  std::uint32_t limit = size_indicated_ ? indicated_ : entry_->capacity;
  if (size_ + n > limit) return abort(SdoAbort::kLengthTooHigh);
  std::memcpy(buf_.data() + size_, d + 1, n);
  size_ += n;
  std::uint8_t confirm = toggled(kScsDownloadSegment | toggle_);
  toggle_ ^= kToggle;
  if (d[0] & kLastSegment) return finish_download(now, confirm);
  touch(now);
  send_command(confirm);
}

void SdoServer::on_upload_segment(Bytes d, TimeUs now) {
  if (ccs(d) != kCcsUploadSegment) return abort(SdoAbort::kCommandSpecifier);
  if ((d[0] & kToggle) != toggle_) return abort(SdoAbort::kToggleBit);
  std::uint32_t n = std::min<std::uint32_t>(7, size_ - offset_);
  bool last = offset_ + n == size_;
  std::uint8_t cs = toggled(std::uint8_t(kScsUploadSegment | toggle_ | segment_unused(n) | (last ? kLastSegment : 0)));
  send_segment(cs, buf_.data() + offset_, int(n));
  offset_ += n;
  toggle_ ^= kToggle;
  if (last) return idle();
  touch(now);
}

// Every download ends here: the OD write with the client's access rights;
// the observer hears of it once the value was stored.
SdoAbort SdoServer::write_remote(const OdEntry& e, std::span<const std::uint8_t> data, TimeUs now) {
  SdoAbort result = node_.write(e, data, now);
  if (ok(result))
    if (NodeObserver* o = node_.observer()) o->on_remote_write(node_, e, WriteVia::kSdo, now);
  return result;
}

// The assembled value is written once, then confirmed with `confirm`.
void SdoServer::finish_download(TimeUs now, std::uint8_t confirm) {
  if (size_indicated_ && size_ != indicated_)
    return abort(size_ < indicated_ ? SdoAbort::kLengthTooLow : SdoAbort::kLengthTooHigh);
  SdoAbort result = write_remote(*entry_, {buf_.data(), size_}, now);
  if (!ok(result)) return abort(result);
  idle();
  send_command(confirm);
}

// ------------------------------------------------------------ block download

void SdoServer::on_block_download_segment(Bytes d, TimeUs now) {
  if (drop_segment()) return;
  std::uint8_t seq = d[0] & kSeqMask;
  if (seq == 0) return abort(SdoAbort::kSequenceNumber);
  touch(now);
  arm_block_ack(now);
  if (seq == seqno_ + 1 && seq <= blksize_) {
    std::uint32_t limit = size_indicated_ ? indicated_ : entry_->capacity;
    if (size_ >= limit) return abort(SdoAbort::kLengthTooHigh);  // no room for >= 1 byte
    std::memcpy(buf_.data() + size_, d + 1, 7);
    size_ += 7;
    seqno_ = seq;
    if (d[0] & kSeqLast) {
      last_segment_ = true;
      return send_block_download_ack();
    }
    if (seq == blksize_) send_block_download_ack();
    return;
  }
  // Duplicate, or a frame before the (re)started sequence: ignore. A gap:
  // break the sub-block and acknowledge the last good segment; the client
  // resends from there, numbered from 1 again.
  if (seq == seqno_ || seqno_ == 0) return;
  send_block_download_ack();
}

void SdoServer::send_block_download_ack() {
  std::uint8_t d[8] = {kScsBlockDownload | kScAck, seqno_, blksize_};
  send_raw(d);
  seqno_ = 0;
  if (last_segment_) {
    state_ = State::kBlockDownloadEnd;
    block_ack_at_ = kNever;
  }
}

void SdoServer::arm_block_ack(TimeUs now) {
  block_ack_at_ = timeout_ > 0 ? now + response_delay_ + timeout_ * 7 / 10 : kNever;
}

void SdoServer::on_block_download_end(Bytes d, TimeUs now) {
  if ((d[0] & kBlockEndMask) != (kCcsBlockDownload | kScEnd)) return abort(SdoAbort::kCommandSpecifier);
  std::uint32_t unused = block_end_unused_bytes(d[0]);
  if (unused == 7 || unused > size_) return abort(SdoAbort::kCommandSpecifier);
  size_ -= unused;
  if (crc_ && crc16_ccitt({buf_.data(), size_}) != get_u16(d + 1)) return abort(SdoAbort::kCrc);
  finish_download(now, kScsBlockDownload | kScEnd);
}

// ------------------------------------------------------------ block upload

void SdoServer::on_block_upload_start(Bytes d, TimeUs now) {
  if ((d[0] & kBlockEndMask) != (kCcsBlockUpload | kScStartUpload)) return abort(SdoAbort::kCommandSpecifier);
  send_block_upload_sub(now);
}

// Sends up to blksize_ segments from offset_; seqno_ counts them.
void SdoServer::send_block_upload_sub(TimeUs now) {
  seqno_ = 0;
  last_segment_ = false;
  std::uint32_t pos = offset_;
  while (seqno_ < blksize_ && !last_segment_) {
    std::uint32_t n = std::min<std::uint32_t>(7, size_ - pos);
    last_segment_ = pos + n >= size_;
    ++seqno_;
    if (!drop_segment()) send_segment(std::uint8_t((last_segment_ ? kSeqLast : 0) | seqno_), buf_.data() + pos, int(n));
    pos += n;
  }
  state_ = State::kBlockUploadAck;
  touch(now);
}

void SdoServer::on_block_upload_ack(Bytes d, TimeUs now) {
  if ((d[0] & kBlockEndMask) != (kCcsBlockUpload | kScAck)) return abort(SdoAbort::kCommandSpecifier);
  std::uint8_t ackseq = d[1];
  std::uint8_t blk = d[2];
  if (ackseq > seqno_) return abort(SdoAbort::kSequenceNumber);
  if (blk == 0 || blk > kMaxBlockSize) return abort(SdoAbort::kBlockSize);
  offset_ = std::min<std::uint32_t>(size_, offset_ + 7u * ackseq);
  blksize_ = blk;
  if (last_segment_ && ackseq == seqno_) return send_block_upload_end(now);
  send_block_upload_sub(now);  // the rest, or a resend after ackseq
}

void SdoServer::send_block_upload_end(TimeUs now) {
  // n = bytes of the last segment that carry no data (CiA 301 §7.2.4.3.15).
  std::uint32_t unused = size_ == 0 ? 7 : (7 - size_ % 7) % 7;
  std::uint8_t d[8] = {std::uint8_t(kScsBlockUpload | kScEnd | block_end_unused(unused))};
  // CiA 301 §7.2.4.3.15: the CRC is only meaningful when both sides asked
  // for it, but masters that check it whenever the server offered CRC (the
  // npm package canopen does) exist: the real CRC is always sent, never 0x0000.
  put_u16(d + 1, crc16_ccitt({buf_.data(), size_}));
  send_raw(d);
  state_ = State::kBlockUploadEnd;
  touch(now);
}

void SdoServer::on_block_upload_end(Bytes d, TimeUs) {
  if ((d[0] & kBlockEndMask) != (kCcsBlockUpload | kScEnd)) return abort(SdoAbort::kCommandSpecifier);
  idle();
}

// ------------------------------------------------------------ state, frames

void SdoServer::start(State s, TimeUs now) {
  state_ = s;
  touch(now);
}

void SdoServer::touch(TimeUs now) {
  deadline_ = timeout_ > 0 ? std::max(now, turnaround_end_) + response_delay_ + timeout_ : kNever;
}

void SdoServer::idle() {
  state_ = State::kIdle;
  deadline_ = kNever;
  block_ack_at_ = kNever;
  entry_ = nullptr;
}

void SdoServer::abort(SdoAbort code) { abort(std::uint32_t(code), index_, sub_); }

void SdoServer::abort(std::uint32_t code, std::uint16_t index, std::uint8_t sub) {
  idle();
  std::uint8_t d[8] = {kCsAbort};
  put_u16(d + 1, index);
  d[3] = sub;
  put_u32(d + 4, node_.options().sdo_abort_map.apply(code));
  send_raw(d);
}

void SdoServer::send_initiate_response(std::uint8_t cs, const std::uint8_t* payload, int n) {
  std::uint8_t d[8] = {cs};
  put_u16(d + 1, index_);
  d[3] = sub_;
  if (n > 0) std::memcpy(d + 4, payload, std::size_t(std::min(n, 4)));
  send_raw(d);
}

void SdoServer::send_segment(std::uint8_t cs, const std::uint8_t* payload, int n) {
  std::uint8_t d[8] = {cs};
  if (n > 0) std::memcpy(d + 1, payload, std::size_t(std::min(n, 7)));
  send_raw(d);
}

void SdoServer::send_command(std::uint8_t cs) {
  std::uint8_t d[8] = {cs};
  send_raw(d);
}

void SdoServer::send_raw(const std::uint8_t* d) {
  const TimeUs at = answer_time();
  if (at <= now_ && delayed_n_ == 0) return send_now(d);
  if (delayed_n_ == delayed_.size()) return;  // more than a whole block in the pipe: lost
  Delayed& slot = delayed_[(delayed_head_ + delayed_n_++) % delayed_.size()];
  slot.at = at;
  std::memcpy(slot.data, d, 8);
  delayed_changed();
}

// One request at a time, in arrival order (see the header): the turnaround
// starts when the request arrived or the previous one's ended, whichever is
// later. Frames of the server's own (process()) have none.
TimeUs SdoServer::answer_time() {
  if (answer_at_ != kNever) return answer_at_;
  const TimeUs turnaround = in_frame_ ? turnaround_.next(node_.seed()) : 0;
  turnaround_end_ = std::max(now_, turnaround_end_) + turnaround;
  answer_at_ = turnaround_end_ + response_delay_;
  if (in_frame_ && deadline_ != kNever)
    deadline_ = std::max(deadline_.value(), answer_at_ + timeout_);  // from the departure
  return answer_at_;
}

// A sub-block of 127 segments plus the frames around it (not on the frame path).
void SdoServer::reserve_pipe() {
  if (delayed_.empty()) delayed_.resize(2 * kMaxBlockSize + 2);
}

// ------------------------------------------------------------ fault injection

void SdoServer::set_response_delay(TimeUs delay) {
  response_delay_ = std::max<TimeUs>(delay, 0);
  if (response_delay_ > 0) reserve_pipe();
}

void SdoServer::set_block_drop(std::uint32_t every_n, double probability, std::uint64_t seed) {
  drop_every_n_ = every_n;
  probability = std::clamp(probability, 0.0, 1.0);
  drop_threshold_ = probability >= 1.0 ? 0xFFFFFFFFu : std::uint32_t(probability * 4294967296.0);
  drop_seed_ = seed;
  drop_rng_ = mix_seed(seed, node_.power_ons()) | 1;
  drop_count_ = 0;
}

void SdoServer::set_faults(const Faults& faults) {
  if (faults.toggle_seed != faults_.toggle_seed || faults_.toggle_probability == 0)
    toggle_random_ = FaultRandom(mix_seed(faults.toggle_seed, node_.power_ons()));
  faults_ = faults;
}

void SdoServer::restart_faults(std::uint32_t power_on) {
  drop_rng_ = mix_seed(drop_seed_, power_on) | 1;
  drop_count_ = 0;
  toggle_random_ = FaultRandom(mix_seed(faults_.toggle_seed, power_on));
}

// A request the silent server never sees: every frame when the whole server
// is silent, else the initiate of a silent object (its transfer never
// starts, so its later frames are not for a running transfer either).
bool SdoServer::silenced(Bytes d) const {
  for (std::size_t i = 0; i < faults_.silent_n; ++i) {
    const ObjectMatch& m = faults_.silent[i];
    if (m.index == 0) return true;
    if (state_ == State::kIdle && m.matches(get_u16(d + 1), d[3])) return true;
  }
  return false;
}

std::uint8_t SdoServer::toggled(std::uint8_t cs) {
  if (faults_.toggle_probability > 0 && toggle_random_.chance(faults_.toggle_probability)) cs ^= kToggle;
  return cs;
}

bool SdoServer::drop_segment() {
  bool drop = false;
  if (drop_every_n_ > 0) {
    drop = ++drop_count_ % drop_every_n_ == 0;
  } else if (drop_threshold_ > 0) {
    drop_rng_ ^= drop_rng_ << 13;  // xorshift64
    drop_rng_ ^= drop_rng_ >> 7;
    drop_rng_ ^= drop_rng_ << 17;
    drop = std::uint32_t(drop_rng_ >> 32) < drop_threshold_;
  }
  dropped_ += drop;
  return drop;
}

void SdoServer::send_now(const std::uint8_t* d) {
  CanFrame f;
  f.id = tx_id_;
  f.dlc = 8;
  f.flags = tx_ext_ ? CanFrame::kExtended : 0;
  std::memcpy(f.data, d, 8);
  node_.send(f);
}

}  // namespace cansim
