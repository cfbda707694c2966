#include "ctl/connection.hpp"

#include <unistd.h>

#include <cerrno>
#include <cstdlib>
#include <cstring>
#include <type_traits>

#include "ctl/decode.hpp"

namespace cansim::ctl {

void expect(int r, const char* what) {
  if (r < 0) throw Failure(std::string(what) + ": " + std::strerror(-r));
}

namespace {

struct BusError {
  sd_bus_error error = SD_BUS_ERROR_NULL;
  ~BusError() { sd_bus_error_free(&error); }
};

void append_value(sd_bus_message* m, const Value& value) {
  std::visit(
      [m](const auto& v) {
        using T = std::decay_t<decltype(v)>;
        if constexpr (std::is_same_v<T, bool>) {
          int b = v;
          expect(sd_bus_message_append_basic(m, 'b', &b), "cannot build the call");
        } else if constexpr (std::is_same_v<T, std::string>) {
          expect(sd_bus_message_append_basic(m, 's', v.c_str()), "cannot build the call");
        } else if constexpr (std::is_same_v<T, Bytes>) {
          expect(sd_bus_message_append_array(m, 'y', v.data(), v.size()), "cannot build the call");
        } else {
          expect(sd_bus_message_append_basic(m, signature(Value(v))[0], &v), "cannot build the call");
        }
      },
      value);
}

void append_arg(sd_bus_message* m, const Arg& arg) {
  if (const Value* v = std::get_if<Value>(&arg)) return append_value(m, *v);
  if (const Variant* v = std::get_if<Variant>(&arg)) {
    expect(sd_bus_message_open_container(m, 'v', signature(v->value)), "cannot build the call");
    append_value(m, v->value);
    expect(sd_bus_message_close_container(m), "cannot build the call");
    return;
  }
  expect(sd_bus_message_open_container(m, 'a', "{ss}"), "cannot build the call");
  for (const auto& [key, value] : std::get<StringMap>(arg))
    expect(sd_bus_message_append(m, "{ss}", key.c_str(), value.c_str()), "cannot build the call");
  expect(sd_bus_message_close_container(m), "cannot build the call");
}

bool is_missing_service(const sd_bus_error& e) {
  return sd_bus_error_has_names(&e, SD_BUS_ERROR_SERVICE_UNKNOWN, SD_BUS_ERROR_NAME_HAS_NO_OWNER);
}

bool address_char_is_plain(unsigned char c) {
  return (c >= '0' && c <= '9') || (c >= 'a' && c <= 'z') || (c >= 'A' && c <= 'Z') || std::strchr("-_/.\\*", c);
}

// A full listen backlog (EAGAIN: the daemon is accepting a burst of other
// clients) is retried for up to a second.
sd_bus* open_socket(const std::string& path) {
  for (int attempt = 0;; ++attempt) {
    sd_bus* bus = nullptr;
    expect(sd_bus_new(&bus), "cannot create a D-Bus connection");
    int r = sd_bus_set_address(bus, socket_address(path).c_str());
    if (r >= 0) r = sd_bus_start(bus);
    if (r >= 0) return bus;
    sd_bus_unref(bus);
    if (r != -EAGAIN || attempt == 100) expect(r, ("cannot connect to the control socket " + path).c_str());
    ::usleep(10'000);
  }
}

sd_bus* open_bus(const Endpoint& endpoint) {
  if (endpoint.kind == BusKind::kSocket) return open_socket(endpoint.socket);
  sd_bus* bus = nullptr;
  int r = endpoint.kind == BusKind::kSystem ? sd_bus_open_system(&bus) : sd_bus_open_user(&bus);
  expect(r, ("cannot connect to " + describe(endpoint)).c_str());
  return bus;
}

}  // namespace

Environment process_environment() {
  auto env = [](const char* name) {
    const char* v = std::getenv(name);
    return std::string(v ? v : "");
  };
  return {env("CANSIM_CONTROL_SOCKET"), env("XDG_RUNTIME_DIR"), static_cast<unsigned>(geteuid())};
}

std::vector<std::string> default_socket_paths(const Environment& env) {
  std::vector<std::string> paths;
  if (!env.xdg_runtime_dir.empty()) paths.push_back(env.xdg_runtime_dir + "/cansimd/control");
  paths.push_back("/run/cansimd/control");  // as root, and under systemd ($RUNTIME_DIRECTORY)
  paths.push_back("/tmp/cansimd-" + std::to_string(env.uid) + "/control");
  return paths;
}

Endpoint choose_endpoint(const GlobalOptions& options, const Environment& env,
                         const std::function<bool(const std::string&)>& socket_exists) {
  if (options.bus == BusKind::kSocket) return {BusKind::kSocket, options.socket};
  if (options.bus != BusKind::kDefault) return {options.bus, ""};
  if (!env.control_socket.empty()) return {BusKind::kSocket, env.control_socket};
  for (const std::string& path : default_socket_paths(env)) {
    if (socket_exists(path)) return {BusKind::kSocket, path};
  }
  return {env.uid == 0 ? BusKind::kSystem : BusKind::kUser, ""};
}

std::string socket_address(std::string_view path) {
  static constexpr char kHex[] = "0123456789abcdef";
  std::string out = "unix:path=";
  for (char ch : path) {
    auto c = static_cast<unsigned char>(ch);
    if (address_char_is_plain(c) && c != '\0') {
      out += ch;
    } else {
      out += '%';
      out += kHex[c >> 4];
      out += kHex[c & 0xF];
    }
  }
  return out;
}

std::string describe(const Endpoint& e) {
  switch (e.kind) {
    case BusKind::kSystem: return "the system bus";
    case BusKind::kUser: return "the user bus";
    default: return "the control socket " + e.socket;
  }
}

Connection::Connection(const Endpoint& endpoint, double timeout_s)
    : bus_(open_bus(endpoint)),
      destination_(endpoint.kind == BusKind::kSocket ? nullptr : kBusName),
      timeout_us_(static_cast<std::uint64_t>(timeout_s * 1e6)),
      where_(describe(endpoint)) {
  sd_bus_set_method_call_timeout(bus_, timeout_us_);
}

Connection::~Connection() { sd_bus_flush_close_unref(bus_); }

MessagePtr Connection::call(const std::string& path, const std::string& interface, const std::string& method,
                            const std::vector<Arg>& args) {
  return call_with(path, interface, method, [&](sd_bus_message* m) {
    for (const Arg& a : args) append_arg(m, a);
  });
}

MessagePtr Connection::call_with(const std::string& path, const std::string& interface, const std::string& method,
                                 const std::function<void(sd_bus_message*)>& append) {
  sd_bus_message* m = nullptr;
  expect(sd_bus_message_new_method_call(bus_, &m, destination_, path.c_str(), interface.c_str(), method.c_str()),
         "cannot build the call");
  MessagePtr request(m);
  append(m);
  BusError e;
  sd_bus_message* reply = nullptr;
  int r = sd_bus_call(bus_, m, timeout_us_, &e.error, &reply);
  if (r >= 0) return MessagePtr(reply);
  if (is_missing_service(e.error)) throw Failure("cansimd is not running on " + where_ + " (no " + kBusName + ")");
  if (sd_bus_error_is_set(&e.error)) throw Failure(e.error.message ? e.error.message : e.error.name, e.error.name);
  throw Failure("no answer on " + where_ + ": " + std::strerror(-r));
}

std::string Connection::node_path(const std::string& node) {
  MessagePtr reply = call(kFleetPath, kFleetInterface, "GetNode", {Value(node)});
  return read_object_path(reply.get());
}

std::int64_t Connection::simulated_time_us() {
  std::vector<Arg> property{Value(std::string(kFleetInterface)), Value(std::string("SimulatedTime"))};
  MessagePtr reply = call(kFleetPath, kPropertiesInterface, "Get", property);
  return read_int64(reply.get());
}

}  // namespace cansim::ctl
