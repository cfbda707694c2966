// libFuzzer target: the fleet loader. The input is a fleet configuration's
// text, read twice:
//   - as the file config/fuzz-fleet.yaml of the source tree (profiles are
//     resolved as cansimd resolves them: config/profiles, profiles/ of the
//     source tree, ./profiles), then checked as `cansimd --check` does
//     (config::load_fleet checks every profile
//     and variant, daemon::make_node_application for every node);
//   - as a control API AddNodes fragment (one entry, a list, or a document)
//     added to the demo fleet (config/cansimd.yaml): parse_fleet_fragment,
//     merge_fleet, check_fleet of the new nodes.
// No crash, no sanitizer report, no hang; every rejection is a
// config::ConfigError whose message starts with "<file>:<line>[:<column>]:
// <key>: " (else abort()), and names the input's file unless it is what the
// file it names says when loaded alone: an entry's override blamed on its
// profile aborts (it did: "profiles/p92c.yaml:1:1: vendor.cia404..." for
// the fleet entry's own `vendor: {cia404: {chanels: 1}}`). Seeds:
// fuzz/corpus-fleet/.
#include <cstdint>
#include <exception>
#include <memory>
#include <string>

#include "config/fleet.hpp"
#include "daemon/daemon.hpp"
#include "loader_support.hpp"

using namespace cansim;

namespace {

const std::string kFleetFile = std::string(CANSIM_SOURCE_DIR) + "/config/fuzz-fleet.yaml";

const config::FleetConfig& demo_fleet() {
  static const config::FleetConfig f = [] {
    const std::string demo = std::string(CANSIM_SOURCE_DIR) + "/config/cansimd.yaml";
    return config::load_fleet(demo, daemon::profile_search(demo));
  }();
  return f;
}

// What loading `file` alone as a profile (faithful, then strict) and building
// its node says; empty when both load.
std::string error_of_file_alone(const std::string& file, bool strict) {
  try {
    config::NodeConfig n;
    n.key = "vcan0/alone/0";
    n.name = "alone";
    n.interface = "vcan0";
    n.profile = std::make_shared<config::Profile>(config::load_any_profile(file, strict));
    n.node_id = n.profile->node_id;
    n.bit_rate_kbit = n.profile->bit_rate_kbit;
    daemon::make_node_application(n, 1);
  } catch (const std::exception& e) {
    return e.what();
  }
  return {};
}

// A rejection names the input (`input_file`), or is the error of the file it
// names, whatever the input says about it.
void check_attribution(const std::string& message, const std::string& input_file) {
  if (message.rfind(input_file + ":", 0) == 0) return;
  const std::string file = message.substr(0, message.find(':'));
  if (error_of_file_alone(file, false) == message || error_of_file_alone(file, true) == message) return;
  std::fprintf(stderr, "rejection blamed on %s, which loads alone without it: %s\n", file.c_str(), message.c_str());
  std::abort();
}

template <class Fn>
void expect_config_error_only(const std::string& input_file, Fn&& fn) {
  try {
    fn();
  } catch (const config::ConfigError& e) {
    fuzz::check_error_format(e.what());
    check_attribution(e.what(), input_file);
  } catch (const std::exception& e) {
    fuzz::unexpected_exception(e.what());
  }
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const std::string text(reinterpret_cast<const char*>(data), size);
  // A profile given by absolute path may name any file: keep away from the
  // special file systems (a read of /dev/zero or /proc/kmsg never ends).
  for (const char* special : {"/dev", "/proc", "/sys", "/run"})
    if (text.find(special) != std::string::npos) return 0;
  const config::FleetConfig& running = demo_fleet();
  expect_config_error_only(kFleetFile, [&] {
    config::FleetConfig f = config::parse_fleet(text, kFleetFile, daemon::profile_search(kFleetFile));
    daemon::check_fleet(f);
  });
  expect_config_error_only("<AddNodes #1>", [&] {
    config::FleetConfig extra =
        config::parse_fleet_fragment(text, "<AddNodes #1>", daemon::profile_search(kFleetFile), running);
    config::FleetConfig merged = running;
    config::merge_fleet(merged, extra);
    daemon::check_fleet(extra);  // the running fleet's profiles are prepared already
  });
  return 0;
}

extern "C" std::size_t LLVMFuzzerCustomMutator(std::uint8_t* data, std::size_t size, std::size_t max_size,
                                               unsigned seed) {
  return fuzz::mutate_yaml(data, size, max_size, seed);
}

extern "C" std::size_t LLVMFuzzerCustomCrossOver(const std::uint8_t* d1, std::size_t s1, const std::uint8_t* d2,
                                                 std::size_t s2, std::uint8_t* out, std::size_t max_out,
                                                 unsigned seed) {
  return fuzz::crossover_yaml(d1, s1, d2, s2, out, max_out, seed);
}
