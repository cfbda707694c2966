#include "ctl/targets.hpp"

#include <algorithm>
#include <map>

#include "ctl/top.hpp"
#include "ctl/values.hpp"

namespace cansim::ctl {

namespace {

bool is_glob(const std::string& spec) { return spec.find_first_of("*?[") != std::string::npos; }

struct IdRange {
  std::string interface;
  std::uint64_t first = 0, last = 0;
};

// "vcan0/0x10-0x13", "vcan0/16-19".
std::optional<IdRange> id_range(const std::string& spec) {
  const std::size_t slash = spec.find('/'), dash = spec.rfind('-');
  if (slash == std::string::npos || dash == std::string::npos || dash < slash) return std::nullopt;
  auto first = parse_unsigned(spec.substr(slash + 1, dash - slash - 1));
  auto last = parse_unsigned(spec.substr(dash + 1));
  if (!first || !last || *first > *last) return std::nullopt;
  return IdRange{spec.substr(0, slash), *first, *last};
}

}  // namespace

std::optional<std::vector<NodeRow>> group_targets(const std::string& spec, const std::vector<NodeRow>& rows) {
  std::vector<NodeRow> out;
  if (is_glob(spec)) {
    std::copy_if(rows.begin(), rows.end(), std::back_inserter(out),
                 [&](const NodeRow& r) { return glob_matches(spec, r.key, r.name); });
  } else if (auto range = id_range(spec)) {
    std::copy_if(rows.begin(), rows.end(), std::back_inserter(out), [&](const NodeRow& r) {
      return r.interface == range->interface && r.node_id >= range->first && r.node_id <= range->last;
    });
  } else {
    std::copy_if(rows.begin(), rows.end(), std::back_inserter(out), [&](const NodeRow& r) { return r.name == spec; });
    if (out.size() < 2) return std::nullopt;  // one node: the daemon resolves it
  }
  std::sort(out.begin(), out.end(), [](const NodeRow& a, const NodeRow& b) { return natural_less(a.key, b.key); });
  return out;
}

}  // namespace cansim::ctl
