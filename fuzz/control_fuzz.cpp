// libFuzzer target: arbitrary method calls into the control API's dispatch
// layer. Each input is a sequence of calls (object path, interface, member,
// signature and argument values chosen by the input, often a real method with
// fuzzed values, sometimes garbage) sent over a real sd-bus peer connection
// to a fake-clock fleet, with time steps between them. No crash, no sanitizer
// report, no hang; the fleet keeps running. Texts and maps reach far past the
// bounds of config/limits.hpp (Input::big, long a{ss}): the seeds
// big-*.bin in corpus-control start from those (see the end of this file).
// The server reads through the private socket's message gate (BusPair::kGated),
// so a call over limits::kMessageBytes meets it; raw byte streams go through
// its framing too.
#include <systemd/sd-bus.h>

#include <algorithm>
#include <cstdint>
#include <cstring>
#include <vector>
#include <memory>
#include <string>

#include "control/message_gate.hpp"
#include "support/control_fleet.hpp"

namespace {

using namespace cansim;

constexpr const char* kFleet = R"(
interfaces: {vcan0: {bit_rate: 250}}
nodes:
  - {profile: generic-404, interface: vcan0, node_id: 0x10, count: 2, name: generic}
  - {profile: dps, interface: vcan0, bit_rate: 250, name: dps}
)";

struct Input {
  const std::uint8_t* p;
  std::size_t n;
  std::uint8_t byte() { return n ? (--n, *p++) : 0; }
  std::uint64_t u64() {
    std::uint64_t v = 0;
    for (int i = 0; i < 8; ++i) v = (v << 8) | byte();
    return v;
  }
  double real() {
    switch (byte() % 6) {
      case 0: return -1.0;
      case 1: return 1e300;
      case 2: return std::nan("");
      case 3: return double(std::int16_t(u64()));
      case 4: return double(u64() % 100000) / 1000.0;
      default: return 0.0;
    }
  }
  std::string big();
  std::string text() {
    static const char* const kWords[] = {
        "pressure", "temperature", "bar", "psi", "degC", "K", "nonsense", "", "generic/0", "dps", "vcan0/0x10",
        "vcan0/16", "open", "silent", "power_cycle", "drift", "1 s", "-1 s", "0.5 bar", "start", "reset", "reset-comm",
        "{profile: generic-404, interface: vcan0, node_id: 0x30, name: x}", "[", "- constant: 3 bar",
        "{ramp: {from: 1 bar, to: 2 bar, duration: 1 s}}", "/tmp/cansim-fuzz.csv", "duration", "at", "channel", "value",
        "\xff\xfe",
        // `csv:` tables outside the profile folders: refused unopened
        "table: {csv: /etc/hostname}", "table: {csv: ../../../../etc/hostname}",
        ("{profile: generic-404, interface: vcan0, node_id: 0x32, name: z, physics: {pressure: {table: {csv: "
         "/etc/hostname}}}}")};
    std::uint8_t k = byte();
    if (k < 200) return kWords[k % (sizeof kWords / sizeof *kWords)];
    if (k < 204) return big();
    std::string s;
    for (std::uint8_t len = byte() % 24; len > 0; --len) s.push_back(char(byte() | 1));
    return s;
  }
};

// A large text from three bytes (config/limits.hpp's bounds, and far past
// them): a head, a piece repeated up to 65,536 times, a tail.
// Deep flow and block nesting, long vendor maps of unknown or repeated keys,
// long tables.
std::string Input::big() {
  static constexpr struct {
    const char* head;
    const char* piece;
    const char* tail;
  } kBig[] = {
      {"", "[", ""},
      {"", "- ", "x"},
      {"a: ", "{a: ", "1"},
      {"{profile: generic-404, interface: vcan0, node_id: 0x30, name: x, vendor: {", "k: 1, ", "}}"},
      {"{profile: dps, interface: vcan0, node_id: 0x31, name: y, vendor: {", "span_check_period: 1 ms, ", "}}"},
      {"table: {points: [", "[1 s, 2 bar], ", "[9 s, 1 bar]]}"},
      {"", "- {profile: generic-404, interface: vb, node_id: 1, count: 3, name: n}\n", ""},
      {"", " ", ""},
      {"- &t {table: {points: [[0 s, 1 bar], [1 s, 2 bar]]}}\n", "- *t\n", ""},
      // 32 bytes a piece: past 32,768 pieces the message is over the private
      // socket's bound (limits::kMessageBytes), answered by its gate unread
      {"", "0123456789abcdef0123456789abcdef", ""},
  };
  const auto& b = kBig[byte() % (sizeof kBig / sizeof *kBig)];
  const std::size_t pieces = ((std::size_t(byte()) << 8) | byte()) + 1;
  std::string s = b.head;
  for (std::size_t i = 0; i < pieces; ++i) s += b.piece;
  return s + b.tail;
}

struct Method {
  const char* interface;
  const char* member;
  const char* signature;
  bool node;
};
constexpr Method kMethods[] = {
    {"io.cansim.Fleet1", "ListNodes", "", false},
    {"io.cansim.Fleet1", "GetNode", "s", false},
    {"io.cansim.Fleet1", "AddNodes", "s", false},
    {"io.cansim.Fleet1", "RemoveNode", "s", false},
    {"io.cansim.Fleet1", "Reload", "", false},
    {"io.cansim.Fleet1", "GetBusStatistics", "", false},
    {"io.cansim.Fleet1", "Subscribe", "", false},
    {"io.cansim.Fleet1", "Unsubscribe", "", false},
    {"io.cansim.Node1", "Hold", "s", true},
    {"io.cansim.Node1", "Step", "sds", true},
    {"io.cansim.Node1", "Ramp", "sdsd", true},
    {"io.cansim.Node1", "SetModel", "ss", true},
    {"io.cansim.Node1", "RestoreModel", "s", true},
    {"io.cansim.Node1", "Override", "sds", true},
    {"io.cansim.Node1", "ClearOverride", "s", true},
    {"io.cansim.Node1", "ArmFault", "sa{ss}", true},
    {"io.cansim.Node1", "CancelFault", "u", true},
    {"io.cansim.Node1", "ListFaults", "", true},
    {"io.cansim.Node1", "PowerCycle", "d", true},
    {"io.cansim.Node1", "Nmt", "s", true},
    {"io.cansim.Node1", "Store", "y", true},
    {"io.cansim.Node1", "Restore", "y", true},
    {"io.cansim.Node1", "Read", "qy", true},
    {"io.cansim.Node1", "Write", "qyv", true},
    {"io.cansim.Node1", "StopRecording", "", true},
    {"org.freedesktop.DBus.Properties", "GetAll", "s", true},
    {"org.freedesktop.DBus.ObjectManager", "GetManagedObjects", "", false},
    {"org.freedesktop.DBus.Introspectable", "Introspect", "", true},
};

// Appends one argument of basic type `t` from the input.
int append_basic(sd_bus_message* m, char t, Input& in) {
  switch (t) {
    case 'y': {
      std::uint8_t v = in.byte();
      return sd_bus_message_append_basic(m, t, &v);
    }
    case 'b': {
      int v = in.byte() & 1;
      return sd_bus_message_append_basic(m, t, &v);
    }
    case 'n':
    case 'q': {
      std::uint16_t v = std::uint16_t(in.u64());
      return sd_bus_message_append_basic(m, t, &v);
    }
    case 'i':
    case 'u': {
      std::uint32_t v = std::uint32_t(in.u64());
      return sd_bus_message_append_basic(m, t, &v);
    }
    case 'x':
    case 't': {
      std::uint64_t v = in.u64();
      return sd_bus_message_append_basic(m, t, &v);
    }
    case 'd': {
      double v = in.real();
      return sd_bus_message_append_basic(m, t, &v);
    }
    default: {
      std::string s = in.text();
      return sd_bus_message_append_basic(m, 's', s.c_str());
    }
  }
}

int append_args(sd_bus_message* m, const char* sig, Input& in) {
  for (const char* c = sig; *c; ++c) {
    int r = 0;
    if (std::strncmp(c, "a{ss}", 5) == 0) {
      r = sd_bus_message_open_container(m, 'a', "{ss}");
      // Mostly a few entries; sometimes up to 65,535 (ArmFault's bound is 32).
      const std::uint8_t n = in.byte();
      std::size_t entries = n < 252 ? n % 4 : (std::size_t(in.byte()) << 8) | in.byte();
      for (std::size_t k = entries; r >= 0 && k > 0; --k) {
        std::string key = in.text(), value = in.text();
        r = sd_bus_message_append(m, "{ss}", key.c_str(), value.c_str());
      }
      if (r >= 0) r = sd_bus_message_close_container(m);
      c += 4;
    } else if (*c == 'v') {
      static const char kTypes[] = "ybnqiuxtds";
      char t = kTypes[in.byte() % (sizeof kTypes - 1)];
      const char inner[2] = {t, 0};
      r = sd_bus_message_open_container(m, 'v', inner);
      if (r >= 0) r = append_basic(m, t, in);
      if (r >= 0) r = sd_bus_message_close_container(m);
    } else {
      r = append_basic(m, *c, in);
    }
    if (r < 0) return r;
  }
  return 0;
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  // Never destroyed: at exit spdlog's registry may go first, and a fleet's
  // control service still logs (its rate-limited journal line) when it goes.
  static auto& fleet = *new std::unique_ptr<test::ControlFleet>;
  static auto& bus = *new std::unique_ptr<test::BusPair>;
  static int inputs = 0;
  // A fresh fleet now and then: calls accumulate state (removed nodes, faults).
  if (!fleet || ++inputs % 200 == 0 || fleet->nodes().empty()) {
    bus.reset();
    fleet.reset();
    fleet = std::make_unique<test::ControlFleet>(kFleet);
    bus = std::make_unique<test::BusPair>(fleet->service(), test::BusPair::kGated);
  }
  Input in{data, size};
  for (int calls = 0; in.n > 0 && calls < 16; ++calls) {
    const std::uint8_t what = in.byte();
    if (what % 8 == 7) {  // time passes
      fleet->run_until(fleet->now() + TimeUs(in.byte()) * 10000);
      continue;
    }
    if (what % 16 == 6) {  // a raw byte stream through the gate's framing (a bound of 64 bytes)
      control::MessageFraming framing(64);
      std::vector<std::uint8_t> pass;
      for (std::uint8_t pieces = in.byte() % 8; pieces > 0 && in.n > 0; --pieces) {
        const std::size_t len = std::min<std::size_t>(in.byte() % 64, in.n);
        control::MessageFraming::Out out{&pass};
        framing.feed({in.p, len}, out);
        in.p += len;
        in.n -= len;
        if (out.broken) break;
      }
      continue;
    }
    const Method& method = kMethods[in.byte() % (sizeof kMethods / sizeof *kMethods)];
    std::string path = "/io/cansim/Cansimd1";
    if (method.node) {
      auto nodes = fleet->nodes();
      std::uint8_t k = in.byte();
      if (k < 240 && !nodes.empty()) path = control::node_path(*nodes[k % nodes.size()]);
      else path = "/io/cansim/Cansimd1/node/vcan0/none/_30";
    }
    sd_bus_message* m = nullptr;
    if (sd_bus_message_new_method_call(bus->client(), &m, nullptr, path.c_str(), method.interface, method.member) < 0)
      continue;
    // Mostly the method's own signature; sometimes a wrong one.
    static const char* const kWrong[] = {"", "s", "u", "ss", "d", "qyv", "sds", "yyyy"};
    const char* sig = (what & 0x30) == 0x30 ? kWrong[in.byte() % 8] : method.signature;
    if (append_args(m, sig, in) < 0) {
      sd_bus_message_unref(m);
      continue;
    }
    if (sd_bus_message* r = bus->call(m)) sd_bus_message_unref(r);
    for (auto& [name, s] : bus->take_signals()) sd_bus_message_unref(s);
  }
  return 0;
}

// The seeds big-*.bin (fuzz/corpus-control), one call each: byte 0 the call
// kind (0: a method), byte 1 the method (index in kMethods), for a node
// method a node byte (0: the first node), then the arguments: a text is a
// word (< 200), a big() text (200..203: pattern byte, two count bytes), a
// map of strings a count byte (>= 252: two more for up to 65,535 entries).
//   big-armfault-map.bin   ArmFault("open", 50,000 x {"pressure": "pressure"})
//   big-addnodes-deep.bin  AddNodes of 64 KiB of '['
//   big-addnodes-vendor.bin AddNodes with a 15 KB vendor map (just under the bound)
//   big-addnodes-dash.bin  AddNodes of "- " x 65,536 (compact block nesting)
//   big-setmodel-deep.bin  SetModel("pressure", 64 KiB of '[')
//   big-addnodes-entries.bin AddNodes of 17 entries (refused: 4 at most)
//   big-setmodel-aliases.bin SetModel of a table and 4,097 aliases of it
