// libFuzzer target: the socketcand protocol (io/socketcand.hpp). The input
// is what a client sends, fed to a server Session in pieces whose lengths
// its first byte chooses (TCP splits a stream anywhere), and then what a
// server sends, read by the client side (MessageReader,
// parse_frame_message). No crash, no sanitizer report, no hang, and:
//   - every answer is one or more `< ... >` messages, each preceded by
//     spaces and a newline once the handshake is over, none longer than the
//     protocol's bound, none with a `<` or `>` inside (else abort());
//   - every frame the session hands the bus is a valid classic CAN frame;
//   - a frame the client side reads writes back as the same frame.
// Seeds: fuzz/corpus-socketcand/.
#include <cstdint>
#include <cstdlib>
#include <string>
#include <string_view>

#include "io/socketcand.hpp"

using namespace cansim;
using namespace cansim::io::socketcand;

namespace {

struct Checked : Session::Sink {
  void frame(const CanFrame& f) override {
    const bool ext = f.extended();
    if (f.dlc > 8 || f.id > (ext ? 0x1FFFFFFFu : 0x7FFu) || (f.flags & ~(CanFrame::kRtr | CanFrame::kExtended)))
      std::abort();
    ++frames;
  }
  std::size_t frames = 0;
};

// Answers are `< ... >` messages with only whitespace between them.
void check_answers(std::string_view out) {
  std::size_t i = 0;
  while (i < out.size()) {
    if (out[i] == '\n' || out[i] == ' ') {
      ++i;
      continue;
    }
    if (out[i] != '<') std::abort();
    const std::size_t end = out.find('>', i);
    if (end == std::string_view::npos || out.find('<', i + 1) < end) std::abort();
    if (end - i + 1 > kMaxMessage + 64) std::abort();  // an error quotes a word of at most 16 letters
    i = end + 1;
  }
}

void read_back(std::string_view text) {
  MessageReader reader;
  reader.append(text);
  std::string body;
  for (int n = 0; n < 1000 && reader.next(body); ++n) {
    CanFrame f;
    double seconds = 0;
    if (!parse_frame_message(body, f, seconds)) continue;
    char buf[kMaxFrameText];
    const std::size_t len = format_frame(f, {1, 2}, buf);
    CanFrame again;
    double t = 0;
    const std::string_view text(buf, len);
    const std::size_t open = text.find('<');
    if (len % kRecord || open == std::string_view::npos || text.back() != '>') std::abort();
    if (!parse_frame_message(text.substr(open + 1, len - open - 2), again, t) || !(again == f)) std::abort();
  }
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  if (size == 0) return 0;
  const std::size_t piece = 1 + data[0] % 64;
  std::string_view in(reinterpret_cast<const char*>(data) + 1, size - 1);
  Session session("bench");
  Checked sink;
  std::string out;
  for (std::size_t at = 0; at < in.size(); at += piece) {
    session.feed(in.substr(at, piece), out, sink);
    check_answers(out);
  }
  read_back(in);
  return 0;
}
