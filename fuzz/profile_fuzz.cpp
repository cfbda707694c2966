// libFuzzer target: the YAML profile loader and everything a profile feeds
// when cansimd starts. The input is a profile's text; it goes through
// config::parse_profile (vendor, physics,
// sensor, faults sections), daemon::make_node_application (the node's
// personality and physics), and a node built from it boots and runs 200 ms
// of simulated time. No crash, no sanitizer report, no hang, no deadline that
// stops advancing; every rejection is a config::ConfigError whose message
// starts with "fuzz-profile.yaml:<line>[:<column>]: <key>: " (else abort()).
//
// Seeds: fuzz/corpus-profile/ (the shipped profiles/*.yaml and small
// variants); mutations: libFuzzer's, plus line-level YAML mutations
// (loader_support.hpp).
#include <cstdint>
#include <exception>
#include <memory>
#include <string>

#include "config/profile.hpp"
#include "core/node.hpp"
#include "daemon/daemon.hpp"
#include "loader_support.hpp"
#include "personalities/registry.hpp"

using namespace cansim;

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const std::string text(reinterpret_cast<const char*>(data), size);
  try {
    auto profile = std::make_shared<config::Profile>(config::parse_profile(text, "fuzz-profile.yaml"));
    fuzz::run_profile_node(profile);
  } catch (const config::ConfigError& e) {
    fuzz::check_error_format(e.what());
  } catch (const std::exception& e) {
    fuzz::unexpected_exception(e.what());
  }
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
