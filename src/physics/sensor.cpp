#include "physics/sensor.hpp"

#include <algorithm>
#include <cmath>
#include <stdexcept>

#include "physics/quantize.hpp"
#include "physics/random.hpp"

namespace cansim::physics {

namespace {
constexpr double kSettle = 40.0;                // time constants after which a lag has forgotten its start
constexpr std::int64_t kMaxLagCatchUp = 65536;  // bound for lag / first-order filter catch-up
constexpr double kInf = std::numeric_limits<double>::infinity();

// Samples a first-order response of time constant tau_s takes to forget its
// start at rate_hz, at most kMaxLagCatchUp: a huge or non-finite time
// constant (a device object can set one) never casts out of range.
std::int64_t settle_samples(double tau_s, double rate_hz) {
  const double n = std::ceil(kSettle * tau_s * rate_hz) + 1;
  return n < double(kMaxLagCatchUp) ? std::int64_t(std::max(n, 0.0)) : kMaxLagCatchUp;
}

std::string check_channel(const ChannelSpec& c) {
  if (!c.enabled) return {};
  if (!std::isfinite(c.range_min) || !std::isfinite(c.range_max) || !(c.range_max > c.range_min))
    return "range_max must be > range_min";
  if (!(c.sample_rate_hz >= 0.001) || !(c.sample_rate_hz <= 1.0e6)) return "sample_rate_hz must be in [0.001, 1e6]";
  if (!std::isfinite(c.adc.code_at_range_min) || !std::isfinite(c.adc.code_at_range_max) ||
      c.adc.code_at_range_max == c.adc.code_at_range_min)
    return "adc: code_at_range_min/max must differ";
  if (c.adc.code_min > c.adc.code_max) return "adc: code_min > code_max";
  if (!(c.noise_rms >= 0)) return "noise_rms must be >= 0";
  if (!(c.errors.hysteresis >= 0)) return "hysteresis must be >= 0";
  if (!(c.errors.total_error_band >= 0)) return "total_error_band must be >= 0";
  if (!(c.response_time_constant_s >= 0)) return "response_time_constant_s must be >= 0";
  if (c.filter.length < 1) return "filter length must be >= 1";
  if (c.filter.type == FilterType::FirstOrder && !(c.filter.time_constant_s > 0))
    return "first-order filter needs time_constant_s > 0";
  if (!(c.overload.margin >= 0) || !(c.overload.hysteresis >= 0)) return "overload margin/hysteresis must be >= 0";
  return {};
}

}  // namespace

AdcSpec AdcSpec::unsigned_bits(unsigned bits, double headroom) {
  AdcSpec a;
  const double full = std::ldexp(1.0, int(bits)) - 1.0;
  // codes 0..full cover [range_min - h*span, range_max + h*span]
  a.code_at_range_min = full * headroom / (1.0 + 2.0 * headroom);
  a.code_at_range_max = full * (1.0 + headroom) / (1.0 + 2.0 * headroom);
  a.code_min = 0;
  a.code_max = std::int32_t(std::min(full, 2147483647.0));
  return a;
}

AdcSpec AdcSpec::int16_field(double full_scale_code) {
  AdcSpec a;
  a.code_at_range_min = 0.0;
  a.code_at_range_max = full_scale_code;
  a.code_min = -32768;
  a.code_max = 32767;
  return a;
}

TimeUs lookback_us(const SensorSpec& spec) {
  double seconds = 1.0;
  for (const ChannelSpec* c : {&spec.pressure, &spec.temperature}) {
    if (!c->enabled || !(c->sample_rate_hz > 0)) continue;
    double samples = std::max<double>(2.0 * c->filter.length, c->catch_up_samples);
    for (double tau :
         {c->response_time_constant_s, c->filter.type == FilterType::FirstOrder ? c->filter.time_constant_s : 0.0})
      if (tau > 0)
        samples = std::max(samples, std::min<double>(kMaxLagCatchUp, std::ceil(kSettle * tau * c->sample_rate_hz) + 1));
    seconds = std::max(seconds, (samples + 2.0) / c->sample_rate_hz);
  }
  return seconds_to_us(std::min(seconds, 3600.0));
}

std::string validate(const SensorSpec& spec) {
  if (auto e = check_channel(spec.pressure); !e.empty()) return "pressure: " + e;
  if (auto e = check_channel(spec.temperature); !e.empty()) return "temperature: " + e;
  return {};
}

// ======================================================================= channel

struct Sensor::ChannelState {
  ChannelSpec spec;
  Channel which;
  std::uint64_t noise_key = 0, spike_key = 0;
  // sampling
  std::int64_t rate_mhz = 1000000;  // sample rate in millihertz (integer time arithmetic)
  double rate_hz = 1000.0;
  // derived
  double span = 1, c0 = 0, c1 = 1, code_per_unit = 1;
  double lag_alpha = 0, iir_alpha = 0;
  std::int64_t lag_need = 1, iir_need = 1;
  // state
  std::int64_t next_index = 0;
  bool started = false;
  bool filter_fresh = true;
  std::int64_t filter_origin = 0;
  std::vector<std::int32_t> ring;
  std::uint32_t ring_pos = 0;
  std::int64_t ring_sum = 0;
  std::int64_t block_sum = 0;
  std::uint32_t block_count = 0;
  double block_out = 0;
  std::uint32_t block_skip = 0;
  double iir = 0;
  double lag = 0, hyst = 0;
  double last_valid = 0;
  bool have_valid = false;
  TimeUs stuck_onset = std::numeric_limits<TimeUs>::min();
  double stuck_latched = 0;
  bool pos_ovl = false, neg_ovl = false;
  OverloadCounters counters;
  bool damaged = false;
  ChannelReading out;

  void configure(std::uint64_t seed) {
    rate_mhz = std::max<std::int64_t>(1, std::llround(spec.sample_rate_hz * 1000.0));
    rate_hz = double(rate_mhz) / 1000.0;
    span = spec.range_max - spec.range_min;
    c0 = spec.adc.code_at_range_min;
    c1 = spec.adc.code_at_range_max;
    code_per_unit = (c1 - c0) / span;
    if (spec.response_time_constant_s > 0) {
      lag_alpha = -std::expm1(-1.0 / (spec.response_time_constant_s * rate_hz));
      lag_need = settle_samples(spec.response_time_constant_s, rate_hz);
    }
    configure_filter();
    noise_key = derive_seed(seed, 0xA001);
    spike_key = derive_seed(seed, 0xA002);
    draw_errors(derive_seed(seed, 0xA003));
  }

  void configure_filter() {
    const std::uint32_t n = std::max<std::uint32_t>(1, spec.filter.length);
    spec.filter.length = n;
    if (spec.filter.type == FilterType::MovingAverage) {
      if (ring.capacity() < n) ring.reserve(std::max(n, spec.filter_capacity));
      ring.assign(n, 0);
    }
    if (spec.filter.type == FilterType::FirstOrder) {
      iir_alpha = -std::expm1(-1.0 / (spec.filter.time_constant_s * rate_hz));
      iir_need = settle_samples(spec.filter.time_constant_s, rate_hz);
    }
    filter_fresh = true;
  }

  void draw_errors(std::uint64_t key) {
    auto& e = spec.errors;
    if (!(e.total_error_band > 0)) return;
    double budget = e.total_error_band - std::abs(e.nonlinearity) - 0.5 * e.hysteresis - 3.0 * spec.noise_rms -
                    0.5 * std::abs(1.0 / code_per_unit);
    if (spec.output_steps > 0) budget -= 0.5 * span / spec.output_steps;
    budget = std::max(0.0, budget);
    const double dtmax = std::max(std::abs(e.compensated_min_k - e.reference_temperature_k),
                                  std::abs(e.compensated_max_k - e.reference_temperature_k));
    Xoshiro256ss rng(key);
    e.zero_offset = rng.uniform(-1.0, 1.0) * 0.3 * budget;
    e.span_error = rng.uniform(-1.0, 1.0) * 0.3 * budget / span;
    const double tz = rng.uniform(-1.0, 1.0) * 0.2 * budget;
    const double ts = rng.uniform(-1.0, 1.0) * 0.2 * budget / span;
    e.thermal_zero_per_k = dtmax > 0 ? tz / dtmax : 0.0;
    e.thermal_span_per_k = dtmax > 0 ? ts / dtmax : 0.0;
  }

  std::int64_t index_at(TimeUs t, TimeUs boot) const {
    if (t < boot) return -1;
    const std::int64_t dt = t - boot;
    if (dt <= std::numeric_limits<std::int64_t>::max() / rate_mhz) return dt * rate_mhz / 1000000000;
    return std::int64_t(__int128(dt) * rate_mhz / 1000000000);
  }
  TimeUs time_of(std::int64_t n, TimeUs boot) const {
    if (n <= std::numeric_limits<std::int64_t>::max() / 1000000000) return boot + n * 1000000000 / rate_mhz;
    return boot + TimeUs(__int128(n) * 1000000000 / rate_mhz);
  }
  double seconds_of(std::int64_t n, TimeUs boot) const { return us_to_seconds(boot) + double(n) / rate_hz; }

  // First sample index to process to bring the channel to sample N.
  std::int64_t begin(std::int64_t N) {
    if (N < next_index) return N + 1;  // nothing to do
    std::int64_t need = 1;
    const std::int64_t len = spec.filter.length;
    switch (spec.filter.type) {
      case FilterType::None: break;
      case FilterType::MovingAverage: need = len; break;
      case FilterType::RepeatingAverage: {
        const std::int64_t rel = N - filter_origin;
        const std::int64_t k = (rel + 1) / len;
        const std::int64_t start = filter_origin + std::max<std::int64_t>(k - 1, 0) * len;
        need = N - start + 1;
        break;
      }
      case FilterType::FirstOrder: need = iir_need; break;
    }
    if (spec.response_time_constant_s > 0) need = std::max(need, lag_need);
    need = std::max<std::int64_t>(need, spec.catch_up_samples);
    const std::int64_t start = std::max(next_index, N + 1 - need);
    if (start > next_index) {
      // Samples skipped: the filter restarts with the first processed sample and its window
      // is completely refilled before sample N. Lag and hysteresis keep their state (the lag
      // forgets it within the processed settling window).
      filter_fresh = true;
    }
    return start;
  }

  // Samples a read processes at most when it comes after a gap (begin()).
  std::int64_t read_window() const {
    std::int64_t need = 1;
    const std::int64_t len = spec.filter.length;
    if (spec.filter.type == FilterType::MovingAverage) need = len;
    if (spec.filter.type == FilterType::RepeatingAverage) need = 2 * len;
    if (spec.filter.type == FilterType::FirstOrder) need = iir_need;
    if (spec.response_time_constant_s > 0) need = std::max(need, lag_need);
    return std::max<std::int64_t>(need, spec.catch_up_samples);
  }

  // The element's output (before the ADC) for a truth in [lo, hi] and a
  // sensor temperature in [tlo, thi], as element_output() gives it without
  // faults: the static errors are bilinear in (truth, temperature), the bow
  // between 0 and its peak, hysteresis and lag between their state and the
  // input, the noise at most kNormalBound rms.
  void element_range(double lo, double hi, double tlo, double thi, double& out_lo, double& out_hi) const {
    const auto& e = spec.errors;
    out_lo = std::numeric_limits<double>::infinity();
    out_hi = -out_lo;
    for (double x : {lo, hi})
      for (double t_sensor : {tlo, thi}) {
        const double dT = t_sensor - e.reference_temperature_k, rel = x - spec.range_min;
        const double v =
            x + e.zero_offset + e.thermal_zero_per_k * dT + rel * (e.span_error + e.thermal_span_per_k * dT);
        out_lo = std::min(out_lo, v);
        out_hi = std::max(out_hi, v);
      }
    out_lo += std::min(0.0, e.nonlinearity);
    out_hi += std::max(0.0, e.nonlinearity);
    if (e.hysteresis > 0.0) {
      out_lo = std::min(out_lo - 0.5 * e.hysteresis, hyst);
      out_hi = std::max(out_hi + 0.5 * e.hysteresis, hyst);
    }
    if (spec.response_time_constant_s > 0.0) {
      out_lo = std::min(out_lo, lag);
      out_hi = std::max(out_hi, lag);
    }
    out_lo -= kNormalBound * spec.noise_rms;
    out_hi += kNormalBound * spec.noise_rms;
  }

  // The range of the filter's output for new codes in [lo, hi]: its state
  // (older codes) unless it restarts.
  void filter_range(double& lo, double& hi) const {
    if (filter_fresh) return;
    switch (spec.filter.type) {
      case FilterType::None: return;
      case FilterType::MovingAverage:
        for (std::int32_t c : ring) lo = std::min<double>(lo, c), hi = std::max<double>(hi, c);
        return;
      case FilterType::RepeatingAverage: lo = std::min(lo, block_out), hi = std::max(hi, block_out); return;
      case FilterType::FirstOrder: lo = std::min(lo, iir), hi = std::max(hi, iir); return;
    }
  }

  // Output quantisation and back to physical units (device_output's last
  // steps), both monotone in the filtered code.
  double output_value(double fc) const {
    if (spec.output_steps > 0) {
      const double steps = spec.output_steps;
      fc = c0 + round_half_away((fc - c0) / (c1 - c0) * steps) / steps * (c1 - c0);
    }
    return spec.range_min + (fc - c0) / code_per_unit;
  }

  // Whether the overload state stays as it is for a source value in [lo, hi].
  bool overload_stays(double lo, double hi) const {
    const double top = spec.range_max + spec.overload.margin, bottom = spec.range_min - spec.overload.margin;
    const double h = spec.overload.hysteresis;
    const bool pos = pos_ovl ? lo > top - h : hi <= top;
    const bool neg = neg_ovl ? hi < bottom + h : lo >= bottom;
    return pos && neg;
  }

  double filter(std::int32_t c, std::int64_t n) {
    const auto len = spec.filter.length;
    if (filter_fresh) {
      filter_fresh = false;
      if (spec.filter.type == FilterType::MovingAverage) {
        std::fill(ring.begin(), ring.end(), c);
        ring_pos = 0;
        ring_sum = std::int64_t(c) * len;
      }
      block_sum = 0;
      block_count = 0;
      block_out = c;
      iir = c;
      // Blocks are aligned to filter_origin: a restart in the middle of a block waits for
      // the next block boundary (output held meanwhile).
      block_skip = 0;
      if (spec.filter.type == FilterType::RepeatingAverage) {
        const auto r = std::uint32_t((n - filter_origin) % len);
        if (r != 0) block_skip = len - r;
      }
    }
    switch (spec.filter.type) {
      case FilterType::None: return c;
      case FilterType::MovingAverage:
        ring_sum += std::int64_t(c) - ring[ring_pos];
        ring[ring_pos] = c;
        if (++ring_pos == len) ring_pos = 0;
        return double(ring_sum) / double(len);
      case FilterType::RepeatingAverage:
        if (block_skip > 0) {  // partial block after a mid-block restart: wait for alignment
          --block_skip;
          return block_out;
        }
        block_sum += c;
        if (++block_count == len) {
          block_out = double(block_sum) / double(len);
          block_sum = 0;
          block_count = 0;
        }
        return block_out;
      case FilterType::FirstOrder: iir += iir_alpha * (c - iir); return iir;
    }
    return c;
  }
  // Standard normal for sample n: a pure function of (noise_key, n).
  double noise_normal(std::int64_t n) const { return counter_normal(noise_key, std::uint64_t(n)); }

  void step(std::int64_t n, const Quantity& q, const MeasurementFaults& mf, TimeUs t_us) {
    const double t_sensor = q.temperature_k + mf.over_temperature_k;
    const double x_true = which == Channel::Pressure ? q.pressure_pa : t_sensor;
    if (x_true > spec.overload.safe_max || x_true < spec.overload.safe_min) damaged = true;
    const double x = element_output(n, x_true, t_sensor, mf);
    std::uint8_t flags = 0;
    const std::int32_t counts = adc_counts(x, mf, flags);
    started = true;
    // While the element is open / shorted / damaged the filter is not fed (the device flags
    // the value invalid); it restarts with the first good sample afterwards.
    const bool invalid = damaged || mf.open || mf.short_circuit;
    double value = device_output(n, counts, invalid);
    value = apply_stuck(value, mf, flags);
    if (mf.any()) flags |= kFlagFault;
    if (damaged) flags |= kFlagDamaged;
    const std::uint8_t status = invalid ? invalid_status(value) : valid_status(counts, value);

    out.value = value;
    out.fraction = (value - spec.range_min) / span;
    out.truth = x_true;
    out.adc_counts = counts;
    out.status = status;
    out.flags = flags;
    out.sample_index = n;
    out.sample_time_us = t_us;
    next_index = n + 1;
  }

  // The sensing element: static, thermal and non-linearity errors, hysteresis,
  // response time, drift, noise and spikes on the true value.
  double element_output(std::int64_t n, double x_true, double t_sensor, const MeasurementFaults& mf) {
    const bool first = !started;
    const auto& e = spec.errors;
    const double dT = t_sensor - e.reference_temperature_k;
    double x = x_true;
    const double rel = x_true - spec.range_min;
    x += e.zero_offset + e.thermal_zero_per_k * dT + rel * (e.span_error + e.thermal_span_per_k * dT);
    if (e.nonlinearity != 0.0) {
      const double u = std::clamp(rel / span, 0.0, 1.0);
      x += e.nonlinearity * 4.0 * u * (1.0 - u);
    }
    if (e.hysteresis > 0.0) {
      const double h = 0.5 * e.hysteresis;
      if (first) hyst = x;
      else if (x > hyst + h) hyst = x - h;
      else if (x < hyst - h) hyst = x + h;
      x = hyst;
    }
    if (spec.response_time_constant_s > 0.0) {
      if (first) lag = x;
      else lag += lag_alpha * (x - lag);
      x = lag;
    }
    x += mf.drift;
    const double sigma2 = spec.noise_rms * spec.noise_rms + mf.extra_noise_rms * mf.extra_noise_rms;
    if (sigma2 > 0.0) x += std::sqrt(sigma2) * noise_normal(n);
    if (mf.spike_rate_hz > 0.0) {
      const std::uint64_t bits = counter_hash(spike_key, std::uint64_t(n));
      if (uniform01(bits) < mf.spike_rate_hz / rate_hz) x += (bits & 1) ? mf.spike_amplitude : -mf.spike_amplitude;
    }
    return x;
  }

  // The ADC: saturating codes; an open / shorted element reads the rail.
  std::int32_t adc_counts(double x, const MeasurementFaults& mf, std::uint8_t& flags) const {
    const double code_r = round_half_away(c0 + (x - spec.range_min) * code_per_unit);
    std::int32_t counts;
    if (!(code_r > spec.adc.code_min)) {
      counts = spec.adc.code_min;
      if (!(code_r == spec.adc.code_min)) flags |= kFlagAdcSaturated;
    } else if (code_r >= spec.adc.code_max) {
      counts = spec.adc.code_max;
      if (code_r > spec.adc.code_max) flags |= kFlagAdcSaturated;
    } else {
      counts = std::int32_t(code_r);
    }
    if (mf.open) counts = spec.adc.code_min, flags |= kFlagOpen;
    if (mf.short_circuit) counts = spec.adc.code_max, flags |= kFlagShort;
    return counts;
  }

  // Device filter on integer codes, output quantisation, back to physical units.
  double device_output(std::int64_t n, std::int32_t counts, bool invalid) {
    double fc;
    if (invalid) {
      filter_fresh = true;
      fc = counts;
    } else {
      fc = filter(counts, n);
    }
    if (spec.output_steps > 0) {
      const double steps = spec.output_steps;
      fc = c0 + round_half_away((fc - c0) / (c1 - c0) * steps) / steps * (c1 - c0);
    }
    return spec.range_min + (fc - c0) / code_per_unit;
  }

  // A stuck output holds the value latched at the stuck fault's onset.
  double apply_stuck(double value, const MeasurementFaults& mf, std::uint8_t& flags) {
    if (!mf.stuck) {
      stuck_onset = std::numeric_limits<TimeUs>::min();
      return value;
    }
    flags |= kFlagStuck;
    if (stuck_onset != mf.stuck_onset_us) {
      stuck_onset = mf.stuck_onset_us;
      stuck_latched = std::isnan(mf.stuck_value) ? (out.sample_index >= 0 ? out.value : value) : mf.stuck_value;
    }
    return stuck_latched;
  }

  // Not valid: the output holds the last valid value where the spec says so.
  std::uint8_t invalid_status(double& value) const {
    if (spec.invalid_output == InvalidOutput::HoldLastValid && have_valid) value = last_valid;
    return kStatusInvalid;
  }

  // Valid: overload against the range and its margin, with hysteresis and counters.
  std::uint8_t valid_status(std::int32_t counts, double value) {
    const double src =
        spec.overload.source == OverloadSource::Raw ? spec.range_min + (counts - c0) / code_per_unit : value;
    const double hi = spec.range_max + spec.overload.margin;
    const double lo = spec.range_min - spec.overload.margin;
    if (!pos_ovl && src > hi) {
      pos_ovl = true;
      if (counters.positive != UINT32_MAX) ++counters.positive;
    } else if (pos_ovl && src <= hi - spec.overload.hysteresis) {
      pos_ovl = false;
    }
    if (!neg_ovl && src < lo) {
      neg_ovl = true;
      if (counters.negative != UINT32_MAX) ++counters.negative;
    } else if (neg_ovl && src >= lo + spec.overload.hysteresis) {
      neg_ovl = false;
    }
    last_valid = value;
    have_valid = true;
    return std::uint8_t((pos_ovl ? kStatusPositiveOverload : 0) | (neg_ovl ? kStatusNegativeOverload : 0));
  }

  void reboot() {
    next_index = 0;
    started = false;
    filter_fresh = true;
    filter_origin = 0;
    block_skip = 0;
    pos_ovl = neg_ovl = false;
    have_valid = false;
    stuck_onset = std::numeric_limits<TimeUs>::min();
    out = ChannelReading{};
  }
};

// ======================================================================= sensor

Sensor::Sensor(const SensorSpec& spec, ProcessModel process, std::uint64_t seed, const FaultSet* faults,
               TimeUs boot_time_us)
    : spec_(spec), process_(std::move(process)), faults_(faults), seed_(seed), boot_us_(boot_time_us), ch_(2) {
  if (auto e = validate(spec); !e.empty()) throw std::invalid_argument("sensor: " + e);
  const ChannelSpec* cs[2] = {&spec_.pressure, &spec_.temperature};
  for (int i = 0; i < 2; ++i) {
    ch_[i].spec = *cs[i];
    ch_[i].which = Channel(i);
    if (cs[i]->enabled) ch_[i].configure(derive_seed(seed, 0x5E0 + i));
  }
}

Sensor::Sensor(Sensor&&) noexcept = default;
Sensor& Sensor::operator=(Sensor&&) noexcept = default;
Sensor::Sensor(const Sensor&) = default;
Sensor& Sensor::operator=(const Sensor&) = default;
Sensor::~Sensor() = default;

const SensorReading& Sensor::read(TimeUs t) {
  if (t <= last_read_us_) return reading_;
  last_read_us_ = t;
  ChannelState& P = ch_[0];
  ChannelState& T = ch_[1];
  const bool pe = P.spec.enabled, te = T.spec.enabled;
  const std::int64_t np = pe ? P.index_at(t, boot_us_) : -1;
  const std::int64_t nt = te ? T.index_at(t, boot_us_) : -1;
  std::int64_t ip = np >= 0 ? P.begin(np) : 0;
  std::int64_t it = nt >= 0 ? T.begin(nt) : 0;
  static const MeasurementFaults kNoFaults{};
  bool evaluated = false;
  while (true) {
    const bool hp = np >= 0 && ip <= np;
    const bool ht = nt >= 0 && it <= nt;
    if (!hp && !ht) break;
    const double tp = hp ? P.seconds_of(ip, boot_us_) : kInf;
    const double tt = ht ? T.seconds_of(it, boot_us_) : kInf;
    const double ts = std::min(tp, tt);
    last_q_ = process_.at(ts);
    evaluated = true;
    if (hp && tp == ts) {
      const TimeUs tu = P.time_of(ip, boot_us_);
      const MeasurementFaults mf =
          faults_ && faults_->has_measurement_faults() ? faults_->measurement(FaultChannel::Pressure, tu) : kNoFaults;
      P.step(ip, last_q_, mf, tu);
      ++ip;
      if (hook_) hook_(hook_ctx_, Channel::Pressure, P.out);
    }
    if (ht && tt == ts) {
      const TimeUs tu = T.time_of(it, boot_us_);
      const MeasurementFaults mf = faults_ && faults_->has_measurement_faults()
                                       ? faults_->measurement(FaultChannel::Temperature, tu)
                                       : kNoFaults;
      T.step(it, last_q_, mf, tu);
      ++it;
      if (hook_) hook_(hook_ctx_, Channel::Temperature, T.out);
    }
  }
  if ((!pe || !te) && !evaluated && t >= boot_us_) last_q_ = process_.at(us_to_seconds(t));
  reading_.pressure = P.out;
  reading_.temperature = T.out;
  if (!pe) {
    reading_.pressure = ChannelReading{};
    reading_.pressure.value = reading_.pressure.truth = last_q_.pressure_pa;
    reading_.pressure.flags = kFlagDisabled;
  }
  if (!te) {
    reading_.temperature = ChannelReading{};
    reading_.temperature.value = reading_.temperature.truth = last_q_.temperature_k;
    reading_.temperature.flags = kFlagDisabled;
  }
  return reading_;
}

Steadiness Sensor::steadiness(Channel ch, TimeUs t) const {
  constexpr TimeUs kHorizons[] = {kNever, 60'000'000, 5'000'000, 500'000};
  Steadiness out{t, 0.0, 0.0, 0};
  const ChannelState& c = ch_[int(ch)];
  TimeUs until = kNever;
  if (c.spec.enabled && faults_ && faults_->has_measurement_faults()) {
    until = faults_->measurement_quiet_until(
        ch == Channel::Pressure ? FaultChannel::Pressure : FaultChannel::Temperature, t);
    if (until <= t) return out;
  }
  for (TimeUs horizon : kHorizons) {
    const TimeUs end = horizon == kNever || t > kNever - horizon ? until : std::min(until, t + horizon);
    if (end <= t) continue;
    if (steady_between(ch, t, end, out)) {
      out.until = end;
      return out;
    }
  }
  out = Steadiness{t, 0.0, 0.0, 0};
  return out;
}

// One read at a time in (t, end): the samples it processes lie in
// [t - its window, end); the process is evaluated once per processed sample
// of either channel.
bool Sensor::steady_between(Channel ch, TimeUs t, TimeUs end, Steadiness& out) const {
  const ChannelState& c = ch_[int(ch)];
  double lookback = 0.0;
  int queries = 1;
  for (const ChannelState& x : ch_)
    if (x.spec.enabled) {
      const std::int64_t window = x.read_window();
      lookback = std::max(lookback, double(window) / x.rate_hz);
      queries += int(std::min<std::int64_t>(window, 1 << 20));
    }
  const double t0 = us_to_seconds(t) - lookback;
  const double t1 = end == kNever ? std::numeric_limits<double>::infinity() : us_to_seconds(end);
  double lo = 0, hi = 0;
  if (!process_.bounds(ch, t0, t1, queries, lo, hi)) return false;
  if (!c.spec.enabled) {  // the truth, status 0
    out.lo = lo, out.hi = hi, out.status = 0;
    return true;
  }
  if (!c.started) return false;
  double tlo = lo, thi = hi;  // the sensor's temperature: the temperature channel's truth
  if (ch == Channel::Pressure && !process_.bounds(Channel::Temperature, t0, t1, queries, tlo, thi)) return false;
  const bool damaged = c.damaged || hi > c.spec.overload.safe_max || lo < c.spec.overload.safe_min;
  if (damaged != c.damaged) return false;  // it may become damaged
  double xlo = 0, xhi = 0;
  c.element_range(lo, hi, tlo, thi, xlo, xhi);
  const MeasurementFaults none{};
  std::uint8_t flags = 0;
  double clo = c.adc_counts(xlo, none, flags), chi = c.adc_counts(xhi, none, flags);
  if (clo > chi) std::swap(clo, chi);
  if (damaged) {  // not valid: the last valid value, or what the chain gives
    if (c.out.status != kStatusInvalid) return false;
    const bool hold = c.spec.invalid_output == InvalidOutput::HoldLastValid && c.have_valid;
    out.lo = hold ? c.last_valid : std::min(c.output_value(clo), c.output_value(chi));
    out.hi = hold ? c.last_valid : std::max(c.output_value(clo), c.output_value(chi));
    out.status = kStatusInvalid;
    return true;
  }
  double flo = clo, fhi = chi;
  c.filter_range(flo, fhi);
  const double v1 = c.output_value(flo), v2 = c.output_value(fhi);
  out.lo = std::min(v1, v2);
  out.hi = std::max(v1, v2);
  double slo = out.lo, shi = out.hi;
  if (c.spec.overload.source == OverloadSource::Raw) {
    const double r1 = c.spec.range_min + (clo - c.c0) / c.code_per_unit;
    const double r2 = c.spec.range_min + (chi - c.c0) / c.code_per_unit;
    slo = std::min(r1, r2), shi = std::max(r1, r2);
  }
  if (!c.overload_stays(slo, shi)) return false;
  out.status = std::uint8_t((c.pos_ovl ? kStatusPositiveOverload : 0) | (c.neg_ovl ? kStatusNegativeOverload : 0));
  return c.out.status == out.status;
}

void Sensor::reboot(TimeUs t) {
  boot_us_ = t;
  last_read_us_ = std::numeric_limits<TimeUs>::min();
  ch_[0].reboot();
  ch_[1].reboot();
  reading_ = SensorReading{};
}

void Sensor::replace(TimeUs t) {
  reboot(t);
  for (auto& c : ch_) {
    c.damaged = false;
    c.counters = {};
  }
}

void Sensor::set_filter(Channel ch, const FilterSpec& filter) {
  ChannelState& c = ch_[int(ch)];
  c.spec.filter = filter;
  if (!c.spec.enabled) return;
  c.configure_filter();
  c.filter_origin = c.next_index;
  c.block_skip = 0;
}

const FilterSpec& Sensor::filter(Channel ch) const { return ch_[int(ch)].spec.filter; }

bool Sensor::damaged() const { return ch_[0].damaged || ch_[1].damaged; }
bool Sensor::damaged(Channel ch) const { return ch_[int(ch)].damaged; }

OverloadCounters Sensor::counters(Channel ch) const { return ch_[int(ch)].counters; }

void Sensor::reset_counters() {
  for (auto& c : ch_) c.counters = {};
}

const ErrorSpec& Sensor::effective_errors(Channel ch) const { return ch_[int(ch)].spec.errors; }

}  // namespace cansim::physics
