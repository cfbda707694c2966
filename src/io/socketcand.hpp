// The socketcand protocol (linux-can/socketcand doc/protocol.md), sans I/O:
// the server side of one client connection as a state machine over bytes
// (Session), and the client side's message reader (for cansimctl monitor /
// capture). docs/socketcand.md says what cansimd serves.
//
// Decisions:
// - Modes as socketcand has them: NO_BUS (greeted with `< hi >`) -> `< open
//   BUS >` -> BCM -> `< rawmode >` -> RAW. BCM's cyclic jobs and filters are
//   not served (`< error ... >`); `< send >`, `< sendrtr >` and `< echo >`
//   work in BCM and RAW; only RAW receives the bus's frames.
// - Messages are `<` ... `>`, tokens split by any whitespace; text between
//   messages must be whitespace. Every malformed message is answered `< error
//   WHY >` (a message never quotes the client's bytes but for a command word
//   of letters); opening another bus is answered as socketcand does (`< error
//   could not open bus >`) and the connection closes.
// - Frames out are socketcand's `< frame ID SECONDS.MICROS DATA >` (ID as
//   %03X / %08X, DATA as %02X without spaces, two spaces before `>` when
//   there is no data) and `< rtr ID SECONDS.MICROS DLC >`; an error the
//   master's controller would report (fault error_frames, a collision) is
//   socketcand's `< error CLASS SECONDS.MICROS >`, CLASS the error frame's
//   CAN_ERR_* class bits as %03X (socketcand's state_raw.c does the same
//   with the error frames SocketCAN gives it).
// - The handshake answers (`< hi >`, `< ok >` to open and rawmode) go alone,
//   without a separator: python-can 4.1 reads each in one recv() and compares
//   it whole. Every later message starts with a newline: python-can drops the
//   character after the last complete message of each read (shared reference
//   python-can-socketcand.md: 30 of 200 back-to-back frames arrived without a
//   separator, 200 of 200 with one), and a separator *before* each message is
//   the one it drops when a read ends inside a message, while a read that
//   ends with a message leaves nothing behind (a trailing separator made it
//   warn "No opening < found" after every read).
// - And each such message fills a whole number of 64-byte records: spaces,
//   the newline, the message. python-can reads 1024 bytes at a time; with
//   records that divide it, a read of a busy stream ends at a message's end
//   instead of inside one (where python-can warns "Got incomplete message"
//   and loses the character after the last complete one, a space here).
// - `< send ID ... >`: an ID of 8 hex digits, or above 0x7FF, is a 29-bit
//   identifier (socketcand: 8 digits); DLC is one digit 0..8 (socketcand
//   reads it decimal, python-can writes it hex: the same for 0..8); each data
//   byte is one or two hex digits (python-can writes `%x`).
#pragma once

#include <cstddef>
#include <cstdint>
#include <string>
#include <string_view>

#include "core/can_frame.hpp"

namespace cansim::io::socketcand {

inline constexpr std::string_view kHi = "< hi >";
inline constexpr std::string_view kOk = "< ok >";
inline constexpr std::string_view kEcho = "< echo >";
inline constexpr char kSeparator = '\n';
inline constexpr std::size_t kRecord = 64;  // every message after the handshake: a multiple of it
// The longest message taken (python-can's longest is `< send 1FFFFFFF 8 ff
// ff ff ff ff ff ff ff >`, 42 bytes); a longer one is an error.
inline constexpr std::size_t kMaxMessage = 128;
// A frame's message, `< frame 1FFFFFFF 9999999999.999999 0011223344556677 >`
// (54 bytes until the year 2286) with its separator, is one record.
inline constexpr std::size_t kMaxFrameText = 2 * kRecord;

// Wall-clock time of a frame as socketcand sends it (seconds, microseconds).
struct Stamp {
  std::int64_t sec = 0;
  std::int32_t usec = 0;
};

// Writes the message for a frame on the wire, padded to its records
// (spaces, the separator, the message); returns its length (kRecord until
// the year 2286, at most kMaxFrameText).
std::size_t format_frame(const CanFrame& frame, Stamp at, char* out);
// The same for an error frame of class `error_class` (CAN_ERR_* bits of its
// can_id without CAN_ERR_FLAG): `< error 004 1700000000.000123 >`.
std::size_t format_error(std::uint32_t error_class, Stamp at, char* out);
// A message after the handshake as it is sent: padded to whole records.
std::string record(std::string_view message);

// The server side of one connection. The owner writes greeting() at accept,
// passes what the client sends to feed(), writes what feed() appended to
// `out`, and sends the frames it hands to `on_frame` to the bus.
class Session {
 public:
  enum class Mode : std::uint8_t { kNoBus, kBcm, kRaw, kClosed };

  class Sink {
   public:
    virtual ~Sink() = default;
    virtual void frame(const CanFrame& frame) = 0;
  };

  explicit Session(std::string bus_name) : bus_(std::move(bus_name)) {}

  static std::string_view greeting() { return kHi; }
  // Takes the client's bytes: complete messages act at once (replies to
  // `out`, frames to `sink`); an incomplete one waits for more. Nothing is
  // taken after the session closed.
  void feed(std::string_view bytes, std::string& out, Sink& sink);
  Mode mode() const { return mode_; }
  // In RAW mode: the bus's frames go to this client.
  bool receives_frames() const { return mode_ == Mode::kRaw; }
  bool closed() const { return mode_ == Mode::kClosed; }
  // Messages handled so far (the owner's proof that the client read the
  // answer to `< rawmode >` once it sends again).
  std::uint64_t messages() const { return messages_; }
  std::uint64_t errors() const { return errors_; }

 private:
  void message(std::string_view body, std::string& out, Sink& sink);
  void reply(std::string_view text, std::string& out) const;
  void error(std::string_view why, std::string& out);
  void send(std::string_view args, bool rtr, std::string& out, Sink& sink);

  std::string bus_;
  Mode mode_ = Mode::kNoBus;
  bool handshaken_ = false;     // `< ok >` to rawmode sent: later messages start with a separator
  std::string pending_;         // an incomplete message, `<` included
  bool discarding_ = false;     // inside a message that was too long: skip to its `>`
  bool junk_reported_ = false;  // text outside < > reported once per run
  std::uint64_t messages_ = 0, errors_ = 0;
};

// The client side: splits what a socketcand server sends into messages.
// next() gives the body of each complete `< ... >` (without the brackets);
// text between messages is skipped; an over-long message is dropped.
class MessageReader {
 public:
  void append(std::string_view bytes);
  bool next(std::string& body);

 private:
  std::string buffer_;
  std::size_t pos_ = 0;
};

// A `frame` or `rtr` message body (as MessageReader gives it) as a frame and
// its time (seconds since the epoch); false for any other message.
bool parse_frame_message(std::string_view body, CanFrame& frame, double& seconds);
// `send ID DLC B0 ...` / `sendrtr ID DLC` arguments; false with `why` set.
bool parse_send(std::string_view args, bool rtr, CanFrame& frame, std::string& why);

}  // namespace cansim::io::socketcand
