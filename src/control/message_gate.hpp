// What a peer of the private socket sends reaches sd-bus only through this
// gate, in bounded slices, and a message only once its header has said how
// large it is. sd-bus itself takes messages of up to 128 MiB and checks
// such a message whole: reading and dispatching one of 100 MiB held the loop
// 0.4 s here and 1.1-1.2 s in the VM, before any size check of cansimd's
// could refuse it. The gate reads the socket (at most kSliceBytes a pass),
// follows the D-Bus framing (the SASL lines up to BEGIN, then each message's
// 16-byte fixed header: body length, serial, header fields length) and
// writes what it let through into a pipe, sd-bus's input (sd-bus writes its
// answers to the socket itself). A message larger than limits::kMessageBytes
// is never handed on: its bytes are read and dropped, slice by slice, and
// sd-bus gets in its place a call without arguments under the same serial,
// io.cansim.Gate1.MessageTooLarge, which the endpoints answer with
// io.cansim.Error.TooLarge: the client gets its answer, the loop never held
// more than a slice.
//
// sd-bus cannot read the peer's credentials from a pipe: the endpoints take
// them from the socket (SO_PEERCRED) when they accept it.
#pragma once

#include <systemd/sd-bus.h>

#include <cstddef>
#include <cstdint>
#include <span>
#include <string>
#include <vector>

namespace cansim::control {

// The D-Bus framing of one connection's byte stream, from its first byte
// (no I/O: the fuzzer feeds it too). feed() splits what arrived into bytes
// to hand on and bytes to drop, and says when a message was over the bound.
class MessageFraming {
 public:
  explicit MessageFraming(std::size_t max_message_bytes);

  struct Out {
    std::vector<std::uint8_t>* pass;  // bytes for sd-bus are appended here
    std::size_t dropped = 0;          // bytes of oversized messages skipped
    bool oversized = false;           // a message over the bound began (its stand-in is in `pass`)
    std::uint64_t oversized_bytes = 0;
    const char* broken = nullptr;  // not D-Bus (or a handshake line over the bound): close
  };
  // Consumes every byte of `in`.
  void feed(std::span<const std::uint8_t> in, Out& out);

  bool authenticated() const { return phase_ != Phase::kAuth; }
  // The largest SASL handshake taken (sd-bus's own bound is 1 MiB).
  static constexpr std::size_t kAuthBytes = 16 * 1024;

 private:
  enum class Phase { kAuth, kHeader, kBody, kSkip };
  void header_complete(Out& out);

  std::size_t max_;
  Phase phase_ = Phase::kAuth;
  std::size_t auth_bytes_ = 0;
  std::string line_;  // the SASL line so far (without its \r\n)
  std::uint8_t header_[16] = {};
  std::size_t header_size_ = 0;
  std::uint64_t left_ = 0;  // of the current body or skipped message
};

// The stand-in for an oversized message: a method call with the same serial
// and flags, io.cansim.Gate1.MessageTooLarge on the root path, no body.
std::vector<std::uint8_t> too_large_stand_in(std::uint32_t serial, std::uint8_t flags);

// The socket's side: reads a slice, hands on through the pipe.
class MessageGate {
 public:
  static constexpr std::size_t kSliceBytes = 64 * 1024;

  // `socket`: the accepted connection (not owned: sd-bus owns it as its
  // output). Creates the pipe; input_fd() is its read end, for sd-bus (who
  // then owns it), valid() false when the pipe could not be made.
  MessageGate(int socket, std::size_t max_message_bytes);
  ~MessageGate();
  MessageGate(const MessageGate&) = delete;
  MessageGate& operator=(const MessageGate&) = delete;

  bool valid() const { return pipe_write_ >= 0 || ended_; }
  int input_fd() const { return pipe_read_; }
  // sd-bus took input_fd() (sd_bus_set_fd): it closes it.
  void input_taken() { input_taken_ = true; }

  enum class Pump { kNothing, kMoved, kEnd };
  // Moves at most kSliceBytes from the socket towards sd-bus. kEnd: the
  // peer closed, failed or broke the framing (why() says which); sd-bus
  // then reads the end of its input.
  Pump pump();
  // The socket may be read (nothing waits for room in the pipe).
  bool wants_read() const { return staged_.empty() && !ended_; }
  const char* why() const { return why_; }
  // The last oversized message (for the TooLarge answer) and how many.
  std::uint64_t last_oversized_bytes() const { return last_oversized_; }
  std::uint64_t oversized_count() const { return oversized_; }
  std::size_t max_bytes() const { return max_; }

 private:
  bool flush();  // staged bytes into the pipe; false when some stay
  void end(const char* why);

  int socket_;
  std::size_t max_;
  int pipe_read_ = -1, pipe_write_ = -1;
  MessageFraming framing_;
  std::vector<std::uint8_t> staged_;
  std::size_t staged_at_ = 0;
  bool ended_ = false;
  bool input_taken_ = false;
  const char* why_ = nullptr;
  std::uint64_t last_oversized_ = 0, oversized_ = 0;
};

// Answers the gate's stand-ins on `bus` (a message filter, ahead of the
// objects): io.cansim.Error.TooLarge naming the message's size and the bound.
int answer_oversized(sd_bus* bus, const MessageGate& gate, sd_bus_slot** slot = nullptr);

}  // namespace cansim::control
