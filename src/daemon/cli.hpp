// cansimd command line. Bad usage is reported as an error string; main()
// prints it with the usage text and exits 2.
#pragma once

#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include "config/limits.hpp"

namespace cansim::daemon {

struct CliOptions {
  std::string profile;              // --profile FILE|NAME: one node
  std::string interface = "vcan0";  // --interface IF (with --profile; --export-dbc: the bus)
  bool interface_given = false;
  std::optional<int> node_id;         // --node-id N (with --profile)
  std::string config;                 // --config FILE: a fleet
  std::string export_eds;             // --export-eds FILE|NAME: write the profile's EDS and exit
  std::string export_dbc;             // --export-dbc CONFIG|PROFILE: write a bus's DBC and exit
  std::string output;                 // --output FILE (with --export-eds / --export-dbc; default stdout)
  bool check = false;                 // --check: validate and exit
  bool strict = false;                // --strict: every node CiA-strict (entry options still win)
  bool strict_eds = false;            // --strict-eds: what the EDS reader would repair is an error
  bool quirks = false;                // --quirks: print the profile's quirk inventory and exit
  std::string state_dir;              // --state-dir, $STATE_DIRECTORY, ./state
  std::string log_level = "info";     // --log-level
  std::optional<std::uint64_t> seed;  // --seed
  std::string record;                 // --record FILE (--profile) | DIR (--config)
  std::string bus = "auto";           // --bus auto|system|user|none: the control API's bus
  std::string control_socket;         // --control-socket PATH|none (empty: the default path)
  std::size_t max_clients = limits::kDefaultMaxClients;  // --max-clients N: peers served at once
  std::string address_file;  // --address-file FILE: the socketcand buses' addresses (docs/socketcand.md)
  bool socketcand = false;   // --socketcand: every interface a socketcand bus on a free loopback port
  bool version = false;
  bool help = false;
};

struct CliResult {
  CliOptions options;
  std::string error;  // non-empty: usage error (exit 2)
};

// args excludes argv[0]. state_directory_env is $STATE_DIRECTORY (may be null).
CliResult parse_cli(const std::vector<std::string>& args, const char* state_directory_env);
std::string usage_text();

}  // namespace cansim::daemon
