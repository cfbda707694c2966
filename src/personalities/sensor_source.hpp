// Where the CiA 404 chain's values come from: a MeasurementSource. The
// node's physics is a SensorSource (physics::Sensor with its process model
// and fault schedule, and an optional CSV recording of what it sampled);
// tests give the chain fakes.
#pragma once

#include <cstdint>
#include <memory>
#include <span>
#include <string>
#include <vector>

#include "core/can_frame.hpp"
#include "physics/fault.hpp"
#include "physics/recorder.hpp"
#include "physics/sensor.hpp"

namespace cansim::personalities {

// Where a channel's values come from. The default wraps a physics::Sensor.
class MeasurementSource {
 public:
  struct Sample {
    double si = 0.0;          // Pa / K
    std::int32_t raw = 0;     // ADC counts
    std::uint8_t status = 0;  // physics kStatus* bits
  };
  virtual ~MeasurementSource() = default;
  // Must return the same sample for the same `now`: the chain evaluates a
  // channel once per instant and reuses it.
  virtual Sample sample(physics::Channel ch, TimeUs now) = 0;
  virtual void set_filter(physics::Channel, const physics::FilterSpec&) {}
  virtual TimeUs sample_period_us(physics::Channel) const { return 1000; }
  // What the channel's next sample gives if taken before `until`, while
  // nothing else samples it (physics::Sensor::steadiness). Default: nothing
  // is sure (until = now).
  virtual physics::Steadiness steady(physics::Channel, TimeUs now) const { return {now, 0.0, 0.0, 0}; }
  virtual void reboot(TimeUs) {}
  // The node's fault schedule (null: this source has none).
  virtual physics::FaultSet* fault_set() { return nullptr; }
  // A copy of this source's state for a chain's copy (SourceSlot; null:
  // this source has none) and the way back to it.
  virtual std::unique_ptr<MeasurementSource> snapshot() const { return nullptr; }
  virtual void restore(const MeasurementSource&) {}
};

// The physics::Sensor of one node with its scheduled faults.
class SensorSource : public MeasurementSource {
 public:
  // `plants` resolves the process's plant terms (null: it has none); it
  // outlives the source.
  SensorSource(const physics::SensorSpec& sensor, const physics::ProcessSpec& process,
               std::span<const physics::FaultSpec> faults, std::uint64_t node_seed,
               const physics::PlantResolver* plants = nullptr);
  Sample sample(physics::Channel ch, TimeUs now) override;
  void set_filter(physics::Channel ch, const physics::FilterSpec& f) override { sensor_.set_filter(ch, f); }
  TimeUs sample_period_us(physics::Channel ch) const override;
  // Nothing is sure while a recording runs: it wants a row at each check.
  physics::Steadiness steady(physics::Channel ch, TimeUs now) const override {
    return recorder_ ? physics::Steadiness{now, 0.0, 0.0, 0} : sensor_.steadiness(ch, now);
  }
  void reboot(TimeUs now) override { sensor_.reboot(now); }
  physics::FaultSet* fault_set() override { return faults_.get(); }
  // The sensor with its process model and the fault schedule; a recording is
  // output, not state: a snapshot has none and a restore leaves it running.
  std::unique_ptr<MeasurementSource> snapshot() const override;
  void restore(const MeasurementSource& snapshot) override;
  physics::Sensor& sensor() { return sensor_; }
  physics::FaultSet& faults() { return *faults_; }

  // ---- the process model at run time. The sensor first catches up to `now`
  // with the old model, so what it sampled before `now` stays (its filters
  // then follow the new truth). set_process: the terms' time 0 is `now`;
  // throws std::invalid_argument, changing nothing, on invalid terms.
  void set_process(physics::Channel ch, const std::vector<physics::TermSpec>& terms, TimeUs now);
  void restore_process(physics::Channel ch, TimeUs now);  // back to the profile's model
  // The process model's value (Pa / K) at `now`.
  double true_value(physics::Channel ch, TimeUs now);

  // Records one CSV row (physics::CsvRecorder) per instant the node reads its
  // sensor, replacing a running recording. Returns false with *error (the
  // running recording kept) when the file cannot be created, is not a
  // regular file or lies in the state folder.
  bool record_to(const std::string& path, std::string* error);
  void set_state_dir(std::string dir) { state_dir_ = std::move(dir); }
  // Flushes and closes the recording.
  void stop_recording();
  const std::string& recording() const { return recording_; }  // its path, "" when none
  const physics::CsvRecorder* recorder() const { return recorder_.get(); }

 private:
  SensorSource(const SensorSource& other);  // for snapshot()
  void catch_up(TimeUs now) { sensor_.read(now); }

  std::unique_ptr<physics::FaultSet> faults_;  // the sensor keeps a pointer to it
  std::uint64_t process_seed_;
  const physics::PlantResolver* plants_ = nullptr;
  physics::Sensor sensor_;
  std::unique_ptr<physics::CsvRecorder> recorder_;
  std::string recording_;
  TimeUs recorded_at_ = -1;
  std::string state_dir_;  // recordings never go there
};

}  // namespace cansim::personalities
