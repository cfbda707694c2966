// spdlog set-up: journald (systemd sink) when started by systemd
// (JOURNAL_STREAM set), else the terminal (stderr, coloured when a tty).
#pragma once

#include <string>

namespace cansim::daemon {

// level: trace, debug, info, warn, error, critical, off.
void setup_logging(const std::string& level);

}  // namespace cansim::daemon
