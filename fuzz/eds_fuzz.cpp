// libFuzzer target: the CiA 306 EDS / DCF reader and everything an imported
// device description feeds when cansimd starts. The input is a file's text;
// it goes through config::parse_eds and profile_from_eds, then
// daemon::make_node_application (generic
// personality, CiA 404 chain when the objects are there), and a node built
// from it boots and runs 200 ms of simulated time. An accepted file must
// also export (config::write_eds) to a file that reads back to the same
// object dictionary. No crash, no sanitizer report, no hang; every rejection
// is a config::ConfigError "fuzz.eds:<line>: <where>: ..." with a line of the
// input (else abort()).
//
// Seeds: fuzz/corpus-eds/ (the exported EDS of every profile, written by
// scripts/fuzz-run, hand-written messy files and the foreign-style files of
// tests/data/eds); mutations: libFuzzer's
// plus line-level ones (lines duplicated, dropped, swapped, values after '='
// replaced by interesting ones).
#include <cstdint>
#include <cstring>
#include <exception>
#include <memory>
#include <random>
#include <string>

#include "config/eds_reader.hpp"
#include "config/eds_writer.hpp"
#include "core/node.hpp"
#include "daemon/daemon.hpp"
#include "loader_support.hpp"
#include "personalities/registry.hpp"

using namespace cansim;

namespace {

std::size_t line_count(const std::string& text) {
  std::size_t n = 1;
  for (char c : text) n += c == '\n';
  return n;
}

// "fuzz.eds:<line>: " with 1 <= line <= the input's lines.
bool names_an_input_line(const std::string& message, const std::string& text) {
  const std::string prefix = "fuzz.eds:";
  if (message.rfind(prefix, 0) != 0) return false;
  std::size_t line = 0, at = prefix.size();
  while (at < message.size() && message[at] >= '0' && message[at] <= '9' && line < 1000000000)
    line = line * 10 + std::size_t(message[at++] - '0');
  return line >= 1 && line <= line_count(text) && message.compare(at, 2, ": ") == 0;
}

void check_eds_error(const std::string& message, const std::string& text) {
  fuzz::check_error_format(message);
  if (names_an_input_line(message, text)) return;
  std::fprintf(stderr, "rejection without fuzz.eds:<line of the input>: %s\n", message.c_str());
  std::abort();
}

void same_or_abort(bool same, const OdEntry& e, const char* what) {
  if (same) return;
  std::fprintf(stderr, "export / import changed %s of 0x%04X:%02X\n", what, e.index, e.sub);
  std::abort();
}

// An accepted file exports to an EDS that reads back to the same dictionary
// (string defaults aside: the writer turns line breaks into blanks).
void check_export_round_trip(const config::Profile& p) {
  const std::string text = config::write_eds(*p.layout, *p.options, config::identity_of(p));
  const config::Profile back = config::profile_from_eds(config::parse_eds(text, "export.eds"));
  const auto a = p.layout->entries(), b = back.layout->entries();
  if (a.size() != b.size()) {
    std::fprintf(stderr, "export / import changed the number of entries: %zu -> %zu\n", a.size(), b.size());
    std::abort();
  }
  for (std::size_t i = 0; i < a.size(); ++i) {
    same_or_abort(a[i].index == b[i].index && a[i].sub == b[i].sub, a[i], "the address");
    same_or_abort(a[i].type == b[i].type && a[i].access == b[i].access, a[i], "type or access");
    same_or_abort(a[i].pdo_mappable == b[i].pdo_mappable, a[i], "PDO mapping");
    same_or_abort(a[i].has_low == b[i].has_low && a[i].has_high == b[i].has_high, a[i], "the limits");
    if (is_variable_size(a[i].type)) continue;
    same_or_abort(a[i].default_bytes == b[i].default_bytes, a[i], "the default");
    same_or_abort(a[i].default_plus_node_id == b[i].default_plus_node_id, a[i], "$NODEID");
    const std::size_t n = type_size(a[i].type);
    same_or_abort(std::memcmp(a[i].low, b[i].low, n) == 0 && std::memcmp(a[i].high, b[i].high, n) == 0, a[i],
                  "the limit values");
  }
}

const char* interesting_eds_value(std::mt19937& rng) {
  static const char* const kValues[] = {
      "", "0", "-1", "1", "010", "08", "0x", "0x7F", "0x80", "0xFF", "0xFFFF", "0xFFFFFFFF", "0x100000000",
      "0xFFFFFFFFFFFFFFFF", "-0x8000000000000000", "18446744073709551616", "1.5", "-0", "1e400", "nan", "inf",
      "$NODEID", "$NODEID+0x180", "0x180+$NODEID", "$NodeID + 0x200", "$NODEID+$NODEID", "+",
      "0x80000000+0x180+$nodeid", "0x7", "0x8", "0x9", "0x5", "0x2", "0x0009", "0x000F", "0x000A", "0x0008", "0x0011",
      "0x001B", "0x0C", "ro", "rw", "wo", "const", "rwr", "rww", "RW", "254", "255", "256", "0 ; comment", "00 11 22",
      "0A0B0C", "abc",
      // what the reader repairs: hex flags, REAL bits, the SDO server's COB-IDs, 0 = not set
      "0x0", "0x1", "0x3E6B851F", "0x7FF0000000000000", "0x610", "0x80000000", "$NODEID+0x600", "$NODEID+0x580"};
  return kValues[rng() % (sizeof kValues / sizeof *kValues)];
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const std::string text(reinterpret_cast<const char*>(data), size);
  std::shared_ptr<config::Profile> profile;
  try {
    profile = std::make_shared<config::Profile>(config::profile_from_eds(config::parse_eds(text, "fuzz.eds")));
  } catch (const config::ConfigError& e) {
    check_eds_error(e.what(), text);
    return 0;
  } catch (const std::exception& e) {
    fuzz::unexpected_exception(e.what());
  }
  try {
    check_export_round_trip(*profile);
  } catch (const std::exception& e) {
    std::fprintf(stderr, "the export of an accepted file does not read back: %s\n", e.what());
    std::abort();
  }
  try {
    fuzz::run_profile_node(profile);
  } catch (const config::ConfigError& e) {
    fuzz::check_error_format(e.what());  // the personality's own checks (no vendor section here)
  } catch (const std::exception& e) {
    fuzz::unexpected_exception(e.what());
  }
  return 0;
}

extern "C" std::size_t LLVMFuzzerCustomMutator(std::uint8_t* data, std::size_t size, std::size_t max_size,
                                               unsigned seed) {
  std::mt19937 rng(seed);
  if (rng() % 3 == 0 || size == 0) return LLVMFuzzerMutate(data, size, max_size);
  const std::string text(reinterpret_cast<const char*>(data), size);
  const auto lines = fuzz::split_lines(text);
  std::vector<std::string> out(lines.begin(), lines.end());
  const std::size_t a = rng() % out.size(), b = rng() % out.size();
  switch (rng() % 4) {
    case 0: out.insert(out.begin() + long(b), out[a]); break;
    case 1: out.erase(out.begin() + long(a)); break;
    case 2: std::swap(out[a], out[b]); break;
    default: {
      std::string& l = out[a];
      const std::size_t eq = l.find('=');
      if (eq == std::string::npos) break;
      const bool newline = !l.empty() && l.back() == '\n';
      l = l.substr(0, eq + 1) + interesting_eds_value(rng) + (newline ? "\n" : "");
    }
  }
  std::string joined;
  for (const auto& l : out) joined += l;
  if (joined.size() > max_size) return LLVMFuzzerMutate(data, size, max_size);
  std::memcpy(data, joined.data(), joined.size());
  return joined.size();
}

extern "C" std::size_t LLVMFuzzerCustomCrossOver(const std::uint8_t* d1, std::size_t s1, const std::uint8_t* d2,
                                                 std::size_t s2, std::uint8_t* out, std::size_t max_out,
                                                 unsigned seed) {
  return fuzz::crossover_yaml(d1, s1, d2, s2, out, max_out, seed);
}
