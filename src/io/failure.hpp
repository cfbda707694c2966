// How io says that something failed, once for the layer: nothing in io
// throws. A call that can fail returns false (a count: -1) and leaves the
// reason as text, "what: strerror(errno)" ("epoll_ctl(ADD): No space left
// on device", "127.0.0.1:29536: Address already in use"): an object keeps it
// in error() until its next failure (CanInterface, EventLoop,
// SocketcandServer), a free function writes it to its `why` argument
// (socketcand::parse_send). A query of the kernel that cannot learn
// something answers "unknown" in its result (kernel_link: empty kind, bit
// rate 0). The loop never unwinds: its owner decides what a failure means
// (the daemon: fatal at start, retried or the client dropped later).
#pragma once

#include <cstring>
#include <string>

namespace cansim::io {

// "what: <the system's text for err>".
inline std::string failure(const std::string& what, int err) { return what + ": " + std::strerror(err); }

}  // namespace cansim::io
