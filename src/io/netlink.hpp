// One request to the kernel's routing netlink (RTM_GETLINK, RTM_GETQDISC)
// and its answers, on a socket of its own: at most 1 s for each read, no
// capability needed. Used where cansimd asks what an interface is
// (io/can_interface.cpp) and how it can be paced (io/kernel_pacing.cpp).
#pragma once

#include <linux/netlink.h>
#include <linux/rtnetlink.h>
#include <sys/socket.h>
#include <sys/time.h>
#include <unistd.h>

#include <cstdint>

namespace cansim::io {

// Sends `type` with `body` (a dump of every object when `dump`) and calls
// each(const nlmsghdr*) for every answer until the dump is done (or after
// the first read of a single request).
template <typename Body, typename Each>
void netlink_route_query(std::uint16_t type, bool dump, const Body& body, Each&& each) {
  const int fd = ::socket(AF_NETLINK, SOCK_RAW | SOCK_CLOEXEC, NETLINK_ROUTE);
  if (fd < 0) return;
  struct {
    nlmsghdr h;
    Body b;
  } req{};
  req.h.nlmsg_len = NLMSG_LENGTH(sizeof(Body));
  req.h.nlmsg_type = type;
  req.h.nlmsg_flags = std::uint16_t(NLM_F_REQUEST | (dump ? NLM_F_DUMP : 0));
  req.h.nlmsg_seq = 1;
  req.b = body;
  timeval tv{1, 0};
  ::setsockopt(fd, SOL_SOCKET, SO_RCVTIMEO, &tv, sizeof tv);
  if (::send(fd, &req, req.h.nlmsg_len, 0) >= 0) {
    alignas(nlmsghdr) char buf[16384];
    for (bool done = false; !done;) {
      const ssize_t n = ::recv(fd, buf, sizeof buf, 0);
      if (n <= 0) break;
      done = !dump;
      int len = int(n);
      for (auto* h = reinterpret_cast<const nlmsghdr*>(buf); NLMSG_OK(h, len); h = NLMSG_NEXT(h, len)) {
        if (h->nlmsg_type == NLMSG_DONE || h->nlmsg_type == NLMSG_ERROR) done = true;
        else each(h);
      }
    }
  }
  ::close(fd);
}

}  // namespace cansim::io
