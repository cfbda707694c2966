// Fault injection: scheduling (at / after / duration / repeat period / count) and queries.
//
// A FaultSet holds scheduled faults of one node. The same FaultSpec is used for faults
// from the profile (armed at boot) and for faults triggered later by the runtime control
// API (armed at the time of the request): `at_us` is absolute simulated time, `after_us`
// is relative to the arm time.
//
// Measurement faults (open, short, stuck, drift, spikes, noise burst, over-temperature)
// are applied by physics::Sensor. Communication faults are only scheduled here; the
// node / personality layers query `active(kind, t)` or poll start/end edges:
//
//     FaultEdge e;
//     while (faults.poll(now_us, e)) { if (e.kind == FaultKind::PowerCycle && e.started) ... }
//
// All queries are allocation-free; add() may allocate when the set grows past its capacity.
#pragma once

#include <cstddef>
#include <cstdint>
#include <limits>
#include <optional>
#include <string_view>
#include <vector>

#include "physics/channel.hpp"
#include "physics/time.hpp"

namespace cansim::physics {

enum class FaultKind : std::uint8_t {
  // measurement faults (applied in the sensor chain)
  SensorOpen,       // open circuit: status "not valid", ADC at the negative rail
  SensorShort,      // short circuit: status "not valid", ADC at the positive rail
  StuckValue,       // output frozen (at onset value or at stuck_value)
  Drift,            // error growing linearly with time since onset
  Spikes,           // random single-sample spikes
  NoiseBurst,       // extra gaussian noise
  OverTemperature,  // the sensor element is hotter than the process (temperature reading + thermal errors)
  // communication faults (acted on by node / personality layers)
  EepromError,    // EEPROM / data-set error at boot (check active(EepromError, boot_time))
  Silent,         // node alive but sends no frames
  PowerCycle,     // power off for `duration` then boot (duration 0: immediate reboot)
  BusOff,         // CAN bus-off; recovery at the end of the duration
  HeartbeatStop,  // heartbeat producer stops
  SlowSdo,        // SDO answers delayed by sdo_delay_us
  SdoBlockDrop,   // SDO block transfer segments dropped
  // network faults (the node's frames, its twin, its SDO server, its clock,
  // error frames; FaultSpec::net has their parameters)
  FrameDrop,        // the selected frames never reach the wire
  FrameDelay,       // ... reach it delay (+ up to jitter) later
  FrameFreeze,      // ... keep the data of the first one
  FrameCorrupt,     // ... have chosen (or random) bytes changed
  FrameDlc,         // ... have another length
  FrameDuplicate,   // ... are sent twice
  NodeIdCollision,  // a second node answers at the node's ID
  Babbling,         // the node floods a COB-ID
  SdoAbort,         // an object answers an abort code
  SdoSilent,        // an object, or the whole SDO server, never answers
  SdoToggleError,   // segments carry the wrong toggle bit
  ClockDrift,       // the node's time base runs fast or slow by ppm
  ErrorFrames,      // CAN error frames for the master
  // plant faults (applied by physics::Plant on a block or input: docs/plants.md)
  Leak,        // a gas volume loses mass: an orifice (leak_kv) or a flow (leak_flow_kgs) to the ambient
  Blocked,     // a valve, pump or line passes no flow
  ValveStuck,  // a valve's opening, or an input, freezes at its value at the onset
  InputLost,   // an input's command stops arriving: its timeout behaviour shows
};
inline constexpr std::size_t kFaultKindCount = 31;

constexpr bool is_frame_fault(FaultKind k) {
  return std::uint8_t(k) >= std::uint8_t(FaultKind::FrameDrop) &&
         std::uint8_t(k) <= std::uint8_t(FaultKind::FrameDuplicate);
}

constexpr bool is_measurement_fault(FaultKind k) { return std::uint8_t(k) <= std::uint8_t(FaultKind::OverTemperature); }
constexpr bool is_plant_fault(FaultKind k) { return std::uint8_t(k) >= std::uint8_t(FaultKind::Leak); }

// Names used in profiles / the control API: "open" "short" "stuck" "drift" "spikes"
// "noise_burst" "over_temperature" "eeprom_error" "silent" "power_cycle" "bus_off"
// "heartbeat_stop" "slow_sdo" "sdo_block_drop", the network faults (a public
// contract, docs/faults.md): "frame_drop" "frame_delay" "frame_freeze" "frame_corrupt"
// "frame_dlc" "frame_duplicate" "node_id_collision" "babbling" "sdo_abort" "sdo_silent"
// "sdo_toggle_error" "clock_drift" "error_frames"; plants: "leak" "blocked" "valve_stuck"
// "input_lost".
std::string_view to_string(FaultKind k);
std::optional<FaultKind> parse_fault_kind(std::string_view s);

// Which measurement channels a measurement fault affects (ignored by OverTemperature,
// which heats the whole sensor, and by communication faults): a set of Channel
// bits, one or both.
enum class FaultChannel : std::uint8_t {
  Pressure = 1u << unsigned(Channel::Pressure),
  Temperature = 1u << unsigned(Channel::Temperature),
  Both = Pressure | Temperature,
};
// A channel's name (physics/channel.hpp) or "both": the profile's `channel:` values.
std::string_view to_string(FaultChannel c);
std::optional<FaultChannel> parse_fault_channel(std::string_view s);

struct FaultTiming {
  // Absolute start of the first occurrence (simulated time, us). If unset, the fault
  // starts `after_us` after the time it is armed (FaultSet::add's arm_time).
  std::optional<TimeUs> at_us;
  TimeUs after_us = 0;
  // Length of each occurrence. < 0: until cancelled. 0: instantaneous (a start and an
  // end edge at the same time, never `active`; e.g. an immediate power cycle).
  // When repeating, a duration >= period is clipped to the period.
  TimeUs duration_us = -1;
  // > 0: the occurrence repeats every period_us (start to start).
  TimeUs period_us = 0;
  // Number of occurrences when repeating; 0 = unlimited. Ignored without a period.
  std::uint32_t count = 0;
};

// Which of the node's frames a network fault acts on (`service:` or `cob_id:`).
enum class FrameService : std::uint8_t { None, CobId, Tpdo, Heartbeat, Emcy, Sdo, BootUp, Lss };

// The class of an error_frames fault (`class:`), as a master's controller reports it.
enum class ErrorClass : std::uint8_t { Warning, Passive, BusOff, Restarted, Stuff, Form, Ack };

// Parameters of the network faults (their profile keys in parentheses).
struct NetFaultParams {
  FrameService service = FrameService::None;   // (service) or CobId (cob_id)
  std::uint16_t tpdo = 0;                      // service tpdo1..tpdo512
  std::uint32_t cob_id = 0;                    // (cob_id): 11-bit, or 29-bit above 0x7FF
  double probability = 1.0;                    // (probability) each selected frame / segment
  TimeUs delay_us = 0;                         // frame_delay (delay)
  TimeUs jitter_us = 0;                        // frame_delay (jitter): up to this much more
  std::uint8_t bytes = 0;                      // frame_corrupt (bytes): bit i = byte i; 0: one random byte
  int value = -1;                              // frame_corrupt (value) 0..255; -1: random bits flipped
  std::uint8_t dlc = 0;                        // frame_dlc (dlc)
  double rate_hz = 0;                          // babbling (rate): frames per second
  double duty = 0;                             // babbling (duty): share of the bus, 0..1
  std::uint16_t index = 0;                     // sdo_abort / sdo_silent (index); sdo_silent 0: every object
  int sub = -1;                                // (sub); -1: every sub-index
  std::uint32_t code = 0;                      // sdo_abort (code)
  double ppm = 0;                              // clock_drift (ppm): > 0 runs fast
  ErrorClass error_class = ErrorClass::Stuff;  // error_frames (class)
  TimeUs error_period_us = 0;                  // error_frames (period): 0 one at the start
};

struct FaultSpec {
  FaultKind kind = FaultKind::SensorOpen;
  FaultChannel channel = FaultChannel::Pressure;
  FaultTiming timing;
  // Parameters, in SI units of the affected channel (Pa for pressure, K for temperature):
  double stuck_value = std::numeric_limits<double>::quiet_NaN();  // StuckValue: NaN = freeze at onset
  double drift_per_s = 0.0;                                       // Drift: error added = drift_per_s * (t - onset)
  double spike_amplitude = 0.0;                                   // Spikes: added to one sample, random sign
  double spike_rate_hz = 0.0;       // Spikes: mean spikes per second (Bernoulli per sample)
  double noise_rms = 0.0;           // NoiseBurst: additional rms noise
  double over_temperature_k = 0.0;  // OverTemperature: added to the sensor temperature (K)
  TimeUs sdo_delay_us = 0;          // SlowSdo: extra delay before each SDO answer
  std::uint32_t drop_every_n = 0;   // SdoBlockDrop: drop every n-th segment (0: use probability)
  double drop_probability = 0.0;    // SdoBlockDrop: probability to drop a segment
  NetFaultParams net;               // the network faults' parameters
  double leak_kv = 0.0;             // Leak: Kv (m3/h) of the hole to the ambient (the plant's valve law)
  double leak_flow_kgs = 0.0;       // Leak: a constant outflow while the volume is above the ambient
  std::uint32_t id = 0;             // caller's tag (e.g. control API request id), echoed in edges
};

using FaultHandle = std::uint32_t;
inline constexpr FaultHandle kInvalidFaultHandle = 0xFFFFFFFFu;

// A start or end of one occurrence, in time order.
struct FaultEdge {
  FaultKind kind;
  bool started;              // true: occurrence began; false: it ended
  TimeUs time_us;            // when (scheduled time, <= the poll time)
  std::uint32_t occurrence;  // 0-based occurrence index
  FaultHandle handle;
  const FaultSpec* spec;  // valid until the set is modified
};

// One armed fault as a control API lists it (FaultSet::armed_faults).
struct FaultInfo {
  FaultHandle handle = kInvalidFaultHandle;
  FaultKind kind = FaultKind::SensorOpen;
  FaultChannel channel = FaultChannel::Pressure;  // meaningful for measurement faults
  bool active = false;                            // an occurrence is in force
  TimeUs first_start = 0;                         // start of the first occurrence
  TimeUs duration_us = -1;                        // each occurrence; < 0: until cancelled
  TimeUs period_us = 0;                           // 0: one occurrence
  std::uint32_t count = 1;                        // occurrences; 0: unlimited
};

// Measurement faults in effect for one channel at one instant (combined).
struct MeasurementFaults {
  bool open = false;
  bool short_circuit = false;
  bool stuck = false;
  double stuck_value = std::numeric_limits<double>::quiet_NaN();  // NaN: freeze at onset
  TimeUs stuck_onset_us = 0;     // onset of the stuck occurrence (to latch the value once)
  double drift = 0.0;            // total drift offset at this instant
  double spike_amplitude = 0.0;  // largest active spike amplitude
  double spike_rate_hz = 0.0;    // summed spike rates
  double extra_noise_rms = 0.0;  // root-sum-square of active noise bursts
  double over_temperature_k = 0.0;
  bool any() const {
    return open || short_circuit || stuck || drift != 0.0 || spike_rate_hz > 0.0 || extra_noise_rms > 0.0 ||
           over_temperature_k != 0.0;
  }
};

class FaultSet {
 public:
  explicit FaultSet(std::size_t capacity = 8);

  // Schedules a fault; `arm_time_us` is the reference for timing.after_us.
  FaultHandle add(const FaultSpec& spec, TimeUs arm_time_us);
  // Ends a fault at `now_us`: an active occurrence ends then (an end edge is produced),
  // no further occurrences start. Returns false for an unknown handle.
  bool cancel(FaultHandle h, TimeUs now_us);
  // Removes everything (node replaced).
  void clear();
  // The seed of the faults' own randomness (network faults: which frames
  // they hit): derive_seed(seed(), handle) per fault. From the fleet seed.
  void set_seed(std::uint64_t seed) { seed_ = seed; }
  std::uint64_t seed() const { return seed_; }

  std::size_t size() const { return entries_.size(); }
  const FaultSpec* spec(FaultHandle h) const;

  // Is any fault of `kind` active at t?
  bool active(FaultKind kind, TimeUs t) const;
  // The first active fault of `kind` at t (nullptr if none); *onset_us = start of its occurrence.
  const FaultSpec* active_spec(FaultKind kind, TimeUs t, TimeUs* onset_us = nullptr) const;
  // Is fault h active at t? (*onset_us as above)
  bool active(FaultHandle h, TimeUs t, TimeUs* onset_us = nullptr) const;

  // Next start/end edge with time <= now_us, in time order across all faults (ties:
  // in handle order, an occurrence's start before its end). Returns false when none is due.
  bool poll(TimeUs now_us, FaultEdge& out);
  // Time of the next pending edge (INT64_MAX if none): lets an event loop schedule a timer.
  TimeUs next_edge_time() const;

  // The faults still armed at t (not cancelled, an occurrence in force or to come), in
  // handle order, timing normalised as add() does. Allocates (control path).
  std::vector<FaultInfo> armed_faults(TimeUs t) const;

  // Combined measurement faults for `channel` at t. Cheap when no measurement fault exists.
  MeasurementFaults measurement(FaultChannel channel, TimeUs t) const;
  bool has_measurement_faults() const { return measurement_count_ > 0; }
  // Until when no measurement fault acts on `channel` (over-temperature acts on
  // both): t when one is in force at t, the start of the next occurrence of
  // one, or kNever.
  TimeUs measurement_quiet_until(FaultChannel channel, TimeUs t) const;

 private:
  struct Entry {
    FaultSpec spec;
    TimeUs start;      // first occurrence start
    TimeUs cancel_at;  // INT64_MAX if not cancelled
    // edge cursor
    std::uint32_t next_occ = 0;
    bool end_pending = false;
    bool done = false;
  };
  bool occurrence_at(const Entry& e, TimeUs t, TimeUs* onset) const;
  bool armed(const Entry& e, TimeUs t) const;
  TimeUs pending_edge_time(const Entry& e) const;  // INT64_MAX if none
  void advance_cursor(Entry& e);

  std::vector<Entry> entries_;
  std::size_t measurement_count_ = 0;
  std::uint64_t seed_ = 1;
};

}  // namespace cansim::physics
