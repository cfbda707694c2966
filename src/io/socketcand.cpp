#include "io/socketcand.hpp"

#include <charconv>
#include <cstring>
#include <initializer_list>

#include "core/protocol.hpp"

namespace cansim::io::socketcand {

namespace {

constexpr char kHexDigits[] = "0123456789ABCDEF";
constexpr std::uint32_t kMaxStandardId = cob::kId11Mask;
constexpr std::uint32_t kMaxExtendedId = cob::kId29Mask;
constexpr std::size_t kExtendedIdDigits = 8;  // socketcand: `%08X`, and 8 digits in `send` mean 29 bits
constexpr std::size_t kMaxCommandWord = 16;

bool is_space(char c) { return c == ' ' || c == '\t' || c == '\n' || c == '\r' || c == '\f' || c == '\v'; }

// The next whitespace-separated token of `s` (empty at the end); `s` moves past it.
std::string_view next_token(std::string_view& s) {
  std::size_t i = 0;
  while (i < s.size() && is_space(s[i])) ++i;
  std::size_t j = i;
  while (j < s.size() && !is_space(s[j])) ++j;
  std::string_view token = s.substr(i, j - i);
  s.remove_prefix(j);
  return token;
}

bool parse_hex(std::string_view s, std::uint32_t& value) {
  if (s.empty() || s.size() > 8) return false;
  auto [end, ec] = std::from_chars(s.data(), s.data() + s.size(), value, 16);
  return ec == std::errc{} && end == s.data() + s.size();
}

// An identifier as socketcand writes and reads it.
bool parse_id(std::string_view s, CanFrame& frame) {
  std::uint32_t id = 0;
  if (!parse_hex(s, id) || id > kMaxExtendedId) return false;
  frame.id = id;
  if (s.size() == kExtendedIdDigits || id > kMaxStandardId) frame.flags |= CanFrame::kExtended;
  return true;
}

bool parse_dlc(std::string_view s, std::uint8_t& dlc) {
  if (s.size() != 1 || s[0] < '0' || s[0] > '8') return false;
  dlc = std::uint8_t(s[0] - '0');
  return true;
}

// The command word, quoted in an error only when it is a plain word.
std::string word_of(std::string_view cmd) {
  if (cmd.size() > kMaxCommandWord) return {};
  for (char c : cmd)
    if (!((c >= 'a' && c <= 'z') || (c >= 'A' && c <= 'Z') || (c >= '0' && c <= '9'))) return {};
  return std::string(cmd);
}

bool one_of(std::string_view s, std::initializer_list<std::string_view> words) {
  for (std::string_view w : words)
    if (s == w) return true;
  return false;
}

char* put_hex(char* p, std::uint32_t v, int digits) {
  for (int i = digits - 1; i >= 0; --i) p[i] = kHexDigits[v & 0xF], v >>= 4;
  return p + digits;
}

char* put_decimal(char* p, std::uint64_t v, int min_digits) {
  char tmp[24];
  int n = 0;
  do tmp[n++] = char('0' + v % 10), v /= 10;
  while (v);
  while (n < min_digits) tmp[n++] = '0';
  while (n) *p++ = tmp[--n];
  return p;
}

char* put(char* p, std::string_view s) {
  for (char c : s) *p++ = c;
  return p;
}

}  // namespace

namespace {
// `text` (length n, at most 2 records less 1) as whole records: spaces, the
// separator, the text.
std::size_t pad_records(const char* text, std::size_t n, char* out) {
  const std::size_t total = (n + 1 + kRecord - 1) / kRecord * kRecord;
  std::memset(out, ' ', total - n - 1);
  out[total - n - 1] = kSeparator;
  std::memmove(out + total - n, text, n);
  return total;
}

// SECONDS.MICROS and a space.
char* put_stamp(char* p, Stamp at) {
  p = put_decimal(p, std::uint64_t(at.sec < 0 ? 0 : at.sec), 1);
  *p++ = '.';
  p = put_decimal(p, std::uint64_t(at.usec < 0 ? 0 : at.usec % 1000000), 6);
  *p++ = ' ';
  return p;
}
}  // namespace

std::size_t format_frame(const CanFrame& frame, Stamp at, char* out) {
  char message[kMaxFrameText];
  char* p = message;
  p = put(p, frame.rtr() ? "< rtr " : "< frame ");
  p = frame.extended() ? put_hex(p, frame.id & kMaxExtendedId, 8) : put_hex(p, frame.id & kMaxStandardId, 3);
  *p++ = ' ';
  p = put_stamp(p, at);
  const std::uint8_t dlc = frame.dlc > 8 ? 8 : frame.dlc;
  if (frame.rtr()) {
    p = put_decimal(p, dlc, 1);
    *p++ = ' ';
  } else {
    for (std::uint8_t i = 0; i < dlc; ++i) p = put_hex(p, frame.data[i], 2);
    *p++ = ' ';  // with no data: two spaces, as socketcand (python-can splits on them)
  }
  p = put(p, ">");
  return pad_records(message, std::size_t(p - message), out);
}

std::size_t format_error(std::uint32_t error_class, Stamp at, char* out) {
  char message[kMaxFrameText];
  char* p = message;
  p = put(p, "< error ");
  p = put_hex(p, error_class & kMaxExtendedId, 3);
  *p++ = ' ';
  p = put_stamp(p, at);
  p = put(p, ">");
  return pad_records(message, std::size_t(p - message), out);
}

bool parse_send(std::string_view args, bool rtr, CanFrame& frame, std::string& why) {
  const char* what = rtr ? "sendrtr" : "send";
  frame = CanFrame{};
  if (rtr) frame.flags |= CanFrame::kRtr;
  if (!parse_id(next_token(args), frame)) {
    why = std::string(what) + ": expected an identifier of 1 to 8 hex digits, at most 1FFFFFFF";
    return false;
  }
  if (!parse_dlc(next_token(args), frame.dlc)) {
    why = std::string(what) + ": expected a DLC of 0 to 8";
    return false;
  }
  std::size_t n = 0;
  for (std::string_view b = next_token(args); !b.empty(); b = next_token(args), ++n) {
    std::uint32_t v = 0;
    if (rtr) {
      why = "sendrtr: expected no data bytes";
      return false;
    }
    if (n == 8 || b.size() > 2 || !parse_hex(b, v)) {
      why = n == 8 ? "send: more than 8 data bytes"
                   : "send: data byte " + std::to_string(n + 1) + " is not 1 or 2 hex digits";
      return false;
    }
    frame.data[n] = std::uint8_t(v);
  }
  if (!rtr && n != frame.dlc) {
    why = "send: " + std::to_string(n) + " data byte(s) for DLC " + std::to_string(frame.dlc);
    return false;
  }
  return true;
}

// ---------------------------------------------------------------- Session

std::string record(std::string_view message) {
  const std::size_t total = (message.size() + 1 + kRecord - 1) / kRecord * kRecord;
  std::string out(total - message.size() - 1, ' ');
  out.push_back(kSeparator);
  return out.append(message);
}

void Session::reply(std::string_view text, std::string& out) const {
  out.append(handshaken_ ? record(text) : std::string(text));
}

void Session::error(std::string_view why, std::string& out) {
  ++errors_;
  std::string text = "< error ";
  text.append(why);
  text.append(" >");
  reply(text, out);
}

void Session::feed(std::string_view bytes, std::string& out, Sink& sink) {
  for (char c : bytes) {
    if (closed()) return;
    if (discarding_) {
      discarding_ = c != '>';
      continue;
    }
    if (pending_.empty()) {
      if (c == '<') {
        pending_.push_back(c);
        junk_reported_ = false;
      } else if (!is_space(c) && !junk_reported_) {
        error("text outside a message ignored", out);
        junk_reported_ = true;
      }
      continue;
    }
    if (c == '<') {  // a new message begins: the last one never ended
      error("message without its closing bracket ignored", out);
      pending_.assign(1, c);
      continue;
    }
    pending_.push_back(c);
    if (c == '>') {
      const std::string body = pending_.substr(1, pending_.size() - 2);
      pending_.clear();
      message(body, out, sink);
    } else if (pending_.size() > kMaxMessage) {
      error("message longer than " + std::to_string(kMaxMessage) + " bytes ignored", out);
      pending_.clear();
      discarding_ = true;
    }
  }
}

void Session::send(std::string_view args, bool rtr, std::string& out, Sink& sink) {
  CanFrame frame;
  std::string why;
  if (parse_send(args, rtr, frame, why)) sink.frame(frame);
  else error(why, out);
}

void Session::message(std::string_view body, std::string& out, Sink& sink) {
  ++messages_;
  std::string_view rest = body;
  const std::string_view cmd = next_token(rest);
  std::string_view after = rest;
  const bool alone = next_token(after).empty();
  const std::string word = word_of(cmd);
  if (cmd.empty()) return error("empty message", out);
  if (mode_ == Mode::kNoBus) {
    if (cmd != "open") return error("unknown command " + word + " (expected open BUS)", out);
    const std::string_view name = next_token(rest);
    if (name.empty() || !next_token(rest).empty()) return error("open: expected one bus name", out);
    if (name != bus_) {
      reply("< error could not open bus: this port serves " + bus_ + " >", out);
      ++errors_;
      mode_ = Mode::kClosed;
      return;
    }
    mode_ = Mode::kBcm;
    return reply(kOk, out);
  }
  if (cmd == "send" || cmd == "sendrtr") return send(rest, cmd == "sendrtr", out, sink);
  if ((cmd == "echo" || cmd == "rawmode" || cmd == "bcmmode") && !alone)
    return error(word + ": expected no arguments", out);
  if (cmd == "echo") return reply(kEcho, out);
  if (cmd == "rawmode" || cmd == "bcmmode") {
    mode_ = cmd == "rawmode" ? Mode::kRaw : Mode::kBcm;
    reply(kOk, out);
    handshaken_ |= mode_ == Mode::kRaw;
    return;
  }
  if (cmd == "open") return error("open: bus " + bus_ + " is open already", out);
  if (one_of(cmd, {"add", "update", "delete", "filter", "muxfilter", "subscribe", "unsubscribe"}))
    return error(word + ": the broadcast manager's jobs are not served, use rawmode", out);
  if (one_of(cmd, {"controlmode", "isotpmode", "statistics", "isotpconf", "sendpdu"}))
    return error(word + ": not served (rawmode and bcmmode are)", out);
  error("unknown command " + word, out);
}

// ---------------------------------------------------------------- client side

void MessageReader::append(std::string_view bytes) {
  if (pos_ > 0 && pos_ >= buffer_.size() / 2) {
    buffer_.erase(0, pos_);
    pos_ = 0;
  }
  buffer_.append(bytes);
}

bool MessageReader::next(std::string& body) {
  for (;;) {
    const std::size_t open = buffer_.find('<', pos_);
    if (open == std::string::npos) {
      pos_ = buffer_.size();
      return false;
    }
    const std::size_t close = buffer_.find('>', open + 1);
    const std::size_t next_open = buffer_.find('<', open + 1);
    if (close == std::string::npos) {
      if (next_open != std::string::npos || buffer_.size() - open > kMaxMessage) {
        pos_ = next_open == std::string::npos ? buffer_.size() : next_open;  // unterminated: dropped
        continue;
      }
      pos_ = open;
      return false;
    }
    if (next_open < close) {  // `< ... < ... >`: the first never ended
      pos_ = next_open;
      continue;
    }
    body.assign(buffer_, open + 1, close - open - 1);
    pos_ = close + 1;
    return true;
  }
}

bool parse_frame_message(std::string_view body, CanFrame& frame, double& seconds) {
  const std::string_view kind = next_token(body);
  if (kind != "frame" && kind != "rtr") return false;
  frame = CanFrame{};
  if (!parse_id(next_token(body), frame)) return false;
  const std::string_view stamp = next_token(body);
  auto [end, ec] = std::from_chars(stamp.data(), stamp.data() + stamp.size(), seconds);
  if (stamp.empty() || ec != std::errc{} || end != stamp.data() + stamp.size()) return false;
  if (kind == "rtr") {
    frame.flags |= CanFrame::kRtr;
    return parse_dlc(next_token(body), frame.dlc) && next_token(body).empty();
  }
  // socketcand writes the data as one run of hex digits; its protocol
  // document shows bytes apart: either is taken.
  std::string hex;
  for (std::string_view t = next_token(body); !t.empty(); t = next_token(body)) hex.append(t);
  if (hex.size() % 2 || hex.size() > 16) return false;
  for (std::size_t i = 0; i < hex.size(); i += 2) {
    std::uint32_t v = 0;
    if (!parse_hex(std::string_view(hex).substr(i, 2), v)) return false;
    frame.data[frame.dlc++] = std::uint8_t(v);
  }
  return true;
}

}  // namespace cansim::io::socketcand
