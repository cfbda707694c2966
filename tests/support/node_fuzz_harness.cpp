#include "support/node_fuzz_harness.hpp"

#include <yaml-cpp/yaml.h>

#include <algorithm>
#include <cstdio>
#include <cstdlib>

#include "personalities/registry.hpp"

namespace cansim::test {

namespace {

constexpr std::size_t kRecord = 13;
constexpr std::uint8_t kArmFault = 14;
constexpr std::uint8_t kPowerCycle = 15;

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

std::size_t node_fuzz_variant(const std::string& name) {
  for (std::size_t i = 0; i < kNodeFuzzVariantCount; ++i)
    if (name == kNodeFuzzVariants[i].name) return i;
  return kNodeFuzzVariantCount;
}

config::Profile node_fuzz_profile(const std::string& profiles, const NodeFuzzVariant& variant) {
  const std::string path = profiles + "/" + variant.profile + ".yaml";
  YAML::Node root = config::load_yaml_file(path);
  YAML::Node vendor = root["vendor"];
  vendor["cia404"]["event_check_period"] = "100 ms";
  // Each personality's supervision period (config/vendor_settings.cpp).
  const std::string personality = root["personality"].as<std::string>();
  for (const auto& [who, key] : {std::pair{"honeywell-dps", "span_check_period"},
                                 {"danfoss-p92c", "monitor_period"},
                                 {"gems-9000", "supervision_period"},
                                 {"adz-smc", "stay_set_period"}})
    if (personality == who) vendor[key] = "500 ms";
  for (const auto& [channel, rate] : {std::pair{"pressure", "10 Hz"}, {"temperature", "1 Hz"}})
    if (root["sensor"][channel]) root["sensor"][channel]["sample_rate"] = rate;
  if (variant.strict) root["strict"] = true;
  return config::parse_profile(root, path);
}

void NodeFuzzHarness::CheckingSink::send(const CanFrame& f) {
  if (f.dlc > 8) std::abort();
  if (!f.extended() && f.id > 0x7FF) std::abort();
  if (*recording) sent.push_back({*clock, f});
}

NodeFuzzHarness::NodeFuzzHarness(const config::Profile& profile)
    : app_(personalities::make_application(profile, personalities::NodeContext{})),
      measurement_(personalities::measurement_control(app_.get())) {
  sink_.clock = &now_;
  sink_.recording = &recording_;
  node_.emplace(config::node_setup(profile), sink_, app_.get(), &storage_);
  node_->power_on(0);
  // Inputs start from the boot-up (a profile's boot_up_delay_ms would spend
  // the first records of every input in INITIALISING, deaf to NMT).
  while (node_->state() == NmtState::kInitialising && node_->next_deadline() <= ms(10000))
    run_until(node_->next_deadline());
  booted_at_ = now_;
  node_at_power_on_.emplace(node_->snapshot());
  storage_at_power_on_ = storage_.data;
  if (app_) {
    app_at_power_on_ = app_->snapshot();
    if (!app_at_power_on_) {
      std::fprintf(stderr, "node fuzz: the application of profile %s takes no snapshots\n", profile.name.c_str());
      std::abort();
    }
  }
}

NodeFuzzHarness::~NodeFuzzHarness() { node_.reset(); }  // before the application it points to

// Plain copies: no allocation once the buffers have grown to what the inputs
// so far needed.
void NodeFuzzHarness::start_from_power_on() {
  node_->restore(*node_at_power_on_);
  if (app_) app_->restore(*app_at_power_on_);
  storage_.data = storage_at_power_on_;
  storage_.rejections.clear();  // one input's, not a growing log
  sink_.sent.clear();
  now_ = booted_at_;
}

void NodeFuzzHarness::run(std::span<const std::uint8_t> input) {
  start_from_power_on();
  for (std::size_t at = 0; at + kRecord <= input.size(); at += kRecord) run_record(input.data() + at);
  if (node_->sdo().busy()) run_until(now_ + ms(1100));  // past the SDO timeout
}

void NodeFuzzHarness::run_record(const std::uint8_t* r) {
  run_until(now_ + TimeUs(r[0] | (r[1] << 8)) * 10);
  switch (r[2] & 0x0F) {
    case kPowerCycle:
      node_->power_off();
      node_->power_on(now_);
      return;
    case kArmFault: arm_fault(r); break;
    default: deliver(r); break;
  }
  // A deadline in the past would make the loop spin.
  if (node_->next_deadline() < now_) run_until(now_);
}

void NodeFuzzHarness::arm_fault(const std::uint8_t* r) {
  if (!measurement_) return;
  physics::FaultSpec f;
  f.kind = physics::FaultKind(std::uint8_t(physics::FaultKind::Silent) + r[3] % 6);
  const TimeUs duration = ms(r[5] | (r[6] << 8));
  f.timing.duration_us = duration > 0 ? duration : -1;
  f.sdo_delay_us = ms(r[7]);
  f.drop_every_n = r[8] % 5;
  f.drop_probability = r[9] / 255.0;
  measurement_->arm_fault(*node_, f, now_);
}

void NodeFuzzHarness::deliver(const std::uint8_t* r) {
  CanFrame f;
  f.id = cob_id(r[2], r[3], node_->node_id() == 0xFF ? 0x7F : node_->node_id());
  f.dlc = std::uint8_t(r[4] > 8 ? 8 : r[4]);
  if (r[2] & 0x80) f.flags = CanFrame::kRtr;
  for (int i = 0; i < 8; ++i) f.data[i] = r[5 + i];
  node_->on_frame(f, now_);
}

// Advances to `t` through every deadline; a deadline that does not move is a
// spinning loop in the daemon, so it counts as a crash.
void NodeFuzzHarness::run_until(TimeUs t) {
  long guard = 0;
  for (TimeUs next = node_->next_deadline(); next <= t; next = node_->next_deadline()) {
    if (++guard > 2000000) std::abort();
    now_ = std::max(now_, next);
    node_->advance(now_);
  }
  now_ = std::max(now_, t);
}

NodeFuzzHarness& NodeFuzzTarget::harness(std::size_t variant) {
  if (!harnesses_[variant]) {
    profile_storage_[variant] = node_fuzz_profile(profiles_, kNodeFuzzVariants[variant]);
    harnesses_[variant] = std::make_unique<NodeFuzzHarness>(profile_storage_[variant]);
  }
  return *harnesses_[variant];
}

void NodeFuzzTarget::run(std::span<const std::uint8_t> input) {
  if (input.empty()) return;
  harness(node_fuzz_variant(input[0])).run(input.subspan(1));
}

}  // namespace cansim::test
