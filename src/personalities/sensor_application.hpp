// How a personality is built, once for all of them:
//   SensorApplication            a node's CiA 404 chain and device part (plain
//                                values), the Application hooks as CiA 404
//                                has them, and the MeasurementControl the
//                                control API acts through;
//   VendorApplication<Self, S>   adds the vendor's settings S, the snapshot
//                                as a plain copy of Self and the dispatch of
//                                the vendor objects' indications: a
//                                personality declares a table of them,
//                                Self::kObjectHooks (object_hooks.hpp), and
//                                every other object is the chain's. A
//                                personality is `final` and derives from
//                                it, adding its own small state and
//                                overriding only the hooks its manual
//                                changes (calling the base for the rest);
//   make_sensor_application<App> the node of a profile: App around the
//                                profile's physics (registry.cpp).
// No state lives outside these values, so a copy of an application is a
// snapshot of it and an assignment restores one (no allocation once the
// buffers have grown).
#pragma once

#include <cstdint>
#include <memory>

#include "core/application.hpp"
#include "core/nmt.hpp"
#include "personalities/cia404.hpp"
#include "personalities/device_part.hpp"
#include "personalities/measurement_control.hpp"
#include "personalities/node_context.hpp"
#include "personalities/object_hooks.hpp"

namespace cansim::personalities {

class SensorApplication : public Application, public MeasurementControl {
 public:
  Cia404Chain& chain() { return chain_; }
  const Cia404Chain& chain() const { return chain_; }
  DevicePart& device() { return device_; }

  void on_reset(Node& node, ResetKind kind, TimeUs now) override {
    chain_.on_reset(node, kind, now);
    device_.on_reset(now);
  }
  void on_nmt_state(Node& node, NmtState, TimeUs now) override { chain_.on_nmt_state(node, now); }
  void on_pdo_config(Node& node, TimeUs now) override { chain_.on_pdo_config(node, now); }
  void refresh(Node& node, const OdEntry& e, TimeUs now) override { chain_.refresh(node, e, now); }
  SdoAbort check_write(Node& node, const OdEntry& e, std::span<const std::uint8_t> data, TimeUs now) override {
    return chain_.check_write(node, e, data, now);
  }
  void after_write(Node& node, const OdEntry& e, TimeUs now) override { chain_.after_write(node, e, now); }
  TimeUs process(Node& node, TimeUs now) override { return chain_.process(node, now); }
  TimeUs environment(Node& node, TimeUs now) override { return device_.environment(node, chain_.fault_set(), now); }

  // ---- MeasurementControl: the chain's channels and process model, the
  // device part's fault schedule (sensor_application.cpp)
  bool has_channel(physics::Channel ch) const final { return chain_.has_channel(ch); }
  ChannelView view(Node& node, physics::Channel ch, TimeUs now) final { return chain_.view(node, ch, now); }
  EntryScale entry_scale(const Node& node, const OdEntry& e) const final { return chain_.entry_scale(node, e); }
  bool set_process(Node& node, physics::Channel ch, const std::vector<physics::TermSpec>& terms, TimeUs now) final {
    return chain_.set_process(node, ch, terms, now);
  }
  bool restore_process(Node& node, physics::Channel ch, TimeUs now) final {
    return chain_.restore_process(node, ch, now);
  }
  double true_value_si(physics::Channel ch, TimeUs now) final { return chain_.true_value_si(ch, now); }
  void set_override(Node& node, physics::Channel ch, std::optional<double> si, TimeUs now) final {
    chain_.set_override(node, ch, si, now);
  }
  std::vector<OverrideView> overrides() const final { return chain_.overrides(); }
  physics::FaultHandle arm_fault(Node& node, const physics::FaultSpec& spec, TimeUs now) final;
  bool cancel_fault(Node& node, physics::FaultHandle h, TimeUs now) final;
  std::vector<physics::FaultInfo> faults(TimeUs now) const final {
    return DevicePart::armed_faults(chain_.fault_set(), now);
  }
  void set_fault_listener(FaultListener listener) final { device_.set_fault_listener(std::move(listener)); }
  bool start_recording(Node& node, const std::string& path, std::string* error, TimeUs now) final;
  void stop_recording() final { chain_.stop_recording(); }
  const std::string& recording() const final { return chain_.recording(); }

 protected:
  // node_index: the node's place in its group (DevicePart::seed_of).
  SensorApplication(std::shared_ptr<const Cia404Profile> profile, std::unique_ptr<MeasurementSource> source,
                    std::uint32_t node_index)
      : chain_(std::move(profile), std::move(source)), device_(DevicePart::seed_of(node_index)) {}
  SensorApplication(const SensorApplication&) = default;
  SensorApplication& operator=(const SensorApplication&) = default;

  Cia404Chain chain_;
  DevicePart device_;
};

template <class Self, class Settings>
class VendorApplication : public SensorApplication {
 public:
  using DeviceSettings = Settings;  // the `vendor:` keys (config/vendor_settings.cpp)

  VendorApplication(std::shared_ptr<const Cia404Profile> profile, std::unique_ptr<MeasurementSource> source,
                    const Settings& settings, std::uint32_t node_index = 0)
      : SensorApplication(std::move(profile), std::move(source), node_index), settings_(settings) {}

  // No vendor objects of its own; a personality with some hides this.
  static constexpr ObjectHooks<Self> kObjectHooks{};

  // The object's indication in Self::kObjectHooks, else the chain's.
  void refresh(Node& node, const OdEntry& e, TimeUs now) override {
    if (const Hook* h = Self::kObjectHooks.find(e.index, &Hook::read)) return (self().*h->read)(node, e, now);
    chain_.refresh(node, e, now);
  }
  SdoAbort check_write(Node& node, const OdEntry& e, std::span<const std::uint8_t> data, TimeUs now) override {
    if (const Hook* h = Self::kObjectHooks.find(e.index, &Hook::check)) return (self().*h->check)(node, e, data, now);
    return chain_.check_write(node, e, data, now);
  }
  void after_write(Node& node, const OdEntry& e, TimeUs now) override {
    if (const Hook* h = Self::kObjectHooks.find(e.index, &Hook::written)) return (self().*h->written)(node, e, now);
    chain_.after_write(node, e, now);
  }

  // A copy of the whole application (null when its source takes no snapshots).
  std::unique_ptr<Application> snapshot() const final {
    return chain_.copyable() ? std::make_unique<Self>(static_cast<const Self&>(*this)) : nullptr;
  }
  void restore(const Application& snapshot) final { static_cast<Self&>(*this) = static_cast<const Self&>(snapshot); }

 protected:
  using Hook = ObjectHook<Self>;
  Settings settings_;

 private:
  Self& self() { return static_cast<Self&>(*this); }
};

// The application of a node of `profile`: App measuring the profile's physics.
template <class App>
std::unique_ptr<Application> make_sensor_application(const model::Profile& profile,
                                                     const typename App::DeviceSettings& settings,
                                                     const NodeContext& ctx) {
  return std::make_unique<App>(profile.cia404, make_sensor_source(profile, ctx), settings, ctx.index);
}

}  // namespace cansim::personalities
