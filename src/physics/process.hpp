// The process ("the truth"): pressure and temperature as functions of simulated time.
//
// A ProcessSpec holds two lists of additive terms, one per channel:
//   pressure(t)    = sum of pressure terms    [Pa, absolute or gauge as the profile decides]
//   temperature(t) = sum of temperature terms [K]
// Temperature is evaluated first; a GasLawSpec pressure term may use it.
//
// All deterministic terms are pure functions of t. Stochastic terms (random walk,
// Ornstein-Uhlenbeck) are stateful: they advance from the last query time to the new
// one with an exact discretisation (exact AR(1) for OU, any dt) and draw their normal
// deviates from a counter-based generator seeded from (model seed, channel, term index),
// so the same seed and the same query times give the identical series. A query earlier
// than the last one returns the last value (they never run backwards).
//
// Values in the specs are SI (Pa, K, s, Hz); the config layer converts YAML units with
// physics/units.hpp (note: temperature *amplitudes / rates* use delta_to_kelvin).
//
// At run time a channel's terms can be replaced (set_channel, the control API's Step /
// Ramp / SetModel): the new terms run on their own time axis starting when they were set,
// and restore_channel brings the constructed terms back (their state kept meanwhile).
#pragma once

#include <cstdint>
#include <limits>
#include <optional>
#include <string>
#include <variant>
#include <vector>

#include "physics/channel.hpp"
#include "physics/table.hpp"

namespace cansim::physics {

struct Quantity {
  double pressure_pa = 0.0;
  double temperature_k = 0.0;
};

inline constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();

// value(t) = value
struct ConstantSpec {
  double value = 0.0;
};

// value(t) = from + (to - from) * clamp((t - start_s) / duration_s, 0, 1)
// (duration_s == 0: a step from `from` to `to` at start_s)
struct RampSpec {
  double from = 0.0;
  double to = 0.0;
  double start_s = 0.0;
  double duration_s = 0.0;
};

// value(t) = table(t); see TableSpec (inline points or a CSV loaded via load_table_csv).
struct TableTermSpec {
  TableSpec table;
};

// value(t) = amplitude * sin(2 pi frequency_hz t + phase_rad)   (zero mean; add a ConstantSpec)
struct SineSpec {
  double amplitude = 0.0;
  double frequency_hz = 1.0;
  double phase_rad = 0.0;
};

// Square / pulse train (trapezoid with optional edges). Before delay_s: low.
// Each period starts with the rising edge (rise_s, linear), stays high until
// duty * period_s after the period start, then falls (fall_s, linear) to low.
// Square wave: duty 0.5, rise_s = fall_s = 0.
struct PulseSpec {
  double low = 0.0;
  double high = 1.0;
  double period_s = 1.0;
  double duty = 0.5;     // fraction of the period from rise start to fall start, (0, 1)
  double delay_s = 0.0;  // time of the first rising edge
  double rise_s = 0.0;
  double fall_s = 0.0;
};

// One harmonic of a pump pulsation: amplitude * sin(2 pi * order * shaft_hz * t + phase_rad).
struct Harmonic {
  double order = 1.0;  // multiple of the shaft frequency (e.g. pistons = 3 -> 3, 6, 9 ...)
  double amplitude = 0.0;
  double phase_rad = 0.0;
};

// Pump pulsation: sum of harmonics of the shaft speed (zero mean).
struct PulsationSpec {
  double shaft_hz = 25.0;  // shaft speed in revolutions per second (rpm / 60)
  std::vector<Harmonic> harmonics;

  // Typical piston pump: harmonics at k * pistons * shaft, amplitude / k for k = 1..n.
  static PulsationSpec piston_pump(double rpm, int pistons, double amplitude, int n_harmonics = 3);
};

// Response of a first-order lag to a setpoint signal (table; hold = steps, linear = ramps):
//   time_constant_s * dy/dt + y = setpoint(t)
// The system is at rest at the table's first value; if `initial` is not NaN, y(0) = initial
// and it relaxes towards the setpoint (e.g. Newton heating / cooling).
struct FirstOrderSpec {
  TableSpec setpoint;
  double time_constant_s = 1.0;
  double initial = kNaN;
};

// Response of a second-order system to a setpoint signal:
//   y'' + 2 zeta w y' + w^2 y = w^2 setpoint(t),   w = 2 pi natural_frequency_hz
// damping < 1 overshoots and rings, = 1 critically damped, > 1 overdamped. Must be > 0.
// `initial` as for FirstOrderSpec (released from rest at y(0) = initial).
struct SecondOrderSpec {
  TableSpec setpoint;
  double natural_frequency_hz = 1.0;
  double damping = 0.5;
  double initial = kNaN;
};

// Random walk (Wiener process with drift), starting at `initial` at t = 0:
//   x(t+dt) = x(t) + drift_per_s dt + sigma_per_sqrt_s sqrt(dt) N(0,1),  clamped to [min, max].
struct RandomWalkSpec {
  double initial = 0.0;
  double sigma_per_sqrt_s = 0.0;
  double drift_per_s = 0.0;
  double min = -std::numeric_limits<double>::infinity();
  double max = std::numeric_limits<double>::infinity();
};

// Ornstein-Uhlenbeck drift around `mean` with correlation time tau_s and stationary
// standard deviation `sigma` (exact AR(1) update for any dt):
//   x(t+dt) = mean + (x - mean) e^{-dt/tau} + sigma sqrt(1 - e^{-2 dt/tau}) N(0,1)
// initial: NaN = start at mean.
struct OrnsteinUhlenbeckSpec {
  double mean = 0.0;
  double tau_s = 60.0;
  double sigma = 0.0;
  double initial = kNaN;
};

// The value of a plant variable (physics/plant.hpp, docs/plants.md): a sensor
// on a plant reads what the plant is at each of its samples. Resolved when
// the model is built (ProcessModel's PlantResolver); `origin` is the loader's
// location of the term for errors.
struct PlantTermSpec {
  std::string ref;  // "PLANT.VARIABLE", e.g. "vessel.pressure"
  std::string origin;
};

// What a resolved plant term reads: value(context, var, t) at absolute
// simulated time t (µs). Its context outlives the model.
struct PlantTap {
  double (*value)(void* context, std::uint32_t var, std::int64_t t_us) = nullptr;
  void* context = nullptr;
  std::uint32_t var = 0;
};

// Pressure term of a closed gas volume (isochoric ideal gas, p/T constant):
//   p(t) = reference_pressure_pa * T(t) / reference_temperature_k
// where T(t) is the *total* temperature channel of the same model. Pressure channel only.
struct GasLawSpec {
  double reference_pressure_pa = 1.0e5;
  double reference_temperature_k = 293.15;
};

using TermSpec = std::variant<ConstantSpec, RampSpec, TableTermSpec, SineSpec, PulseSpec, PulsationSpec, FirstOrderSpec,
                              SecondOrderSpec, RandomWalkSpec, OrnsteinUhlenbeckSpec, GasLawSpec, PlantTermSpec>;

struct ProcessSpec {
  std::vector<TermSpec> pressure;     // additive terms, Pa
  std::vector<TermSpec> temperature;  // additive terms, K
};

// Term lists for the control verbs. Times are on the terms' own axis (0 = start_s of
// ProcessModel::set_channel). Hold / step: constant_terms(value).
std::vector<TermSpec> constant_terms(double value);
// Linear from `from` to `to` between start_s and start_s + duration_s, then `to`.
std::vector<TermSpec> ramp_terms(double from, double to, double start_s, double duration_s);

// Closed gas volume exchanging heat with an ambient (Newton's law, time constant tau):
//   T' = (T_ambient(t) - T) / tau,  T(0) = initial_temperature_k,  p = p0 * T / T(0).
struct GasVolumeSpec {
  double initial_pressure_pa = 1.0e5;     // p at t = 0
  double initial_temperature_k = 293.15;  // gas temperature at t = 0
  TableSpec ambient_k;                    // ambient temperature (constant: one point)
  double time_constant_s = 600.0;         // thermal time constant
};
// Appends the gas-volume terms (FirstOrder temperature + GasLaw pressure) to `spec`.
void add_gas_volume(ProcessSpec& spec, const GasVolumeSpec& gas);

// Returns "" if valid, else a human-readable reason ("pressure[2]: ...").
std::string validate(const ProcessSpec& spec);
// The same for the terms of one channel.
std::string validate(Channel channel, const std::vector<TermSpec>& terms);

class PlantResolver;  // physics/plant.hpp

// Evaluates a ProcessSpec. Construction compiles the spec (allocates); at() does not.
class ProcessModel {
 public:
  ProcessModel();  // 1 bar, 20 degC constant
  // Throws std::invalid_argument if validate(spec) fails, or when a plant
  // term does not resolve (`plants` null: the spec may have none). The
  // plants are read up to `lookback_us` in the past (the sensor's catch-up).
  ProcessModel(const ProcessSpec& spec, std::uint64_t seed, const PlantResolver* plants = nullptr,
               std::int64_t lookback_us = 0);
  ProcessModel(ProcessModel&&) noexcept;
  ProcessModel& operator=(ProcessModel&&) noexcept;
  ProcessModel(const ProcessModel&);
  ProcessModel& operator=(const ProcessModel&);
  ~ProcessModel();

  // Pressure and temperature at simulated time t (seconds). Not const: stochastic terms advance.
  Quantity at(double t_s);
  // Same, with the project's microsecond time base.
  Quantity at_us(std::int64_t t_us) { return at(double(t_us) * 1e-6); }
  // at() for an observer: stochastic terms are not advanced (they give their latest
  // value), so looking does not change the series the sensor samples.
  Quantity peek(double t_s) const;

  // Replaces one channel's terms; their time 0 is start_s (simulated seconds: the
  // time they are set at). Compiles (allocates). Throws std::invalid_argument, changing nothing,
  // when validate(channel, terms) fails. Stochastic terms are seeded from `seed` as
  // the constructor does. A temperature change reaches GasLaw pressure terms.
  void set_channel(Channel channel, const std::vector<TermSpec>& terms, std::uint64_t seed, double start_s = 0.0,
                   const PlantResolver* plants = nullptr, std::int64_t lookback_us = 0);
  // Back to the constructed terms (no-op when the channel was never replaced).
  void restore_channel(Channel channel);

  // Restart stochastic terms (same seed -> same series again).
  void reset();

  bool has_stochastic_terms() const;
  // Some term of a channel reads a plant.
  bool reads_plant() const;

  // Where a channel's value can be when the model is next evaluated `queries`
  // times (or fewer), each at a time in [t0_s, t1_s] (t1_s may be infinite):
  // deterministic terms over that span, stochastic ones from their latest
  // state (a normal deviate is at most kNormalBound). False, leaving lo / hi
  // as they are, when a term has no such bound (second-order responses, an
  // unclamped random walk over an infinite span).
  bool bounds(Channel channel, double t0_s, double t1_s, int queries, double& lo, double& hi) const;

  struct Term;  // compiled term (implementation detail)

 private:
  struct Terms {
    std::vector<Term> terms;
    double start_s = 0.0;  // the terms' time 0
  };
  Terms& terms(Channel c) { return channels_[std::size_t(c)]; }
  const Terms& terms(Channel c) const { return channels_[std::size_t(c)]; }

  Terms channels_[2];                    // [Pressure], [Temperature]
  std::optional<Terms> constructed_[2];  // set while the channel is replaced
};

// One list of additive terms as a function of time, on its own (a plant's
// time input: docs/plants.md). The terms of a channel but gas_law and plant
// terms. Construction compiles (allocates); at() does not.
class TermSeries {
 public:
  TermSeries();
  // Throws std::invalid_argument for an invalid or unsupported term.
  TermSeries(const std::vector<TermSpec>& terms, std::uint64_t seed);
  TermSeries(TermSeries&&) noexcept;
  TermSeries& operator=(TermSeries&&) noexcept;
  ~TermSeries();
  // The sum at t (seconds). Stochastic terms advance (never backwards).
  double at(double t_s);
  // True when no term changes after t (a constant, a ramp or table at its end).
  bool constant_after(double t_s) const;

 private:
  std::vector<ProcessModel::Term> terms_;
};

// Closed forms used by the response terms (exposed for tests).
namespace response {
// Free response 1 - S(tau) of a unit step for a first-order lag.
double first_order_free(double tau, double time_constant);
// Integral of the free response from 0 to tau (ramp-following error build-up).
double first_order_integral(double tau, double time_constant);
// Same for the second-order system (w in rad/s, zeta > 0).
double second_order_free(double tau, double w, double zeta);
double second_order_integral(double tau, double w, double zeta);
}  // namespace response

}  // namespace cansim::physics
