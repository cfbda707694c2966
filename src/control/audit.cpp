#include "control/audit.hpp"

#include <spdlog/spdlog.h>

#include <cstdio>
#include <cstring>

#include "control/control_host.hpp"
#include "control/names.hpp"

namespace cansim::control {

namespace {

constexpr std::size_t kMaxText = 80;  // longer strings (YAML) are cut
constexpr std::size_t kMaxSenders = 256;

std::string one_line(std::string s) {
  for (char& c : s)
    if (c == '\n' || c == '\r' || c == '\t') c = ' ';
  if (s.size() > kMaxText) s = s.substr(0, kMaxText) + "...";
  return s;
}

std::string hex(unsigned v, int digits) {
  char buf[16];
  std::snprintf(buf, sizeof buf, "0x%0*X", digits, v);
  return buf;
}

std::string describe_value(sd_bus_message* m);

std::string describe_basic(sd_bus_message* m, char type) {
  union {
    std::uint8_t y;
    int b;
    std::int16_t n;
    std::uint16_t q;
    std::int32_t i;
    std::uint32_t u;
    std::int64_t x;
    std::uint64_t t;
    double d;
    const char* s;
  } v{};
  if (sd_bus_message_read_basic(m, type, &v) <= 0) return "?";
  char buf[32];
  switch (type) {
    case 'y': return std::to_string(v.y);
    case 'b': return v.b ? "true" : "false";
    case 'n': return std::to_string(v.n);
    case 'q': return std::to_string(v.q);
    case 'i': return std::to_string(v.i);
    case 'u': return std::to_string(v.u);
    case 'x': return std::to_string(v.x);
    case 't': return std::to_string(v.t);
    case 'd': std::snprintf(buf, sizeof buf, "%g", v.d); return buf;
    default: return one_line(v.s ? v.s : "");
  }
}

std::string describe_bytes(sd_bus_message* m) {
  const void* data = nullptr;
  std::size_t size = 0;
  if (sd_bus_message_read_array(m, 'y', &data, &size) < 0) return "?";
  std::string out;
  for (std::size_t i = 0; i < size && i < kMaxText / 3; ++i) {
    char buf[4];
    std::snprintf(buf, sizeof buf, "%02x", static_cast<const std::uint8_t*>(data)[i]);
    out += (out.empty() ? "" : ":") + std::string(buf);
  }
  return out;
}

std::string describe_map(sd_bus_message* m) {
  std::string out;
  if (sd_bus_message_enter_container(m, 'a', "{ss}") <= 0) return "?";
  const char *key = nullptr, *value = nullptr;
  while (sd_bus_message_read(m, "{ss}", &key, &value) > 0)
    out += (out.empty() ? "" : ", ") + std::string(key) + "=" + value;
  sd_bus_message_exit_container(m);
  return "{" + one_line(out) + "}";
}

std::string describe_value(sd_bus_message* m) {
  char type = 0;
  const char* contents = nullptr;
  if (sd_bus_message_peek_type(m, &type, &contents) <= 0) return "?";
  if (type == 'v') {
    if (sd_bus_message_enter_container(m, 'v', contents) <= 0) return "?";
    std::string v = describe_value(m);
    sd_bus_message_exit_container(m);
    return v;
  }
  if (type == 'a' && contents && std::strcmp(contents, "y") == 0) return describe_bytes(m);
  if (type == 'a' && contents && std::strcmp(contents, "{ss}") == 0) return describe_map(m);
  if (type == 'a' || type == 'r' || type == 'e') {
    sd_bus_message_skip(m, nullptr);
    return "...";
  }
  return describe_basic(m, type);
}

}  // namespace

ActionLimiter::Admission ActionLimiter::admit(Clock::time_point now) {
  Admission a;
  if (now - window_start_ >= window_) {
    a.suppressed = suppressed_line();
    window_start_ = now;
    in_window_ = 0;
  }
  a.log = in_window_ < burst_;
  if (a.log) ++in_window_;
  else ++suppressed_;
  return a;
}

std::optional<ActionRecord> ActionLimiter::suppressed_line() {
  if (suppressed_ == 0) return std::nullopt;
  const auto seconds = std::chrono::duration_cast<std::chrono::seconds>(window_).count();
  ActionRecord r{"", "",
                 "control: " + std::to_string(suppressed_) + " action line(s) suppressed (more than " +
                     std::to_string(burst_) + " in " + std::to_string(seconds) + " s)"};
  suppressed_ = 0;
  return r;
}

std::optional<ActionRecord> ActionLimiter::flush() { return suppressed_line(); }

std::string describe_arguments(sd_bus_message* m) {
  if (sd_bus_message_rewind(m, 1) < 0) return "";
  const char* signature = sd_bus_message_get_signature(m, 1);
  std::string out;
  // (q index, y sub) first: an object address.
  if (signature && std::strncmp(signature, "qy", 2) == 0) {
    std::uint16_t index = 0;
    std::uint8_t sub = 0;
    if (sd_bus_message_read(m, "qy", &index, &sub) > 0) out = " " + hex(index, 4) + ":" + hex(sub, 2).substr(2);
  }
  for (int r = sd_bus_message_at_end(m, 0); r == 0; r = sd_bus_message_at_end(m, 0)) out += " " + describe_value(m);
  return out;
}

std::optional<uid_t> CallerIds::of(sd_bus_message* m) {
  if (auto peer = by_bus_.find(sd_bus_message_get_bus(m)); peer != by_bus_.end()) return peer->second;
  const char* sender = sd_bus_message_get_sender(m);
  if (sender) {
    auto it = by_sender_.find(sender);
    if (it != by_sender_.end()) return it->second;
  }
  sd_bus_creds* creds = nullptr;
  if (sd_bus_query_sender_creds(m, SD_BUS_CREDS_EUID | SD_BUS_CREDS_AUGMENT, &creds) < 0) return std::nullopt;
  uid_t uid = 0;
  const int r = sd_bus_creds_get_euid(creds, &uid);
  sd_bus_creds_unref(creds);
  if (r < 0) return std::nullopt;
  if (sender) {
    if (by_sender_.size() >= kMaxSenders) by_sender_.clear();
    by_sender_[sender] = uid;
  }
  return uid;
}

std::string action_outcome(std::optional<uid_t> uid, int r, const sd_bus_error* e) {
  std::string out = "by uid " + (uid ? std::to_string(*uid) : std::string("?")) + ": ";
  if (r >= 0 && !sd_bus_error_is_set(e)) return out + "done";
  std::string name = sd_bus_error_is_set(e) && e->name ? e->name : "";
  if (name.rfind("io.cansim.Error.", 0) == 0) name.erase(0, std::strlen("io.cansim.Error."));
  const std::string message = sd_bus_error_is_set(e) && e->message ? one_line(e->message) : std::strerror(-r);
  return out + "refused (" + (name.empty() ? "" : name + ": ") + message + ")";
}

void ControlHost::log_action(const ActionRecord& r) { spdlog::info("{}", r.text); }

}  // namespace cansim::control
