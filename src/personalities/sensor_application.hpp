// How a personality is built: a `final` Application holding a Cia404Chain,
// a DevicePart and its own small state, offering MeasurementControl. This
// base has no state: it forwards the Application hooks a device leaves as
// CiA 404 has them to the parts, so a personality overrides only what its
// manual changes (calling these for the CiA 404 part), and its snapshot is
// a plain copy of itself (snapshot_of / restore_from below).
#pragma once

#include <memory>

#include "core/application.hpp"
#include "core/nmt.hpp"
#include "personalities/measurement_control.hpp"

namespace cansim::personalities {

class SensorApplication : public Application, public MeasurementControl {
 public:
  void on_reset(Node& node, ResetKind kind, TimeUs now) override {
    chain().on_reset(node, kind, now);
    device().on_reset(now);
  }
  void on_nmt_state(Node& node, NmtState, TimeUs now) override { chain().on_nmt_state(node, now); }
  void on_pdo_config(Node& node, TimeUs now) override { chain().on_pdo_config(node, now); }
  void refresh(Node& node, const OdEntry& e, TimeUs now) override { chain().refresh(node, e, now); }
  SdoAbort check_write(Node& node, const OdEntry& e, std::span<const std::uint8_t> data, TimeUs now) override {
    return chain().check_write(node, e, data, now);
  }
  void after_write(Node& node, const OdEntry& e, TimeUs now) override { chain().after_write(node, e, now); }
  TimeUs process(Node& node, TimeUs now) override { return chain().process(node, now); }
  TimeUs environment(Node& node, TimeUs now) override { return device().environment(node, chain(), now); }

 protected:
  SensorApplication() = default;
  SensorApplication(const SensorApplication&) = default;
  SensorApplication& operator=(const SensorApplication&) = default;
};

// Application::snapshot / restore of a personality: a copy of the whole
// application (null when its source takes no snapshots), and the assignment
// back (plain copies, no allocation once the buffers have grown).
template <class App>
std::unique_ptr<Application> snapshot_of(const App& app) {
  return app.chain().copyable() ? std::make_unique<App>(app) : nullptr;
}
template <class App>
void restore_from(App& app, const Application& snapshot) {
  app = static_cast<const App&>(snapshot);
}

}  // namespace cansim::personalities
