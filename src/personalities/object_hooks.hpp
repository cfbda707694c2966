// Per-object indications of a personality, as lely-core gives each
// sub-object its own upload / download indication and CANopenNode each OD
// entry its extension: a table of the vendor objects a personality serves,
// each row naming what runs before a read (SDO upload, TPDO sampling: the
// core's kHookRead), what checks a write and what follows it (kHookWrite),
// instead of a switch on indices in the Application hooks.
//
// Decisions:
// - A row covers one object or an area of indices; an object's row may stand
//   inside an area's row (the area's rows come first). The innermost row
//   wins, and a handler it leaves null is the enclosing area's; without one
//   the object is the CiA 404 chain's (VendorApplication dispatches).
// - The table is a constant of the personality (ObjectHooks is consteval:
//   rows out of order or overlapping do not compile), shared by every node
//   of every profile; a lookup is a binary search over the rows and a step
//   out per enclosing area. No allocation, no per-node state.
#pragma once

#include <cstddef>
#include <cstdint>
#include <span>

#include "core/node.hpp"

namespace cansim::personalities {

template <class App>
struct ObjectHook {
  using Read = void (App::*)(Node&, const OdEntry&, TimeUs);
  using Check = SdoAbort (App::*)(Node&, const OdEntry&, std::span<const std::uint8_t>, TimeUs);
  using Written = void (App::*)(Node&, const OdEntry&, TimeUs);

  std::uint16_t first = 0, last = 0;  // the indices the row covers
  Read read = nullptr;                // brings the value up to date before a read
  Check check = nullptr;              // accepts a write (SdoAbort::kNone) or aborts it
  Written written = nullptr;          // reacts to a stored write
};

// A row of one object / of an area of indices.
template <class App>
constexpr ObjectHook<App> object(std::uint16_t index, typename ObjectHook<App>::Read read,
                                 typename ObjectHook<App>::Check check = nullptr,
                                 typename ObjectHook<App>::Written written = nullptr) {
  return {index, index, read, check, written};
}
template <class App>
constexpr ObjectHook<App> area(std::uint16_t first, std::uint16_t last, typename ObjectHook<App>::Read read,
                               typename ObjectHook<App>::Check check = nullptr,
                               typename ObjectHook<App>::Written written = nullptr) {
  return {first, last, read, check, written};
}

template <class App>
class ObjectHooks {
 public:
  using Row = ObjectHook<App>;
  static constexpr std::size_t kMaxRows = 64;

  constexpr ObjectHooks() = default;
  template <std::size_t N>
  consteval explicit ObjectHooks(const Row (&rows)[N]) : rows_(rows, N) {
    static_assert(N <= kMaxRows, "more rows than ObjectHooks holds");
    for (std::size_t i = 0; i < N; ++i) {
      if (rows[i].first > rows[i].last) throw "an object hook row ends before it starts";
      if (i > 0 && rows[i].first <= rows[i - 1].first) throw "object hook rows out of order or repeated";
      // The enclosing area: the nearest earlier row (or its area, ...) that reaches this one.
      int outer = int(i) - 1;
      while (outer >= 0 && rows[std::size_t(outer)].last < rows[i].first) outer = outer_[std::size_t(outer)];
      if (outer >= 0 && rows[std::size_t(outer)].last < rows[i].last) throw "object hook rows overlap";
      outer_[i] = std::int8_t(outer);
    }
  }

  // The innermost row covering `index` whose `handler` is set, or null.
  template <class Handler>
  const Row* find(std::uint16_t index, Handler Row::*handler) const {
    std::size_t lo = 0, hi = rows_.size();  // the last row starting at or before index
    while (lo < hi) {
      const std::size_t mid = (lo + hi) / 2;
      if (rows_[mid].first <= index) lo = mid + 1;
      else hi = mid;
    }
    for (int i = int(lo) - 1; i >= 0; i = outer_[std::size_t(i)]) {
      const Row& r = rows_[std::size_t(i)];
      if (index <= r.last && r.*handler) return &r;
    }
    return nullptr;
  }

 private:
  std::span<const Row> rows_;
  std::int8_t outer_[kMaxRows] = {};  // per row: the enclosing area's row, -1 none
};

}  // namespace cansim::personalities
