#include "physics/fault.hpp"

#include <algorithm>
#include <cmath>

namespace cansim::physics {

namespace {

constexpr std::string_view kNames[kFaultKindCount] = {"open",
                                                      "short",
                                                      "stuck",
                                                      "drift",
                                                      "spikes",
                                                      "noise_burst",
                                                      "over_temperature",
                                                      "eeprom_error",
                                                      "silent",
                                                      "power_cycle",
                                                      "bus_off",
                                                      "heartbeat_stop",
                                                      "slow_sdo",
                                                      "sdo_block_drop",
                                                      "frame_drop",
                                                      "frame_delay",
                                                      "frame_freeze",
                                                      "frame_corrupt",
                                                      "frame_dlc",
                                                      "frame_duplicate",
                                                      "node_id_collision",
                                                      "babbling",
                                                      "sdo_abort",
                                                      "sdo_silent",
                                                      "sdo_toggle_error",
                                                      "clock_drift",
                                                      "error_frames",
                                                      "leak",
                                                      "blocked",
                                                      "valve_stuck",
                                                      "input_lost"};

bool channel_matches(FaultChannel spec, FaultChannel query) { return (unsigned(spec) & unsigned(query)) != 0; }
}  // namespace

std::string_view to_string(FaultKind k) {
  const auto i = std::size_t(k);
  return i < kFaultKindCount ? kNames[i] : std::string_view("?");
}

std::string_view to_string(FaultChannel c) {
  switch (c) {
    case FaultChannel::Pressure: return channel_name(Channel::Pressure);
    case FaultChannel::Temperature: return channel_name(Channel::Temperature);
    case FaultChannel::Both: return "both";
  }
  return "?";
}

std::optional<FaultChannel> parse_fault_channel(std::string_view s) {
  if (s == "both") return FaultChannel::Both;
  if (const std::optional<Channel> c = parse_channel(s)) return FaultChannel(1u << unsigned(*c));
  return std::nullopt;
}

std::optional<FaultKind> parse_fault_kind(std::string_view s) {
  for (std::size_t i = 0; i < kFaultKindCount; ++i)
    if (kNames[i] == s) return FaultKind(i);
  if (s == "sensor_open") return FaultKind::SensorOpen;
  if (s == "sensor_short") return FaultKind::SensorShort;
  if (s == "stuck_value") return FaultKind::StuckValue;
  if (s == "overtemperature") return FaultKind::OverTemperature;
  return std::nullopt;
}

FaultSet::FaultSet(std::size_t capacity) { entries_.reserve(capacity); }

FaultHandle FaultSet::add(const FaultSpec& spec, TimeUs arm_time_us) {
  Entry e{spec, spec.timing.at_us ? *spec.timing.at_us : arm_time_us + spec.timing.after_us, kNever};
  // Normalise timing: a repeating fault with an open-ended duration occurs once.
  if (e.spec.timing.period_us <= 0 || e.spec.timing.duration_us < 0) {
    e.spec.timing.period_us = 0;
    e.spec.timing.count = 1;
  } else if (e.spec.timing.duration_us > e.spec.timing.period_us) {
    e.spec.timing.duration_us = e.spec.timing.period_us;
  }
  entries_.push_back(e);
  if (is_measurement_fault(spec.kind)) ++measurement_count_;
  return FaultHandle(entries_.size() - 1);
}

bool FaultSet::cancel(FaultHandle h, TimeUs now_us) {
  if (h >= entries_.size()) return false;
  auto& e = entries_[h];
  if (now_us < e.cancel_at) e.cancel_at = now_us;
  return true;
}

void FaultSet::clear() {
  entries_.clear();
  measurement_count_ = 0;
}

const FaultSpec* FaultSet::spec(FaultHandle h) const { return h < entries_.size() ? &entries_[h].spec : nullptr; }

bool FaultSet::occurrence_at(const Entry& e, TimeUs t, TimeUs* onset) const {
  if (t < e.start || t >= e.cancel_at) return false;
  const auto& tm = e.spec.timing;
  std::uint64_t k = 0;
  TimeUs on = e.start;
  if (tm.period_us > 0) {
    k = std::uint64_t((t - e.start) / tm.period_us);
    if (tm.count > 0 && k >= tm.count) return false;
    on = e.start + TimeUs(k) * tm.period_us;
  }
  if (on >= e.cancel_at) return false;
  if (tm.duration_us >= 0 && t >= on + tm.duration_us) return false;
  if (onset) *onset = on;
  return true;
}

bool FaultSet::armed(const Entry& e, TimeUs t) const {
  if (t >= e.cancel_at) return false;
  const auto& tm = e.spec.timing;
  const bool endless = tm.duration_us < 0 || (tm.period_us > 0 && tm.count == 0);
  if (endless) return true;
  const TimeUs last_start = e.start + TimeUs(tm.period_us > 0 ? tm.count - 1 : 0) * tm.period_us;
  return t < last_start + tm.duration_us;
}

std::vector<FaultInfo> FaultSet::armed_faults(TimeUs t) const {
  std::vector<FaultInfo> out;
  for (std::size_t h = 0; h < entries_.size(); ++h) {
    const Entry& e = entries_[h];
    if (!armed(e, t)) continue;
    const FaultTiming& tm = e.spec.timing;
    out.push_back({FaultHandle(h), e.spec.kind, e.spec.channel, occurrence_at(e, t, nullptr), e.start, tm.duration_us,
                   tm.period_us, tm.count});
  }
  return out;
}

bool FaultSet::active(FaultKind kind, TimeUs t) const {
  for (const auto& e : entries_)
    if (e.spec.kind == kind && occurrence_at(e, t, nullptr)) return true;
  return false;
}

const FaultSpec* FaultSet::active_spec(FaultKind kind, TimeUs t, TimeUs* onset_us) const {
  for (const auto& e : entries_)
    if (e.spec.kind == kind && occurrence_at(e, t, onset_us)) return &e.spec;
  return nullptr;
}

bool FaultSet::active(FaultHandle h, TimeUs t, TimeUs* onset_us) const {
  return h < entries_.size() && occurrence_at(entries_[h], t, onset_us);
}

TimeUs FaultSet::pending_edge_time(const Entry& e) const {
  if (e.done) return kNever;
  const auto& tm = e.spec.timing;
  const std::uint64_t max_occ = tm.period_us > 0 ? (tm.count == 0 ? UINT64_MAX : tm.count) : 1;
  if (e.next_occ >= max_occ) return kNever;
  const TimeUs on = e.start + TimeUs(e.next_occ) * tm.period_us;
  if (!e.end_pending) return on < e.cancel_at ? on : kNever;
  const TimeUs end = tm.duration_us < 0 ? kNever : on + tm.duration_us;
  return end < e.cancel_at ? end : e.cancel_at;
}

void FaultSet::advance_cursor(Entry& e) {
  if (!e.end_pending) {
    e.end_pending = true;
  } else {
    e.end_pending = false;
    ++e.next_occ;
  }
  if (pending_edge_time(e) == kNever && !e.end_pending) e.done = true;
}

TimeUs FaultSet::next_edge_time() const {
  TimeUs best = kNever;
  for (const auto& e : entries_) {
    const TimeUs t = pending_edge_time(e);
    if (t < best) best = t;
  }
  return best;
}

bool FaultSet::poll(TimeUs now_us, FaultEdge& out) {
  std::size_t best = entries_.size();
  TimeUs best_t = kNever;
  for (std::size_t i = 0; i < entries_.size(); ++i) {
    const TimeUs t = pending_edge_time(entries_[i]);
    if (t <= now_us && t < best_t) {
      best_t = t;
      best = i;
    }
  }
  if (best == entries_.size()) return false;
  Entry& e = entries_[best];
  out = FaultEdge{e.spec.kind, !e.end_pending, best_t, e.next_occ, FaultHandle(best), &e.spec};
  advance_cursor(e);
  return true;
}

TimeUs FaultSet::measurement_quiet_until(FaultChannel channel, TimeUs t) const {
  TimeUs until = kNever;
  if (measurement_count_ == 0) return until;
  for (const auto& e : entries_) {
    if (!is_measurement_fault(e.spec.kind)) continue;
    if (e.spec.kind != FaultKind::OverTemperature && !channel_matches(e.spec.channel, channel)) continue;
    if (occurrence_at(e, t, nullptr)) return t;
    if (t >= e.cancel_at) continue;
    const FaultTiming& tm = e.spec.timing;
    TimeUs next = kNever;
    if (t < e.start) {
      next = e.start;
    } else if (tm.period_us > 0) {
      const std::uint64_t k = std::uint64_t((t - e.start) / tm.period_us) + 1;
      if (tm.count == 0 || k < tm.count) next = e.start + TimeUs(k) * tm.period_us;
    }
    if (next < e.cancel_at) until = std::min(until, next);
  }
  return until;
}

MeasurementFaults FaultSet::measurement(FaultChannel channel, TimeUs t) const {
  MeasurementFaults m;
  if (measurement_count_ == 0) return m;
  double noise2 = 0.0;
  for (const auto& e : entries_) {
    if (!is_measurement_fault(e.spec.kind)) continue;
    const bool heat = e.spec.kind == FaultKind::OverTemperature;
    if (!heat && !channel_matches(e.spec.channel, channel)) continue;
    TimeUs onset = 0;
    if (!occurrence_at(e, t, &onset)) continue;
    switch (e.spec.kind) {
      case FaultKind::SensorOpen: m.open = true; break;
      case FaultKind::SensorShort: m.short_circuit = true; break;
      case FaultKind::StuckValue:
        if (!m.stuck) {
          m.stuck = true;
          m.stuck_value = e.spec.stuck_value;
          m.stuck_onset_us = onset;
        }
        break;
      case FaultKind::Drift: m.drift += e.spec.drift_per_s * us_to_seconds(t - onset); break;
      case FaultKind::Spikes:
        m.spike_rate_hz += e.spec.spike_rate_hz;
        if (std::abs(e.spec.spike_amplitude) > std::abs(m.spike_amplitude)) m.spike_amplitude = e.spec.spike_amplitude;
        break;
      case FaultKind::NoiseBurst: noise2 += e.spec.noise_rms * e.spec.noise_rms; break;
      case FaultKind::OverTemperature: m.over_temperature_k += e.spec.over_temperature_k; break;
      default: break;
    }
  }
  if (noise2 > 0) m.extra_noise_rms = std::sqrt(noise2);
  return m;
}

}  // namespace cansim::physics
