// The typical sensor node of the physics benchmarks (physics_bench,
// plant_bench): a P92C-like chain on a setpoint response with pump
// pulsation, its temperature from a gas volume cooling towards ambient.
#pragma once

#include <cstdint>

#include "physics/random.hpp"
#include "physics/sensor.hpp"
#include "physics/units.hpp"

namespace cansim::bench {

using namespace cansim::physics;

// A typical process: setpoint response (looped steps) + pump pulsation + OU drift;
// temperature from a closed gas volume cooling towards ambient.
inline ProcessSpec typical_process() {
  ProcessSpec ps;
  SecondOrderSpec so;
  so.setpoint.points = {{0, 2e5}, {5, 8e5}, {12, 4e5}, {20, 2e5}};
  so.setpoint.interpolation = Interpolation::Hold;
  so.setpoint.loop = true;
  so.setpoint.period_s = 30;
  so.natural_frequency_hz = 0.8;
  so.damping = 0.3;
  ps.pressure = {so, PulsationSpec::piston_pump(1450, 3, 5000, 3), OrnsteinUhlenbeckSpec{0, 20, 2000}};
  GasVolumeSpec g;
  g.initial_temperature_k = 320;
  g.ambient_k.points = {{0, 293.15}};
  g.time_constant_s = 600;
  add_gas_volume(ps, g);
  ps.pressure.pop_back();  // keep the pressure from the setpoint response
  return ps;
}

// A P92C-like chain: 0..25 bar, 1 kHz, ADC 0..30000, moving average 30, noise, errors,
// temperature channel -40..125 degC with its own moving average.
inline SensorSpec typical_sensor() {
  SensorSpec s;
  auto& p = s.pressure;
  p.range_min = 0;
  p.range_max = 25e5;
  p.sample_rate_hz = 1000;
  p.adc = AdcSpec::int16_field(30000);
  p.noise_rms = 0.0003 * 25e5;
  p.errors.nonlinearity = 0.001 * 25e5;
  p.errors.hysteresis = 0.0005 * 25e5;
  p.errors.total_error_band = 0.01 * 25e5;
  p.response_time_constant_s = 0.002;
  p.filter = {FilterType::MovingAverage, 30};
  p.overload.safe_max = 100e5;
  auto& t = s.temperature;
  t.range_min = to_kelvin(-40, TemperatureUnit::degC);
  t.range_max = to_kelvin(125, TemperatureUnit::degC);
  t.sample_rate_hz = 1000;
  t.adc = AdcSpec::int16_field(30000);
  t.noise_rms = 0.05;
  t.filter = {FilterType::MovingAverage, 10};
  return s;
}

inline Sensor make_sensor(std::uint64_t node, const ProcessSpec& process = typical_process(),
                          const PlantResolver* plants = nullptr) {
  const std::uint64_t seed = derive_seed(0xF1EE7, node);
  return Sensor(typical_sensor(), ProcessModel(process, derive_seed(seed, 1), plants, 10'000), derive_seed(seed, 2));
}

}  // namespace cansim::bench
