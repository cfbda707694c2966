// The CiA 404 chain's side of the runtime control API (docs/control-api.md):
// process model changes, reported-value overrides, channel views and
// recording (the faults are the device part's, device_part.cpp).
#include "personalities/cia404.hpp"

namespace cansim::personalities {

void Cia404Chain::control_changed(Node& node, TimeUs now) {
  invalidate();
  node.wake_app(now);
}

std::optional<std::size_t> Cia404Chain::chain_channel(physics::Channel ch) const {
  for (std::size_t i = 0; i < profile_->channels.size(); ++i)
    if (profile_->channels[i].source == ch) return i;
  return std::nullopt;
}

bool Cia404Chain::set_process(Node& node, physics::Channel ch, const std::vector<physics::TermSpec>& terms,
                              TimeUs now) {
  if (!source_.sensor()) return false;
  source_.sensor()->set_process(ch, terms, now);
  control_changed(node, now);
  return true;
}

bool Cia404Chain::restore_process(Node& node, physics::Channel ch, TimeUs now) {
  if (!source_.sensor()) return false;
  source_.sensor()->restore_process(ch, now);
  control_changed(node, now);
  return true;
}

double Cia404Chain::true_value_si(physics::Channel ch, TimeUs now) {
  return source_.sensor() ? source_.sensor()->true_value(ch, now) : std::numeric_limits<double>::quiet_NaN();
}

Cia404Chain::ChannelView Cia404Chain::view(Node& node, physics::Channel ch, TimeUs now) {
  ChannelView v;
  const std::optional<std::size_t> c = chain_channel(ch);
  if (!c) return v;
  const Measurement m = measure(node, *c, now);
  v.true_value = unit(*c).from_si(true_value_si(ch, now));
  v.reported = m.pv;
  if (const std::optional<CountScaling> counts = count_scaling(*c)) {
    v.counts = m.pv;
    v.reported = m.pv * counts->factor + counts->offset;
  }
  v.unit = unit(*c).name;
  v.status = m.status;
  return v;
}

void Cia404Chain::set_override(Node& node, physics::Channel ch, std::optional<double> si, TimeUs now) {
  override_si_[std::size_t(ch)] = si;
  control_changed(node, now);
}

std::vector<Cia404Chain::OverrideView> Cia404Chain::overrides() const {
  std::vector<OverrideView> out;
  for (physics::Channel ch : {physics::Channel::Pressure, physics::Channel::Temperature}) {
    const std::optional<double>& si = override_si_[std::size_t(ch)];
    const std::optional<std::size_t> c = chain_channel(ch);
    if (si && c) out.push_back({ch, unit(*c).from_si(*si), unit(*c).name});
  }
  return out;
}

bool Cia404Chain::start_recording(const std::string& path, std::string* error) {
  if (source_.sensor()) return source_.sensor()->record_to(path, error);
  if (error) *error = "the node has no sensor to record";
  return false;
}

void Cia404Chain::stop_recording() {
  if (source_.sensor()) source_.sensor()->stop_recording();
}

const std::string& Cia404Chain::recording() const {
  static const std::string kNone;
  return source_.sensor() ? source_.sensor()->recording() : kNone;
}

}  // namespace cansim::personalities
