// Plants: processes that answer the controller (docs/plants.md).
//
// A plant is a graph of named blocks wired by name, fed by named inputs, and
// read by any number of sensor chains. It advances on its own fixed step
// (default 1 ms) in whole steps, lazily: a read or an input change at time t
// first computes every step k with k * step <= t, so a plant that nobody
// reads costs nothing and wakes no timer. Its values depend only on the
// fleet seed, its inputs and their times, never on who reads it or how often.
//
// Decisions:
//  * Step k computes, at t_k = k * step, every block's outputs from the
//    state x_k and the inputs at t_k, then the next state x_{k+1}. A reading
//    at t with t_k <= t < t_{k+1} is step k's value. An input set at t acts
//    from the first step after t (the plant is first brought to t).
//  * Blocks with state (volume, lag, second order, integrator, rate limit,
//    dead time, line, heat source) output from their state only: they break
//    loops. A cycle through blocks without state is an algebraic loop,
//    refused at load with the cycle named. Outputs are computed in one
//    topological order, then the states advance.
//  * Linear blocks advance exactly for a piecewise-constant input (zero-order
//    hold: first and second order by their closed-form transition, the
//    integrator by u * step). A gas volume integrates its mass balance with
//    an exponential Euler step on the flows wired straight from its own
//    pressure (their derivatives), so it is exact for flows linear in its
//    pressure (a choked valve) and stable for any valve on any step.
//  * Flows are mass flows (kg/s), positive from upstream to downstream;
//    openings and speeds are fractions 0..1 (clamped). Pressures are absolute.
//  * A NaN or an infinity never leaves a block: the output keeps its last
//    finite value (a state its last finite state), the block counts it, and
//    the plant's hook (the daemon's journal line) names the block.
//  * History: a variable a sensor reads is kept for the sensor's look-back
//    (Plant::watch), so a chain that catches up samples of the past reads
//    what the plant was then, whoever advanced it since.
//  * Nothing on the step path allocates: slots, rings and block states are
//    sized when the plant is built.
#pragma once

#include <cstdint>
#include <limits>
#include <memory>
#include <optional>
#include <stdexcept>
#include <string>
#include <string_view>
#include <variant>
#include <vector>

#include "physics/fault.hpp"
#include "physics/plant_units.hpp"
#include "physics/process.hpp"
#include "physics/table.hpp"
#include "physics/time.hpp"

namespace cansim::physics {

// A refused plant: `where` is the loader's location of the part at fault
// (e.g. "fleet.yaml:14:9: plants.tank.blocks.vent"), what() includes it.
class PlantError : public std::invalid_argument {
 public:
  PlantError(const std::string& where, const std::string& what)
      : std::invalid_argument(where.empty() ? what : where + ": " + what), where(where), reason(what) {}
  std::string where;
  std::string reason;
};

// ------------------------------------------------------------------ specs

// A block input: a constant (SI) or a name: an input, BLOCK (its first
// output), BLOCK.OUTPUT, or OUTPUT when one block of the plant has it.
struct PlantSignal {
  std::string ref;
  double constant = 0.0;
  std::string origin;  // loader's location, for errors
  static PlantSignal value(double v) { return {"", v, ""}; }
  bool is_constant() const { return ref.empty(); }
};

struct GasVolumeBlock {
  double volume_m3 = 1e-3;
  double initial_pressure_pa = kAmbientPressurePa;
  double temperature_k = kRoomTemperatureK;  // isothermal at this temperature ...
  std::optional<PlantSignal> temperature;    // ... or following this signal (K)
  std::vector<PlantSignal> inflow, outflow;  // kg/s
};

// Flow through a restriction. Gas, Kv law (VDI/VDE 2173, the valve makers'
// sizing formula): supercritical (p2 <= p1 / 2, choked) Qn = 257 Kv p1 /
// sqrt(rho_n T1), else Qn = 514 Kv sqrt(dp p2 / (rho_n T1)) [bar, K, m3/h].
// Liquid, Kv law: Q = Kv sqrt(dp / SG) [m3/h, bar]. Orifice (area and
// discharge coefficient): isentropic nozzle for a gas (choked below the
// critical ratio), Bernoulli for a liquid. Linear in dp below linear_below.
struct ValveBlock {
  enum class Law : std::uint8_t { kKv, kOrifice };
  Law law = Law::kKv;
  double kv = 1.0;          // m3/h at full opening
  double area_m2 = 1e-6;    // orifice
  double discharge = 0.62;  // orifice discharge coefficient
  double linear_below_pa = 1000.0;
  PlantSignal upstream = PlantSignal::value(kAmbientPressurePa);
  PlantSignal downstream = PlantSignal::value(kAmbientPressurePa);
  PlantSignal opening = PlantSignal::value(1.0);
  PlantSignal temperature = PlantSignal::value(kRoomTemperatureK);  // of the gas upstream
};

// A pump or compressor: flow = speed * nominal flow; with a curve (flow at
// full speed against outlet - inlet pressure) flow = speed * curve(dp /
// speed^2) (the affinity laws).
struct PumpBlock {
  double nominal_flow_kgs = 1e-3;
  std::vector<TablePoint> curve;  // t_s = dp in Pa, value = kg/s at full speed; empty: none
  PlantSignal speed = PlantSignal::value(1.0);
  PlantSignal inlet = PlantSignal::value(kAmbientPressurePa);
  PlantSignal outlet = PlantSignal::value(kAmbientPressurePa);
};

// A line: what enters comes out `delay` later (transport dead time).
struct LineBlock {
  PlantSignal in;
  double delay_s = 0.1;
};

// A thermal mass with a heat source or sink: tau dT/dt = ambient + gain * power - T.
struct HeatSourceBlock {
  double time_constant_s = 60.0;
  double gain_k_per_w = 0.01;
  double initial_k = std::numeric_limits<double>::quiet_NaN();  // NaN: settled at t = 0
  PlantSignal power = PlantSignal::value(0.0);
  PlantSignal ambient = PlantSignal::value(kRoomTemperatureK);
};

struct GainBlock {
  PlantSignal in;
  double k = 1.0;
};
struct OffsetBlock {
  PlantSignal in;
  double offset = 0.0;
};
struct SumBlock {
  std::vector<PlantSignal> add, subtract;
};
// tau dy/dt + y = gain * u. initial NaN: settled at t = 0.
struct LagBlock {
  PlantSignal in;
  double time_constant_s = 1.0;
  double gain = 1.0;
  double initial = std::numeric_limits<double>::quiet_NaN();
};
// y'' + 2 zeta w y' + w^2 y = w^2 gain u, w = 2 pi natural_frequency.
struct SecondOrderBlock {
  PlantSignal in;
  double natural_frequency_hz = 1.0;
  double damping = 0.7;
  double gain = 1.0;
  double initial = std::numeric_limits<double>::quiet_NaN();
};
// dy/dt = gain * u, y held in [min, max] (clamping anti-windup: at a limit
// the integrator does not wind further, it leaves it as soon as u turns).
struct IntegratorBlock {
  PlantSignal in;
  double gain = 1.0;
  double min = -std::numeric_limits<double>::infinity();
  double max = std::numeric_limits<double>::infinity();
  double initial = 0.0;
};
// y follows u at most `rise` per second up and `fall` per second down.
struct RateLimitBlock {
  PlantSignal in;
  double rise_per_s = 1.0;
  double fall_per_s = 1.0;
  double initial = std::numeric_limits<double>::quiet_NaN();
};
struct SaturationBlock {
  PlantSignal in;
  double min = 0.0, max = 1.0;
};
struct DeadTimeBlock {
  PlantSignal in;
  double delay_s = 0.1;
  double initial = std::numeric_limits<double>::quiet_NaN();  // NaN: the first input
};
// y = table(u): linear between points, the end values beyond them.
struct TableBlock {
  PlantSignal in;
  std::vector<TablePoint> points;  // t_s = u (SI), value = y (SI)
};

using BlockParams = std::variant<GasVolumeBlock, ValveBlock, PumpBlock, LineBlock, HeatSourceBlock, GainBlock,
                                 OffsetBlock, SumBlock, LagBlock, SecondOrderBlock, IntegratorBlock, RateLimitBlock,
                                 SaturationBlock, DeadTimeBlock, TableBlock>;

// The type names of a plant's `blocks:` (gas_volume, valve, ...), in the
// order of BlockParams.
std::string_view block_type_name(const BlockParams& p);
std::string block_type_names();

struct BlockSpec {
  std::string name;
  BlockParams params;
  // What a linear block's output measures (nullopt: what its input does).
  std::optional<QuantityKind> kind;
  std::string origin;
};

struct PlantInputSpec {
  enum class Source : std::uint8_t {
    kPush,      // set at run time: frames, node objects, the control API
    kTime,      // a function of time (today's process terms)
    kPlant,     // another plant's variable
    kExternal,  // pulled from outside at every step (a node's output)
  };
  std::string name;
  QuantityKind kind = QuantityKind::kNumber;
  std::string unit;                  // as configured ("%", "bar"); "" : the kind's display unit
  double initial = 0.0;              // SI, until the first value comes
  TimeUs timeout_us = 0;             // > 0: no value for this long is a lost command ...
  std::optional<double> on_timeout;  // ... then this value (SI); nullopt: hold the last one
  Source source = Source::kPush;
  std::vector<TermSpec> terms;  // kTime
  std::string plant_ref;        // kPlant: "PLANT.VARIABLE"
  std::string description;      // where its values come from, for people ("frame vcan0 0x300 ...")
  std::string origin;
};

// Plant fault kinds (FaultKind::Leak .. InputLost) with their target.
struct PlantFaultSpec {
  FaultSpec fault;
  std::string target;  // a block (leak: a gas volume; blocked: a valve, pump or line; valve_stuck: a valve) or an input
  std::string origin;
};

struct PlantSpec {
  std::string name;
  std::string origin;
  TimeUs step_us = 1000;
  Medium medium;
  std::vector<PlantInputSpec> inputs;
  std::vector<BlockSpec> blocks;
  std::vector<PlantFaultSpec> faults;  // armed at time 0
};

// ------------------------------------------------------------------ the engine

using PlantVar = std::uint32_t;  // a variable (block output or input) of one plant
inline constexpr PlantVar kNoVar = 0xFFFFFFFFu;

// A value pulled from outside at every step (Source::kExternal): a pure
// function of time, as a node's moving output.
struct ExternalSource {
  double (*value)(const void* context, TimeUs t) = nullptr;
  const void* context = nullptr;
  explicit operator bool() const { return value != nullptr; }
};

// Called on the step path when a block produced a NaN or an infinity (the
// owner logs it; it must not touch the plant).
using NonFiniteHook = void (*)(void* context, const std::string& plant, const std::string& block, std::uint64_t count,
                               TimeUs t);
// Called on the step path when a fault of the plant begins or ends (the
// step at or after the edge time t); it must not touch the plant.
class Plant;
using PlantFaultHook = void (*)(void* context, const Plant& plant, FaultHandle id, FaultKind kind, bool started,
                                TimeUs t);

class PlantGroup;

class Plant {
 public:
  // Throws PlantError (naming the spec's part) for an invalid spec: an
  // unknown name, an algebraic loop, an impossible parameter. Inputs of kind
  // kPlant are left unbound (PlantSet binds them).
  Plant(const PlantSpec& spec, std::uint64_t seed);
  ~Plant();
  Plant(const Plant&) = delete;
  Plant& operator=(const Plant&) = delete;

  const std::string& name() const { return spec_.name; }
  const PlantSpec& spec() const { return spec_; }
  TimeUs step_us() const { return step_us_; }
  // The time of the latest computed step (-step before the first).
  TimeUs time() const { return (next_ - 1) * step_us_; }
  std::uint64_t steps() const { return std::uint64_t(next_); }

  // ---- variables
  struct VariableInfo {
    std::string name;  // "vessel.pressure", or the input's name
    QuantityKind kind;
    bool is_input;
  };
  // A variable by name (as a block input names it); kNoVar with *why.
  PlantVar find(std::string_view name, std::string* why = nullptr) const;
  const std::vector<VariableInfo>& variables() const { return vars_; }
  // Keeps `var`'s values for `lookback_us` (at least 256 steps): readers of
  // the past get them. Allocates (set-up, not the read path).
  void watch(PlantVar var, TimeUs lookback_us);
  // The value at t (SI): advances the plant to t; a t before the latest step
  // reads the history of a watched variable (the oldest kept value beyond
  // it; the current value for a variable nobody watches).
  double value(PlantVar var, TimeUs t);
  // Computes every step up to t (see the header). Plants of one group (cross
  // references) advance together.
  void advance_to(TimeUs t);

  // ---- inputs (index into spec().inputs)
  std::size_t input_count() const;
  std::optional<std::size_t> find_input(std::string_view name) const;
  // A value of a kPush input arrives at t (SI). Non-finite values are
  // refused (counted). Dropped while an input_lost fault is in force.
  void set_input(std::size_t input, double value, TimeUs t);
  // The control API: the input is `value` whatever its source says, until
  // clear_override.
  void override_input(std::size_t input, double value, TimeUs t);
  void clear_override(std::size_t input, TimeUs t);
  void bind_external(std::size_t input, ExternalSource source, TimeUs t);
  struct InputState {
    double value = 0;         // SI, what the latest step used
    double current = 0;       // SI, what it is now (an override or a value set since: the next step's)
    double source_value = 0;  // what its source gave last
    TimeUs updated = -1;      // when its source gave it (-1: never)
    bool overridden = false;
    bool stuck = false;         // valve_stuck in force
    bool lost = false;          // input_lost in force
    bool timed_out = false;     // the timeout behaviour shows
    std::uint64_t refused = 0;  // non-finite values refused
  };
  // `now`: the instant `current` is for (the plant's time when earlier).
  InputState input_state(std::size_t input, TimeUs now = -1) const;

  // ---- faults (FaultKind::Leak, Blocked, ValveStuck, InputLost)
  // Throws PlantError when the kind does not fit the target.
  FaultHandle arm_fault(const PlantFaultSpec& spec, TimeUs now);
  bool cancel_fault(FaultHandle h, TimeUs now);
  std::vector<FaultInfo> armed_faults(TimeUs now) const;
  const FaultSpec* fault_spec(FaultHandle h) const { return faults_.spec(h); }
  const std::string& fault_target(FaultHandle h) const;
  // When the next fault edge is due (TimeUs max: none): the owner advances
  // the plant then, so the edge shows on time even with nobody reading.
  TimeUs next_fault_edge() const;
  void set_fault_hook(PlantFaultHook hook, void* context) {
    fault_hook_ = hook;
    fault_context_ = context;
  }

  // ---- non-finite values
  struct BlockHealth {
    std::string name;
    std::uint64_t non_finite = 0;
  };
  std::vector<BlockHealth> health() const;
  void set_non_finite_hook(NonFiniteHook hook, void* context) {
    hook_ = hook;
    hook_context_ = context;
  }

  struct Impl;

 private:
  friend class PlantSet;
  friend class PlantGroup;
  void step_once();
  void advance_own(TimeUs t);
  void bind_plant(std::size_t input, Plant* other, PlantVar var);
  void apply_fault_edges(TimeUs t);
  double input_value(std::size_t i, TimeUs t);
  void record_history();
  double history(PlantVar var, std::int64_t step) const;

  PlantSpec spec_;
  TimeUs step_us_;
  std::int64_t next_ = 0;  // the next step to compute
  std::vector<VariableInfo> vars_;
  std::unique_ptr<Impl> impl_;
  struct Input;
  std::vector<Input> inputs_;
  FaultSet faults_;
  std::vector<std::string> fault_targets_;  // by handle
  TimeUs next_edge_ = std::numeric_limits<TimeUs>::max();
  NonFiniteHook hook_ = nullptr;
  void* hook_context_ = nullptr;
  PlantFaultHook fault_hook_ = nullptr;
  void* fault_context_ = nullptr;
  PlantGroup* group_ = nullptr;
};

// Every plant of a fleet, by name: builds them, binds the inputs that read
// another plant (refusing a cycle between plants), and groups plants that
// read each other so they advance together.
class PlantSet {
 public:
  // Throws PlantError. `seed`: the fleet seed (each plant derives its own).
  PlantSet(const std::vector<PlantSpec>& specs, std::uint64_t seed);
  ~PlantSet();
  Plant* find(std::string_view name) const;
  const std::vector<std::unique_ptr<Plant>>& plants() const { return plants_; }
  // "PLANT.VARIABLE" -> the plant and its variable; null with *why.
  Plant* resolve(std::string_view ref, PlantVar& var, std::string* why) const;
  void set_non_finite_hook(NonFiniteHook hook, void* context);
  void set_fault_hook(PlantFaultHook hook, void* context);
  // Every plant advanced to t (what an observer's look-up does anyway).
  void advance_all(TimeUs t);
  // The earliest next_fault_edge() of the plants; advance_faults(now) brings
  // the plants with an edge due by now to now.
  TimeUs next_fault_edge() const;
  void advance_faults(TimeUs now);

 private:
  std::vector<std::unique_ptr<Plant>> plants_;
  std::vector<std::unique_ptr<PlantGroup>> groups_;
};

// How a sensor's process term finds its plant variable (physics::PlantTermSpec).
class PlantResolver {
 public:
  virtual ~PlantResolver() = default;
  // Throws std::invalid_argument naming the term's origin when the
  // reference does not resolve.
  virtual PlantTap resolve(const PlantTermSpec& term, Channel channel, TimeUs lookback_us) const = 0;
};

// A PlantSet as a resolver: checks that the variable measures what the
// channel does (a pressure for the pressure channel, a temperature for the
// temperature channel) and watches it for the reader's look-back.
class PlantSetResolver : public PlantResolver {
 public:
  explicit PlantSetResolver(const PlantSet& set) : set_(set) {}
  PlantTap resolve(const PlantTermSpec& term, Channel channel, TimeUs lookback_us) const override;

 private:
  const PlantSet& set_;
};

}  // namespace cansim::physics
