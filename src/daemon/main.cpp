// cansimd: simulated CANopen sensor fleet on SocketCAN. See `cansimd --help`.
#include <spdlog/spdlog.h>

#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <functional>
#include <string>
#include <vector>

#include "config/eds_writer.hpp"
#include "config/fleet.hpp"
#include "daemon/cli.hpp"
#include "daemon/daemon.hpp"
#include "daemon/dbc_export.hpp"
#include "daemon/logging.hpp"
#include "config/strict_mode.hpp"
#include "personalities/registry.hpp"

#ifndef CANSIM_VERSION
#define CANSIM_VERSION "unknown"
#endif

using namespace cansim;

namespace {

config::FleetConfig load(const daemon::CliOptions& o, config::ProfileStore* store = nullptr) {
  const bool single = o.config.empty();
  config::ProfileSearch search = daemon::profile_search(single ? "" : o.config);
  search.strict = o.strict;
  search.strict_eds = o.strict_eds;
  search.store = store;
  config::FleetConfig fleet = single ? config::single_node_fleet(o.profile, o.interface, o.node_id, search)
                                     : config::load_fleet(o.config, search);
  config::apply_record_option(fleet, o.record, single);
  return fleet;
}

// An export (--export-eds, --export-dbc) to --output FILE or stdout. Exit 0,
// or 1 with the error on stderr.
int exported(const std::string& path, const std::function<std::string()>& text) {
  try {
    const std::string t = text();
    if (path.empty()) {
      std::fputs(t.c_str(), stdout);
      return 0;
    }
    std::ofstream out(path, std::ios::binary);
    out << t;
    out.close();
    if (!out) throw config::ConfigError(path + ": cannot write the file");
    return 0;
  } catch (const std::exception& e) {
    std::fprintf(stderr, "cansimd: %s\n", e.what());
    return 1;
  }
}

// cansimd --export-eds: the profile's EDS, or with --node-id the DCF of that
// node at power-on.
std::string eds_text(const daemon::CliOptions& o) {
  const std::string path = config::find_profile(o.export_eds, ".", daemon::profile_search(""));
  if (path.empty()) throw config::ConfigError(o.export_eds + ": profile not found (expected a file or a profile name)");
  const config::Profile profile = config::load_any_profile(path, o.strict, o.strict_eds);
  if (o.node_id) return config::write_default_dcf(profile, std::uint8_t(*o.node_id));
  config::EdsIdentity id = config::identity_of(profile);
  id.created = config::eds_time_now();
  return config::write_eds(*profile.layout, *profile.options, id);
}

// cansimd --export-dbc: the DBC of one bus of a fleet file, or of one node of a profile.
std::string dbc_text(const daemon::CliOptions& o) {
  config::ProfileSearch search = daemon::profile_search(o.export_dbc);
  search.strict = o.strict;
  search.strict_eds = o.strict_eds;
  const bool fleet_file = config::is_fleet_file(o.export_dbc);
  config::FleetConfig fleet = fleet_file ? config::load_fleet(o.export_dbc, search)
                                         : config::single_node_fleet(o.export_dbc, o.interface, o.node_id, search);
  return daemon::export_dbc(fleet, fleet_file && o.interface_given ? o.interface : "");
}

// `cansimd --profile P --quirks`: the deviations faithful mode has, as a
// Markdown table (scripts/gen-quirk-docs pastes it into docs/devices).
int print_quirks(const daemon::CliOptions& o) {
  config::FleetConfig fleet = config::single_node_fleet(o.profile, o.interface, o.node_id, daemon::profile_search(""));
  const config::Profile& profile = *fleet.profiles.front();
  const std::vector<config::Quirk> rows = config::quirk_inventory(profile);
  std::printf("%s: %zu deviation(s) from CiA 301 / 305 / 404 in faithful mode; strict mode sets the strict value.\n",
              profile.name.c_str(), rows.size());
  if (rows.empty()) return 0;
  std::printf("\n| Quirk | Manual | Faithful | Strict |\n|---|---|---|---|\n");
  for (const config::Quirk& q : rows)
    std::printf("| `%s` | %s | `%s` | `%s` |\n", q.name.c_str(), q.reference.c_str(), q.faithful.c_str(),
                q.strict.c_str());
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  std::vector<std::string> args(argv + 1, argv + argc);
  daemon::CliResult cli = daemon::parse_cli(args, std::getenv("STATE_DIRECTORY"));
  if (!cli.error.empty()) {
    std::fprintf(stderr, "cansimd: %s\n\n%s", cli.error.c_str(), daemon::usage_text().c_str());
    return 2;
  }
  const daemon::CliOptions& o = cli.options;
  if (o.help) {
    std::fputs(daemon::usage_text().c_str(), stdout);
    return 0;
  }
  if (o.version) {
    std::printf("cansimd %s\n", CANSIM_VERSION);
    return 0;
  }
  if (!o.export_eds.empty()) return exported(o.output, [&] { return eds_text(o); });
  if (!o.export_dbc.empty()) return exported(o.output, [&] { return dbc_text(o); });
  daemon::setup_logging(o.log_level);
  try {
    if (o.quirks) return print_quirks(o);
    if (o.check) {
      config::FleetConfig fleet = load(o);
      std::vector<std::string> warnings;
      const std::string summary = daemon::check_fleet(fleet, &warnings);
      // Valid but probably not meant (a node at another rate than its bus is
      // how LSS bit-rate switching is tested): warned about, exit 0.
      for (const std::string& w : warnings) std::fprintf(stderr, "cansimd: warning: %s\n", w.c_str());
      std::printf("%s%s\n", summary.c_str(),
                  warnings.empty() ? "" : (", " + std::to_string(warnings.size()) + " warning(s)").c_str());
      return 0;
    }
    daemon::DaemonSettings settings;
    settings.state_dir = o.state_dir;
    settings.seed = o.seed;
    settings.load = [o](config::ProfileStore* store) {
      config::FleetConfig fleet = load(o, store);
      for (const std::string& w : daemon::load_warnings(fleet)) spdlog::warn("{}", w);
      return fleet;
    };
    settings.config_file = o.config.empty() ? o.profile : o.config;
    settings.strict = o.strict;
    settings.strict_eds = o.strict_eds;
    settings.bus = o.bus == "system" ? control::BusChoice::kSystem
                   : o.bus == "user" ? control::BusChoice::kUser
                   : o.bus == "none" ? control::BusChoice::kNone
                                     : control::BusChoice::kAuto;
    settings.control_socket = o.control_socket;
    settings.max_clients = o.max_clients;
    settings.address_file = o.address_file;
    settings.socketcand = o.socketcand;
    spdlog::info("cansimd {} starting, stored parameters in {}", CANSIM_VERSION, o.state_dir);
    daemon::Daemon d(std::move(settings));
    return d.run();
  } catch (const std::exception& e) {
    if (o.check || o.quirks) std::fprintf(stderr, "%s\n", e.what());
    else spdlog::critical("{}", e.what());
    return 1;
  }
}
