// Whether the kernel can pace a virtual CAN interface's frames for a timed
// bus (docs/bus-model.md "Kernel pacing"): an ETF qdisc (sch_etf, Earliest
// TxTime First) on the interface releases each frame a socket wrote with
// SO_TXTIME at its launch time, with the kernel's hrtimer, so a whole burst
// is written at once and keeps its spacing whatever the loop's wake-ups do
// (/work/shared/reference/kernel-paced-tx.md has the measured facts).
//
// Decisions:
// - An ETF qdisc drops every frame without a launch time, so it must never
//   be the interface's root qdisc where other programs (the master under
//   test) write: the set-up (scripts/cansim-pace, run by the service) puts a
//   `prio` qdisc at the root and ETF under its first band; cansimd's socket
//   takes a priority the prio map sends to that band (SO_PRIORITY, 0..6
//   needs no capability), everyone else's frames go through the other
//   bands untouched. A root ETF is used as it is (nobody else can write).
// - ETF releases a frame `delta` before its launch time: cansimd asks for
//   (end of the frame on the modelled bus) + delta, so it is dequeued, and
//   on a vcan received, when its EOF ends.
// - Pacing needs txqueuelen > 0 (a vcan has 0: every send would fail with
//   ENOBUFS), clockid TAI and neither deadline mode nor offload.
// Read with netlink (RTM_GETQDISC, RTM_GETLINK); no capability needed.
#pragma once

#include <cstdint>
#include <string>

namespace cansim::io {

struct KernelPacing {
  bool available = false;
  std::int64_t delta_ns = 0;  // ETF's delta
  int priority = -1;          // SO_PRIORITY for the ETF band (-1: root ETF, none needed)
  std::string why;            // available: where the ETF is; else why it cannot pace
};

KernelPacing kernel_pacing(const std::string& ifname);

}  // namespace cansim::io
