#include "physics/plant.hpp"

#include <algorithm>
#include <cmath>
#include <functional>
#include <map>
#include <set>

#include "physics/plant_blocks.hpp"
#include "physics/random.hpp"

namespace cansim::physics {

namespace {

using Slot = std::uint32_t;
constexpr Slot kNoSlot = 0xFFFFFFFFu;
constexpr double kTwoPi = 6.283185307179586476925286766559;
constexpr std::size_t kMinHistorySteps = 256;
constexpr std::size_t kMaxHistorySteps = std::size_t(1) << 20;
constexpr std::size_t kMaxDelaySteps = std::size_t(1) << 22;  // 70 min at 1 ms
constexpr TimeUs kGroupChunkUs = 100'000;                     // plants that read each other advance in turns of 100 ms

template <class... Ts>
struct overloaded : Ts... {
  using Ts::operator()...;
};
template <class... Ts>
overloaded(Ts...) -> overloaded<Ts...>;

bool finite(double v) { return std::isfinite(v); }

// ------------------------------------------------------------------ blocks at run time
//
// Each block writes its outputs to v[out], v[out + 1] ... in output(); blocks
// with state advance it in update() (false: the new state would not be
// finite, the old one is kept) and, when told to settle, take the steady
// state of the inputs they see in settle().

struct GasVolumeRt {
  Slot out;          // pressure, temperature, mass
  Slot temperature;  // kNoSlot: isothermal
  double temperature_k;
  double volume, r, initial_pressure;
  std::vector<Slot> inflow, outflow;
  std::vector<std::pair<const double*, double>> derivatives;  // d flow / d p (this volume), sign
  double mass = 0;
  bool initialised = false;
  double leak_kv = 0, leak_flow = 0;
  int leaks = 0;
  Medium medium;

  double temp(const double* v) const { return temperature == kNoSlot ? temperature_k : v[temperature]; }
  void output(double* v) {
    const double t = temp(v);
    if (!initialised) {
      mass = initial_pressure * volume / (r * t);
      initialised = true;
    }
    v[out] = mass * r * t / volume;
    v[out + 1] = t;
    v[out + 2] = mass;
  }
  // dm/dt = sum(in) - sum(out) - leak; the flows wired straight from this
  // volume's pressure are taken implicitly: dm = h F phi1(h dF/dm).
  bool update(double* v, double h) {
    const double t = temp(v);
    const double p = v[out];
    double net = 0, dfdp = 0;
    for (Slot s : inflow) net += v[s];
    for (Slot s : outflow) net -= v[s];
    for (const auto& [partial, sign] : derivatives) dfdp += sign * *partial;
    if (leaks > 0) {
      if (leak_kv > 0) {
        const flow::Flow f = flow::kv_gas(p, kAmbientPressurePa, flow::kv_gas_coefficient(leak_kv, medium, t), 1000.0);
        net -= f.m;
        dfdp -= f.d1;
      }
      if (leak_flow > 0 && p > kAmbientPressurePa) net -= leak_flow;
    }
    const double lambda = dfdp * r * t / volume;  // d net / d mass
    const double next = std::max(0.0, mass + h * net * flow::phi1(lambda * h));
    if (!finite(next)) return false;
    mass = next;
    return true;
  }
};

struct ValveRt {
  Slot out;  // flow
  Slot upstream, downstream, opening, temperature;
  ValveBlock::Law law;
  double kv, k;  // Kv at full opening; Cd A at full opening
  double linear;
  Medium medium;
  double d_up = 0, d_down = 0;
  int blocked = 0, stuck = 0;
  double stuck_opening = 0;

  double opening_of(const double* v) const { return stuck > 0 ? stuck_opening : std::clamp(v[opening], 0.0, 1.0); }
  flow::Flow forward(double p1, double p2, double x, double t) const {
    if (law == ValveBlock::Law::kKv)
      return medium.gas ? flow::kv_gas(p1, p2, flow::kv_gas_coefficient(kv * x, medium, t), linear)
                        : flow::kv_liquid(p1, p2, kv * x, medium.density, linear);
    return medium.gas ? flow::orifice_gas(p1, p2, k * x, medium, t, linear)
                      : flow::orifice_liquid(p1, p2, k * x, medium.density, linear);
  }
  void output(double* v) {
    const double x = opening_of(v);
    const double p1 = v[upstream], p2 = v[downstream];
    flow::Flow f;
    if (blocked == 0 && x > 0) {
      if (p1 >= p2) {
        f = forward(p1, p2, x, v[temperature]);
      } else {  // reverse flow: the same law from downstream to upstream
        const flow::Flow r = forward(p2, p1, x, v[temperature]);
        f = {-r.m, -r.d2, -r.d1};
      }
    }
    v[out] = f.m;
    d_up = f.d1;
    d_down = f.d2;
  }
};

struct PumpRt {
  Slot out;
  Slot speed, inlet, outlet;
  double nominal;
  Table curve;
  bool has_curve;
  int blocked = 0;
  double d_outlet = 0, d_inlet = 0;
  void output(double* v) {
    const double s = std::clamp(v[speed], 0.0, 1.0);
    d_outlet = d_inlet = 0;
    if (blocked > 0 || s <= 0) {
      v[out] = 0;
      return;
    }
    if (!has_curve) {
      v[out] = s * nominal;
      return;
    }
    const double x = (v[outlet] - v[inlet]) / (s * s);  // affinity: head goes with speed^2
    v[out] = s * curve.value(x);
    const double slope = curve.slope(x) / s;
    d_outlet = slope;
    d_inlet = -slope;
  }
};

// A ring of the last n inputs: output = the input n steps ago.
struct DelayRing {
  std::vector<double> ring;
  std::size_t pos = 0;
  double oldest() const { return ring[pos]; }
  void push(double u) {
    ring[pos] = u;
    if (++pos == ring.size()) pos = 0;
  }
  void fill(double u) { std::fill(ring.begin(), ring.end(), u); }
};

struct LineRt {
  Slot out, in;
  DelayRing delay;
  int blocked = 0;
  void output(double* v) { v[out] = blocked > 0 ? 0.0 : delay.oldest(); }
  bool update(double* v, double) {
    delay.push(v[in]);
    return true;
  }
};

struct HeatSourceRt {
  Slot out, power, ambient;
  double decay, gain;  // e^(-h / tau), K/W
  double temperature;
  bool settle_first;
  double target(const double* v) const { return v[ambient] + gain * v[power]; }
  void output(double* v) { v[out] = temperature; }
  bool update(double* v, double) {
    const double ss = target(v);
    const double next = ss + (temperature - ss) * decay;
    if (!finite(next)) return false;
    temperature = next;
    return true;
  }
  void settle(const double* v) { temperature = target(v); }
};

struct GainRt {
  Slot out, in;
  double k;
  void output(double* v) { v[out] = k * v[in]; }
};
struct OffsetRt {
  Slot out, in;
  double offset;
  void output(double* v) { v[out] = v[in] + offset; }
};
struct SumRt {
  Slot out;
  std::vector<Slot> add, subtract;
  void output(double* v) {
    double s = 0;
    for (Slot a : add) s += v[a];
    for (Slot b : subtract) s -= v[b];
    v[out] = s;
  }
};
struct SaturationRt {
  Slot out, in;
  double min, max;
  void output(double* v) { v[out] = std::clamp(v[in], min, max); }
};
struct TableRt {
  Slot out, in;
  Table table;
  void output(double* v) { v[out] = table.value(v[in]); }
};

// Zero-order hold: y(k + 1) = g u + (y(k) - g u) e^(-h / tau), exact for u held over the step.
struct LagRt {
  Slot out, in;
  double decay, gain, y;
  bool settle_first;
  void output(double* v) { v[out] = y; }
  bool update(double* v, double) {
    const double target = gain * v[in];
    const double next = target + (y - target) * decay;
    if (!finite(next)) return false;
    y = next;
    return true;
  }
  void settle(const double* v) { y = gain * v[in]; }
};

// Zero-order hold of y'' + 2 zeta w y' + w^2 y = w^2 g u: the error e = (y -
// g u, y') moves by the transition matrix phi = e^(A h) of the free system.
struct SecondOrderRt {
  Slot out, in;
  double phi[2][2];
  double gain, y, dy = 0;
  bool settle_first;
  void output(double* v) { v[out] = y; }
  bool update(double* v, double) {
    const double target = gain * v[in];
    const double e = y - target;
    const double ny = target + phi[0][0] * e + phi[0][1] * dy;
    const double ndy = phi[1][0] * e + phi[1][1] * dy;
    if (!finite(ny) || !finite(ndy)) return false;
    y = ny;
    dy = ndy;
    return true;
  }
  void settle(const double* v) {
    y = gain * v[in];
    dy = 0;
  }
};

struct IntegratorRt {
  Slot out, in;
  double gain, min, max, y;
  void output(double* v) { v[out] = y; }
  bool update(double* v, double h) {
    const double next = std::clamp(y + gain * v[in] * h, min, max);
    if (!finite(next)) return false;
    y = next;
    return true;
  }
};

struct RateLimitRt {
  Slot out, in;
  double rise, fall, y;  // per step
  bool settle_first;
  void output(double* v) { v[out] = y; }
  bool update(double* v, double) {
    const double next = y + std::clamp(v[in] - y, -fall, rise);
    if (!finite(next)) return false;
    y = next;
    return true;
  }
  void settle(const double* v) { y = v[in]; }
};

struct DeadTimeRt {
  Slot out, in;
  DelayRing delay;
  bool settle_first;
  void output(double* v) { v[out] = delay.oldest(); }
  bool update(double* v, double) {
    delay.push(v[in]);
    return true;
  }
  void settle(const double* v) { delay.fill(v[in]); }
};

using BlockRt = std::variant<GasVolumeRt, ValveRt, PumpRt, LineRt, HeatSourceRt, GainRt, OffsetRt, SumRt, LagRt,
                             SecondOrderRt, IntegratorRt, RateLimitRt, SaturationRt, DeadTimeRt, TableRt>;

template <class B>
concept HasUpdate = requires(B b, double* v) {
  b.update(v, 1.0);
};
template <class B>
concept HasSettle = requires(B b, const double* v) {
  b.settle(v);
};

// The transition matrix of the free second-order system over h (closed forms
// of the responses from (1, 0) and (0, 1): under-, critically and overdamped).
void second_order_transition(double w, double zeta, double h, double phi[2][2]) {
  if (std::abs(zeta - 1.0) < 1e-9) {
    const double e = std::exp(-w * h);
    phi[0][0] = e * (1 + w * h);
    phi[0][1] = h * e;
    phi[1][0] = -w * w * h * e;
    phi[1][1] = e * (1 - w * h);
  } else if (zeta < 1.0) {
    const double a = zeta * w, b = w * std::sqrt(1 - zeta * zeta);
    const double e = std::exp(-a * h), c = std::cos(b * h), s = std::sin(b * h);
    phi[0][0] = e * (c + a / b * s);
    phi[0][1] = e * s / b;
    phi[1][0] = -e * w * w / b * s;
    phi[1][1] = e * (c - a / b * s);
  } else {
    const double r = std::sqrt(zeta * zeta - 1);
    const double p2 = w * (zeta + r), p1 = w * w / p2;  // p1 < p2
    const double e1 = std::exp(-p1 * h), e2 = std::exp(-p2 * h);
    const double d = p2 - p1;
    phi[0][0] = (p2 * e1 - p1 * e2) / d;
    phi[0][1] = (e1 - e2) / d;
    phi[1][0] = p1 * p2 * (e2 - e1) / d;
    phi[1][1] = (p2 * e2 - p1 * e1) / d;
  }
}

// Output names of each block type, the first is its main output.
struct Outputs {
  const char* names[3];
  QuantityKind kinds[3];
  int count;
};
Outputs outputs_of(const BlockParams& p) {
  using K = QuantityKind;
  return std::visit(
      overloaded{
          [](const GasVolumeBlock&) {
            return Outputs{{"pressure", "temperature", "mass"}, {K::kPressure, K::kTemperature, K::kMass}, 3};
          },
          [](const ValveBlock&) {
            return Outputs{{"flow"}, {K::kMassFlow}, 1};
          },
          [](const PumpBlock&) {
            return Outputs{{"flow"}, {K::kMassFlow}, 1};
          },
          [](const LineBlock&) {
            return Outputs{{"flow"}, {K::kMassFlow}, 1};
          },
          [](const HeatSourceBlock&) {
            return Outputs{{"temperature"}, {K::kTemperature}, 1};
          },
          [](const auto&) {
            return Outputs{{"out"}, {K::kNumber}, 1};
          },
      },
      p);
}

constexpr const char* kBlockTypeNames[] = {"gas_volume", "valve",      "pump",       "line",      "heat_source",
                                           "gain",       "offset",     "sum",        "lag",       "second_order",
                                           "integrator", "rate_limit", "saturation", "dead_time", "table"};
static_assert(std::size(kBlockTypeNames) == std::variant_size_v<BlockParams>);

}  // namespace

std::string_view block_type_name(const BlockParams& p) { return kBlockTypeNames[p.index()]; }

std::string block_type_names() {
  std::string out;
  for (const char* n : kBlockTypeNames) out += (out.empty() ? "" : ", ") + std::string(n);
  return out;
}

// ------------------------------------------------------------------ the plant's parts

struct Plant::Input {
  PlantInputSpec::Source source;
  Slot slot;
  TimeUs timeout;
  std::optional<double> on_timeout;
  InputState st;
  TermSeries series;
  Plant* other = nullptr;
  PlantVar other_var = kNoVar;
  ExternalSource external;
  int stuck = 0, lost = 0;
  double stuck_value = 0;
  double override_value = 0;
};

namespace {
struct History {
  Slot slot;
  std::vector<double> ring;  // power-of-two size, indexed by step
  std::int64_t first = 0;    // the first step it holds
};
}  // namespace

struct Plant::Impl {
  std::vector<double> v;     // every slot's value this step
  std::vector<double> good;  // the last finite value of each slot
  std::vector<BlockRt> blocks;
  std::vector<std::string> block_names;
  std::vector<std::uint64_t> non_finite;
  std::vector<std::uint32_t> order;       // output() order
  std::vector<std::uint32_t> stateful;    // blocks with update()
  std::vector<std::uint32_t> settling;    // blocks that settle at step 0
  std::vector<Slot> var_slot;             // PlantVar -> slot
  std::vector<std::int32_t> var_history;  // PlantVar -> index in history, -1
  std::vector<History> history;
  std::vector<std::pair<Slot, Slot>> block_outputs;  // per block: first slot, count
  std::map<std::string, std::uint32_t, std::less<>> block_index;
  std::map<std::string, std::size_t, std::less<>> input_index;
  double h = 1e-3;
};

// ------------------------------------------------------------------ building

namespace {

// Builds the run-time graph of one plant from its spec.
class Builder {
 public:
  Builder(const PlantSpec& spec, Plant::Impl& impl, std::vector<Plant::VariableInfo>& vars)
      : spec_(spec), impl_(impl), vars_(vars) {}

  void declare() {
    for (std::size_t i = 0; i < spec_.inputs.size(); ++i) {
      const PlantInputSpec& in = spec_.inputs[i];
      if (in.name.empty() || in.name.find('.') != std::string::npos)
        throw PlantError(in.origin, "expected an input name without '.'");
      if (!impl_.input_index.emplace(in.name, i).second)
        throw PlantError(in.origin, "input " + in.name + " defined twice");
      add_var(in.name, in.kind, true);
    }
    for (std::uint32_t b = 0; b < spec_.blocks.size(); ++b) {
      const BlockSpec& bs = spec_.blocks[b];
      if (bs.name.empty() || bs.name.find('.') != std::string::npos)
        throw PlantError(bs.origin, "expected a block name without '.'");
      if (impl_.input_index.count(bs.name)) throw PlantError(bs.origin, bs.name + " is already an input's name");
      if (!impl_.block_index.emplace(bs.name, b).second)
        throw PlantError(bs.origin, "block " + bs.name + " defined twice");
      const Outputs o = outputs_of(bs.params);
      impl_.block_outputs.emplace_back(Slot(vars_.size()), Slot(o.count));
      for (int i = 0; i < o.count; ++i) {
        const bool linear = bs.params.index() >= 5;
        add_var(bs.name + "." + o.names[i], linear && bs.kind ? *bs.kind : o.kinds[i], false);
        output_names_.emplace(o.names[i], Slot(vars_.size() - 1));
      }
    }
    // Slots: the variables first (var i is slot i), constants after.
    impl_.var_slot.resize(vars_.size());
    for (Slot i = 0; i < vars_.size(); ++i) impl_.var_slot[i] = i;
  }

  // The slot a signal reads; records the block it depends on (feeds) when
  // that input is direct feedthrough.
  Slot resolve(const PlantSignal& s, std::uint32_t block, bool feedthrough) {
    if (s.is_constant()) {
      if (!finite(s.constant)) throw PlantError(s.origin, "expected a finite value");
      constants_.push_back(s.constant);
      return Slot(vars_.size() + constants_.size() - 1);
    }
    std::string why;
    const PlantVar var = find_var(s.ref, &why);
    if (var == kNoVar) throw PlantError(s.origin.empty() ? spec_.blocks[block].origin : s.origin, why);
    if (feedthrough && !vars_[var].is_input) edges_[block].insert(producer_of(var));
    return impl_.var_slot[var];
  }

  PlantVar find_var(std::string_view name, std::string* why) const {
    if (auto it = impl_.input_index.find(name); it != impl_.input_index.end()) return PlantVar(it->second);
    const auto dot = name.find('.');
    if (dot == std::string_view::npos) {
      if (auto it = impl_.block_index.find(name); it != impl_.block_index.end())
        return impl_.block_outputs[it->second].first;
      const auto [lo, hi] = output_names_.equal_range(std::string(name));
      if (lo != hi && std::next(lo) == hi) return lo->second;
      if (why) {
        if (lo == hi) {
          *why = "unknown name '" + std::string(name) +
                 "': expected an input, a block, BLOCK.OUTPUT or an output name (" + names() + ")";
        } else {
          std::string which;
          for (auto it = lo; it != hi; ++it) which += (which.empty() ? "" : ", ") + vars_[it->second].name;
          *why = "'" + std::string(name) + "' is ambiguous: " + which;
        }
      }
      return kNoVar;
    }
    for (PlantVar i = 0; i < vars_.size(); ++i)
      if (!vars_[i].is_input && vars_[i].name == name) return i;
    if (why) *why = "unknown variable '" + std::string(name) + "' (" + names() + ")";
    return kNoVar;
  }

  std::uint32_t producer_of(PlantVar var) const {
    for (std::uint32_t b = 0; b < impl_.block_outputs.size(); ++b) {
      const auto [first, count] = impl_.block_outputs[b];
      if (var >= first && var < first + count) return b;
    }
    return 0;
  }

  std::string names() const {
    std::string out;
    for (const auto& v : vars_) out += (out.empty() ? "" : ", ") + v.name;
    return out;
  }

  void build_blocks(double h) {
    edges_.resize(spec_.blocks.size());
    for (std::uint32_t b = 0; b < spec_.blocks.size(); ++b) impl_.blocks.push_back(build(b, h));
    impl_.v.assign(vars_.size() + constants_.size(), 0.0);
    for (std::size_t i = 0; i < constants_.size(); ++i) impl_.v[vars_.size() + i] = constants_[i];
    impl_.good = impl_.v;
    for (std::uint32_t b = 0; b < impl_.blocks.size(); ++b) {
      impl_.block_names.push_back(spec_.blocks[b].name);
      std::visit(
          [&](auto& rt) {
            using B = std::decay_t<decltype(rt)>;
            if constexpr (HasUpdate<B>) impl_.stateful.push_back(b);
            if constexpr (HasSettle<B>)
              if (rt.settle_first) impl_.settling.push_back(b);
          },
          impl_.blocks[b]);
    }
    impl_.non_finite.assign(impl_.blocks.size(), 0);
    wire_volume_derivatives();
    infer_kinds();
    sort();
  }

 private:
  void add_var(std::string name, QuantityKind kind, bool input) { vars_.push_back({std::move(name), kind, input}); }

  Slot out_slot(std::uint32_t b) const { return impl_.block_outputs[b].first; }

  static void positive(const BlockSpec& bs, double v, const char* what) {
    if (!(v > 0) || !finite(v)) throw PlantError(bs.origin, std::string("expected ") + what + " > 0");
  }

  BlockRt build(std::uint32_t b, double h) {
    const BlockSpec& bs = spec_.blocks[b];
    const Slot out = out_slot(b);
    return std::visit(
        overloaded{
            [&](const GasVolumeBlock& p) -> BlockRt {
              if (!spec_.medium.gas)
                throw PlantError(bs.origin,
                                 "a gas_volume needs a gas medium (the plant's is " + spec_.medium.name + ")");
              positive(bs, p.volume_m3, "a volume");
              positive(bs, p.initial_pressure_pa, "an absolute pressure");
              positive(bs, p.temperature_k, "an absolute temperature");
              GasVolumeRt g;
              g.out = out;
              g.temperature = kNoSlot;
              g.temperature_k = p.temperature_k;
              g.volume = p.volume_m3;
              g.r = spec_.medium.r_specific;
              g.initial_pressure = p.initial_pressure_pa;
              if (p.temperature) g.temperature = resolve(*p.temperature, b, true);
              for (const auto& s : p.inflow) g.inflow.push_back(resolve(s, b, false));
              for (const auto& s : p.outflow) g.outflow.push_back(resolve(s, b, false));
              g.medium = spec_.medium;
              return g;
            },
            [&](const ValveBlock& p) -> BlockRt {
              if (p.law == ValveBlock::Law::kKv && !(p.kv >= 0 && finite(p.kv)))
                throw PlantError(bs.origin, "expected kv >= 0");
              if (p.law == ValveBlock::Law::kOrifice) {
                positive(bs, p.area_m2, "an area");
                if (!(p.discharge > 0 && p.discharge <= 1))
                  throw PlantError(bs.origin, "expected a discharge coefficient in (0, 1]");
              }
              positive(bs, p.linear_below_pa, "linear_below");
              ValveRt v{out,
                        resolve(p.upstream, b, true),
                        resolve(p.downstream, b, true),
                        resolve(p.opening, b, true),
                        resolve(p.temperature, b, true),
                        p.law,
                        p.kv,
                        p.area_m2 * p.discharge,
                        p.linear_below_pa,
                        spec_.medium};
              return v;
            },
            [&](const PumpBlock& p) -> BlockRt {
              if (!(p.nominal_flow_kgs >= 0) || !finite(p.nominal_flow_kgs))
                throw PlantError(bs.origin, "expected a flow >= 0");
              PumpRt r{out,
                       resolve(p.speed, b, true),
                       resolve(p.inlet, b, true),
                       resolve(p.outlet, b, true),
                       p.nominal_flow_kgs,
                       {},
                       !p.curve.empty()};
              if (r.has_curve) r.curve = table(bs, p.curve);
              return r;
            },
            [&](const LineBlock& p) -> BlockRt {
              LineRt r{out, resolve(p.in, b, false), {}};
              r.delay.ring.assign(delay_steps(bs, p.delay_s, h), 0.0);
              return r;
            },
            [&](const HeatSourceBlock& p) -> BlockRt {
              positive(bs, p.time_constant_s, "a time constant");
              if (!finite(p.gain_k_per_w)) throw PlantError(bs.origin, "expected a finite gain");
              return HeatSourceRt{out,
                                  resolve(p.power, b, false),
                                  resolve(p.ambient, b, false),
                                  std::exp(-h / p.time_constant_s),
                                  p.gain_k_per_w,
                                  std::isnan(p.initial_k) ? 0.0 : p.initial_k,
                                  std::isnan(p.initial_k)};
            },
            [&](const GainBlock& p) -> BlockRt {
              if (!finite(p.k)) throw PlantError(bs.origin, "expected a finite gain");
              return GainRt{out, resolve(p.in, b, true), p.k};
            },
            [&](const OffsetBlock& p) -> BlockRt {
              if (!finite(p.offset)) throw PlantError(bs.origin, "expected a finite offset");
              return OffsetRt{out, resolve(p.in, b, true), p.offset};
            },
            [&](const SumBlock& p) -> BlockRt {
              if (p.add.empty() && p.subtract.empty())
                throw PlantError(bs.origin, "expected signals to add or subtract");
              SumRt r{out, {}, {}};
              for (const auto& s : p.add) r.add.push_back(resolve(s, b, true));
              for (const auto& s : p.subtract) r.subtract.push_back(resolve(s, b, true));
              return r;
            },
            [&](const LagBlock& p) -> BlockRt {
              positive(bs, p.time_constant_s, "a time constant");
              return LagRt{out,
                           resolve(p.in, b, false),
                           std::exp(-h / p.time_constant_s),
                           p.gain,
                           std::isnan(p.initial) ? 0.0 : p.initial,
                           std::isnan(p.initial)};
            },
            [&](const SecondOrderBlock& p) -> BlockRt {
              positive(bs, p.natural_frequency_hz, "a natural frequency");
              positive(bs, p.damping, "a damping ratio");
              SecondOrderRt r{out, resolve(p.in, b, false), {}, p.gain, std::isnan(p.initial) ? 0.0 : p.initial,
                              0.0, std::isnan(p.initial)};
              second_order_transition(kTwoPi * p.natural_frequency_hz, p.damping, h, r.phi);
              return r;
            },
            [&](const IntegratorBlock& p) -> BlockRt {
              if (!(p.min <= p.max)) throw PlantError(bs.origin, "expected min <= max");
              if (!finite(p.initial) || p.initial < p.min || p.initial > p.max)
                throw PlantError(bs.origin, "expected an initial value within [min, max]");
              return IntegratorRt{out, resolve(p.in, b, false), p.gain, p.min, p.max, p.initial};
            },
            [&](const RateLimitBlock& p) -> BlockRt {
              positive(bs, p.rise_per_s, "a rise rate");
              positive(bs, p.fall_per_s, "a fall rate");
              return RateLimitRt{out,
                                 resolve(p.in, b, false),
                                 p.rise_per_s * h,
                                 p.fall_per_s * h,
                                 std::isnan(p.initial) ? 0.0 : p.initial,
                                 std::isnan(p.initial)};
            },
            [&](const SaturationBlock& p) -> BlockRt {
              if (!(p.min < p.max)) throw PlantError(bs.origin, "expected min < max");
              return SaturationRt{out, resolve(p.in, b, true), p.min, p.max};
            },
            [&](const DeadTimeBlock& p) -> BlockRt {
              DeadTimeRt r{out, resolve(p.in, b, false), {}, std::isnan(p.initial)};
              r.delay.ring.assign(delay_steps(bs, p.delay_s, h), std::isnan(p.initial) ? 0.0 : p.initial);
              return r;
            },
            [&](const TableBlock& p) -> BlockRt {
              return TableRt{out, resolve(p.in, b, true), table(bs, p.points)};
            },
        },
        bs.params);
  }

  static std::size_t delay_steps(const BlockSpec& bs, double delay_s, double h) {
    const double n = std::round(delay_s / h);
    if (!(n >= 1))
      throw PlantError(bs.origin, "expected a delay of at least one step (" + std::to_string(h * 1e3) + " ms)");
    if (n > double(kMaxDelaySteps))
      throw PlantError(bs.origin, "expected a delay of at most " + std::to_string(kMaxDelaySteps) + " steps");
    return std::size_t(n);
  }

  static Table table(const BlockSpec& bs, const std::vector<TablePoint>& points) {
    if (points.size() < 1) throw PlantError(bs.origin, "expected a table of at least one point");
    for (std::size_t i = 0; i < points.size(); ++i) {
      if (!finite(points[i].t_s) || !finite(points[i].value))
        throw PlantError(bs.origin, "expected finite table points");
      if (i > 0 && !(points[i].t_s > points[i - 1].t_s))
        throw PlantError(bs.origin, "expected increasing table arguments");
    }
    return Table(TableSpec{points, Interpolation::Linear, false, 0.0});
  }

  // A valve or pump wired straight from a volume's pressure: the volume
  // integrates that flow's dependence on its pressure implicitly.
  void wire_volume_derivatives() {
    for (std::uint32_t b = 0; b < impl_.blocks.size(); ++b) {
      auto* g = std::get_if<GasVolumeRt>(&impl_.blocks[b]);
      if (!g) continue;
      const Slot pressure = g->out;
      auto add = [&](Slot flow_slot, double sign) {
        for (std::uint32_t f = 0; f < impl_.blocks.size(); ++f) {
          if (impl_.block_outputs[f].first != flow_slot) continue;
          if (auto* v = std::get_if<ValveRt>(&impl_.blocks[f])) {
            if (v->upstream == pressure) g->derivatives.emplace_back(&v->d_up, sign);
            if (v->downstream == pressure) g->derivatives.emplace_back(&v->d_down, sign);
          } else if (auto* p = std::get_if<PumpRt>(&impl_.blocks[f])) {
            if (p->outlet == pressure) g->derivatives.emplace_back(&p->d_outlet, sign);
            if (p->inlet == pressure) g->derivatives.emplace_back(&p->d_inlet, sign);
          }
        }
      };
      for (Slot s : g->inflow) add(s, +1.0);
      for (Slot s : g->outflow) add(s, -1.0);
    }
  }

  // A linear block without `kind:` measures what its first signal does.
  void infer_kinds() {
    for (std::size_t pass = 0; pass < spec_.blocks.size(); ++pass) {
      bool changed = false;
      for (std::uint32_t b = 0; b < spec_.blocks.size(); ++b) {
        const BlockSpec& bs = spec_.blocks[b];
        if (bs.params.index() < 5 || bs.kind) continue;
        const PlantSignal* first = first_signal(bs.params);
        if (!first || first->is_constant()) continue;
        const PlantVar src = find_var(first->ref, nullptr);
        const PlantVar dst = impl_.block_outputs[b].first;
        if (src != kNoVar && vars_[dst].kind != vars_[src].kind) {
          vars_[dst].kind = vars_[src].kind;
          changed = true;
        }
      }
      if (!changed) break;
    }
  }

  static const PlantSignal* first_signal(const BlockParams& p) {
    return std::visit(overloaded{
                          [](const SumBlock& s) -> const PlantSignal* {
                            return !s.add.empty() ? &s.add[0] : s.subtract.empty() ? nullptr : &s.subtract[0];
                          },
                          [](const auto& s) -> const PlantSignal* {
                            if constexpr (requires { s.in; }) return &s.in;
                            return nullptr;
                          },
                      },
                      p);
  }

  // Outputs in an order where every direct-feedthrough input is computed
  // first; a cycle is an algebraic loop (no block in it holds state).
  void sort() {
    const std::size_t n = spec_.blocks.size();
    std::vector<int> mark(n, 0);  // 0 new, 1 on the path, 2 done
    std::vector<std::uint32_t> path;
    std::function<void(std::uint32_t)> visit = [&](std::uint32_t b) {
      if (mark[b] == 2) return;
      if (mark[b] == 1) {
        auto start = std::find(path.begin(), path.end(), b);
        std::string cycle;
        for (auto it = start; it != path.end(); ++it) cycle += spec_.blocks[*it].name + " -> ";
        cycle += spec_.blocks[b].name;
        throw PlantError(
            spec_.blocks[b].origin,
            "algebraic loop " + cycle +
                ": no block in it holds state (put a lag, an integrator, a dead time or a volume in the loop)");
      }
      mark[b] = 1;
      path.push_back(b);
      for (std::uint32_t dep : edges_[b]) visit(dep);
      path.pop_back();
      mark[b] = 2;
      impl_.order.push_back(b);
    };
    for (std::uint32_t b = 0; b < n; ++b) visit(b);
  }

  const PlantSpec& spec_;
  Plant::Impl& impl_;
  std::vector<Plant::VariableInfo>& vars_;
  std::vector<double> constants_;
  std::multimap<std::string, Slot> output_names_;
  std::vector<std::set<std::uint32_t>> edges_;  // block -> the blocks its feedthrough inputs read
};

}  // namespace

Plant::Plant(const PlantSpec& spec, std::uint64_t seed)
    : spec_(spec), step_us_(spec.step_us), impl_(std::make_unique<Impl>()), faults_(spec.faults.size() + 4) {
  if (step_us_ < 10 || step_us_ > 1'000'000) throw PlantError(spec.origin, "expected a step from 10 us to 1 s");
  impl_->h = double(step_us_) * 1e-6;
  Builder b(spec_, *impl_, vars_);
  b.declare();
  b.build_blocks(impl_->h);
  impl_->var_history.assign(vars_.size(), -1);
  inputs_.resize(spec_.inputs.size());
  for (std::size_t i = 0; i < spec_.inputs.size(); ++i) {
    const PlantInputSpec& s = spec_.inputs[i];
    Input& in = inputs_[i];
    in.source = s.source;
    in.slot = impl_->var_slot[i];
    in.timeout = s.timeout_us;
    in.on_timeout = s.on_timeout;
    if (!finite(s.initial)) throw PlantError(s.origin, "expected a finite initial value");
    if (s.timeout_us < 0) throw PlantError(s.origin, "expected a timeout >= 0");
    in.st.value = in.st.source_value = s.initial;
    impl_->v[in.slot] = impl_->good[in.slot] = s.initial;
    if (s.source == PlantInputSpec::Source::kTime) {
      try {
        in.series = TermSeries(s.terms, derive_seed(seed, hash_string(s.name)));
      } catch (const std::invalid_argument& e) {
        throw PlantError(s.origin, e.what());
      }
    }
  }
  for (const PlantFaultSpec& f : spec_.faults) arm_fault(f, 0);
}

Plant::~Plant() = default;

PlantVar Plant::find(std::string_view name, std::string* why) const {
  // The builder's rules, on the finished variable list.
  if (auto it = impl_->input_index.find(name); it != impl_->input_index.end()) return PlantVar(it->second);
  if (name.find('.') != std::string_view::npos) {
    for (PlantVar i = 0; i < vars_.size(); ++i)
      if (!vars_[i].is_input && vars_[i].name == name) return i;
  } else {
    if (auto it = impl_->block_index.find(name); it != impl_->block_index.end())
      return impl_->block_outputs[it->second].first;
    PlantVar found = kNoVar;
    std::string which;
    for (PlantVar i = 0; i < vars_.size(); ++i) {
      const std::string& n = vars_[i].name;
      const auto dot = n.find('.');
      if (vars_[i].is_input || dot == std::string::npos || n.compare(dot + 1, std::string::npos, name) != 0) continue;
      which += (which.empty() ? "" : ", ") + n;
      found = found == kNoVar ? i : kNoVar - 1;
    }
    if (found == kNoVar - 1) {
      if (why) *why = "'" + std::string(name) + "' is ambiguous in plant " + spec_.name + ": " + which;
      return kNoVar;
    }
    if (found != kNoVar) return found;
  }
  if (why) {
    std::string names;
    for (const auto& v : vars_) names += (names.empty() ? "" : ", ") + v.name;
    *why = "plant " + spec_.name + " has no variable '" + std::string(name) + "' (" + names + ")";
  }
  return kNoVar;
}

std::size_t Plant::input_count() const { return inputs_.size(); }

std::optional<std::size_t> Plant::find_input(std::string_view name) const {
  auto it = impl_->input_index.find(name);
  if (it == impl_->input_index.end()) return std::nullopt;
  return it->second;
}

// ------------------------------------------------------------------ stepping

class PlantGroup {
 public:
  std::vector<Plant*> order;  // every plant after the plants it reads
  void advance(TimeUs t) {
    if (busy_) return;
    busy_ = true;
    TimeUs from = t;
    for (Plant* p : order) from = std::min(from, p->time());
    for (TimeUs c = std::max<TimeUs>(0, from);; c = std::min(t, c + kGroupChunkUs)) {
      for (Plant* p : order) p->advance_own(c);
      if (c >= t) break;
    }
    busy_ = false;
  }

 private:
  bool busy_ = false;
};

void Plant::advance_to(TimeUs t) {
  if (t < 0 || t / step_us_ < next_) return;
  if (group_) group_->advance(t);
  else advance_own(t);
}

void Plant::advance_own(TimeUs t) {
  if (t < 0) return;
  const std::int64_t last = t / step_us_;
  while (next_ <= last) step_once();
}

double Plant::input_value(std::size_t i, TimeUs t) {
  Input& in = inputs_[i];
  InputState& st = in.st;
  if (in.lost == 0) {
    switch (in.source) {
      case PlantInputSpec::Source::kPush: break;
      case PlantInputSpec::Source::kTime:
        st.source_value = in.series.at(double(t) / 1e6);  // exact for whole ms (0.1 s is 0.1)
        st.updated = t;
        break;
      case PlantInputSpec::Source::kPlant:
        if (in.other) {
          st.source_value = in.other->history(in.other_var, t / in.other->step_us_);
          st.updated = t;
        }
        break;
      case PlantInputSpec::Source::kExternal:
        if (in.external) {
          const double x = in.external.value(in.external.context, t);
          if (finite(x)) {
            st.source_value = x;
            st.updated = t;
          } else {
            ++st.refused;
          }
        }
        break;
    }
  }
  const TimeUs since = st.updated < 0 ? 0 : st.updated;
  st.timed_out = in.timeout > 0 && t - since >= in.timeout;
  double value = st.timed_out && in.on_timeout ? *in.on_timeout : st.source_value;
  if (in.stuck > 0) value = in.stuck_value;
  if (st.overridden) value = in.override_value;
  st.value = value;
  return value;
}

void Plant::step_once() {
  Impl& m = *impl_;
  const TimeUs t = next_ * step_us_;
  if (t >= next_edge_) apply_fault_edges(t);
  double* v = m.v.data();
  for (std::size_t i = 0; i < inputs_.size(); ++i) v[inputs_[i].slot] = input_value(i, t);
  auto outputs = [&] {
    for (std::uint32_t b : m.order) {
      std::visit([v](auto& rt) { rt.output(v); }, m.blocks[b]);
      const auto [first, count] = m.block_outputs[b];
      for (Slot s = first; s < first + count; ++s) {
        if (finite(v[s])) {
          m.good[s] = v[s];
          continue;
        }
        v[s] = m.good[s];
        if (++m.non_finite[b] && hook_) hook_(hook_context_, spec_.name, m.block_names[b], m.non_finite[b], t);
      }
    }
  };
  outputs();
  if (next_ == 0 && !m.settling.empty()) {  // blocks without an initial value start settled on what they see
    for (std::uint32_t b : m.settling)
      std::visit(
          [v](auto& rt) {
            if constexpr (HasSettle<std::decay_t<decltype(rt)>>) rt.settle(v);
          },
          m.blocks[b]);
    outputs();
  }
  for (std::uint32_t b : m.stateful) {
    const bool ok = std::visit(
        [&](auto& rt) {
          if constexpr (HasUpdate<std::decay_t<decltype(rt)>>) return rt.update(v, m.h);
          return true;
        },
        m.blocks[b]);
    if (!ok && ++m.non_finite[b] && hook_) hook_(hook_context_, spec_.name, m.block_names[b], m.non_finite[b], t);
  }
  record_history();
  ++next_;
}

// ------------------------------------------------------------------ reading

void Plant::watch(PlantVar var, TimeUs lookback_us) {
  if (var >= vars_.size()) return;
  std::size_t steps = std::size_t(std::max<TimeUs>(0, lookback_us) / step_us_) + 2;
  steps = std::clamp(steps, kMinHistorySteps, kMaxHistorySteps);
  std::size_t size = 1;
  while (size < steps) size <<= 1;
  Impl& m = *impl_;
  std::int32_t& h = m.var_history[var];
  if (h < 0) {
    h = std::int32_t(m.history.size());
    m.history.push_back({m.var_slot[var], std::vector<double>(size, m.v[m.var_slot[var]]), next_});
    return;
  }
  History& old = m.history[std::size_t(h)];
  if (old.ring.size() >= size) return;
  std::vector<double> bigger(size);
  const std::size_t old_mask = old.ring.size() - 1;
  const std::int64_t kept = std::max(old.first, next_ - std::int64_t(old.ring.size()));
  for (std::int64_t k = kept; k < next_; ++k) bigger[std::size_t(k) & (size - 1)] = old.ring[std::size_t(k) & old_mask];
  old.first = kept;
  old.ring.swap(bigger);
}

void Plant::record_history() {
  for (History& h : impl_->history) h.ring[std::size_t(next_) & (h.ring.size() - 1)] = impl_->v[h.slot];
}

double Plant::history(PlantVar var, std::int64_t step) const {
  const Impl& m = *impl_;
  const Slot slot = m.var_slot[var];
  if (step >= next_ - 1) return m.v[slot];
  const std::int32_t h = m.var_history[var];
  if (h < 0) return m.v[slot];
  const History& r = m.history[std::size_t(h)];
  const std::int64_t oldest = std::max(r.first, next_ - std::int64_t(r.ring.size()));
  return r.ring[std::size_t(std::max(step, oldest)) & (r.ring.size() - 1)];
}

double Plant::value(PlantVar var, TimeUs t) {
  if (var >= vars_.size()) return 0.0;
  advance_to(t);
  return history(var, t < 0 ? -1 : t / step_us_);
}

// ------------------------------------------------------------------ inputs

void Plant::set_input(std::size_t i, double value, TimeUs t) {
  if (i >= inputs_.size()) return;
  Input& in = inputs_[i];
  if (!finite(value)) {
    ++in.st.refused;
    return;
  }
  advance_to(t);
  if (in.lost > 0) return;
  in.st.source_value = value;
  in.st.updated = t;
}

void Plant::override_input(std::size_t i, double value, TimeUs t) {
  if (i >= inputs_.size() || !finite(value)) return;
  advance_to(t);
  inputs_[i].st.overridden = true;
  inputs_[i].override_value = value;
}

void Plant::clear_override(std::size_t i, TimeUs t) {
  if (i >= inputs_.size()) return;
  advance_to(t);
  inputs_[i].st.overridden = false;
}

void Plant::bind_external(std::size_t i, ExternalSource source, TimeUs t) {
  if (i >= inputs_.size()) return;
  advance_to(t);
  inputs_[i].external = source;
}

void Plant::bind_plant(std::size_t i, Plant* other, PlantVar var) {
  inputs_[i].other = other;
  inputs_[i].other_var = var;
}

Plant::InputState Plant::input_state(std::size_t i, TimeUs now) const {
  if (i >= inputs_.size()) return {};
  const Input& in = inputs_[i];
  InputState s = in.st;
  s.stuck = in.stuck > 0;
  s.lost = in.lost > 0;
  // What the next step takes, as input_value() will (a pulled source: its latest value).
  now = std::max(now, time());
  const bool pushed = in.source == PlantInputSpec::Source::kPush;
  const bool timed_out = in.timeout > 0 && now - std::max<TimeUs>(0, s.updated) >= in.timeout;
  s.current = !pushed ? s.value : timed_out && in.on_timeout ? *in.on_timeout : s.source_value;
  if (in.stuck > 0) s.current = in.stuck_value;
  if (s.overridden) s.current = in.override_value;
  return s;
}

// ------------------------------------------------------------------ faults

namespace {
struct FaultTarget {
  std::int32_t block = -1;
  std::int32_t input = -1;
};
}  // namespace

FaultHandle Plant::arm_fault(const PlantFaultSpec& f, TimeUs now) {
  if (!is_plant_fault(f.fault.kind))
    throw PlantError(f.origin, "expected a plant fault (leak, blocked, valve_stuck, input_lost)");
  const auto kind = f.fault.kind;
  const std::string kname(to_string(kind));
  auto block = impl_->block_index.find(f.target);
  auto input = impl_->input_index.find(f.target);
  const BlockRt* b = block == impl_->block_index.end() ? nullptr : &impl_->blocks[block->second];
  const bool is_input = input != impl_->input_index.end();
  if (f.target.empty())
    throw PlantError(f.origin, kname + ": expected a target (a block or an input of plant " + spec_.name + ")");
  if (!b && !is_input)
    throw PlantError(f.origin, kname + ": plant " + spec_.name + " has no block or input '" + f.target + "'");
  const bool fits = (kind == FaultKind::Leak && b && std::holds_alternative<GasVolumeRt>(*b)) ||
                    (kind == FaultKind::Blocked && b &&
                     (std::holds_alternative<ValveRt>(*b) || std::holds_alternative<PumpRt>(*b) ||
                      std::holds_alternative<LineRt>(*b))) ||
                    (kind == FaultKind::ValveStuck && ((b && std::holds_alternative<ValveRt>(*b)) || is_input)) ||
                    (kind == FaultKind::InputLost && is_input);
  if (!fits) {
    const char* expected = kind == FaultKind::Leak         ? "a gas_volume"
                           : kind == FaultKind::Blocked    ? "a valve, pump or line"
                           : kind == FaultKind::ValveStuck ? "a valve or an input"
                                                           : "an input";
    throw PlantError(f.origin, kname + ": expected " + expected + " as target, got '" + f.target + "'");
  }
  if (kind == FaultKind::Leak && !(f.fault.leak_kv > 0) && !(f.fault.leak_flow_kgs > 0))
    throw PlantError(f.origin, "leak: expected kv (the hole's Kv) or flow (a constant outflow) > 0");
  advance_to(now);
  const FaultHandle h = faults_.add(f.fault, now);
  fault_targets_.resize(std::size_t(h) + 1);
  fault_targets_[h] = f.target;
  next_edge_ = faults_.next_edge_time();
  return h;
}

bool Plant::cancel_fault(FaultHandle h, TimeUs now) {
  advance_to(now);
  const bool ok = faults_.cancel(h, now);
  next_edge_ = faults_.next_edge_time();
  return ok;
}

std::vector<FaultInfo> Plant::armed_faults(TimeUs now) const { return faults_.armed_faults(now); }

// The step that applies the next edge (the first at or after it).
TimeUs Plant::next_fault_edge() const {
  if (next_edge_ >= std::numeric_limits<TimeUs>::max() - step_us_) return std::numeric_limits<TimeUs>::max();
  const TimeUs at = std::max<TimeUs>(next_edge_, next_ * step_us_);
  return (at + step_us_ - 1) / step_us_ * step_us_;
}

const std::string& Plant::fault_target(FaultHandle h) const {
  static const std::string kNone;
  return h < fault_targets_.size() ? fault_targets_[h] : kNone;
}

void Plant::apply_fault_edges(TimeUs t) {
  FaultEdge e;
  Impl& m = *impl_;
  while (faults_.poll(t, e)) {
    if (fault_hook_) fault_hook_(fault_context_, *this, e.handle, e.kind, e.started, e.time_us);
    const std::string& target = fault_targets_[e.handle];
    const int d = e.started ? 1 : -1;
    auto block = m.block_index.find(target);
    auto input = m.input_index.find(target);
    BlockRt* b = block == m.block_index.end() ? nullptr : &m.blocks[block->second];
    Input* in = input == m.input_index.end() ? nullptr : &inputs_[input->second];
    switch (e.kind) {
      case FaultKind::Leak:
        if (auto* g = b ? std::get_if<GasVolumeRt>(b) : nullptr) {
          g->leaks += d;
          g->leak_kv = g->leaks > 0 ? g->leak_kv + d * e.spec->leak_kv : 0.0;
          g->leak_flow = g->leaks > 0 ? g->leak_flow + d * e.spec->leak_flow_kgs : 0.0;
        }
        break;
      case FaultKind::Blocked:
        if (b)
          std::visit(
              [d](auto& rt) {
                if constexpr (requires { rt.blocked; }) rt.blocked += d;
              },
              *b);
        break;
      case FaultKind::ValveStuck:
        if (auto* valve = b ? std::get_if<ValveRt>(b) : nullptr) {
          if (e.started && valve->stuck == 0) valve->stuck_opening = valve->opening_of(m.v.data());
          valve->stuck += d;
        } else if (in) {
          if (e.started && in->stuck == 0) in->stuck_value = in->st.value;
          in->stuck += d;
        }
        break;
      case FaultKind::InputLost:
        if (in) in->lost += d;
        break;
      default: break;
    }
  }
  next_edge_ = faults_.next_edge_time();
}

std::vector<Plant::BlockHealth> Plant::health() const {
  std::vector<BlockHealth> out;
  for (std::size_t b = 0; b < impl_->block_names.size(); ++b)
    out.push_back({impl_->block_names[b], impl_->non_finite[b]});
  return out;
}

// ------------------------------------------------------------------ the set

PlantSet::PlantSet(const std::vector<PlantSpec>& specs, std::uint64_t seed) {
  for (const PlantSpec& s : specs) {
    if (find(s.name)) throw PlantError(s.origin, "plant " + s.name + " defined twice");
    plants_.push_back(std::make_unique<Plant>(s, derive_seed(seed, hash_string("plant/" + s.name))));
  }
  // Inputs reading another plant; the graph of plants must have no cycle.
  const std::size_t n = plants_.size();
  std::vector<std::set<std::size_t>> reads(n);
  for (std::size_t p = 0; p < n; ++p) {
    Plant& plant = *plants_[p];
    for (std::size_t i = 0; i < plant.spec().inputs.size(); ++i) {
      const PlantInputSpec& in = plant.spec().inputs[i];
      if (in.source != PlantInputSpec::Source::kPlant) continue;
      PlantVar var = kNoVar;
      std::string why;
      Plant* other = resolve(in.plant_ref, var, &why);
      if (!other) throw PlantError(in.origin, why);
      if (other == &plant)
        throw PlantError(in.origin, "a plant's input cannot read the plant itself: wire the block directly");
      other->watch(var, 2 * kGroupChunkUs + plant.step_us());
      plant.bind_plant(i, other, var);
      for (std::size_t q = 0; q < n; ++q)
        if (plants_[q].get() == other) reads[p].insert(q);
    }
  }
  std::vector<int> mark(n, 0);
  std::vector<std::size_t> order;
  std::function<void(std::size_t)> visit = [&](std::size_t p) {
    if (mark[p] == 2) return;
    if (mark[p] == 1)
      throw PlantError(plants_[p]->spec().origin,
                       "plants read each other in a cycle through plant " + plants_[p]->name());
    mark[p] = 1;
    for (std::size_t q : reads[p]) visit(q);
    mark[p] = 2;
    order.push_back(p);
  };
  for (std::size_t p = 0; p < n; ++p) visit(p);
  // Connected plants form one group (union of the read relation).
  std::vector<std::size_t> root(n);
  for (std::size_t p = 0; p < n; ++p) root[p] = p;
  std::function<std::size_t(std::size_t)> find_root = [&](std::size_t p) {
    return root[p] == p ? p : root[p] = find_root(root[p]);
  };
  for (std::size_t p = 0; p < n; ++p)
    for (std::size_t q : reads[p]) root[find_root(p)] = find_root(q);
  std::map<std::size_t, PlantGroup*> groups;
  for (std::size_t p : order) {
    const std::size_t r = find_root(p);
    bool linked = !reads[p].empty();
    for (std::size_t q = 0; q < n && !linked; ++q) linked = reads[q].count(p) > 0;
    if (!linked) continue;
    if (!groups.count(r)) {
      groups_.push_back(std::make_unique<PlantGroup>());
      groups[r] = groups_.back().get();
    }
    groups[r]->order.push_back(plants_[p].get());
    plants_[p]->group_ = groups[r];
  }
}

PlantSet::~PlantSet() = default;

Plant* PlantSet::find(std::string_view name) const {
  for (const auto& p : plants_)
    if (p->name() == name) return p.get();
  return nullptr;
}

Plant* PlantSet::resolve(std::string_view ref, PlantVar& var, std::string* why) const {
  const auto dot = ref.find('.');
  if (dot == std::string_view::npos || dot == 0) {
    if (why) *why = "expected PLANT.VARIABLE, got '" + std::string(ref) + "'";
    return nullptr;
  }
  Plant* p = find(ref.substr(0, dot));
  if (!p) {
    if (why) {
      std::string names;
      for (const auto& q : plants_) names += (names.empty() ? "" : ", ") + q->name();
      *why = "no plant '" + std::string(ref.substr(0, dot)) + "' (plants: " + (names.empty() ? "none" : names) + ")";
    }
    return nullptr;
  }
  var = p->find(ref.substr(dot + 1), why);
  return var == kNoVar ? nullptr : p;
}

void PlantSet::set_non_finite_hook(NonFiniteHook hook, void* context) {
  for (auto& p : plants_) p->set_non_finite_hook(hook, context);
}

void PlantSet::set_fault_hook(PlantFaultHook hook, void* context) {
  for (auto& p : plants_) p->set_fault_hook(hook, context);
}

void PlantSet::advance_all(TimeUs t) {
  for (auto& p : plants_) p->advance_to(t);
}

TimeUs PlantSet::next_fault_edge() const {
  TimeUs next = std::numeric_limits<TimeUs>::max();
  for (const auto& p : plants_) next = std::min(next, p->next_fault_edge());
  return next;
}

void PlantSet::advance_faults(TimeUs now) {
  for (auto& p : plants_)
    if (p->next_fault_edge() <= now) p->advance_to(now);
}

namespace {
double read_plant(void* context, std::uint32_t var, std::int64_t t) {
  return static_cast<Plant*>(context)->value(var, t);
}
}  // namespace

PlantTap PlantSetResolver::resolve(const PlantTermSpec& term, Channel channel, TimeUs lookback_us) const {
  PlantVar var = kNoVar;
  std::string why;
  Plant* p = set_.resolve(term.ref, var, &why);
  const std::string at = term.origin.empty() ? "" : term.origin + ": ";
  if (!p) throw std::invalid_argument(at + why);
  const QuantityKind want = channel == Channel::Pressure ? QuantityKind::kPressure : QuantityKind::kTemperature;
  const QuantityKind kind = p->variables()[var].kind;
  if (kind != want && kind != QuantityKind::kNumber)
    throw std::invalid_argument(at + "plant variable " + term.ref + " is a " + std::string(kind_name(kind)) + "; the " +
                                (channel == Channel::Pressure ? "pressure" : "temperature") + " channel needs a " +
                                std::string(kind_name(want)));
  p->watch(var, lookback_us);
  return PlantTap{read_plant, p, var};
}

}  // namespace cansim::physics
