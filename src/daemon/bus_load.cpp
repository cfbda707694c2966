#include "daemon/bus_load.hpp"

#include "core/protocol.hpp"

namespace cansim::daemon {

namespace {

void add_frames(Traffic& t, double per_s, int dlc, bool extended) {
  if (per_s <= 0) return;
  t.frames_per_s += per_s;
  t.bits_per_s += per_s * frame_bits(dlc, extended);
  t.stuffed_bits_per_s += per_s * stuffed_frame_bits(dlc, extended);
}

// Bytes a TPDO carries, from its mapping object (CiA 301 §7.5.2.36).
int tpdo_length(const Node& node, std::uint16_t mapping_index) {
  const OdValues& v = node.values();
  if (!node.od().find(mapping_index, 0)) return 8;
  unsigned count = unsigned(v.u(mapping_index, 0));
  unsigned bits = 0;
  for (unsigned sub = 1; sub <= count && sub <= 64; ++sub)
    bits += unsigned(v.u(mapping_index, std::uint8_t(sub)) & 0xFF);
  int bytes = int((bits + 7) / 8);
  return bytes > 8 ? 8 : bytes;
}

}  // namespace

int frame_bits(int dlc, bool extended) { return (extended ? 67 : 47) + 8 * dlc; }

int stuffed_frame_bits(int dlc, bool extended) {
  int stuffable = (extended ? 54 : 34) + 8 * dlc;
  return frame_bits(dlc, extended) + (stuffable - 1) / 4;
}

Traffic estimate_traffic(const Node& node) {
  Traffic t;
  const OdValues& v = node.values();
  const OdLayout& od = node.od();
  if (od.find(0x1017, 0)) {
    std::uint64_t ms = v.u(0x1017, 0);
    if (ms > 0) add_frames(t, 1000.0 / double(ms), 1, false);
  }
  // SYNC rate as far as this node knows it (0x1006 communication cycle period, µs).
  double sync_per_s = 0;
  if (od.find(0x1006, 0) && v.u(0x1006, 0) > 0) sync_per_s = 1e6 / double(v.u(0x1006, 0));
  // The TPDOs the layout has (objects in index order): not a lookup for
  // each of the 512 possible ones.
  for (const OdObject& object : od.objects()) {
    const std::uint16_t comm = object.index;
    if (comm < 0x1800 || comm >= 0x1A00 || !od.find(object, 1)) continue;
    std::uint32_t cob = std::uint32_t(v.u(comm, 1));
    if (cob & cob::kInvalid) continue;
    unsigned type = od.find(comm, 2) ? unsigned(v.u(comm, 2)) : 255;
    int dlc = tpdo_length(node, std::uint16_t(comm + 0x200));
    bool ext = cob & cob::kFrame29Bit;
    if (type >= 254) {
      std::uint64_t timer_ms = od.find(comm, 5) ? v.u(comm, 5) : 0;
      if (timer_ms > 0) add_frames(t, 1000.0 / double(timer_ms), dlc, ext);
    } else if (type >= 1 && type <= 240) {
      add_frames(t, sync_per_s / type, dlc, ext);  // CiA 301: every type-th SYNC
    }
  }
  return t;
}

}  // namespace cansim::daemon
