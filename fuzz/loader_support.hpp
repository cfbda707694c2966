// Shared by the loader fuzz targets (profile_fuzz, fleet_fuzz): the check that
// every rejection names file:line, a node run over a short simulated time,
// and a line-level YAML mutator (structure-aware mutations of the shipped
// files: lines duplicated, dropped, swapped, moved between inputs, values
// replaced by interesting ones) on top of libFuzzer's byte mutations.
#pragma once

#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <memory>
#include <random>
#include <string>
#include <string_view>
#include <vector>

#include "config/fleet.hpp"
#include "core/node.hpp"
#include "daemon/daemon.hpp"
#include "support/memory_storage.hpp"

extern "C" std::size_t LLVMFuzzerMutate(std::uint8_t* data, std::size_t size, std::size_t max_size);

namespace cansim::fuzz {

using test::MemoryStorage;

// A config::ConfigError message must start with "<file>:<line>[:<column>]: "
// (yaml_util.cpp's fail(), the YAML syntax errors) followed by the key path
// or "YAML syntax error". Anything else aborts, so libFuzzer keeps the input.
inline bool has_error_format(const std::string& m) {
  std::size_t i = m.find(':');
  if (i == 0 || i == std::string::npos || m.find('\n') < i) return false;
  auto digits = [&](std::size_t& at) {
    const std::size_t start = at;
    while (at < m.size() && m[at] >= '0' && m[at] <= '9') ++at;
    return at > start;
  };
  ++i;
  if (!digits(i)) return false;  // line
  if (i < m.size() && m[i] == ':' && i + 1 < m.size() && m[i + 1] != ' ') {
    ++i;
    if (!digits(i)) return false;  // column
  }
  if (m.compare(i, 2, ": ") != 0) return false;
  const std::string rest = m.substr(i + 2);
  if (rest.rfind("YAML syntax error: ", 0) == 0) return true;
  const std::size_t key_end = rest.find(": ");  // the key path
  return key_end != std::string::npos && key_end > 0;
}

inline void check_error_format(const std::string& message) {
  if (!has_error_format(message)) {
    std::fprintf(stderr, "rejection without file:line:key: ");
    for (const char c : message) std::fprintf(stderr, c >= ' ' && c < 0x7f ? "%c" : "\\x%02x", c);
    std::fprintf(stderr, "\n");
    std::abort();
  }
}

[[noreturn]] inline void unexpected_exception(const char* what) {
  std::fprintf(stderr, "not a config::ConfigError: %s\n", what);
  std::abort();
}

class CheckingSink : public FrameSink {
 public:
  void send(const CanFrame& f) override {
    if (f.dlc > 8) std::abort();
    if (!f.extended() && f.id > 0x7FF) std::abort();
  }
};

// Powers the node on and runs it for `span` of simulated time; a deadline
// that does not move (the daemon would spin) aborts.
inline void run_node(Node& node, TimeUs span) {
  TimeUs now = 0;
  node.power_on(now);
  long guard = 0;
  for (TimeUs next = node.next_deadline(); next <= span; next = node.next_deadline()) {
    if (++guard > 200000) {
      std::fprintf(stderr, "node deadline does not advance (at %lld us)\n", static_cast<long long>(now));
      std::abort();
    }
    now = std::max(now, next);
    node.advance(now);
  }
}

// A node of `profile` as the daemon builds it (its application and physics,
// a storage in memory) on a checking sink, run for 200 ms of simulated time.
inline void run_profile_node(const std::shared_ptr<config::Profile>& profile) {
  config::NodeConfig n;
  n.key = "vcan0/fuzz/0";
  n.name = "fuzz";
  n.interface = "vcan0";
  n.node_id = profile->node_id;
  n.bit_rate_kbit = profile->bit_rate_kbit;
  n.serial = 7;
  n.profile = profile;
  auto app = daemon::make_node_application(n, 1);
  CheckingSink sink;
  MemoryStorage storage;
  const NodeSetup setup = daemon::node_setup(n, 1);
  Node node(setup, sink, app.get(), &storage);
  node.set_bus_bit_rate(setup.bit_rate_index);
  run_node(node, ms(200));
  node.power_off();
}

// ---- line-level YAML mutations
inline std::vector<std::string_view> split_lines(std::string_view s) {
  std::vector<std::string_view> out;
  std::size_t at = 0;
  while (at < s.size()) {
    std::size_t nl = s.find('\n', at);
    if (nl == std::string_view::npos) nl = s.size() - 1;
    out.push_back(s.substr(at, nl - at + 1));
    at = nl + 1;
  }
  return out;
}

// Values that hit the loaders' edges: types, ranges, YAML forms.
inline const char* interesting_value(std::mt19937& rng) {
  static const char* const kValues[] = {"0",
                                        "-1",
                                        "1",
                                        "255",
                                        "256",
                                        "65535",
                                        "0x7F",
                                        "0x80",
                                        "0xFFFFFFFF",
                                        "0x100000000",
                                        "-0x8000000000000000",
                                        "9223372036854775807",
                                        "18446744073709551615",
                                        "1e308",
                                        "-1e308",
                                        ".nan",
                                        ".inf",
                                        "1.5",
                                        "''",
                                        "~",
                                        "null",
                                        "[]",
                                        "{}",
                                        "[1, 2]",
                                        "{a: 1}",
                                        "yes",
                                        "no",
                                        "$NODEID",
                                        "$NODEID+0x180",
                                        "0x80000000+0x180+$NODEID",
                                        "1..8",
                                        "0..255",
                                        "3..1",
                                        "rw",
                                        "ro",
                                        "const",
                                        "UNSIGNED8",
                                        "REAL32",
                                        "VISIBLE_STRING",
                                        "DOMAIN",
                                        "OCTET_STRING",
                                        "INTEGER64",
                                        "BOOLEAN",
                                        "0 s",
                                        "-1 s",
                                        "1 ms",
                                        "10 bar",
                                        "1e9 bar",
                                        "-5 degC",
                                        "0 K",
                                        "nonsense",
                                        "&a x",
                                        "*a",
                                        "!!binary AA==",
                                        "\"\\x00\"",
                                        "0b101",
                                        "1_000",
                                        "1000",
                                        "250",
                                        "0x6130",
                                        "0x1A00",
                                        "0x1800",
                                        "0x1017",
                                        "generic",
                                        "honeywell-dps",
                                        "trafag-cmp",
                                        "gems-9000",
                                        "danfoss-p92c",
                                        "adz-smc",
                                        "generic-404",
                                        "dps",
                                        "vcan0",
                                        "vcan1",
                                        "127",
                                        "128",
                                        "pressure",
                                        "temperature",
                                        "bar",
                                        "psi",
                                        "Pa"};
  return kValues[rng() % (sizeof kValues / sizeof *kValues)];
}

// Mutates `data` line-wise; falls back to libFuzzer's mutator.
inline std::size_t mutate_yaml(std::uint8_t* data, std::size_t size, std::size_t max_size, unsigned seed) {
  std::mt19937 rng(seed);
  if (rng() % 3 == 0 || size == 0) return LLVMFuzzerMutate(data, size, max_size);
  std::string text(reinterpret_cast<const char*>(data), size);
  std::vector<std::string_view> lines = split_lines(text);
  std::vector<std::string> out(lines.begin(), lines.end());
  if (out.empty()) return LLVMFuzzerMutate(data, size, max_size);
  const std::size_t a = rng() % out.size(), b = rng() % out.size();
  switch (rng() % 6) {
    case 0: out.insert(out.begin() + long(b), out[a]); break;  // duplicate a line
    case 1: out.erase(out.begin() + long(a)); break;           // drop a line
    case 2: std::swap(out[a], out[b]); break;                  // swap two lines
    case 3: {                                                  // replace a value after ': '
      std::string& l = out[a];
      std::vector<std::size_t> colons;
      for (std::size_t i = 0; i + 1 < l.size(); ++i)
        if (l[i] == ':' && l[i + 1] == ' ') colons.push_back(i + 2);
      if (colons.empty()) break;
      const std::size_t from = colons[rng() % colons.size()];
      std::size_t to = l.find_first_of(",}\n#", from);
      if (to == std::string::npos) to = l.size();
      l.replace(from, to - from, interesting_value(rng));
      break;
    }
    case 4: {  // change the indentation
      std::string& l = out[a];
      if (rng() % 2 && !l.empty() && l[0] == ' ') l.erase(0, std::min<std::size_t>(2, l.find_first_not_of(' ')));
      else l.insert(0, "  ");
      break;
    }
    default: {  // a flow item gets a key from another line
      std::string& l = out[a];
      const std::string& other = out[b];
      const std::size_t colon = other.find(": ");
      const std::size_t brace = l.find('{');
      if (colon == std::string::npos || brace == std::string::npos) break;
      std::size_t key_start = other.find_last_of(" {,-", colon);
      key_start = key_start == std::string::npos || key_start >= colon ? 0 : key_start + 1;
      l.insert(brace + 1, other.substr(key_start, colon - key_start) + ": " + interesting_value(rng) + ", ");
      break;
    }
  }
  std::string joined;
  for (const auto& l : out) joined += l;
  if (joined.size() > max_size) return LLVMFuzzerMutate(data, size, max_size);
  std::memcpy(data, joined.data(), joined.size());
  return joined.size();
}

// Splices a run of lines from another input into this one.
inline std::size_t crossover_yaml(const std::uint8_t* d1, std::size_t s1, const std::uint8_t* d2, std::size_t s2,
                                  std::uint8_t* out, std::size_t max_out, unsigned seed) {
  std::mt19937 rng(seed);
  std::string a(reinterpret_cast<const char*>(d1), s1), b(reinterpret_cast<const char*>(d2), s2);
  auto la = split_lines(a), lb = split_lines(b);
  std::string joined;
  if (la.empty() || lb.empty()) {
    joined = a;
  } else {
    const std::size_t cut = rng() % la.size(), from = rng() % lb.size(), n = 1 + rng() % 8;
    for (std::size_t i = 0; i < cut; ++i) joined += la[i];
    for (std::size_t i = from; i < std::min(lb.size(), from + n); ++i) joined += lb[i];
    for (std::size_t i = cut; i < la.size(); ++i) joined += la[i];
  }
  if (joined.size() > max_out) joined.resize(max_out);
  std::memcpy(out, joined.data(), joined.size());
  return joined.size();
}

}  // namespace cansim::fuzz
