// The sensor: the measurement chain of one device, fed by a ProcessModel.
//
// Per channel (pressure, temperature), for every sample n at the channel's sample rate
// (sample n is taken at boot + n / sample_rate_hz):
//
//   truth x  (process; temperature + over-temperature fault for the temperature channel)
//     -> damage check (truth beyond overload_safe_min/max latches "damaged")
//     -> static + thermal errors: x + zero(T) + (x - range_min) * span_err(T) + bow(x)
//     -> hysteresis (backlash of full width `hysteresis`)
//     -> response lag (first order, response_time_constant_s)
//     -> drift fault, gaussian noise (+ noise burst), spikes
//     -> ADC: linear map of the range to codes, round, saturate   (open/short: rails)
//     -> device filter on the integer codes: none / moving average / repeating average /
//        first order (CiA 404 0x61A0/0x61A1, CMP filter times, Gems 0x2030)
//     -> optional output quantisation (output_steps per span, e.g. CMP 13 bit = 8192)
//     -> physical value; stuck fault; status (invalid / overload) and overload counters
//
// Lazy evaluation: read(t) processes only the samples since the previous read, and at
// most the samples that can still influence the output (the filter window, or the settling
// time of a first-order lag/filter). Noise and spikes are counter-based functions of
// (seed, sample index), so skipped-then-recomputed samples are bit-identical to a device
// that sampled every period: a moving average read at arbitrary times equals the brute-
// force per-sample result exactly (integer codes, exact integer sums).
// Overload counters, damage, hysteresis and the sample hook only see the processed samples
// (set catch_up_samples to widen the window if every excursion between sparse reads must be
// counted; reads every few ms, as PDO/SDO traffic does, process every sample anyway).
//
// read() never allocates.
#pragma once

#include <cmath>
#include <cstdint>
#include <limits>
#include <memory>
#include <string>
#include <vector>

#include "physics/fault.hpp"
#include "physics/process.hpp"
#include "physics/time.hpp"

namespace cansim::physics {

// CiA 404 0x6150 status bits.
inline constexpr std::uint8_t kStatusInvalid = 0x01;
inline constexpr std::uint8_t kStatusPositiveOverload = 0x02;
inline constexpr std::uint8_t kStatusNegativeOverload = 0x04;

// Additional diagnostic flags (not CiA bits).
inline constexpr std::uint8_t kFlagDamaged = 0x01;       // overload-safe limit exceeded (latched)
inline constexpr std::uint8_t kFlagAdcSaturated = 0x02;  // latest raw code hit code_min/code_max
inline constexpr std::uint8_t kFlagStuck = 0x04;         // stuck fault active
inline constexpr std::uint8_t kFlagFault = 0x08;         // any measurement fault active
inline constexpr std::uint8_t kFlagOpen = 0x10;          // open-circuit fault
inline constexpr std::uint8_t kFlagShort = 0x20;         // short-circuit fault
inline constexpr std::uint8_t kFlagDisabled = 0x40;      // channel disabled (value = truth)

enum class FilterType : std::uint8_t {
  None,              // latest sample
  MovingAverage,     // mean of the last `length` samples, updated every sample
  RepeatingAverage,  // mean of consecutive blocks of `length` samples, updated once per block
  FirstOrder,        // y += (x - y) * (1 - exp(-1 / (time_constant_s * rate)))
};

struct FilterSpec {
  FilterType type = FilterType::None;
  // Window / block length in samples (CiA 404 0x61A1; CMP: filter time / sample period). >= 1.
  std::uint32_t length = 1;
  // FirstOrder only: time constant in seconds (> 0).
  double time_constant_s = 0.0;

  // Window given as a time (CMP 0x61A1: filter time in ms, temperature in 0.1 s):
  // length = max(1, round(window_s * sample_rate_hz)).
  static FilterSpec from_time(FilterType type, double window_s, double sample_rate_hz) {
    FilterSpec f;
    f.type = type;
    const double n = std::round(window_s * sample_rate_hz);
    f.length = n < 1.0 ? 1u : (n > 4294967295.0 ? 4294967295u : std::uint32_t(n));
    if (type == FilterType::FirstOrder) f.time_constant_s = window_s;
    return f;
  }
};

// Linear ADC: range_min -> code_at_range_min, range_max -> code_at_range_max (codes may be
// fractional, e.g. to give headroom), round half away from zero, saturate to [code_min, code_max].
// The codes are the device's raw value (e.g. CiA 404 0x7100 field value).
struct AdcSpec {
  double code_at_range_min = 0.0;
  double code_at_range_max = 16777215.0;  // default: 24-bit, effectively ideal
  std::int32_t code_min = -(1 << 30);
  std::int32_t code_max = 1 << 30;

  // `bits`-bit unsigned ADC with codes 0 .. 2^bits - 1 covering the range extended by
  // `headroom` (fraction of span) on both sides, saturating at 0 and 2^bits - 1.
  static AdcSpec unsigned_bits(unsigned bits, double headroom = 0.0);
  // Field-value style: range -> [0, full_scale_code] (e.g. 20000, 30000), saturating at the
  // INTEGER16 limits (-32768 .. 32767).
  static AdcSpec int16_field(double full_scale_code);
};

// Static, thermal, non-linearity and hysteresis errors (all SI: Pa or K of the channel).
struct ErrorSpec {
  double zero_offset = 0.0;         // zero error at the reference temperature
  double span_error = 0.0;          // relative gain error (0.001 = +0.1 % of reading above range_min)
  double nonlinearity = 0.0;        // peak bow at mid-span (signed), zero at both range ends
  double hysteresis = 0.0;          // full width of the hysteresis loop (error in +-hysteresis/2)
  double thermal_zero_per_k = 0.0;  // zero shift per K away from the reference temperature
  double thermal_span_per_k = 0.0;  // relative span change per K away from the reference
  double reference_temperature_k = 298.15;
  // Total error band (SI, e.g. 0.02 * span for +-2 %FS). If > 0, the four static terms above
  // (zero_offset, span_error, thermal_zero_per_k, thermal_span_per_k) are REPLACED by values
  // drawn from the sensor seed such that, over [compensated_min_k, compensated_max_k] and the
  // whole span, |zero + span + thermal errors| + |nonlinearity| + hysteresis/2 + 3 noise_rms
  // + half an output step stays within the band.
  double total_error_band = 0.0;
  double compensated_min_k = 233.15;  // -40 degC
  double compensated_max_k = 358.15;  // +85 degC
};

enum class OverloadSource : std::uint8_t {
  Raw,       // unfiltered ADC value (e.g. SMC: FV > 20000)
  Filtered,  // the reported (filtered) value (e.g. P92C, Gems)
};

struct OverloadSpec {
  OverloadSource source = OverloadSource::Filtered;
  double margin = 0.0;      // SI: positive overload above range_max + margin, negative below range_min - margin
  double hysteresis = 0.0;  // SI: leave the overload state only when back inside by this amount
  // Truth beyond these limits damages the sensor (latched until Sensor::replace()).
  double safe_max = std::numeric_limits<double>::infinity();
  double safe_min = -std::numeric_limits<double>::infinity();
};

enum class InvalidOutput : std::uint8_t {
  HoldLastValid,  // while invalid, value = last valid value (P92C / SMC behaviour)
  PassThrough,    // while invalid, value = what the chain produces (rails for open/short)
};

struct ChannelSpec {
  bool enabled = true;           // false: no chain, value = truth, status 0 (e.g. DPS temperature)
  double range_min = 0.0;        // span start, SI (Pa / K)
  double range_max = 1.0e6;      // span end, SI (Pa / K)
  double sample_rate_hz = 1000;  // device sampling rate (P92C, SMC, CMP: 1000; Gems: 100)
  AdcSpec adc;
  std::uint32_t output_steps = 0;  // output quantisation steps per span (0 = none; CMP 13 bit: 8192)
  double noise_rms = 0.0;          // white gaussian noise per sample, SI
  ErrorSpec errors;
  double response_time_constant_s = 0.0;  // sensing element first-order lag (0 = none)
  FilterSpec filter;
  OverloadSpec overload;
  InvalidOutput invalid_output = InvalidOutput::HoldLastValid;
  // Minimum number of samples processed per read (0 = only what the filter/lag needs).
  std::uint32_t catch_up_samples = 0;
  // Ring capacity reserved for runtime filter changes (0 = filter.length).
  std::uint32_t filter_capacity = 0;
};

struct SensorSpec {
  ChannelSpec pressure;     // range in Pa
  ChannelSpec temperature;  // range in K
};

// Returns "" if valid, else the reason ("pressure: ...").
std::string validate(const SensorSpec& spec);

// How far back a read may process samples (the filter window, a lag's
// settling time, catch_up_samples), at least 1 s: what a plant the sensor
// reads keeps as history for it.
TimeUs lookback_us(const SensorSpec& spec);

struct ChannelReading {
  double value = 0.0;              // reported value, SI (Pa / K)
  double fraction = 0.0;           // (value - range_min) / span: 0..1 inside the span
  double truth = 0.0;              // process value at the latest sample, SI
  std::int32_t adc_counts = 0;     // raw code of the latest sample (unfiltered)
  std::uint8_t status = 0;         // kStatus* bits (CiA 404 0x6150)
  std::uint8_t flags = 0;          // kFlag* bits
  std::int64_t sample_index = -1;  // index of the latest sample since boot (-1: none yet)
  TimeUs sample_time_us = 0;       // time of the latest sample

  bool valid() const { return (status & kStatusInvalid) == 0; }
};

struct SensorReading {
  ChannelReading pressure;
  ChannelReading temperature;
};

struct OverloadCounters {
  std::uint32_t positive = 0;  // rising edges into positive overload (saturating)
  std::uint32_t negative = 0;  // rising edges into negative overload (saturating)
};

// What a channel reports at its next read (Sensor::steadiness).
struct Steadiness {
  TimeUs until = 0;           // sure for a read before this time (the asking time: nothing is sure)
  double lo = 0.0, hi = 0.0;  // the reported value (SI) stays within
  std::uint8_t status = 0;    // and the status bits are these
};

// Optional per-sample observer (event logic evaluated "at every ADC sample", stay-set
// min/max capture...). Called synchronously from read() for every processed sample
// (all samples since the previous read if catch_up_samples covers the read interval).
using SampleHook = void (*)(void* context, Channel channel, const ChannelReading& sample);

class Sensor {
 public:
  // `seed` drives noise, spikes and the per-instance error draw (use derive_seed(node seed, tag)).
  // `faults` may be null; it must outlive the sensor. Throws std::invalid_argument on a bad spec.
  Sensor(const SensorSpec& spec, ProcessModel process, std::uint64_t seed, const FaultSet* faults = nullptr,
         TimeUs boot_time_us = 0);
  Sensor(Sensor&&) noexcept;
  Sensor& operator=(Sensor&&) noexcept;
  // A copy carries the whole state (process model, filters, noise draws, damage) and the fault
  // set pointer and sample hook as they are; an owner with its own FaultSet re-points it with
  // set_faults(). Assigning into a sensor of the same spec does not allocate.
  Sensor(const Sensor&);
  Sensor& operator=(const Sensor&);
  ~Sensor();

  // Advance to t (processing missed samples) and return the readings of the latest samples.
  // t earlier than the last read returns the last reading.
  const SensorReading& read(TimeUs t);
  const SensorReading& read_seconds(double t_s) { return read(seconds_to_us(t_s)); }
  const SensorReading& last() const { return reading_; }

  // What channel `ch` reports if its next read comes before `until`: as the
  // sensor's state, the process model and the fault schedule are at t (a
  // read, a model or a fault change voids it). The first of never, t + 60 s,
  // 5 s and 0.5 s that holds; until = t when none does (a measurement fault
  // in force, a second-order response, a value near a limit, no sample yet).
  Steadiness steadiness(Channel ch, TimeUs t) const;

  // Power cycle / NMT reset node: filters and sampling restart at t, damage stays.
  void reboot(TimeUs t);
  // Node replaced: everything cleared (damage, counters, process stochastic state), boot at t.
  void replace(TimeUs t);

  // Runtime filter change (SDO 0x61A0/0x61A1): the filter buffer restarts with the next sample.
  // Allocates only if length exceeds filter_capacity.
  void set_filter(Channel ch, const FilterSpec& filter);
  const FilterSpec& filter(Channel ch) const;

  // Any channel damaged (overload-safe limit exceeded; cleared only by replace()).
  bool damaged() const;
  bool damaged(Channel ch) const;
  OverloadCounters counters(Channel ch) const;
  void reset_counters();

  void set_faults(const FaultSet* faults) { faults_ = faults; }
  void set_sample_hook(SampleHook hook, void* context) {
    hook_ = hook;
    hook_ctx_ = context;
  }

  ProcessModel& process() { return process_; }
  const SensorSpec& spec() const { return spec_; }
  // Effective static errors after the per-instance draw (for diagnostics and tests).
  const ErrorSpec& effective_errors(Channel ch) const;

  struct ChannelState;  // implementation detail

 private:
  bool steady_between(Channel ch, TimeUs t, TimeUs end, Steadiness& out) const;

  SensorSpec spec_;
  ProcessModel process_;
  const FaultSet* faults_;
  std::uint64_t seed_;
  TimeUs boot_us_ = 0;
  TimeUs last_read_us_ = std::numeric_limits<TimeUs>::min();
  SampleHook hook_ = nullptr;
  void* hook_ctx_ = nullptr;
  std::vector<ChannelState> ch_;  // [Pressure], [Temperature]
  Quantity last_q_{};
  SensorReading reading_;
};

}  // namespace cansim::physics
