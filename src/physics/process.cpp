#include "physics/process.hpp"

#include <algorithm>
#include <cmath>
#include <complex>
#include <limits>
#include <stdexcept>

#include "physics/plant.hpp"
#include "physics/random.hpp"

namespace cansim::physics {

namespace {
constexpr double kTwoPi = 6.283185307179586476925286766559;
constexpr double kSettleDecades = 40.0;   // e^-40 ~ 4e-18: older events have settled
constexpr std::size_t kMaxEvents = 4096;  // bound on superposed events per evaluation

double frac(double x) { return x - std::floor(x); }
}  // namespace

// ------------------------------------------------------------------ closed forms

namespace response {

double first_order_free(double tau, double T) { return std::exp(-tau / T); }

double first_order_integral(double tau, double T) { return -T * std::expm1(-tau / T); }

double second_order_free(double tau, double w, double zeta) {
  if (std::abs(zeta - 1.0) < 1e-9) return std::exp(-w * tau) * (1.0 + w * tau);
  if (zeta < 1.0) {
    const double a = zeta * w;
    const double b = w * std::sqrt(1.0 - zeta * zeta);
    return std::exp(-a * tau) * (std::cos(b * tau) + (a / b) * std::sin(b * tau));
  }
  const double r = std::sqrt(zeta * zeta - 1.0);
  const double p2 = w * (zeta + r);
  const double p1 = w * w / p2;
  return (p2 * std::exp(-p1 * tau) - p1 * std::exp(-p2 * tau)) / (p2 - p1);
}

double second_order_integral(double tau, double w, double zeta) {
  if (std::abs(zeta - 1.0) < 1e-9) {
    const double e = std::exp(-w * tau);
    return (2.0 / w) * (-std::expm1(-w * tau)) - tau * e;
  }
  if (zeta < 1.0) {
    const double a = zeta * w;
    const double b = w * std::sqrt(1.0 - zeta * zeta);
    const double e = std::exp(-a * tau);
    const double c = std::cos(b * tau);
    const double s = std::sin(b * tau);
    const double w2 = w * w;
    const double ic = (a - e * (a * c - b * s)) / w2;
    const double is = (b - e * (a * s + b * c)) / w2;
    return ic + (a / b) * is;
  }
  const double r = std::sqrt(zeta * zeta - 1.0);
  const double p2 = w * (zeta + r);
  const double p1 = w * w / p2;
  return (p2 * (-std::expm1(-p1 * tau)) / p1 - p1 * (-std::expm1(-p2 * tau)) / p2) / (p2 - p1);
}

}  // namespace response

// ------------------------------------------------------------------ compiled terms

namespace {

struct CConst {
  double v;
  double eval(double) const { return v; }
};

struct CRamp {
  RampSpec s;
  double eval(double t) const {
    if (t < s.start_s) return s.from;
    if (s.duration_s <= 0 || t >= s.start_s + s.duration_s) return s.to;
    return s.from + (s.to - s.from) * (t - s.start_s) / s.duration_s;
  }
};

struct CTable {
  Table table;
  double eval(double t) const { return table.value(t); }
};

struct CSine {
  double amplitude, freq, phase_cycles;
  double eval(double t) const { return amplitude * std::sin(kTwoPi * frac(freq * t + phase_cycles)); }
};

struct CPulse {
  PulseSpec s;
  double eval(double t) const {
    if (t < s.delay_s) return s.low;
    const double tau = std::fmod(t - s.delay_s, s.period_s);
    const double high_end = s.duty * s.period_s;  // start of the falling edge
    if (tau < s.rise_s) return s.low + (s.high - s.low) * tau / s.rise_s;
    if (tau < high_end) return s.high;
    if (tau < high_end + s.fall_s) return s.high + (s.low - s.high) * (tau - high_end) / s.fall_s;
    return s.low;
  }
};

struct CPulsation {
  struct H {
    double order;
    double a_cos_phi;  // amplitude * cos(phase): coefficient of sin(k theta)
    double a_sin_phi;  // amplitude * sin(phase): coefficient of cos(k theta)
    int int_order;     // > 0 if order is a small positive integer
  };
  double shaft_hz;
  std::vector<H> h;
  int max_int_order = 0;
  double eval(double t) const {
    double sum = 0.0;
    const double cyc = shaft_hz * t;
    if (max_int_order > 0) {
      const double th = kTwoPi * frac(cyc);
      const double s1 = std::sin(th);
      const double c1 = std::cos(th);
      // sin(k th), cos(k th) by the angle-addition recurrence; harmonics sorted by order.
      double sk = s1, ck = c1;
      int k = 1;
      for (const auto& x : h) {
        if (x.int_order <= 0) continue;
        while (k < x.int_order) {
          const double sn = sk * c1 + ck * s1;
          ck = ck * c1 - sk * s1;
          sk = sn;
          ++k;
        }
        sum += x.a_cos_phi * sk + x.a_sin_phi * ck;
      }
    }
    for (const auto& x : h) {
      if (x.int_order > 0) continue;
      const double th = kTwoPi * frac(cyc * x.order);
      sum += x.a_cos_phi * std::sin(th) + x.a_sin_phi * std::cos(th);
    }
    return sum;
  }
};

// Response of a first/second-order system to a piecewise-linear setpoint, by superposition
// of the step / ramp responses of every breakpoint. All free responses share the system's
// modes, so the sum over past breakpoints collapses into a few modal coefficients relative
// to the latest breakpoint t_ref; they are cached per segment between breakpoints (a pure
// function of the segment, so the value depends only on t, not on the query history):
//   y(t) = sp(t) - E_inf * slope(t) - sum_modes W_m * mode_m(t - t_ref)
struct CResponse {
  enum class Mode : std::uint8_t { First, Under, Critical, Over };
  Table sp;
  Mode mode = Mode::First;
  double T = 1, w = 1, zeta = 1;
  double p1 = 0, p2 = 0;         // overdamped poles (rates)
  std::complex<double> s{0, 0};  // underdamped pole -a + i b
  std::complex<double> c{1, 0};  // free response = Re[c e^{s tau}]
  double window = 1;
  double e_inf = 0;
  double initial = kNaN;
  double init_delta = 0;  // initial - response(0) without the initial condition
  // segment cache
  mutable double seg_lo = std::numeric_limits<double>::infinity();
  mutable double seg_hi = -std::numeric_limits<double>::infinity();
  mutable double t_ref = 0, v_ref = 0, slope_ref = 0;
  mutable double W1 = 0, W2 = 0;
  mutable std::complex<double> Wc{0, 0};

  double free(double tau) const {
    switch (mode) {
      case Mode::First: return response::first_order_free(tau, T);
      default: return response::second_order_free(tau, w, mode == Mode::Critical ? 1.0 : zeta);
    }
  }

  // Adds one breakpoint (jump `step`, slope change `k`) that lies d >= 0 before t_ref.
  void accumulate(double d, double step, double k) const {
    switch (mode) {
      case Mode::First: W1 += (step - k * T) * std::exp(-d / T); break;
      case Mode::Under: {
        const double e = std::exp(s.real() * d);
        const std::complex<double> rot(e * std::cos(s.imag() * d), e * std::sin(s.imag() * d));
        Wc += (step + k / s) * c * rot;
        break;
      }
      case Mode::Critical: {
        const double e = std::exp(-w * d);
        const double A = step - 2.0 * k / w, B = step * w - k;
        W1 += (A + B * d) * e;  // P
        W2 += B * e;            // Q
        break;
      }
      case Mode::Over:
        W1 += p2 / (p2 - p1) * (step - k / p1) * std::exp(-p1 * d);
        W2 += -p1 / (p2 - p1) * (step - k / p2) * std::exp(-p2 * d);
        break;
    }
  }

  double modes(double u) const {
    switch (mode) {
      case Mode::First: return W1 * std::exp(-u / T);
      case Mode::Under: {
        const double e = std::exp(s.real() * u);
        return e * (Wc.real() * std::cos(s.imag() * u) - Wc.imag() * std::sin(s.imag() * u));
      }
      case Mode::Critical: return (W1 + W2 * u) * std::exp(-w * u);
      case Mode::Over: return W1 * std::exp(-p1 * u) + W2 * std::exp(-p2 * u);
    }
    return 0.0;
  }

  void rebuild(double t) const {
    constexpr double kInfT = std::numeric_limits<double>::infinity();
    bool any = false;
    sp.for_each_event_back(t, kInfT, 1, [&](const TableEvent& ev) {
      t_ref = ev.t_s;
      any = true;
    });
    W1 = W2 = 0;
    Wc = {0, 0};
    if (!any) {  // before the first breakpoint: at rest at the first value
      t_ref = t;
      v_ref = sp.value(t);
      slope_ref = 0;
      seg_lo = -kInfT;
      seg_hi = sp.next_event_time(t);
      return;
    }
    const double tr = t_ref;
    // Walk back from t (not from t_ref: the event times must come out of the same arithmetic).
    sp.for_each_event_back(t, (t - tr) + window, kMaxEvents,
                           [&](const TableEvent& ev) { accumulate(tr - ev.t_s, ev.step, ev.slope); });
    seg_lo = t_ref;
    seg_hi = sp.next_event_time(t);
    // The setpoint is linear inside the segment: sample it at a point that depends only on
    // the segment (not on t, and away from the breakpoints where rounding could pick a side).
    const double probe = std::isfinite(seg_hi) ? 0.5 * (t_ref + seg_hi) : t_ref + 1.0;
    slope_ref = sp.slope(probe);
    v_ref = sp.value(probe) - slope_ref * (probe - t_ref);
  }

  double base(double t) const {
    if (!(t >= seg_lo && t < seg_hi)) rebuild(t);
    const double u = t - t_ref;
    return v_ref + slope_ref * u - e_inf * slope_ref - modes(u);
  }
  double eval(double t) const {
    if (std::isnan(initial)) return base(t);
    if (t <= 0) return initial;
    return base(t) + init_delta * free(t);
  }
};

struct CRandomWalk {
  RandomWalkSpec s;
  std::uint64_t key;
  double x, t_last;
  std::uint64_t counter;
  void reset() {
    x = s.initial;
    t_last = 0;
    counter = 0;
  }
  double eval(double t) {
    if (t > t_last) {
      const double dt = t - t_last;
      x += s.drift_per_s * dt + s.sigma_per_sqrt_s * std::sqrt(dt) * counter_normal(key, counter++);
      x = std::clamp(x, s.min, s.max);
      t_last = t;
    }
    return x;
  }
};

struct COU {
  OrnsteinUhlenbeckSpec s;
  std::uint64_t key;
  double x, t_last;
  std::uint64_t counter;
  double last_dt = -1, e = 0, sd = 0;
  void reset() {
    x = std::isnan(s.initial) ? s.mean : s.initial;
    t_last = 0;
    counter = 0;
  }
  double eval(double t) {
    if (t > t_last) {
      const double dt = t - t_last;
      if (dt != last_dt) {  // exact AR(1) coefficients, cached for the usual constant step
        last_dt = dt;
        e = std::exp(-dt / s.tau_s);
        sd = s.sigma * std::sqrt(-std::expm1(-2.0 * dt / s.tau_s));
      }
      x = s.mean + (x - s.mean) * e + sd * counter_normal(key, counter++);
      t_last = t;
    }
    return x;
  }
};

struct CGasLaw {
  double ratio;  // p_ref / T_ref
};

// A plant variable: the term's time is relative to its channel's start.
struct CPlant {
  PlantTap tap;
  double start_s;
  double eval(double t) const {
    return tap.value(tap.context, tap.var, std::int64_t(std::llround((t + start_s) * 1e6)));
  }
};

using Compiled =
    std::variant<CConst, CRamp, CTable, CSine, CPulse, CPulsation, CResponse, CRandomWalk, COU, CGasLaw, CPlant>;

}  // namespace

struct ProcessModel::Term {
  Compiled c;
};

namespace {

template <class... Ts>
struct overloaded : Ts... {
  using Ts::operator()...;
};
template <class... Ts>
overloaded(Ts...) -> overloaded<Ts...>;

CResponse make_response(const TableSpec& sp, bool second, double T, double fn, double zeta, double initial) {
  CResponse r;
  r.sp = Table(sp);
  if (second) {
    const double w = kTwoPi * fn;
    r.w = w;
    r.zeta = zeta;
    double rate;
    if (std::abs(zeta - 1.0) < 1e-9) {
      r.mode = CResponse::Mode::Critical;
      rate = w;
    } else if (zeta < 1.0) {
      r.mode = CResponse::Mode::Under;
      const double a = zeta * w, b = w * std::sqrt(1.0 - zeta * zeta);
      r.s = {-a, b};
      r.c = {1.0, -a / b};
      rate = a;
    } else {
      r.mode = CResponse::Mode::Over;
      r.p2 = w * (zeta + std::sqrt(zeta * zeta - 1.0));
      r.p1 = w * w / r.p2;
      rate = r.p1;  // slowest pole
    }
    r.window = kSettleDecades / rate;
    r.e_inf = 2.0 * zeta / w;
  } else {
    r.mode = CResponse::Mode::First;
    r.T = T;
    r.window = kSettleDecades * T;
    r.e_inf = T;
  }
  r.initial = initial;
  if (!std::isnan(initial)) r.init_delta = initial - r.base(0.0);
  return r;
}

// How compile() resolves plant terms.
struct PlantContext {
  const PlantResolver* resolver = nullptr;
  std::int64_t lookback_us = 0;
  double start_s = 0;
  Channel channel = Channel::Pressure;
};

Compiled compile(const TermSpec& ts, std::uint64_t key, const PlantContext& plants = {}) {
  return std::visit(
      overloaded{
          [](const ConstantSpec& s) -> Compiled { return CConst{s.value}; },
          [](const RampSpec& s) -> Compiled { return CRamp{s}; },
          [](const TableTermSpec& s) -> Compiled { return CTable{Table(s.table)}; },
          [](const SineSpec& s) -> Compiled {
            return CSine{s.amplitude, s.frequency_hz, s.phase_rad / kTwoPi};
          },
          [](const PulseSpec& s) -> Compiled { return CPulse{s}; },
          [](const PulsationSpec& s) -> Compiled {
            CPulsation p{s.shaft_hz, {}};
            for (const auto& h : s.harmonics) {
              const double r = std::round(h.order);
              const int io = (r == h.order && r >= 1 && r <= 256) ? int(r) : 0;
              p.h.push_back({h.order, h.amplitude * std::cos(h.phase_rad), h.amplitude * std::sin(h.phase_rad), io});
              p.max_int_order = std::max(p.max_int_order, io);
            }
            std::stable_sort(p.h.begin(), p.h.end(),
                             [](const auto& a, const auto& b) { return a.int_order < b.int_order; });
            return p;
          },
          [](const FirstOrderSpec& s) -> Compiled {
            return make_response(s.setpoint, false, s.time_constant_s, 0, 0, s.initial);
          },
          [](const SecondOrderSpec& s) -> Compiled {
            return make_response(s.setpoint, true, 0, s.natural_frequency_hz, s.damping, s.initial);
          },
          [key](const RandomWalkSpec& s) -> Compiled {
            CRandomWalk r{s, key, 0, 0, 0};
            r.reset();
            return r;
          },
          [key](const OrnsteinUhlenbeckSpec& s) -> Compiled {
            COU r{s, key, 0, 0, 0};
            r.reset();
            return r;
          },
          [](const GasLawSpec& s) -> Compiled { return CGasLaw{s.reference_pressure_pa / s.reference_temperature_k}; },
          [&plants](const PlantTermSpec& s) -> Compiled {
            if (!plants.resolver)
              throw std::invalid_argument((s.origin.empty() ? "" : s.origin + ": ") + "plant " + s.ref +
                                          ": expected a fleet with a plants: section defining it");
            return CPlant{plants.resolver->resolve(s, plants.channel, plants.lookback_us), plants.start_s};
          },
      },
      ts);
}

double eval_term(ProcessModel::Term& term, double t, double temperature) {
  return std::visit(overloaded{
                        [&](CRandomWalk& c) { return c.eval(t); },
                        [&](COU& c) { return c.eval(t); },
                        [&](CGasLaw& c) { return c.ratio * temperature; },
                        [&](const auto& c) { return c.eval(t); },
                    },
                    term.c);
}

struct Range {
  double lo, hi;
};

// A term's values over [t0, t1] (its own time axis) for `queries` evaluations;
// false when it has no bound. `temperature`: the temperature channel's range
// (gas law terms).
bool term_range(const ProcessModel::Term& term, double t0, double t1, int queries, const Range& temperature,
                Range& out) {
  const double k = kNormalBound;
  return std::visit(
      overloaded{
          [&](const CConst& c) {
            return out = {c.v, c.v}, true;
          },
          [&](const CRamp& c) {  // monotone in t
            const double a = c.eval(t0), b = std::isfinite(t1) ? c.eval(t1) : c.s.to;
            return out = {std::min(a, b), std::max(a, b)}, true;
          },
          [&](const CTable& c) {
            return out = {c.table.min_value(), c.table.max_value()}, true;
          },
          [&](const CSine& c) {
            return out = {-std::abs(c.amplitude), std::abs(c.amplitude)}, true;
          },
          [&](const CPulse& c) {
            return out = {std::min(c.s.low, c.s.high), std::max(c.s.low, c.s.high)}, true;
          },
          [&](const CPulsation& c) {
            double a = 0;
            for (const auto& h : c.h) a += std::abs(h.a_cos_phi) + std::abs(h.a_sin_phi);
            return out = {-a, a}, true;
          },
          [&](const CResponse& c) {
            // A first-order lag moves from where it is towards its setpoints.
            if (c.mode != CResponse::Mode::First) return false;
            const double y = c.eval(t0);
            out = {std::min(y, c.sp.min_value()), std::max(y, c.sp.max_value())};
            if (!std::isnan(c.initial)) out = {std::min(out.lo, c.initial), std::max(out.hi, c.initial)};
            return true;
          },
          [&](const CRandomWalk& c) {
            const double span = std::max(0.0, t1 - std::min(t0, c.t_last));
            if (!std::isfinite(span)) {
              if (!std::isfinite(c.s.min) || !std::isfinite(c.s.max)) return false;
              return out = {c.s.min, c.s.max}, true;
            }
            // queries steps of dt_i, sum <= span: sum of sqrt(dt_i) <= sqrt(queries * span).
            const double d = std::abs(c.s.drift_per_s) * span + k * c.s.sigma_per_sqrt_s * std::sqrt(queries * span);
            out = {std::max(c.s.min, c.x - d), std::min(c.s.max, c.x + d)};
            return true;
          },
          [&](const COU& c) {
            // Each step pulls towards the mean and adds sd * N, sd <= sigma * min(1, sqrt(2 dt / tau)).
            const double span = std::max(0.0, t1 - std::min(t0, c.t_last));
            const double n = queries;
            const double steps = std::isfinite(span) ? std::min(n, std::sqrt(2.0 * n * span / c.s.tau_s)) : n;
            const double d = k * c.s.sigma * steps, y = c.x - c.s.mean;
            out = {c.s.mean + std::min(0.0, y) - d, c.s.mean + std::max(0.0, y) + d};
            return true;
          },
          [&](const CGasLaw& c) {
            const double a = c.ratio * temperature.lo, b = c.ratio * temperature.hi;
            return out = {std::min(a, b), std::max(a, b)}, true;
          },
          // A plant variable follows the plant's inputs (frames, writes,
          // outputs) whenever they come: no bound holds, the channel is never steady.
          [](const CPlant&) { return false; },
      },
      term.c);
}

bool channel_range(const std::vector<ProcessModel::Term>& terms, double start_s, double t0, double t1, int queries,
                   const Range& temperature, Range& out) {
  Range sum{0, 0};
  for (const auto& term : terms) {
    Range r{};
    if (!term_range(term, t0 - start_s, t1 - start_s, queries, temperature, r)) return false;
    sum.lo += r.lo;
    sum.hi += r.hi;
  }
  // The closed forms are not exact to the last bit.
  const double eps = 1e-9 * (std::abs(sum.lo) + std::abs(sum.hi) + 1.0);
  out = {sum.lo - eps, sum.hi + eps};
  return true;
}

// eval_term without advancing the stochastic terms.
double peek_term(const ProcessModel::Term& term, double t, double temperature) {
  return std::visit(overloaded{
                        [&](const CRandomWalk& c) { return c.x; },
                        [&](const COU& c) { return c.x; },
                        [&](const CGasLaw& c) { return c.ratio * temperature; },
                        [&](const auto& c) { return c.eval(t); },
                    },
                    term.c);
}

template <class Terms, class Eval>
double sum_terms(Terms& channel, double t, double temperature, Eval eval) {
  double v = 0.0;
  for (auto& term : channel.terms) v += eval(term, t - channel.start_s, temperature);
  return v;
}

std::vector<ProcessModel::Term> compile_terms(const std::vector<TermSpec>& specs, std::uint64_t seed, Channel ch,
                                              PlantContext plants = {}) {
  const std::uint64_t tag = ch == Channel::Pressure ? 0x1000 : 0x2000;
  plants.channel = ch;
  std::vector<ProcessModel::Term> out;
  out.reserve(specs.size());
  for (std::size_t i = 0; i < specs.size(); ++i)
    out.push_back(ProcessModel::Term{compile(specs[i], derive_seed(seed, tag + i), plants)});
  return out;
}

// ------------------------------------------------------------------ validation

bool finite(double v) { return std::isfinite(v); }

std::string check_table(const TableSpec& t) {
  if (t.points.empty()) return "table has no points";
  for (std::size_t i = 0; i < t.points.size(); ++i) {
    if (!finite(t.points[i].t_s) || !finite(t.points[i].value)) return "table point not finite";
    if (i > 0 && t.points[i].t_s < t.points[i - 1].t_s) return "table times must be non-decreasing";
  }
  if (t.loop) {
    const double span = t.points.back().t_s - t.points.front().t_s;
    const double period = t.period_s > 0 ? t.period_s : span;
    if (!(period > 0)) return "looped table needs a positive period";
    if (period < span) return "table period shorter than the table";
  }
  return {};
}

std::string check_term(const TermSpec& ts, bool pressure_channel) {
  return std::visit(
      overloaded{
          [](const ConstantSpec& s) -> std::string { return finite(s.value) ? "" : "constant: not finite"; },
          [](const RampSpec& s) -> std::string {
            if (!finite(s.from) || !finite(s.to) || !finite(s.start_s) || !finite(s.duration_s))
              return "ramp: not finite";
            return s.duration_s < 0 ? "ramp: negative duration" : "";
          },
          [](const TableTermSpec& s) -> std::string {
            auto e = check_table(s.table);
            return e.empty() ? e : "table: " + e;
          },
          [](const SineSpec& s) -> std::string {
            if (!finite(s.amplitude) || !finite(s.frequency_hz) || !finite(s.phase_rad)) return "sine: not finite";
            return s.frequency_hz < 0 ? "sine: negative frequency" : "";
          },
          [](const PulseSpec& s) -> std::string {
            if (!(s.period_s > 0) || !finite(s.period_s)) return "pulse: period must be > 0";
            if (!(s.duty > 0 && s.duty < 1)) return "pulse: duty must be in (0, 1)";
            if (s.rise_s < 0 || s.fall_s < 0) return "pulse: negative edge time";
            if (s.rise_s > s.duty * s.period_s) return "pulse: rise longer than the high phase";
            if (s.duty * s.period_s + s.fall_s > s.period_s) return "pulse: fall does not fit in the period";
            if (!finite(s.low) || !finite(s.high) || !finite(s.delay_s)) return "pulse: not finite";
            return "";
          },
          [](const PulsationSpec& s) -> std::string {
            if (!(s.shaft_hz >= 0) || !finite(s.shaft_hz)) return "pulsation: shaft speed must be >= 0";
            for (const auto& h : s.harmonics)
              if (!finite(h.order) || h.order <= 0 || !finite(h.amplitude) || !finite(h.phase_rad))
                return "pulsation: bad harmonic (order must be > 0)";
            return "";
          },
          [](const FirstOrderSpec& s) -> std::string {
            if (!(s.time_constant_s > 0) || !finite(s.time_constant_s)) return "first_order: time constant must be > 0";
            auto e = check_table(s.setpoint);
            return e.empty() ? e : "first_order setpoint: " + e;
          },
          [](const SecondOrderSpec& s) -> std::string {
            if (!(s.natural_frequency_hz > 0) || !finite(s.natural_frequency_hz))
              return "second_order: natural frequency must be > 0";
            if (!(s.damping > 0) || !finite(s.damping)) return "second_order: damping must be > 0";
            auto e = check_table(s.setpoint);
            return e.empty() ? e : "second_order setpoint: " + e;
          },
          [](const RandomWalkSpec& s) -> std::string {
            if (!(s.sigma_per_sqrt_s >= 0) || !finite(s.initial) || !finite(s.drift_per_s))
              return "random_walk: bad parameters";
            return s.min > s.max ? "random_walk: min > max" : "";
          },
          [](const OrnsteinUhlenbeckSpec& s) -> std::string {
            if (!(s.tau_s > 0) || !finite(s.tau_s)) return "ornstein_uhlenbeck: tau must be > 0";
            if (!(s.sigma >= 0) || !finite(s.mean)) return "ornstein_uhlenbeck: bad sigma/mean";
            return "";
          },
          [pressure_channel](const GasLawSpec& s) -> std::string {
            if (!pressure_channel) return "gas_law is a pressure term";
            if (!(s.reference_temperature_k > 0)) return "gas_law: reference temperature must be > 0 K";
            return finite(s.reference_pressure_pa) ? "" : "gas_law: not finite";
          },
          [](const PlantTermSpec& s) -> std::string {
            return s.ref.find('.') == std::string::npos ? "plant: expected PLANT.VARIABLE" : "";
          },
      },
      ts);
}

}  // namespace

PulsationSpec PulsationSpec::piston_pump(double rpm, int pistons, double amplitude, int n_harmonics) {
  PulsationSpec p;
  p.shaft_hz = rpm / 60.0;
  for (int k = 1; k <= n_harmonics; ++k) p.harmonics.push_back({double(k * pistons), amplitude / k, 0.0});
  return p;
}

void add_gas_volume(ProcessSpec& spec, const GasVolumeSpec& gas) {
  FirstOrderSpec t;
  t.setpoint = gas.ambient_k;
  t.time_constant_s = gas.time_constant_s;
  t.initial = gas.initial_temperature_k;
  spec.temperature.emplace_back(std::move(t));
  spec.pressure.emplace_back(GasLawSpec{gas.initial_pressure_pa, gas.initial_temperature_k});
}

std::vector<TermSpec> constant_terms(double value) { return {ConstantSpec{value}}; }

std::vector<TermSpec> ramp_terms(double from, double to, double start_s, double duration_s) {
  return {RampSpec{from, to, start_s, duration_s}};
}

std::string validate(Channel channel, const std::vector<TermSpec>& terms) {
  const bool pressure = channel == Channel::Pressure;
  for (std::size_t i = 0; i < terms.size(); ++i) {
    auto e = check_term(terms[i], pressure);
    if (!e.empty()) return (pressure ? "pressure[" : "temperature[") + std::to_string(i) + "]: " + e;
  }
  return {};
}

std::string validate(const ProcessSpec& spec) {
  if (auto e = validate(Channel::Pressure, spec.pressure); !e.empty()) return e;
  return validate(Channel::Temperature, spec.temperature);
}

ProcessModel::ProcessModel() {
  terms(Channel::Pressure).terms.push_back(Term{CConst{1.0e5}});
  terms(Channel::Temperature).terms.push_back(Term{CConst{293.15}});
}

ProcessModel::ProcessModel(const ProcessSpec& spec, std::uint64_t seed, const PlantResolver* plants,
                           std::int64_t lookback_us) {
  if (auto e = validate(spec); !e.empty()) throw std::invalid_argument("process: " + e);
  const PlantContext context{plants, lookback_us, 0.0};
  terms(Channel::Pressure).terms = compile_terms(spec.pressure, seed, Channel::Pressure, context);
  terms(Channel::Temperature).terms = compile_terms(spec.temperature, seed, Channel::Temperature, context);
}

ProcessModel::ProcessModel(ProcessModel&&) noexcept = default;
ProcessModel& ProcessModel::operator=(ProcessModel&&) noexcept = default;
ProcessModel::ProcessModel(const ProcessModel&) = default;
ProcessModel& ProcessModel::operator=(const ProcessModel&) = default;
ProcessModel::~ProcessModel() = default;

Quantity ProcessModel::at(double t) {
  const double temp = sum_terms(terms(Channel::Temperature), t, 0.0, eval_term);
  return {sum_terms(terms(Channel::Pressure), t, temp, eval_term), temp};
}

Quantity ProcessModel::peek(double t) const {
  const double temp = sum_terms(terms(Channel::Temperature), t, 0.0, peek_term);
  return {sum_terms(terms(Channel::Pressure), t, temp, peek_term), temp};
}

void ProcessModel::set_channel(Channel channel, const std::vector<TermSpec>& specs, std::uint64_t seed, double start_s,
                               const PlantResolver* plants, std::int64_t lookback_us) {
  if (auto e = validate(channel, specs); !e.empty()) throw std::invalid_argument("process: " + e);
  Terms replacement{compile_terms(specs, seed, channel, PlantContext{plants, lookback_us, start_s}), start_s};
  std::optional<Terms>& constructed = constructed_[std::size_t(channel)];
  if (!constructed) constructed = std::move(terms(channel));
  terms(channel) = std::move(replacement);
}

void ProcessModel::restore_channel(Channel channel) {
  std::optional<Terms>& constructed = constructed_[std::size_t(channel)];
  if (!constructed) return;
  terms(channel) = std::move(*constructed);
  constructed.reset();
}

void ProcessModel::reset() {
  auto r = [](Terms& channel) {
    for (Term& term : channel.terms) {
      if (auto* a = std::get_if<CRandomWalk>(&term.c)) a->reset();
      if (auto* b = std::get_if<COU>(&term.c)) b->reset();
    }
  };
  for (Terms& channel : channels_) r(channel);
  for (std::optional<Terms>& constructed : constructed_)
    if (constructed) r(*constructed);
}

bool ProcessModel::bounds(Channel channel, double t0_s, double t1_s, int queries, double& lo, double& hi) const {
  const Terms& temp = terms(Channel::Temperature);
  Range temperature{}, out{};
  if (!channel_range(temp.terms, temp.start_s, t0_s, t1_s, queries, {}, temperature)) return false;
  if (channel == Channel::Temperature) {
    out = temperature;
  } else {
    const Terms& p = terms(Channel::Pressure);
    if (!channel_range(p.terms, p.start_s, t0_s, t1_s, queries, temperature, out)) return false;
  }
  lo = out.lo;
  hi = out.hi;
  return true;
}

bool ProcessModel::has_stochastic_terms() const {
  auto s = [](const Term& term) {
    return std::holds_alternative<CRandomWalk>(term.c) || std::holds_alternative<COU>(term.c);
  };
  return std::any_of(std::begin(channels_), std::end(channels_),
                     [&](const Terms& c) { return std::any_of(c.terms.begin(), c.terms.end(), s); });
}

bool ProcessModel::reads_plant() const {
  auto p = [](const Term& term) { return std::holds_alternative<CPlant>(term.c); };
  return std::any_of(std::begin(channels_), std::end(channels_),
                     [&](const Terms& c) { return std::any_of(c.terms.begin(), c.terms.end(), p); });
}

// ------------------------------------------------------------------ TermSeries

TermSeries::TermSeries() = default;
TermSeries::TermSeries(TermSeries&&) noexcept = default;
TermSeries& TermSeries::operator=(TermSeries&&) noexcept = default;
TermSeries::~TermSeries() = default;

TermSeries::TermSeries(const std::vector<TermSpec>& specs, std::uint64_t seed) {
  for (std::size_t i = 0; i < specs.size(); ++i) {
    if (std::holds_alternative<GasLawSpec>(specs[i]) || std::holds_alternative<PlantTermSpec>(specs[i]))
      throw std::invalid_argument("term " + std::to_string(i) + ": gas_law and plant terms are channel terms only");
    if (auto e = check_term(specs[i], true); !e.empty())
      throw std::invalid_argument("term " + std::to_string(i) + ": " + e);
    terms_.push_back(ProcessModel::Term{compile(specs[i], derive_seed(seed, 0x3000 + i))});
  }
}

double TermSeries::at(double t) {
  double v = 0.0;
  for (ProcessModel::Term& term : terms_) v += eval_term(term, t, 0.0);
  return v;
}

bool TermSeries::constant_after(double t) const {
  for (const ProcessModel::Term& term : terms_) {
    const bool constant = std::visit(
        overloaded{
            [](const CConst&) { return true; },
            [t](const CRamp& c) { return c.s.duration_s <= 0 ? t >= c.s.start_s : t >= c.s.start_s + c.s.duration_s; },
            [t](const CTable& c) {
              return c.table.next_event_time(t) == std::numeric_limits<double>::infinity() && c.table.slope(t) == 0.0;
            },
            [](const CSine& c) { return c.amplitude == 0.0 || c.freq == 0.0; },
            [](const auto&) { return false; },
        },
        term.c);
    if (!constant) return false;
  }
  return true;
}

}  // namespace cansim::physics
