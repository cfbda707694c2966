#include "personalities/analog_output.hpp"

#include <cmath>

#include "core/nmt.hpp"
#include "core/node.hpp"

namespace cansim::personalities::analog_output {

AnalogOutputApplication::AnalogOutputApplication(const Settings& settings) : settings_(settings) {}

int AnalogOutputApplication::channel_of(const OdEntry& e, std::uint16_t index) const {
  if (e.index != index || e.sub < 1 || e.sub > settings_.channels) return -1;
  return e.sub - 1;
}

double AnalogOutputApplication::position(unsigned ch, TimeUs t) const {
  if (ch >= settings_.channels) return 0.0;
  const Output& o = outputs_[ch];
  if (t <= o.t0) return o.from;
  return o.target + (o.from - o.target) * std::exp(-double(t - o.t0) / double(settings_.response_time_us));
}

void AnalogOutputApplication::notify(TimeUs now) const {
  for (const auto& [listener, context] : listeners_) listener(context, now);
}

void AnalogOutputApplication::add_listener(ChangeListener listener, void* context) {
  listeners_.emplace_back(listener, context);
}

void AnalogOutputApplication::command(unsigned ch, double target, TimeUs now) {
  Output& o = outputs_[ch];
  if (target == o.target && (now >= o.t0)) {
    // The same command again (a cyclic RPDO): the lag goes on undisturbed.
    return;
  }
  notify(now);
  o.from = position(ch, now);
  o.t0 = now;
  o.target = target;
}

void AnalogOutputApplication::on_reset(Node& node, ResetKind kind, TimeUs now) {
  notify(now);
  for (unsigned ch = 0; ch < settings_.channels; ++ch) {
    const OdEntry* e = node.od().find(kOutputObject, std::uint8_t(ch + 1));
    const double cmd = e ? double(node.values().get_i(*e)) : 0.0;
    // Power-on: at rest at the command. A reset of the node: it moves from where it is.
    Output& o = outputs_[ch];
    o.from = kind == ResetKind::kPowerOn ? cmd : position(ch, now);
    o.t0 = now;
    o.target = cmd;
  }
}

// CiA 401 0x6443: leaving OPERATIONAL, an output in error mode 1 goes to its
// error value (0x6444), which becomes its command.
void AnalogOutputApplication::on_nmt_state(Node& node, NmtState state, TimeUs now) {
  if (state == NmtState::kOperational || state == NmtState::kInitialising) return;
  for (unsigned ch = 0; ch < settings_.channels; ++ch) {
    const std::uint8_t sub = std::uint8_t(ch + 1);
    const OdEntry* mode = node.od().find(kErrorModeObject, sub);
    const OdEntry* value = node.od().find(kErrorValueObject, sub);
    const OdEntry* out = node.od().find(kOutputObject, sub);
    if (!mode || !value || !out || node.values().get_u(*mode) != 1) continue;
    const std::int64_t v = std::clamp<std::int64_t>(node.values().get_i(*value), INT16_MIN, INT16_MAX);
    node.values().set_i(*out, v);
    command(ch, double(v), now);
  }
}

void AnalogOutputApplication::refresh(Node& node, const OdEntry& e, TimeUs now) {
  const int ch = channel_of(e, kFeedbackObject);
  if (ch < 0) return;
  const double p = std::round(position(unsigned(ch), now));
  node.values().set_i(e, std::int64_t(std::clamp(p, double(INT16_MIN), double(INT16_MAX))));
}

void AnalogOutputApplication::after_write(Node& node, const OdEntry& e, TimeUs now) {
  const int ch = channel_of(e, kOutputObject);
  if (ch >= 0) command(unsigned(ch), double(node.values().get_i(e)), now);
}

std::unique_ptr<Application> AnalogOutputApplication::snapshot() const {
  return std::make_unique<AnalogOutputApplication>(*this);
}

void AnalogOutputApplication::restore(const Application& snapshot) {
  const auto& from = static_cast<const AnalogOutputApplication&>(snapshot);
  settings_ = from.settings_;
  outputs_ = from.outputs_;
}

namespace {
constexpr RequiredObject kObjects[] = {
    {kOutputObject, 1, 1, "its first output's command (CiA 401 Write analogue output 16-bit)", kHookWrite},
    {kFeedbackObject, 1, 1, "its first output's actual value (CiA 401 Read analogue input 16-bit)", kHookRead},
};
}  // namespace

Requirements requirements() { return {kObjects, 0, ""}; }

std::unique_ptr<Application> make(const model::Profile&, const Settings& settings, const NodeContext&) {
  return std::make_unique<AnalogOutputApplication>(settings);
}

}  // namespace cansim::personalities::analog_output
