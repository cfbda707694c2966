// The connection to cansimd: where (private socket, system or user bus) and
// method calls on it (sd-bus).
#pragma once

#include <systemd/sd-bus.h>

#include <cstdint>
#include <functional>
#include <memory>
#include <stdexcept>
#include <string>
#include <string_view>
#include <vector>

#include "ctl/args.hpp"

namespace cansim::ctl {

// A refused request or a failed connection: main prints it, exit 1.
// `name`: the D-Bus error name when the daemon refused (io.cansim.Error.UnknownNode).
class Failure : public std::runtime_error {
 public:
  explicit Failure(const std::string& what, std::string name = "") : std::runtime_error(what), name(std::move(name)) {}
  std::string name;
};

// r of an sd-bus call: below 0 throws Failure("what: strerror").
void expect(int r, const char* what);

struct MessageUnref {
  void operator()(sd_bus_message* m) const { sd_bus_message_unref(m); }
};
using MessagePtr = std::unique_ptr<sd_bus_message, MessageUnref>;

struct Endpoint {
  BusKind kind = BusKind::kSocket;  // never kDefault
  std::string socket;               // kSocket
  bool operator==(const Endpoint&) const = default;
};

// What the default endpoint depends on.
struct Environment {
  std::string control_socket;   // $CANSIM_CONTROL_SOCKET, "" when unset
  std::string xdg_runtime_dir;  // $XDG_RUNTIME_DIR, "" when unset
  unsigned uid = 0;             // effective uid
};

Environment process_environment();

// Where the daemon's private socket may be, in the order of docs/control-api.md.
std::vector<std::string> default_socket_paths(const Environment& env);

// --socket/--system/--user, else $CANSIM_CONTROL_SOCKET, else the first default
// socket that exists, else the system bus as root, else the user bus.
Endpoint choose_endpoint(const GlobalOptions& options, const Environment& env,
                         const std::function<bool(const std::string&)>& socket_exists);

// The D-Bus address of a unix socket path, escaped as the spec says:
// "unix:path=/run/a%20b/control".
std::string socket_address(std::string_view path);

std::string describe(const Endpoint& e);  // "the control socket /run/...", "the system bus"

class Connection {
 public:
  Connection(const Endpoint& endpoint, double timeout_s);  // throws Failure
  ~Connection();
  Connection(const Connection&) = delete;
  Connection& operator=(const Connection&) = delete;

  sd_bus* bus() const { return bus_; }

  // The reply; a D-Bus error throws Failure with its message.
  MessagePtr call(const std::string& path, const std::string& interface, const std::string& method,
                  const std::vector<Arg>& args = {});
  // The same with arguments `append` writes into the call (what Arg cannot say: arrays of structs).
  MessagePtr call_with(const std::string& path, const std::string& interface, const std::string& method,
                       const std::function<void(sd_bus_message*)>& append);

  std::string node_path(const std::string& node);  // Fleet1.GetNode
  std::int64_t simulated_time_us();                // Fleet1.SimulatedTime

 private:
  sd_bus* bus_ = nullptr;
  const char* destination_ = nullptr;  // none on a peer-to-peer socket
  std::uint64_t timeout_us_ = 0;
  std::string where_;
};

}  // namespace cansim::ctl
