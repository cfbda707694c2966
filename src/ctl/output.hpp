// Prints replies and events: aligned human text, or JSON with --json.
#pragma once

#include <ostream>
#include <string>
#include <string_view>
#include <vector>

#include "ctl/frame_decoder.hpp"
#include "ctl/replies.hpp"

namespace cansim::ctl {

// Rows of text in columns two spaces apart; the first row is the header.
class Table {
 public:
  explicit Table(std::vector<std::string> header) { rows_.push_back(std::move(header)); }
  void add(std::vector<std::string> row) { rows_.push_back(std::move(row)); }
  void print(std::ostream& out) const;

 private:
  std::vector<std::vector<std::string>> rows_;
};

// "1 drift (active), 2 noise", or "none".
std::string format_fault_briefs(const std::vector<FaultBrief>& faults);

// One watch line: "   12.345678 vcan0/dps/0 NmtStateChanged old=stopped new=operational".
std::string format_event(const Event& e);

class Printer {
 public:
  Printer(std::ostream& out, bool json) : out_(out), json_(json) {}

  void nodes(const std::vector<NodeRow>& rows);
  void status(const NodeStatus& s);
  void fault_id(std::uint32_t id);
  void faults(const std::vector<FaultRow>& rows);
  // A Read value; `meaning` (ListObjects) adds its unit: "3.5 bar", "350 (3.50 bar)".
  void value(const ObjectAddress& object, const Value& v, const ObjectInfo* meaning = nullptr);
  void group(const std::vector<GroupResult>& results);  // one line (or object) per node
  // A refusal or a bad command line on stderr: "cansimctl: what", or with
  // --json {"error": what, "name": D-Bus error or null, "exit_status": n}.
  static void error(std::ostream& err, bool json, const std::string& what, const std::string& name, int status);
  void added(const std::vector<NodeRef>& nodes);
  void time(std::int64_t us);
  void stats(const std::vector<BusStats>& rows);
  void document(std::string_view name, const std::string& text);  // as it is; JSON: {"name": text}
  void event(const Event& e);  // one line, flushed

  std::ostream& stream() const { return out_; }
  bool json() const { return json_; }

 private:
  void status_text(const NodeStatus& s);
  void status_json(const NodeStatus& s);

  std::ostream& out_;
  bool json_;
};

}  // namespace cansim::ctl
