#include "personalities/pdo_view.hpp"

#include <span>

#include "personalities/measurement_control.hpp"

namespace cansim::personalities {

namespace {

constexpr std::uint16_t kRpdoComm = 0x1400, kTpdoComm = 0x1800;
constexpr std::uint32_t kExtendedIdBits = 0x1FFFFFFF, kBaseIdBits = 0x7FF;

PdoView view_of(Node& node, const PdoConfig& cfg, bool transmit) {
  PdoView v;
  v.transmit = transmit;
  v.number = unsigned(cfg.comm_index - (transmit ? kTpdoComm : kRpdoComm)) + 1;
  v.extended = (cfg.cobid & kPdoCobFrame) != 0;
  v.can_id = cfg.cobid & (v.extended ? kExtendedIdBits : kBaseIdBits);
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
  const Cia404Chain::EntryScale s = control->chain().entry_scale(node, e);
  return {s.scale, std::string(s.unit)};
}

std::vector<PdoView> pdo_views(Node& node) {
  std::vector<PdoView> out;
  for (const Tpdo& t : node.pdo().tpdos()) out.push_back(view_of(node, t.cfg, true));
  for (const Rpdo& r : node.pdo().rpdos()) out.push_back(view_of(node, r.cfg, false));
  return out;
}

}  // namespace cansim::personalities
