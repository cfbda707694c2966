#include "io/kernel_pacing.hpp"

#include <linux/netlink.h>
#include <linux/pkt_sched.h>
#include <linux/rtnetlink.h>
#include <net/if.h>
#include <sys/socket.h>
#include <unistd.h>

#include <cstring>
#include <ctime>
#include <vector>

#include "io/can_interface.hpp"
#include "io/netlink.hpp"

namespace cansim::io {

namespace {

struct Qdisc {
  std::uint32_t handle = 0, parent = 0;
  std::string kind;
  tc_etf_qopt etf{};
  bool has_etf = false;
  tc_prio_qopt prio{};
  bool has_prio = false;
};

const rtattr* find_attr(const rtattr* a, int len, unsigned short type) {
  for (; RTA_OK(a, len); a = RTA_NEXT(a, len))
    if ((a->rta_type & NLA_TYPE_MASK) == type) return a;
  return nullptr;
}

void read_qdisc(const nlmsghdr* h, int ifindex, std::vector<Qdisc>& out) {
  const auto* t = static_cast<const tcmsg*>(NLMSG_DATA(h));
  if (t->tcm_ifindex != ifindex) return;
  Qdisc q;
  q.handle = t->tcm_handle;
  q.parent = t->tcm_parent;
  const int len = int(h->nlmsg_len) - int(NLMSG_LENGTH(sizeof *t));
  const auto* attrs = reinterpret_cast<const rtattr*>(reinterpret_cast<const char*>(t) + NLMSG_ALIGN(sizeof *t));
  if (const rtattr* k = find_attr(attrs, len, TCA_KIND))
    q.kind.assign(static_cast<const char*>(RTA_DATA(k)),
                  strnlen(static_cast<const char*>(RTA_DATA(k)), RTA_PAYLOAD(k)));
  if (const rtattr* o = find_attr(attrs, len, TCA_OPTIONS)) {
    if (q.kind == "etf") {
      const rtattr* p = find_attr(static_cast<const rtattr*>(RTA_DATA(o)), int(RTA_PAYLOAD(o)), TCA_ETF_PARMS);
      if (p && RTA_PAYLOAD(p) >= sizeof q.etf) {
        std::memcpy(&q.etf, RTA_DATA(p), sizeof q.etf);
        q.has_etf = true;
      }
    } else if (q.kind == "prio" && RTA_PAYLOAD(o) >= sizeof q.prio) {
      std::memcpy(&q.prio, RTA_DATA(o), sizeof q.prio);
      q.has_prio = true;
    }
  }
  out.push_back(q);
}

std::vector<Qdisc> qdiscs(int ifindex) {
  std::vector<Qdisc> out;
  tcmsg t{};
  t.tcm_family = AF_UNSPEC;
  t.tcm_ifindex = ifindex;
  netlink_route_query(RTM_GETQDISC, true, t, [&](const nlmsghdr* h) {
    if (h->nlmsg_type == RTM_NEWQDISC) read_qdisc(h, ifindex, out);
  });
  return out;
}

// The lowest priority an unprivileged socket may take (0..6) that the prio
// qdisc maps to `band`; -1 when none.
int priority_for_band(const tc_prio_qopt& prio, unsigned band) {
  for (int p = 0; p <= 6; ++p)
    if (prio.priomap[p] == band) return p;
  return -1;
}

}  // namespace

KernelPacing kernel_pacing(const std::string& ifname) {
  KernelPacing k;
  const unsigned index = if_nametoindex(ifname.c_str());
  if (index == 0) {
    k.why = "no such interface";
    return k;
  }
  const KernelLink link = kernel_link(ifname);
  // IFF_ECHO (linux/if.h): the driver loops frames back to the local sockets,
  // after the qdisc; without it the CAN core does so before it.
  constexpr unsigned kEcho = 1u << 18;
  if (!(link.flags & kEcho)) {
    k.why = "no echo (vcan echo=1): local sockets get each frame when it is written";
    return k;
  }
  if (link.tx_queue_len == 0) {
    k.why = "txqueuelen 0 (scripts/cansim-pace sets it)";
    return k;
  }
  const std::vector<Qdisc> all = qdiscs(int(index));
  const Qdisc* etf = nullptr;
  for (const Qdisc& q : all)
    if (q.kind == "etf" && q.has_etf) etf = &q;
  if (!etf) {
    k.why = "no ETF qdisc (scripts/cansim-pace sets one up)";
    return k;
  }
  if (etf->etf.clockid != CLOCK_TAI || (etf->etf.flags & (TC_ETF_DEADLINE_MODE_ON | TC_ETF_OFFLOAD_ON))) {
    k.why = "its ETF qdisc is not clockid TAI without deadline mode and offload";
    return k;
  }
  k.delta_ns = etf->etf.delta;
  if (etf->parent == TC_H_ROOT) {
    k.available = true;
    k.why = "ETF at the root";
    return k;
  }
  for (const Qdisc& q : all) {
    if (!q.has_prio || q.handle != TC_H_MAJ(etf->parent)) continue;
    const unsigned minor = TC_H_MIN(etf->parent);
    const int p = minor >= 1 ? priority_for_band(q.prio, minor - 1) : -1;
    if (p < 0) break;
    k.available = true;
    k.priority = p;
    k.why = "ETF under prio band " + std::to_string(minor) + ", socket priority " + std::to_string(p);
    return k;
  }
  k.why = "its ETF qdisc is under no prio band an unprivileged socket priority (0..6) reaches";
  return k;
}

}  // namespace cansim::io
