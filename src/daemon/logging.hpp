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

#include <cstdint>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

namespace cansim::daemon {

// At most `burst` lines in each `period` (a window that opens with the first
// line after the last one closed); the lines held back beyond are counted,
// and the next line let through (or the owner's summary) says how many.
class LineBudget {
 public:
  LineBudget(int burst, std::int64_t period_us) : burst_(burst), period_(period_us) {}
  // True when a line may go out at `now` (µs, monotonic); else it is counted.
  bool allow(std::int64_t now);
  // " (and N more such lines held back in the last 10 s)", or "" when none;
  // the count starts again.
  std::string take_held();
  // Lines are held back and their window has closed: time for a summary.
  bool summary_due(std::int64_t now) const { return held_ > 0 && now - opened_ >= period_; }

 private:
  int burst_;
  std::int64_t period_;
  std::int64_t opened_ = 0;
  int used_ = 0;
  bool open_ = false;
  std::uint64_t held_ = 0;
};

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
