#include "personalities/pdo_view.hpp"

#include <span>

#include "core/protocol.hpp"
#include "personalities/measurement_control.hpp"

namespace cansim::personalities {

namespace {

constexpr std::uint16_t kRpdoComm = 0x1400, kTpdoComm = 0x1800;  // CiA 301 §7.5.2.35 / .37

PdoView view_of(Node& node, const PdoConfig& cfg, bool transmit) {
  PdoView v;
  v.transmit = transmit;
  v.number = unsigned(cfg.comm_index - (transmit ? kTpdoComm : kRpdoComm)) + 1;
  v.extended = (cfg.cobid & cob::kFrame29Bit) != 0;
  v.can_id = cob::can_id(cfg.cobid);
  v.valid = node.pdo().valid(cfg);
  v.transmission_type = cfg.type;
  v.bits = cfg.bits;
  for (const PdoMapItem& item : std::span(cfg.items).first(cfg.item_count)) {
    PdoEntryView e;
    e.bits = item.bits;
    if (item.slot != PdoMapItem::kDummy) {
      e.entry = &node.od().entry(item.slot);
      e.index = e.entry->index;
      e.sub = e.entry->sub;
      e.meaning = object_meaning(node, *e.entry);
    }
    v.entries.push_back(std::move(e));
  }
  return v;
}

}  // namespace

ObjectMeaning object_meaning(Node& node, const OdEntry& e) {
  const MeasurementControl* control = measurement_control(node.app());
  if (!control) return {};
  const MeasurementControl::EntryScale s = control->entry_scale(node, e);
  return {s.scale, s.offset, std::string(s.unit), s.counts, s.count_scale};
}

std::vector<PdoView> pdo_views(Node& node) {
  std::vector<PdoView> out;
  for (const Tpdo& t : node.pdo().tpdos()) out.push_back(view_of(node, t.cfg, true));
  for (const Rpdo& r : node.pdo().rpdos()) out.push_back(view_of(node, r.cfg, false));
  return out;
}

}  // namespace cansim::personalities
