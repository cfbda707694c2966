#include "control/message_gate.hpp"

#include <fcntl.h>
#include <sys/socket.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <cstring>

#include "control/names.hpp"

namespace cansim::control {

namespace {

// D-Bus specification, "Message Format": the fixed part of every header.
constexpr std::size_t kFixedHeader = 16;
constexpr std::size_t kBodyLengthAt = 4, kSerialAt = 8, kFieldsLengthAt = 12;
constexpr std::uint8_t kLittle = 'l', kBig = 'B';
constexpr std::uint8_t kMethodCall = 1;
constexpr std::uint8_t kProtocolVersion = 1;
constexpr std::uint8_t kFlagsKept = 0x1 | 0x2;  // NO_REPLY_EXPECTED, NO_AUTO_START
constexpr std::uint8_t kFieldPath = 1, kFieldInterface = 2, kFieldMember = 3;

std::uint32_t u32(const std::uint8_t* p, bool big) {
  return big ? std::uint32_t(p[0]) << 24 | std::uint32_t(p[1]) << 16 | std::uint32_t(p[2]) << 8 | p[3]
             : std::uint32_t(p[3]) << 24 | std::uint32_t(p[2]) << 16 | std::uint32_t(p[1]) << 8 | p[0];
}

void put_le32(std::vector<std::uint8_t>& m, std::size_t at, std::uint32_t v) {
  for (int i = 0; i < 4; ++i) m[at + std::size_t(i)] = std::uint8_t(v >> (8 * i));
}

void align(std::vector<std::uint8_t>& m, std::size_t to) {
  while (m.size() % to) m.push_back(0);
}

// One header field: (code, variant of a string-like type), 8-aligned.
void field(std::vector<std::uint8_t>& m, std::uint8_t code, char type, const char* text) {
  align(m, 8);
  m.insert(m.end(), {code, 1, std::uint8_t(type), 0});
  const std::size_t len = std::strlen(text);
  m.resize(m.size() + 4);
  put_le32(m, m.size() - 4, std::uint32_t(len));
  m.insert(m.end(), text, text + len + 1);  // with its NUL
}

}  // namespace

std::vector<std::uint8_t> too_large_stand_in(std::uint32_t serial, std::uint8_t flags) {
  std::vector<std::uint8_t> m(kFixedHeader, 0);
  m[0] = kLittle;
  m[1] = kMethodCall;
  m[2] = flags & kFlagsKept;
  m[3] = kProtocolVersion;
  put_le32(m, kSerialAt, serial);
  field(m, kFieldPath, 'o', kRootPath);
  field(m, kFieldInterface, 's', kGateInterface);
  field(m, kFieldMember, 's', kGateTooLarge);
  put_le32(m, kFieldsLengthAt, std::uint32_t(m.size() - kFixedHeader));
  align(m, 8);  // the (empty) body starts 8-aligned
  return m;
}

MessageFraming::MessageFraming(std::size_t max_message_bytes) : max_(max_message_bytes) {}

void MessageFraming::feed(std::span<const std::uint8_t> in, Out& out) {
  std::size_t i = 0;
  while (i < in.size() && !out.broken) {
    const std::size_t rest = in.size() - i;
    switch (phase_) {
      case Phase::kAuth: {  // SASL lines, ending with BEGIN (the very first byte is a NUL)
        const std::uint8_t b = in[i++];
        out.pass->push_back(b);
        if (++auth_bytes_ > kAuthBytes) {
          out.broken = "its D-Bus handshake was longer than 16 KiB";
        } else if (b == '\n' && !line_.empty() && line_.back() == '\r') {
          line_.pop_back();
          if (line_ == "BEGIN") phase_ = Phase::kHeader;
          line_.clear();
        } else if (auth_bytes_ > 1 || b != 0) {
          line_ += char(b);
        }
        break;
      }
      case Phase::kHeader: {
        const std::size_t n = std::min(rest, kFixedHeader - header_size_);
        std::memcpy(header_ + header_size_, in.data() + i, n);
        header_size_ += n;
        i += n;
        if (header_size_ == kFixedHeader) header_complete(out);
        break;
      }
      case Phase::kBody:
      case Phase::kSkip: {
        const std::size_t n = std::size_t(std::min<std::uint64_t>(rest, left_));
        if (phase_ == Phase::kBody) out.pass->insert(out.pass->end(), in.data() + i, in.data() + i + n);
        else out.dropped += n;
        i += n;
        left_ -= n;
        if (left_ == 0) phase_ = Phase::kHeader;
        break;
      }
    }
  }
}

void MessageFraming::header_complete(Out& out) {
  header_size_ = 0;
  if (header_[0] != kLittle && header_[0] != kBig) {
    out.broken = "it sent something that is not a D-Bus message";
    return;
  }
  const bool big = header_[0] == kBig;
  const std::uint64_t fields = u32(header_ + kFieldsLengthAt, big);
  const std::uint64_t total = kFixedHeader + ((fields + 7) & ~std::uint64_t(7)) + u32(header_ + kBodyLengthAt, big);
  left_ = total - kFixedHeader;
  if (total <= max_) {
    out.pass->insert(out.pass->end(), header_, header_ + kFixedHeader);
    phase_ = left_ ? Phase::kBody : Phase::kHeader;
    return;
  }
  const std::uint32_t serial = u32(header_ + kSerialAt, big);
  if (serial == 0) {  // sd-bus would drop it as invalid: nothing to answer
    out.broken = "it sent a message without a serial";
    return;
  }
  const std::vector<std::uint8_t> stand_in = too_large_stand_in(serial, header_[2]);
  out.pass->insert(out.pass->end(), stand_in.begin(), stand_in.end());
  out.oversized = true;
  out.oversized_bytes = total;
  phase_ = Phase::kSkip;
}

MessageGate::MessageGate(int socket, std::size_t max_message_bytes)
    : socket_(socket), max_(max_message_bytes), framing_(max_message_bytes) {
  int p[2];
  if (::pipe2(p, O_CLOEXEC | O_NONBLOCK) == 0) {
    pipe_read_ = p[0];
    pipe_write_ = p[1];
  }
}

MessageGate::~MessageGate() {
  if (pipe_write_ >= 0) ::close(pipe_write_);
  if (pipe_read_ >= 0 && !input_taken_) ::close(pipe_read_);
}

bool MessageGate::flush() {
  while (staged_at_ < staged_.size()) {
    const ssize_t n = ::write(pipe_write_, staged_.data() + staged_at_, staged_.size() - staged_at_);
    if (n < 0) {
      if (errno == EINTR) continue;
      if (errno == EAGAIN) return false;
      end("its messages could not be handed on");
      return false;
    }
    staged_at_ += std::size_t(n);
  }
  staged_.clear();
  staged_at_ = 0;
  return true;
}

void MessageGate::end(const char* why) {
  ended_ = true;
  why_ = why;
  staged_.clear();
  staged_at_ = 0;
  if (pipe_write_ >= 0) ::close(pipe_write_);  // sd-bus reads what is in the pipe, then the end
  pipe_write_ = -1;
}

MessageGate::Pump MessageGate::pump() {
  if (ended_ || !flush()) return Pump::kNothing;
  static std::uint8_t slice[kSliceBytes];  // one loop, one slice at a time
  const ssize_t n = ::recv(socket_, slice, sizeof slice, MSG_DONTWAIT);
  if (n < 0) {
    if (errno == EAGAIN || errno == EWOULDBLOCK || errno == EINTR) return Pump::kNothing;
    end(nullptr);  // reset by the peer: as a close
    return Pump::kEnd;
  }
  if (n == 0) {
    end(nullptr);
    return Pump::kEnd;
  }
  MessageFraming::Out out{&staged_};
  framing_.feed({slice, std::size_t(n)}, out);
  if (out.oversized) {
    ++oversized_;
    last_oversized_ = out.oversized_bytes;
  }
  if (out.broken) {
    end(out.broken);
    return Pump::kEnd;
  }
  flush();
  return Pump::kMoved;
}

int answer_oversized(sd_bus* bus, const MessageGate& gate, sd_bus_slot** slot) {
  return sd_bus_add_filter(
      bus, slot,
      [](sd_bus_message* m, void* userdata, sd_bus_error*) -> int {
        if (sd_bus_message_is_method_call(m, kGateInterface, kGateTooLarge) <= 0) return 0;
        const auto& self = *static_cast<const MessageGate*>(userdata);
        return sd_bus_reply_method_errorf(
            m, kErrorTooLarge, "a message of %llu bytes; cansimd reads at most %zu from a client (docs/limits.md)",
            static_cast<unsigned long long>(self.last_oversized_bytes()), self.max_bytes());
      },
      const_cast<MessageGate*>(&gate));
}

}  // namespace cansim::control
