// `cia401-analog-output` personality: the actuator stand-in of a closed loop
// (profiles/actuator-401.yaml, docs/plants.md "Closing the loop"). A simple
// CiA 401 analogue output device: the master writes the commands 0x6411:01..
// (RPDO1 or SDO, INTEGER16), each output's actual value moves towards its
// command as a first-order lag (vendor `response_time`) and is read back as
// the analogue inputs 0x6401:01.. (the position feedback a TPDO carries).
// Leaving OPERATIONAL (a master's NMT command or the 0x1029 error reaction),
// an output whose error mode 0x6443 is 1 takes its error value 0x6444 (CiA
// 401); mode 0 keeps the last command.
//
// Its outputs feed plants: position() is a pure function of time (the lag in
// closed form from the latest command), and every change of a command first
// tells the listeners (the plants that read it advance to that instant), so
// a plant reads exactly what the TPDO reports.
#pragma once

#include <array>
#include <cstdint>
#include <memory>
#include <vector>

#include "core/application.hpp"
#include "model/device_settings.hpp"
#include "personalities/catalog.hpp"
#include "personalities/node_context.hpp"

namespace cansim::personalities::analog_output {

using Settings = model::AnalogOutputSettings;

constexpr std::uint16_t kOutputObject = 0x6411;      // Write analogue output 16-bit (CiA 401)
constexpr std::uint16_t kFeedbackObject = 0x6401;    // Read analogue input 16-bit: the actual value
constexpr std::uint16_t kErrorModeObject = 0x6443;   // Analogue output error mode (1: error value)
constexpr std::uint16_t kErrorValueObject = 0x6444;  // Analogue output error value (INTEGER32)

class AnalogOutputApplication final : public Application {
 public:
  explicit AnalogOutputApplication(const Settings& settings);

  void on_reset(Node& node, ResetKind kind, TimeUs now) override;
  void on_nmt_state(Node& node, NmtState state, TimeUs now) override;
  void refresh(Node& node, const OdEntry& e, TimeUs now) override;
  void after_write(Node& node, const OdEntry& e, TimeUs now) override;
  std::unique_ptr<Application> snapshot() const override;
  void restore(const Application& snapshot) override;

  // ---- what plants read
  unsigned channels() const { return settings_.channels; }
  // Output `ch` (0-based) at t, in command units: target + (from - target)
  // e^(-(t - t0) / response time) since the latest command at t0.
  double position(unsigned ch, TimeUs t) const;
  // Called at t before a command changes (a write, a reset, the error
  // value), so a reader of position() first advances to t.
  using ChangeListener = void (*)(void* context, TimeUs t);
  void add_listener(ChangeListener listener, void* context);
  void clear_listeners() { listeners_.clear(); }

 private:
  struct Output {
    TimeUs t0 = 0;
    double from = 0, target = 0;
  };
  void command(unsigned ch, double target, TimeUs now);
  void notify(TimeUs now) const;
  int channel_of(const OdEntry& e, std::uint16_t index) const;

  Settings settings_;
  std::array<Output, Settings::kMaxChannels> outputs_{};
  std::vector<std::pair<ChangeListener, void*>> listeners_;
};

// The objects the behaviour needs (personalities/catalog.hpp).
Requirements requirements();

std::unique_ptr<Application> make(const model::Profile& profile, const Settings& settings, const NodeContext& ctx);

}  // namespace cansim::personalities::analog_output
