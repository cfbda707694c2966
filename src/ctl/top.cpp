#include "ctl/top.hpp"

#include <fnmatch.h>
#include <sys/ioctl.h>
#include <termios.h>
#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <optional>
#include <sstream>
#include <thread>

#include "ctl/client_loop.hpp"
#include "ctl/decode.hpp"
#include "ctl/json.hpp"
#include "ctl/output.hpp"

namespace cansim::ctl {

namespace {

constexpr std::uint64_t kRefreshUs = 500000;  // about twice a second

std::string two_hex(std::uint8_t v) {
  char buf[4];
  std::snprintf(buf, sizeof buf, "%02x", v);
  return buf;
}

std::string state_text(const NodeStatus& s) {
  if (!s.powered) return "off";
  return s.on_bus ? s.nmt_state : s.nmt_state + " (off the bus)";
}

std::string active_faults(const std::vector<FaultBrief>& faults) {
  std::string out;
  for (const FaultBrief& f : faults)
    if (f.active) out += (out.empty() ? "" : ",") + f.kind;
  return out.empty() ? "-" : out;
}

TopRow row_of(const NodeStatus& s) {
  TopRow r;
  r.key = s.key;
  r.node_id = s.node_id;
  r.state = state_text(s);
  r.pressure = s.pressure.unit.empty() ? "-"
                                       : format_measure(s.pressure.reported) + " / " +
                                             format_reading_value(s.pressure, s.pressure.true_value);
  if (!std::isnan(s.pressure.counts)) r.pressure += " (" + format_measure(s.pressure.counts) + " counts)";
  r.temperature = format_reading_value(s.temperature, s.temperature.reported);
  if (!std::isnan(s.temperature.counts)) r.temperature += " (" + format_measure(s.temperature.counts) + " counts)";
  r.status = (s.pressure.unit.empty() ? "--" : two_hex(s.pressure.status)) + " " +
             (s.temperature.unit.empty() ? "--" : two_hex(s.temperature.status));
  r.faults = active_faults(s.faults);
  r.emcy = s.emcy_count;
  return r;
}

std::string fps_text(double fps) {
  if (fps < 0) return "-";
  char buf[32];
  std::snprintf(buf, sizeof buf, "%.1f", fps);
  return buf;
}

// The terminal in raw mode and on its alternate screen while top runs.
class Screen {
 public:
  Screen() {
    tcgetattr(STDIN_FILENO, &saved_);
    termios raw = saved_;
    raw.c_lflag &= ~tcflag_t(ICANON | ECHO);
    raw.c_cc[VMIN] = 0;
    raw.c_cc[VTIME] = 0;
    tcsetattr(STDIN_FILENO, TCSANOW, &raw);
    std::fputs("\x1b[?1049h\x1b[?25l", stdout);  // alternate screen, cursor hidden
  }
  ~Screen() {
    std::fputs("\x1b[?25h\x1b[?1049l", stdout);
    std::fflush(stdout);
    tcsetattr(STDIN_FILENO, TCSANOW, &saved_);
  }
  Screen(const Screen&) = delete;
  Screen& operator=(const Screen&) = delete;

  static void size(std::size_t& rows, std::size_t& columns) {
    winsize w{};
    rows = 24, columns = 80;
    if (ioctl(STDOUT_FILENO, TIOCGWINSZ, &w) == 0 && w.ws_row > 0) rows = w.ws_row, columns = w.ws_col;
  }

 private:
  termios saved_{};
};

class Top {
 public:
  Top(Connection& connection, const TopOptions& options, std::ostream& out)
      : connection_(connection), options_(options), out_(out) {}

  int run();
  int once();

 private:
  void fetch_all();
  void fetch_page();
  void sample(const NodeStatus& s);
  std::vector<TopRow> rows() const;
  Json rows_json() const;
  void draw();
  void on_signal(sd_bus_message* m);
  void on_key(ClientLoop& loop);
  std::size_t last_first() const { return nodes_.size() > page_ ? nodes_.size() - page_ : 0; }

  Connection& connection_;
  const TopOptions& options_;
  std::ostream& out_;
  std::vector<NodeStatus> nodes_;  // matching, in natural order
  FrameRates rates_;
  std::size_t first_ = 0;  // first row shown
  std::size_t page_ = 20;
  bool interactive_ = false;
};

double monotonic_seconds() {
  return std::chrono::duration<double>(std::chrono::steady_clock::now().time_since_epoch()).count();
}

void Top::sample(const NodeStatus& s) { rates_.sample(s.key, s.frames_sent, monotonic_seconds()); }

void Top::fetch_all() {
  MessagePtr reply = connection_.call(kFleetPath, "org.freedesktop.DBus.ObjectManager", "GetManagedObjects");
  nodes_ = top_nodes(read_managed_nodes(reply.get()), options_.glob);
  for (const NodeStatus& s : nodes_) sample(s);
}

// The rows on screen, one GetAll each.
void Top::fetch_page() {
  const std::vector<Arg> interface { Value(std::string(kNodeInterface)) };
  for (std::size_t i = first_; i < std::min(nodes_.size(), first_ + page_); ++i) {
    MessagePtr reply = connection_.call(nodes_[i].path, kPropertiesInterface, "GetAll", interface);
    NodeStatus s = read_node_status(reply.get());
    s.path = nodes_[i].path;
    nodes_[i] = std::move(s);
    sample(nodes_[i]);
  }
}

Json Top::rows_json() const {
  Json rows = Json::array();
  for (const NodeStatus& s : nodes_) rows.push_back(top_json(s, rates_));
  return rows;
}

std::vector<TopRow> Top::rows() const {
  std::vector<TopRow> out;
  for (const NodeStatus& s : nodes_) out.push_back(top_row(s, rates_));
  return out;
}

void Top::draw() {
  if (options_.json) return print_json(out_, rows_json());
  if (!interactive_) {
    out_ << format_top_table(rows()) << std::endl;
    return;
  }
  std::size_t height = 24, width = 80;
  Screen::size(height, width);
  page_ = height > 3 ? height - 3 : 1;  // the title, a blank line and the table's header
  first_ = std::min(first_, last_first());
  std::size_t operational = 0;
  for (const NodeStatus& s : nodes_) operational += s.nmt_state == "operational";
  std::string head =
      "cansimctl top: " + std::to_string(nodes_.size()) + " node(s)" +
      (options_.glob.empty() ? "" : " matching '" + options_.glob + "'") + ", " + std::to_string(operational) +
      " operational; rows " + std::to_string(nodes_.empty() ? 0 : first_ + 1) + "-" +
      std::to_string(std::min(nodes_.size(), first_ + page_)) + "  (arrows, PgUp/PgDn, Home/End scroll; q quits)";
  out_ << top_screen(head, format_top_table(rows(), first_, page_), height, width) << std::flush;
}

// NMT states and EMCYs show as they happen; nodes added or removed at once.
void Top::on_signal(sd_bus_message* m) {
  const std::string member = sd_bus_message_get_member(m);
  if (member == "NodeAdded" || member == "NodeRemoved") return fetch_all(), draw();
  if (member != "NmtStateChanged" && member != "EmcySent") return;
  Event e = read_event(m);
  for (NodeStatus& s : nodes_) {
    if (s.key != e.source) continue;
    if (member == "EmcySent") ++s.emcy_count;
    for (const Field& f : e.fields)
      if (f.name == "new") s.nmt_state = format_value(f.value);
  }
  draw();
}

void Top::on_key(ClientLoop& loop) {
  char buf[16];
  const ssize_t n = read(STDIN_FILENO, buf, sizeof buf);
  if (n <= 0) return;
  const std::string keys(buf, std::size_t(n));
  if (keys == "q" || keys == "Q") return loop.stop();
  if (keys == "\x1b[A" || keys == "k") first_ = first_ > 0 ? first_ - 1 : 0;
  else if (keys == "\x1b[B" || keys == "j") first_ = std::min(first_ + 1, last_first());
  else if (keys == "\x1b[5~" || keys == "b") first_ = first_ > page_ ? first_ - page_ : 0;
  else if (keys == "\x1b[6~" || keys == " ") first_ = std::min(first_ + page_, last_first());
  else if (keys == "\x1b[H" || keys == "\x1b[1~" || keys == "g") first_ = 0;
  else if (keys == "\x1b[F" || keys == "\x1b[4~" || keys == "G") first_ = last_first();
  else return;
  fetch_page();
  draw();
}

int Top::once() {
  fetch_all();
  std::this_thread::sleep_for(std::chrono::microseconds(kRefreshUs));
  fetch_all();
  draw();
  return 0;
}

int Top::run() {
  interactive_ = !options_.json && isatty(STDOUT_FILENO) && isatty(STDIN_FILENO);
  ClientLoop loop(connection_);
  loop.on_signals("type='signal',path_namespace='" + std::string(kFleetPath) + "'",
                  [this](sd_bus_message* m) { on_signal(m); });
  connection_.call(kFleetPath, kFleetInterface, "Subscribe");
  std::optional<Screen> screen;
  if (interactive_) {
    screen.emplace();
    loop.on_readable(STDIN_FILENO, [this, &loop] { on_key(loop); });
  }
  fetch_all();
  draw();
  loop.every(kRefreshUs, [this] {
    if (interactive_) fetch_page();
    else fetch_all();
    draw();
  });
  return loop.run("top", options_.json);
}

}  // namespace

bool glob_matches(const std::string& glob, const std::string& key, const std::string& name) {
  if (glob.empty()) return true;
  const std::string index = key.substr(key.rfind('/') + 1);
  for (const std::string& candidate : {key, name + "/" + index, name})
    if (fnmatch(glob.c_str(), candidate.c_str(), 0) == 0) return true;
  return false;
}

void FrameRates::sample(const std::string& key, std::uint64_t frames, double seconds) {
  std::deque<Sample>& list = samples_[key];
  if (!list.empty() && (seconds <= list.back().seconds || frames < list.back().frames)) {
    if (frames >= list.back().frames) return;  // no time passed
    list.clear();                              // removed and added again: counting restarts
  }
  list.push_back({frames, seconds});
  while (list.size() > 2 && seconds - list[1].seconds >= kWindow) list.pop_front();
}

double FrameRates::rate(const std::string& key) const {
  auto it = samples_.find(key);
  if (it == samples_.end() || it->second.size() < 2) return -1;
  const Sample& first = it->second.front();
  const Sample& last = it->second.back();
  return double(last.frames - first.frames) / (last.seconds - first.seconds);
}

std::vector<NodeStatus> top_nodes(std::vector<NodeStatus> nodes, const std::string& glob) {
  std::erase_if(nodes, [&](const NodeStatus& s) { return !glob_matches(glob, s.key, s.name); });
  std::sort(nodes.begin(), nodes.end(),
            [](const NodeStatus& a, const NodeStatus& b) { return natural_less(a.key, b.key); });
  return nodes;
}

TopRow top_row(const NodeStatus& node, const FrameRates& rates) {
  TopRow r = row_of(node);
  r.fps = rates.rate(node.key);
  return r;
}

Json top_json(const NodeStatus& node, const FrameRates& rates) {
  const double fps = rates.rate(node.key);
  return {{"node", node.key},
          {"node_id", node.node_id},
          {"nmt_state", node.nmt_state},
          {"powered", node.powered},
          {"on_bus", node.on_bus},
          {"pressure", node.pressure},
          {"temperature", node.temperature},
          {"faults", node.faults},
          {"emcy_count", node.emcy_count},
          {"frames_per_second", fps < 0 ? Json(nullptr) : Json(std::round(fps * 10) / 10)}};
}

std::string top_screen(const std::string& head, const std::string& table, std::size_t height, std::size_t width) {
  std::vector<std::string> lines{head, ""};
  for (std::size_t start = 0; start < table.size();) {
    std::size_t end = std::min(table.find('\n', start), table.size());
    lines.push_back(table.substr(start, end - start));
    start = end + 1;
  }
  lines.resize(std::min(lines.size(), std::max<std::size_t>(height, 1)));
  // Home, then each line over the old one (cleared to its end), the rest
  // cleared: no flicker. No newline after the last line: on the screen's
  // last row it would scroll the title away.
  std::string screen = "\x1b[H";
  for (std::size_t i = 0; i < lines.size(); ++i) screen += (i ? "\n" : "") + lines[i].substr(0, width) + "\x1b[K";
  return screen + "\x1b[J";
}

std::string format_top_table(const std::vector<TopRow>& rows, std::size_t first, std::size_t count) {
  Table table({"KEY", "ID", "NMT", "PRESSURE (REPORTED / TRUE)", "TEMPERATURE", "STATUS", "FAULTS", "EMCY", "FPS"});
  const std::size_t end = count == 0 ? rows.size() : std::min(rows.size(), first + count);
  for (std::size_t i = first; i < end; ++i) {
    const TopRow& r = rows[i];
    table.add({r.key, "0x" + two_hex(r.node_id), r.state, r.pressure, r.temperature, r.status, r.faults,
               std::to_string(r.emcy), fps_text(r.fps)});
  }
  std::ostringstream out;
  table.print(out);
  return out.str();
}

int run_top(Connection& connection, const TopOptions& options, std::ostream& out) {
  Top top(connection, options, out);
  return options.once ? top.once() : top.run();
}

}  // namespace cansim::ctl
