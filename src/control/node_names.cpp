#include "control/node_names.hpp"

#include <cstdlib>

namespace cansim::control {

namespace {

bool parse_uint(const std::string& s, unsigned long& out) {
  if (s.empty() || s[0] == '-' || s[0] == '+') return false;
  char* end = nullptr;
  errno = 0;
  out = std::strtoul(s.c_str(), &end, 0);
  return errno == 0 && end && *end == 0;
}

template <typename Match>
const NodeHandle* unique(ControlHost& host, const std::string& spec, Match match, std::string* why) {
  const NodeHandle* found = nullptr;
  std::string all;
  int n = 0;
  for (const NodeHandle* h : host.nodes()) {
    if (!match(*h)) continue;
    found = h;
    if (n++ < 5) all += (all.empty() ? "" : ", ") + h->key;
  }
  if (n == 1) return found;
  if (n > 1 && why)
    *why = "'" + spec + "' names " + std::to_string(n) + " nodes (" + all + (n > 5 ? ", ..." : "") + ")";
  return nullptr;
}

}  // namespace

const NodeHandle* resolve_node(ControlHost& host, const std::string& spec, std::string* why) {
  if (why) why->clear();
  if (const NodeHandle* h = host.find(spec)) return h;
  const NodeHandle* h = nullptr;
  const auto slash = spec.find('/');
  const auto last = spec.rfind('/');
  unsigned long number = 0;
  if (slash != std::string::npos && slash == last && parse_uint(spec.substr(slash + 1), number)) {
    const std::string iface = spec.substr(0, slash);
    // IFACE/ID first: "vcan0/5" is a node-ID; "generic/1" (no such interface) an index.
    h = unique(
        host, spec,
        [&](const NodeHandle& n) { return n.interface == iface && host.core().node(n.ref).node_id() == number; }, why);
    if (h || (why && !why->empty())) return h;
    h = unique(
        host, spec, [&](const NodeHandle& n) { return n.name == iface && n.index == number; }, why);
  } else if (slash != std::string::npos) {
    h = unique(
        host, spec, [&](const NodeHandle& n) { return n.key.rfind(spec + "/", 0) == 0; }, why);
  } else {
    h = unique(
        host, spec, [&](const NodeHandle& n) { return n.name == spec; }, why);
  }
  if (!h && why && why->empty()) *why = "no node '" + spec + "'";
  return h;
}

}  // namespace cansim::control
