// Prints replies and events: aligned human text, or JSON with --json. Each
// reply type has one JSON form (to_json below), the same in every verb that
// shows it: a status's faults are watch's Faults, a top row's readings are
// status's (docs/cansimctl.md, "JSON").
#pragma once

#include <ostream>
#include <string>
#include <string_view>
#include <vector>

#include "ctl/frame_decoder.hpp"
#include "ctl/json.hpp"
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

// "3.5 bar", "9 990 440 Pa"; "-" without the channel.
std::string format_reading_value(const Reading& r, double value);

// The JSON of each reply type.
void to_json(Json& j, const NodeRow& r);
void to_json(Json& j, const Reading& r);  // null without the channel
void to_json(Json& j, const OverrideRow& o);
void to_json(Json& j, const FaultBrief& f);
void to_json(Json& j, const FaultRow& f);
void to_json(Json& j, const EmcyRecord& e);  // null when none was sent
void to_json(Json& j, const NodeStatus& s);
void to_json(Json& j, const GroupResult& r);
void to_json(Json& j, const NodeRef& n);
void to_json(Json& j, const BusStats& b);
void to_json(Json& j, const Event& e);

// One watch line: "   12.345678 vcan0/dps/0 NmtStateChanged old=stopped new=operational".
std::string format_event(const Event& e);

class Printer {
 public:
  Printer(std::ostream& out, bool json) : out_(out), json_(json) {}

  void nodes(const std::vector<NodeRow>& rows);
  void status(const NodeStatus& s);
  // `column`: what FaultRow::channel is (a plant's faults: TARGET).
  void faults(const std::vector<FaultRow>& rows, const char* column = "CHANNEL");
  // A Read value of `node`; `meaning` (ListObjects) adds its unit: "3.5 bar", "350 (0x15e) = 3.50 bar".
  void value(const std::string& node, const ObjectAddress& object, const Value& v, const ObjectInfo* meaning = nullptr);
  // What an acting verb did: a fault's id in text, nothing else (the Unix
  // way); with --json one result object, or one per node of a group.
  void acted(const GroupResult& result);
  void group(const std::vector<GroupResult>& results);  // one line (or object) per node
  // A refusal or a bad command line on stderr: "cansimctl: what", or with
  // --json {"error": what, "name": D-Bus error or null, "exit_status": n}.
  static void error(std::ostream& err, bool json, const std::string& what, const std::string& name, int status);
  void added(const std::vector<NodeRef>& nodes);
  void done();  // a fleet verb without a node: {"ok": true} with --json
  void time(std::int64_t us);
  void stats(const std::vector<BusStats>& rows);
  void document(std::string_view name, const std::string& text);  // as it is; JSON: {"name": text}
  void event(const Event& e);                                     // one line, flushed

  std::ostream& stream() const { return out_; }
  bool json() const { return json_; }

 private:
  void status_text(const NodeStatus& s);

  std::ostream& out_;
  bool json_;
};

}  // namespace cansim::ctl
