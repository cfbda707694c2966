// The CiA 404 chain's runtime control hooks (docs/control-api.md): process
// model changes, reported-value overrides, channel views and recording.
#include "personalities/cia404.hpp"

namespace cansim::personalities {

void Cia404Application::control_changed(Node& node, TimeUs now) {
  invalidate();
  node.wake_app(now);
}

std::optional<std::size_t> Cia404Application::chain_channel(physics::Channel ch) const {
  for (std::size_t i = 0; i < profile_->channels.size(); ++i)
    if (profile_->channels[i].source == ch) return i;
  return std::nullopt;
}

bool Cia404Application::set_process(Node& node, physics::Channel ch, const std::vector<physics::TermSpec>& terms,
                                    TimeUs now) {
  if (!sensor_) return false;
  sensor_->set_process(ch, terms, now);
  control_changed(node, now);
  return true;
}

bool Cia404Application::restore_process(Node& node, physics::Channel ch, TimeUs now) {
  if (!sensor_) return false;
  sensor_->restore_process(ch, now);
  control_changed(node, now);
  return true;
}

bool Cia404Application::hold(Node& node, physics::Channel ch, TimeUs now) {
  return step(node, ch, true_value_si(ch, now), now);
}

bool Cia404Application::step(Node& node, physics::Channel ch, double si, TimeUs now) {
  return set_process(node, ch, physics::constant_terms(si), now);
}

bool Cia404Application::ramp(Node& node, physics::Channel ch, double si, double seconds, TimeUs now) {
  return set_process(node, ch, physics::ramp_terms(true_value_si(ch, now), si, 0.0, seconds), now);
}

double Cia404Application::true_value_si(physics::Channel ch, TimeUs now) {
  return sensor_ ? sensor_->true_value(ch, now) : std::numeric_limits<double>::quiet_NaN();
}

Cia404Application::ChannelView Cia404Application::view(Node& node, physics::Channel ch, TimeUs now) {
  ChannelView v;
  const std::optional<std::size_t> c = chain_channel(ch);
  if (!c) return v;
  const Measurement m = measure(node, *c, now);
  v.true_value = unit(*c).from_si(true_value_si(ch, now));
  v.reported = m.pv;
  v.unit = unit(*c).name;
  v.status = m.status;
  return v;
}

void Cia404Application::set_override(Node& node, physics::Channel ch, std::optional<double> si, TimeUs now) {
  override_si_[std::size_t(ch)] = si;
  control_changed(node, now);
}

std::vector<Cia404Application::OverrideView> Cia404Application::overrides() const {
  std::vector<OverrideView> out;
  for (physics::Channel ch : {physics::Channel::Pressure, physics::Channel::Temperature}) {
    const std::optional<double>& si = override_si_[std::size_t(ch)];
    const std::optional<std::size_t> c = chain_channel(ch);
    if (si && c) out.push_back({ch, unit(*c).from_si(*si), unit(*c).name});
  }
  return out;
}

bool Cia404Application::start_recording(const std::string& path, std::string* error) {
  if (sensor_) return sensor_->record_to(path, error);
  if (error) *error = "the node has no sensor to record";
  return false;
}

void Cia404Application::stop_recording() {
  if (sensor_) sensor_->stop_recording();
}

const std::string& Cia404Application::recording() const {
  static const std::string kNone;
  return sensor_ ? sensor_->recording() : kNone;
}

}  // namespace cansim::personalities
