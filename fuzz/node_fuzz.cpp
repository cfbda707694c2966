// libFuzzer target: one generic-404 node (with its personality) fed a
// sequence of (time step, frame) records. Every service sees traffic: NMT,
// SYNC, SDO, LSS, RPDO, RTR on TPDOs, heartbeats of other nodes, raw IDs, and
// power cycles. Must never crash, trip ASan/UBSan, spin without advancing
// time, or send an invalid frame.
//
// Record layout (13 bytes; a shorter tail is ignored):
//   b0-1  time step before the frame, little-endian, in 10 us units (< 656 ms)
//   b2    bits 0-3 target: 0 NMT, 1 SYNC, 2 SDO request, 3 LSS, 4 RPDO1,
//         5 TPDO1..4 (b3 & 3), 6 heartbeat of node b3, 7 raw 11-bit id
//         (b3 | (b2 >> 4 & 7) << 8), 8 SDO with any node-ID b3, 9 EMCY,
//         14 arm a communication fault (kind b3 % 6 from silent..sdo_block_drop,
//         duration b5-6 ms (0: until the end of the input), sdo delay b7 ms,
//         drop every b8 % 5 segments, drop probability b9 / 255),
//         15 power cycle; bit 7 RTR
//   b3    parameter of the target
//   b4    DLC (values above 8 are clamped to 8)
//   b5-12 data bytes
// fuzz/make_seeds.py writes the seed corpus in this format.
//
// Speed (the CI run is 60 s): the profile is loaded and prepared once, with
// the CiA 404 event checks every 100 ms instead of 10 ms and the sensor
// sampling at 100 Hz / 10 Hz instead of 1 kHz / 100 Hz (same code paths,
// a tenth of the physics work per simulated second: it was most of the time
// per input), and the run ends with the last record unless an SDO transfer
// is still open, which then runs into its timeout. Each input gets a fresh
// node, application (physics, armed faults, random state) and storage:
// building them costs little next to the power-on reset every input needs
// anyway (perf: 60 % of this function's time is NmtSlave::restart), and no
// state can leak from one input into the next, so a crash input reproduces
// when run alone.
#include <yaml-cpp/yaml.h>

#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <memory>
#include <optional>

#include "config/profile.hpp"
#include "core/node.hpp"
#include "personalities/cia404.hpp"
#include "personalities/registry.hpp"

namespace {

using namespace cansim;

class CheckingSink : public FrameSink {
 public:
  void send(const CanFrame& f) override {
    if (f.dlc > 8) std::abort();
    if (!f.extended() && f.id > 0x7FF) std::abort();
    ++frames;
  }
  long frames = 0;
};

class NullStorage : public NodeStorage {
 public:
  bool load(std::vector<std::uint8_t>& blob) override {
    blob = data;
    return !data.empty();
  }
  bool save(std::span<const std::uint8_t> blob) override {
    data.assign(blob.begin(), blob.end());
    return true;
  }
  std::vector<std::uint8_t> data;
};

config::Profile& profile() {
  static config::Profile p = [] {
    YAML::Node root = config::load_yaml_file(CANSIM_FUZZ_PROFILE);
    root["vendor"]["cia404"]["event_check_period"] = "100 ms";
    root["sensor"]["pressure"]["sample_rate"] = "100 Hz";
    root["sensor"]["temperature"]["sample_rate"] = "10 Hz";
    config::Profile loaded = config::parse_profile(root, CANSIM_FUZZ_PROFILE);
    personalities::prepare_profile(loaded);
    return loaded;
  }();
  return p;
}

// What one input runs on: a fresh node, application and storage, destroyed
// at the end (allocations and frees balance within a run, so libFuzzer's leak
// check stays quiet).
struct Harness {
  CheckingSink sink;
  NullStorage storage;
  std::unique_ptr<Application> app;
  std::optional<Node> node;

  explicit Harness(const config::Profile& p) : app(personalities::make_application(p, personalities::NodeContext{})) {
    NodeSetup setup;
    setup.layout = p.layout;
    setup.options = p.options;
    setup.node_id = p.node_id;
    setup.bit_rate_index = std::uint8_t(config::bit_rate_index(p.bit_rate_kbit));
    node.emplace(setup, sink, app.get(), &storage);
  }
  ~Harness() { node.reset(); }  // before the application it points to
};

// Advances to `t` through every deadline; a deadline that does not move is a
// spinning loop in the daemon, so it counts as a crash.
void run_until(Node& node, TimeUs& now, TimeUs t) {
  long guard = 0;
  for (TimeUs next = node.next_deadline(); next <= t; next = node.next_deadline()) {
    if (++guard > 2000000) std::abort();
    now = std::max(now, next);
    node.advance(now);
  }
  now = std::max(now, t);
}

std::uint32_t cob_id(std::uint8_t sel, std::uint8_t param, std::uint8_t node_id) {
  switch (sel & 0x0F) {
    case 0: return 0x000;
    case 1: return 0x080;
    case 2: return 0x600u + node_id;
    case 3: return 0x7E5;
    case 4: return 0x200u + node_id;
    case 5: return 0x180u + 0x100u * (param & 3) + node_id;
    case 6: return 0x700u + (param & 0x7F);
    case 7: return std::uint32_t(param) | (std::uint32_t((sel >> 4) & 7) << 8);
    case 8: return 0x600u + (param & 0x7F);
    case 9: return 0x080u + (param & 0x7F);
    default: return 0x7FF;
  }
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  Harness h(profile());
  Node& node = *h.node;
  Application* app = h.app.get();
  TimeUs now = 0;
  node.power_on(now);

  constexpr std::size_t kRecord = 13;
  for (std::size_t at = 0; at + kRecord <= size; at += kRecord) {
    const std::uint8_t* r = data + at;
    TimeUs step = TimeUs(r[0] | (r[1] << 8)) * 10;
    run_until(node, now, now + step);
    if ((r[2] & 0x0F) == 15) {
      node.power_off();
      node.power_on(now);
      continue;
    }
    if ((r[2] & 0x0F) == 14) {
      if (auto* cia = dynamic_cast<personalities::Cia404Application*>(app)) {
        physics::FaultSpec f;
        f.kind = physics::FaultKind(std::uint8_t(physics::FaultKind::Silent) + r[3] % 6);
        const TimeUs duration = ms(r[5] | (r[6] << 8));
        f.timing.duration_us = duration > 0 ? duration : -1;
        f.sdo_delay_us = ms(r[7]);
        f.drop_every_n = r[8] % 5;
        f.drop_probability = r[9] / 255.0;
        cia->arm_fault(node, f, now);
      }
      if (node.next_deadline() < now) run_until(node, now, now);
      continue;
    }
    std::uint8_t dlc = std::uint8_t(r[4] > 8 ? 8 : r[4]);
    CanFrame f;
    f.id = cob_id(r[2], r[3], node.node_id() == 0xFF ? 0x7F : node.node_id());
    f.dlc = dlc;
    if (r[2] & 0x80) f.flags = CanFrame::kRtr;
    for (int i = 0; i < 8; ++i) f.data[i] = r[5 + i];
    node.on_frame(f, now);
    // A deadline in the past would make the loop spin.
    if (node.next_deadline() < now) run_until(node, now, now);
  }
  if (node.sdo().busy()) run_until(node, now, now + ms(1100));  // past the SDO timeout
  return 0;
}
