// SDO server (CiA 301 §7.2.4): expedited, segmented and block transfers on the
// default server channel 0x1200.
//
// Decisions where CiA 301 leaves room (documented here once):
// - Requests must have DLC 8 (CiA 301 §7.2.4.3: every SDO frame carries 8
//   bytes); shorter ones are ignored without answer, like CANopenNode.
//   Option sdo_min_request_dlc lowers the limit for vendors that accept short
//   frames (missing bytes read as 0). RTR frames are ignored.
// - Expedited download without size indication (e=1, s=0): the 4 data bytes
//   carry "an unspecified number of bytes"; the server takes the object's own
//   length when it is 1..4 bytes (low bytes, rest ignored), the text up to the
//   first NUL (at most 4 bytes) for VISIBLE_STRING, and 4 bytes otherwise (so an
//   8-byte object answers 0x06070013). With size indication, the indicated size
//   is compared: longer 0x06070012, shorter 0x06070013 (strings/DOMAIN may be
//   shorter than their capacity).
// - A frame that does not fit the running transfer (e.g. a new initiate while
//   a segmented transfer runs) aborts the running transfer with 0x05040001
//   (command specifier not valid in this state) and the server returns to
//   idle; the new request is not started (the client retries). This is the
//   CiA 301 state-machine reading (Lely, CANopenNode v4); old CANopenNode
//   started a new transfer instead.
// - An abort from the client ends the transfer silently (no reply).
// - Uploads are snapshotted at initiate into a per-node buffer sized at reset
//   from the largest entry of the layout; downloads are assembled there and
//   written once complete (one Node::write). No allocation after reset.
// - An empty value is uploaded expedited without size indication (0x42, data 0).
// - Block transfer: the server always supports CRC; CRC is used only when the
//   client sets its CRC bit too. Server block size is 127. In a sub-block,
//   duplicates and frames before the sequence start are ignored, a gap breaks
//   the sub-block and the last good segment is acknowledged; seqno 0 aborts
//   with 0x05040003, as does an upload ackseq above the segments sent. When
//   segments stop arriving in a download sub-block for 70 % of the SDO
//   timeout, the last good segment is acknowledged (a lost first or last
//   segment of a sub-block is recovered, like CANopenNode's block timeout).
// - sdo_timeout_ms <= 0 disables the protocol timeout.
// - Response time (options sdo_turnaround_us + 0..sdo_turnaround_jitter_us,
//   one draw per request): a request is handled when it arrives (values read
//   and written at that instant), its answers leave at the turnaround after
//   it. The server has one request buffer and handles requests in order, as
//   a device's single-threaded SDO task does: a request that arrives while an
//   answer is still pending starts its turnaround when the previous one
//   ended, so answers keep their order and never overtake each other.
//   Frames the server sends by itself (timeout abort, the acknowledge of a
//   stalled block) have no turnaround. The protocol timeout counts from the
//   last answer's departure. slow_sdo's delay (set_response_delay) comes on top
//   of the turnaround: answer = max(request, previous answer's turnaround
//   end) + turnaround + jitter + slow_sdo's delay. A pending answer dies
//   with a reset and is not sent in an NMT state without SDO.
#pragma once

#include <algorithm>
#include <array>
#include <cstdint>
#include <span>
#include <vector>

#include "core/can_frame.hpp"
#include "core/fault_random.hpp"
#include "core/node_service.hpp"
#include "core/od.hpp"
#include "core/response_time.hpp"

namespace cansim {

class Node;

class SdoServer : private NodeService {
 public:
  explicit SdoServer(Node& node) : NodeService(node) {}
  // Its slots of the node's deadline board (core/node_service.hpp).
  static constexpr DeadlineSlots kDeadlines{DeadlineSlot::kSdoTransfer, 3};
  // The NodeService contract (core/node_service.hpp):
  void reset(TimeUs now);
  bool on_frame(const CanFrame& frame, TimeUs now);
  // process: the delayed answers and the protocol timeout.
  void process(TimeUs now);
  TimeUs next_deadline() const { return std::min({deadline_.value(), block_ack_at_.value(), delayed_at_.value()}); }
  void collect_rx_ids(std::vector<std::uint32_t>& out) const;
  // owns: 0x1200.
  bool owns(std::uint16_t index) const;
  SdoAbort write(const OdEntry& e, std::span<const std::uint8_t> data, TimeUs now);

  // ---- fault injection
  // "Slow SDO": every frame the server sends leaves `delay` after the request
  // that caused it (order kept); the protocol timeout is extended by as much.
  // The first non-zero delay allocates the queue (not on the frame path).
  void set_response_delay(TimeUs delay);
  // "Block segments dropped": every n-th block segment (both directions) is
  // lost, or each with `probability`; the transfer recovers through the
  // block acknowledge (ackseq) as on a noisy bus. n = 0 and p = 0: off.
  void set_block_drop(std::uint32_t every_n, double probability, std::uint64_t seed);
  std::uint32_t dropped_segments() const { return dropped_; }

  // Network faults: objects that answer an abort code, objects
  // (or the whole server) that never answer, segments with the wrong
  // toggle bit. A silent object's requests are not seen at all: no answer,
  // the server's state unchanged (as if the frame were lost); an abort
  // object answers every initiate with its code. Toggle errors flip the
  // toggle bit of the server's segment answers (segmented upload and
  // download) with a probability, from a seeded generator.
  struct ObjectMatch {
    std::uint16_t index = 0;  // 0: every object
    int sub = -1;             // -1: every sub-index
    bool matches(std::uint16_t i, std::uint8_t s) const { return (index == 0 || index == i) && (sub < 0 || sub == s); }
  };
  struct AbortingObject {
    ObjectMatch object;
    std::uint32_t code = 0;
  };
  struct Faults {
    static constexpr std::size_t kMax = 4;
    std::array<ObjectMatch, kMax> silent{};
    std::size_t silent_n = 0;
    std::array<AbortingObject, kMax> aborts{};
    std::size_t abort_n = 0;
    double toggle_probability = 0;
    std::uint64_t toggle_seed = 1;
  };
  void set_faults(const Faults& faults);
  // The node's power-on number `power_on`: the block drop's and the toggle
  // error's generators start again from their seeds and that number
  // (core/fault_random.hpp), and so does every-n-th counting.
  void restart_faults(std::uint32_t power_on);

  // ---- inspection (tests, daemon statistics)
  bool enabled() const { return valid_; }
  bool busy() const { return state_ != State::kIdle; }
  std::uint32_t rx_cob_id() const { return rx_id_; }
  std::uint32_t tx_cob_id() const { return tx_id_; }
  // The frame is one of this server's answers (its COB-ID now).
  bool sends(const CanFrame& f) const { return valid_ && f.id == tx_id_ && f.extended() == tx_ext_; }
  std::size_t buffer_bytes() const { return buf_.size(); }

 private:
  enum class State : std::uint8_t {
    kIdle,
    kDownloadSegment,   // segmented download: waiting for the next segment
    kUploadSegment,     // segmented upload: waiting for the next segment request
    kBlockDownloadSub,  // block download: receiving a sub-block
    kBlockDownloadEnd,  // block download: waiting for the end request
    kBlockUploadStart,  // block upload: waiting for the client's start (0xA3)
    kBlockUploadAck,    // block upload: sub-block sent, waiting for its ack
    kBlockUploadEnd,    // block upload: end sent, waiting for the end response
  };

  using Bytes = const std::uint8_t*;  // an 8-byte request, zero-padded

  // Dispatch per state (small handlers, one per protocol step).
  void on_idle(Bytes d, TimeUs now);
  void on_download_segment(Bytes d, TimeUs now);
  void on_upload_segment(Bytes d, TimeUs now);
  void on_block_download_segment(Bytes d, TimeUs now);
  void on_block_download_end(Bytes d, TimeUs now);
  void on_block_upload_start(Bytes d, TimeUs now);
  void on_block_upload_ack(Bytes d, TimeUs now);
  void on_block_upload_end(Bytes d, TimeUs now);

  void dispatch(Bytes d, TimeUs now);
  void initiate_download(Bytes d, TimeUs now);
  void initiate_upload(Bytes d, TimeUs now);
  void initiate_block_download(Bytes d, TimeUs now);
  void initiate_block_upload(Bytes d, TimeUs now);

  void load_cob_ids();
  void apply_reload();
  // Looks up index_/sub_; sends the abort and returns null on failure.
  const OdEntry* find_entry();
  // Entry checks before a segmented / block download is accepted.
  const OdEntry* download_target();
  // Sends the option's refusal abort when `allowed` is false.
  bool refuse(bool allowed);
  bool segmented_download_allowed() const;
  bool block_allowed() const;
  static SdoAbort check_download_size(const OdEntry& e, std::uint32_t size);
  // Snapshots the entry's value into buf_ (size_); false after an abort.
  bool snapshot(const OdEntry& e, TimeUs now);
  // First answer to an upload (expedited value, or segmented initiate).
  void answer_upload(TimeUs now);
  void finish_download(TimeUs now, std::uint8_t confirm);
  SdoAbort write_remote(const OdEntry& e, std::span<const std::uint8_t> data, TimeUs now);
  void send_block_download_ack();
  void arm_block_ack(TimeUs now);
  void send_block_upload_sub(TimeUs now);
  void send_block_upload_end(TimeUs now);

  void send_initiate_response(std::uint8_t cs, const std::uint8_t* payload = nullptr, int n = 0);
  void send_segment(std::uint8_t cs, const std::uint8_t* payload, int n);
  void send_command(std::uint8_t cs);
  void send_raw(const std::uint8_t* d);
  // When the frames of the request being handled leave (drawn once per request).
  TimeUs answer_time();
  void reserve_pipe();
  void send_now(const std::uint8_t* d);
  bool drop_segment();
  void abort(SdoAbort code);
  void abort(std::uint32_t code, std::uint16_t index, std::uint8_t sub);
  void start(State s, TimeUs now);
  void touch(TimeUs now);
  void idle();

  // configuration (reset)
  bool valid_ = false;
  bool rx_ext_ = false;
  bool tx_ext_ = false;
  bool in_frame_ = false;
  bool reload_pending_ = false;  // 0x1200 changed: reload after the reply
  std::uint32_t rx_id_ = 0;
  std::uint32_t tx_id_ = 0;
  TimeUs timeout_ = 0;
  // transfer
  State state_ = State::kIdle;
  Deadline deadline_{node_, DeadlineSlot::kSdoTransfer};
  Deadline block_ack_at_{node_, DeadlineSlot::kSdoBlockAck};  // block download: acknowledge a stalled sub-block
  const OdEntry* entry_ = nullptr;
  std::uint16_t index_ = 0;
  std::uint8_t sub_ = 0;
  std::uint8_t toggle_ = 0;  // 0x00 / 0x10, as in the command byte
  bool size_indicated_ = false;
  bool crc_ = false;               // block: both sides use the CRC
  std::uint8_t blksize_ = 0;       // block: current sub-block size
  std::uint8_t seqno_ = 0;         // block download: last good seqno; upload: segments sent
  bool last_segment_ = false;      // block: the final segment was received / sent
  std::uint32_t indicated_ = 0;    // download: size the client indicated
  std::uint32_t size_ = 0;         // bytes in buf_ (upload: total; download: received)
  std::uint32_t offset_ = 0;       // upload: bytes confirmed by the client
  std::vector<std::uint8_t> buf_;  // sized at reset: largest entry + one segment
  // fault injection
  struct Delayed {
    TimeUs at;
    std::uint8_t data[8];
  };
  TimeUs now_ = 0;             // time of the request being handled
  TimeUs answer_at_ = kNever;  // its answers' departure, once drawn
  TimeUs turnaround_end_ = 0;  // the last answer's turnaround ended (slow_sdo excluded)
  ResponseTime turnaround_{ResponseTime::Stream::kSdoTurnaround};
  TimeUs response_delay_ = 0;     // slow_sdo
  std::vector<Delayed> delayed_;  // ring, sized by the first set_response_delay
  std::size_t delayed_head_ = 0;
  std::size_t delayed_n_ = 0;
  Deadline delayed_at_{node_, DeadlineSlot::kSdoDelayed};  // the first held answer's departure
  void delayed_changed() { delayed_at_ = delayed_n_ ? delayed_[delayed_head_].at : kNever; }
  std::uint32_t drop_every_n_ = 0;
  std::uint32_t drop_threshold_ = 0;  // probability x 2^32
  std::uint64_t drop_seed_ = 0, drop_rng_ = 0;
  std::uint32_t drop_count_ = 0;
  std::uint32_t dropped_ = 0;
  Faults faults_;
  FaultRandom toggle_random_;
  bool silenced(Bytes d) const;
  std::uint8_t toggled(std::uint8_t cs);
};

}  // namespace cansim
