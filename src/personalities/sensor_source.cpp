#include "personalities/sensor_source.hpp"

#include <algorithm>
#include <cmath>

#include "physics/plant.hpp"
#include "physics/random.hpp"

namespace cansim::personalities {

SensorSource::SensorSource(const physics::SensorSpec& sensor, const physics::ProcessSpec& process,
                           std::span<const physics::FaultSpec> faults, std::uint64_t node_seed,
                           const physics::PlantResolver* plants)
    : faults_(std::make_unique<physics::FaultSet>(faults.size() + 4)),
      process_seed_(physics::derive_seed(node_seed, physics::hash_string("process"))),
      plants_(plants),
      sensor_(sensor, physics::ProcessModel(process, process_seed_, plants, physics::lookback_us(sensor)),
              physics::derive_seed(node_seed, physics::hash_string("sensor")), faults_.get()) {
  faults_->set_seed(physics::derive_seed(node_seed, physics::hash_string("faults")));
  for (const physics::FaultSpec& f : faults) faults_->add(f, 0);
}

void SensorSource::set_process(physics::Channel ch, const std::vector<physics::TermSpec>& terms, TimeUs now) {
  catch_up(now);
  // Seeded by the time as well: two models set at different times draw different noise.
  sensor_.process().set_channel(ch, terms, physics::derive_seed(process_seed_, std::uint64_t(now)),
                                physics::us_to_seconds(now), plants_, physics::lookback_us(sensor_.spec()));
}

void SensorSource::restore_process(physics::Channel ch, TimeUs now) {
  catch_up(now);
  sensor_.process().restore_channel(ch);
}

double SensorSource::true_value(physics::Channel ch, TimeUs now) {
  catch_up(now);  // stochastic terms at the latest sample
  const physics::Quantity q = sensor_.process().peek(physics::us_to_seconds(now));
  return ch == physics::Channel::Pressure ? q.pressure_pa : q.temperature_k;
}

bool SensorSource::record_to(const std::string& path, std::string* error) {
  auto rec = std::make_unique<physics::CsvRecorder>();
  if (!rec->open(path, error, physics::CsvRecorder::kDefaultBuffer, state_dir_)) return false;
  recorder_ = std::move(rec);
  recording_ = path;
  recorded_at_ = -1;
  return true;
}

void SensorSource::stop_recording() {
  recorder_.reset();  // the destructor flushes and closes
  recording_.clear();
}

SensorSource::SensorSource(const SensorSource& other)
    : faults_(std::make_unique<physics::FaultSet>(*other.faults_)),
      process_seed_(other.process_seed_),
      plants_(other.plants_),
      sensor_(other.sensor_) {
  sensor_.set_faults(faults_.get());
}

std::unique_ptr<MeasurementSource> SensorSource::snapshot() const {
  return std::unique_ptr<MeasurementSource>(new SensorSource(*this));
}

void SensorSource::restore(const MeasurementSource& snapshot) {
  const auto& from = dynamic_cast<const SensorSource&>(snapshot);
  *faults_ = *from.faults_;
  sensor_ = from.sensor_;
  sensor_.set_faults(faults_.get());
}

MeasurementSource::Sample SensorSource::sample(physics::Channel ch, TimeUs now) {
  const physics::SensorReading& r = sensor_.read(now);
  if (recorder_ && now != recorded_at_) {
    recorder_->record(now, r);
    recorded_at_ = now;
  }
  const physics::ChannelReading& c = ch == physics::Channel::Pressure ? r.pressure : r.temperature;
  return {c.value, c.adc_counts, c.status};
}

TimeUs SensorSource::sample_period_us(physics::Channel ch) const {
  const physics::ChannelSpec& c =
      ch == physics::Channel::Pressure ? sensor_.spec().pressure : sensor_.spec().temperature;
  return std::max<TimeUs>(1, TimeUs(std::llround(1e6 / c.sample_rate_hz)));
}

}  // namespace cansim::personalities
