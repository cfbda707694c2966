// Prints replies and events: aligned human text, or JSON with --json.
#pragma once

#include <ostream>
#include <string>
#include <string_view>
#include <vector>

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
  void value(const ObjectAddress& object, const Value& v);
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
