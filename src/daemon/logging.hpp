// spdlog set-up: the journal when stderr is systemd's journal stream
// (JOURNAL_STREAM names stderr's device and inode), else the terminal (stderr,
// coloured when a tty).
//
// Journal entries about one interface or one node carry structured fields:
// CANSIM_IFACE=vcan0, and for a node also CANSIM_NODE=vcan0/dps/0 (its fleet
// key), so `journalctl -u cansimd CANSIM_NODE=vcan0/dps/0` selects one node;
// a control action's line also CANSIM_CALLER_UID=.
// A LogSubject names them for the lines logged while it lives (the daemon is
// one thread); an inner one replaces the outer until it ends.
#pragma once

#include <spdlog/common.h>
#include <sys/types.h>

#include <optional>
#include <string>
#include <string_view>
#include <vector>

namespace cansim::daemon {

// level: trace, debug, info, warn, error, critical, off.
void setup_logging(const std::string& level);

class LogSubject {
 public:
  static LogSubject interface(std::string_view name) { return LogSubject(name, {}); }
  // key: the node's fleet key "<interface>/<name>/<index>".
  static LogSubject node(std::string_view key) { return LogSubject(key.substr(0, key.find('/')), key); }
  // A control action: its node (or interface, or neither) and the caller's uid
  // (CANSIM_CALLER_UID=).
  static LogSubject action(std::string_view iface, std::string_view node, std::optional<unsigned> uid) {
    return LogSubject(iface, node, uid ? std::to_string(*uid) : "");
  }
  ~LogSubject();
  LogSubject(const LogSubject&) = delete;
  LogSubject& operator=(const LogSubject&) = delete;

  // The subject in force ("" when none).
  static std::string_view current_interface();
  static std::string_view current_node();
  static std::string_view current_caller_uid();

 private:
  LogSubject(std::string_view iface, std::string_view node, std::string_view uid = {});
  std::string iface_, node_, uid_;
  const LogSubject* outer_;
};

// The journal entry of one line: MESSAGE=, PRIORITY= (syslog), SYSLOG_IDENTIFIER=,
// then CANSIM_IFACE= / CANSIM_NODE= of the subject in force.
std::vector<std::string> journal_fields(spdlog::level::level_enum level, std::string_view message);

// True when JOURNAL_STREAM ("<device>:<inode>") names the file stderr is
// (st_dev, st_ino): then stderr goes to the journal, not to a terminal or a
// file a child of a service was given.
bool journal_stream_matches(const char* journal_stream, dev_t dev, ino_t ino);

}  // namespace cansim::daemon
