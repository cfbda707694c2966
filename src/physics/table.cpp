#include "physics/table.hpp"

#include <algorithm>
#include <charconv>
#include <cmath>
#include <limits>
#include <stdexcept>

namespace cansim::physics {

Table::Table(const TableSpec& spec) : interp_(spec.interpolation), loop_(spec.loop) {
  if (spec.points.empty()) throw std::invalid_argument("table: no points");
  for (std::size_t i = 0; i < spec.points.size(); ++i) {
    const auto& p = spec.points[i];
    if (!std::isfinite(p.t_s) || !std::isfinite(p.value)) throw std::invalid_argument("table: non-finite point");
    if (i > 0 && p.t_s < spec.points[i - 1].t_s) throw std::invalid_argument("table: times must be non-decreasing");
  }
  t0_ = spec.points.front().t_s;
  const double span = spec.points.back().t_s - t0_;
  pts_.reserve(spec.points.size());
  for (const auto& p : spec.points) pts_.push_back({p.t_s - t0_, p.value});
  min_ = max_ = pts_.front().value;
  for (const auto& p : pts_) {
    min_ = std::min(min_, p.value);
    max_ = std::max(max_, p.value);
  }
  const std::size_t m = pts_.size();

  if (loop_) {
    period_ = spec.period_s > 0 ? spec.period_s : span;
    if (!(period_ > 0)) throw std::invalid_argument("table: looped table needs a positive period");
    if (period_ < span) throw std::invalid_argument("table: period shorter than the table");
  }
  const bool wrap_segment = loop_ && period_ > span;  // gap after the last point

  // Group points by identical time; compute knots.
  std::size_t a = 0;
  while (a < m) {
    std::size_t b = a;
    while (b + 1 < m && pts_[b + 1].t_s == pts_[a].t_s) ++b;
    const double tau = pts_[a].t_s;
    const bool last_group = (b == m - 1);
    if (loop_ && last_group && !wrap_segment && a != 0) {
      // Points at tau == period coincide with the next cycle's start: handled at tau 0.
      break;
    }
    double vl, vr, sl, sr;
    vr = pts_[b].value;
    if (interp_ == Interpolation::Linear) {
      vl = a == 0 ? pts_[0].value : pts_[a].value;
      sl = a == 0 ? 0.0 : (pts_[a].value - pts_[a - 1].value) / (tau - pts_[a - 1].t_s);
      if (!last_group) sr = (pts_[b + 1].value - pts_[b].value) / (pts_[b + 1].t_s - tau);
      else if (wrap_segment) sr = (pts_[0].value - pts_[b].value) / (period_ - tau);
      else sr = 0.0;
    } else {
      vl = a == 0 ? pts_[0].value : pts_[a - 1].value;
      sl = 0.0;
      sr = 0.0;
    }
    if (a == 0) {
      // The very first occurrence starts from the pre-start hold (value v0, slope 0).
      first_step_ = vr - vl;
      first_dslope_ = sr - sl;
      if (loop_) {
        // Generic cycle: the left limit is the end of the previous cycle.
        double el, esl;
        if (wrap_segment) {
          const double vlast = pts_[m - 1].value;
          if (interp_ == Interpolation::Linear) {
            el = pts_[0].value;
            esl = (pts_[0].value - vlast) / (period_ - pts_[m - 1].t_s);
          } else {
            el = vlast;
            esl = 0.0;
          }
        } else {
          // Last group sits at tau == period; find its first point.
          std::size_t la = m - 1;
          while (la > 0 && pts_[la - 1].t_s == pts_[m - 1].t_s) --la;
          if (interp_ == Interpolation::Linear) {
            el = pts_[la].value;
            esl = la > 0 ? (pts_[la].value - pts_[la - 1].value) / (pts_[la].t_s - pts_[la - 1].t_s) : 0.0;
          } else {
            el = la > 0 ? pts_[la - 1].value : pts_[0].value;
            esl = 0.0;
          }
        }
        knots_.push_back({0.0, vr - el, sr - esl});
      } else {
        knots_.push_back({t0_, first_step_, first_dslope_});
      }
    } else {
      knots_.push_back({loop_ ? tau : tau + t0_, vr - vl, sr - sl});
    }
    a = b + 1;
  }
}

double Table::cycle_value(double tau) const {
  // Last point with t <= tau.
  auto it = std::upper_bound(pts_.begin(), pts_.end(), tau, [](double x, const TablePoint& p) { return x < p.t_s; });
  std::size_t j = it == pts_.begin() ? 0 : std::size_t(it - pts_.begin()) - 1;
  const auto& pj = pts_[j];
  if (interp_ == Interpolation::Hold) return pj.value;
  if (j + 1 < pts_.size()) {
    const auto& pn = pts_[j + 1];
    return pj.value + (pn.value - pj.value) * (tau - pj.t_s) / (pn.t_s - pj.t_s);
  }
  if (loop_ && period_ > pj.t_s) return pj.value + (pts_[0].value - pj.value) * (tau - pj.t_s) / (period_ - pj.t_s);
  return pj.value;
}

double Table::cycle_slope(double tau) const {
  if (interp_ == Interpolation::Hold) return 0.0;
  auto it = std::upper_bound(pts_.begin(), pts_.end(), tau, [](double x, const TablePoint& p) { return x < p.t_s; });
  std::size_t j = it == pts_.begin() ? 0 : std::size_t(it - pts_.begin()) - 1;
  const auto& pj = pts_[j];
  if (j + 1 < pts_.size()) {
    const auto& pn = pts_[j + 1];
    return (pn.value - pj.value) / (pn.t_s - pj.t_s);
  }
  if (loop_ && period_ > pj.t_s) return (pts_[0].value - pj.value) / (period_ - pj.t_s);
  return 0.0;
}

double Table::value(double t) const {
  if (pts_.empty()) return 0.0;
  if (t < t0_) return pts_[0].value;
  double tau = t - t0_;
  if (loop_) {
    tau = std::fmod(tau, period_);
    if (tau < 0) tau = 0;
  }
  return cycle_value(tau);
}

double Table::slope(double t) const {
  if (pts_.empty() || t < t0_) return 0.0;
  double tau = t - t0_;
  if (loop_) {
    tau = std::fmod(tau, period_);
    if (tau < 0) tau = 0;
  }
  return cycle_slope(tau);
}

double Table::next_event_time(double t) const {
  constexpr double kInf = std::numeric_limits<double>::infinity();
  if (knots_.empty()) return kInf;
  auto first_after = [&](double x) {
    return std::upper_bound(knots_.begin(), knots_.end(), x, [](double v, const Knot& k) { return v < k.tau; });
  };
  if (!loop_) {
    auto it = first_after(t);
    return it == knots_.end() ? kInf : it->tau;
  }
  if (t < t0_) return t0_;
  const double cycles = std::floor((t - t0_) / period_);
  double tau = (t - t0_) - cycles * period_;
  if (tau < 0) tau = 0;
  auto it = first_after(tau);
  double te = it == knots_.end() ? t0_ + (cycles + 1) * period_ + knots_[0].tau : t0_ + cycles * period_ + it->tau;
  if (te <= t) te = std::nextafter(t, kInf);  // rounding guard
  return te;
}

// ---------------------------------------------------------------- CSV

namespace {

bool parse_number(std::string_view tok, double& v) {
  while (!tok.empty() && (tok.front() == ' ' || tok.front() == '\t' || tok.front() == '"')) tok.remove_prefix(1);
  while (!tok.empty() && (tok.back() == ' ' || tok.back() == '\t' || tok.back() == '"' || tok.back() == '\r'))
    tok.remove_suffix(1);
  if (tok.empty()) return false;
  const char* first = tok.data();
  const char* last = tok.data() + tok.size();
  if (*first == '+') ++first;
  auto [ptr, ec] = std::from_chars(first, last, v);
  return ec == std::errc{} && ptr == last && std::isfinite(v);
}

}  // namespace

bool parse_table_csv(std::string_view text, std::vector<TablePoint>& out, std::string* error, double time_scale,
                     double value_scale, double value_offset) {
  out.clear();
  std::size_t line_no = 0;
  bool any_data = false;
  while (!text.empty()) {
    const std::size_t nl = text.find('\n');
    std::string_view line = text.substr(0, nl);
    text = nl == std::string_view::npos ? std::string_view{} : text.substr(nl + 1);
    ++line_no;
    while (!line.empty() && (line.back() == '\r' || line.back() == ' ' || line.back() == '\t')) line.remove_suffix(1);
    std::size_t s = 0;
    while (s < line.size() && (line[s] == ' ' || line[s] == '\t')) ++s;
    line.remove_prefix(s);
    if (line.empty() || line.front() == '#') continue;
    // Tokenise on , ; or whitespace.
    std::string_view tok[2];
    int ntok = 0;
    std::size_t pos = 0;
    while (pos <= line.size() && ntok < 2) {
      std::size_t end = line.find_first_of(",; \t", pos);
      if (end == std::string_view::npos) end = line.size();
      std::string_view t = line.substr(pos, end - pos);
      if (!t.empty()) tok[ntok++] = t;
      pos = end + 1;
      // Collapse runs of whitespace (not of commas: empty CSV fields count as missing).
      while (pos < line.size() && (line[pos] == ' ' || line[pos] == '\t')) ++pos;
    }
    double t = 0, v = 0;
    const bool ok = ntok == 2 && parse_number(tok[0], t) && parse_number(tok[1], v);
    if (!ok) {
      if (!any_data) continue;  // header line(s) before the data
      if (error) *error = "line " + std::to_string(line_no) + ": expected two numeric columns (time, value)";
      return false;
    }
    any_data = true;
    TablePoint p{t * time_scale, v * value_scale + value_offset};
    if (!out.empty() && p.t_s < out.back().t_s) {
      if (error) *error = "line " + std::to_string(line_no) + ": time goes backwards";
      return false;
    }
    out.push_back(p);
  }
  if (out.empty()) {
    if (error) *error = "no data rows";
    return false;
  }
  return true;
}

}  // namespace cansim::physics
