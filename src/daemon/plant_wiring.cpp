#include "daemon/plant_wiring.hpp"

#include <spdlog/spdlog.h>

#include "core/protocol.hpp"
#include "core/node.hpp"
#include "personalities/analog_output.hpp"

namespace cansim::daemon {

namespace {
constexpr TimeUs kNonFiniteLogPeriod = 10'000'000;

std::uint64_t frame_key(io::BusId bus, std::uint32_t id, bool extended) {
  return (std::uint64_t(bus) << 32) | id | (extended ? cob::kRxIdExtended : 0u);
}
std::uint64_t object_key(io::NodeRef ref, std::uint16_t index, std::uint8_t sub) {
  return (std::uint64_t(ref) << 24) | (std::uint64_t(index) << 8) | sub;
}
}  // namespace

struct PlantWiring::Feed {
  const config::PlantInputBinding* binding = nullptr;
  physics::Plant* plant = nullptr;
  std::size_t input = 0;
  personalities::analog_output::AnalogOutputApplication* outputs = nullptr;  // kOutput
};

PlantWiring::PlantWiring(io::LoopCore& core) : core_(core) {}

PlantWiring::~PlantWiring() { detach(core_.now()); }

std::unique_ptr<physics::PlantSet> PlantWiring::build(const config::PlantsConfig& cfg, std::uint64_t seed) {
  try {
    return std::make_unique<physics::PlantSet>(cfg.specs, seed);
  } catch (const physics::PlantError& e) {
    throw config::ConfigError(e.what());
  }
}

void PlantWiring::replace(std::unique_ptr<physics::PlantSet> plants, const config::PlantsConfig& cfg) {
  plants_ = std::move(plants);
  config_ = cfg;
  resolver_ = plants_ ? std::make_unique<physics::PlantSetResolver>(*plants_) : nullptr;
  logged_.clear();
  if (plants_) {
    plants_->set_non_finite_hook(non_finite, this);
    plants_->set_fault_hook(fault_edge, this);
  }
}

void PlantWiring::fault_edge(void* self, const physics::Plant& plant, physics::FaultHandle id, physics::FaultKind kind,
                             bool started, TimeUs t) {
  auto& w = *static_cast<PlantWiring*>(self);
  const std::string& target = plant.fault_target(id);
  spdlog::info("plant {}: fault {} {} on {} {}", plant.name(), id, physics::to_string(kind), target,
               started ? "started" : "ended");
  if (w.fault_listener_) w.fault_listener_(plant.name(), id, kind, target, started, t);
}

TimeUs PlantWiring::next_deadline() const {
  if (!plants_) return kNever;
  const TimeUs t = plants_->next_fault_edge();
  return t == std::numeric_limits<TimeUs>::max() ? kNever : t;
}

void PlantWiring::run_due(TimeUs now) {
  if (plants_) plants_->advance_faults(now);
}

void PlantWiring::non_finite(void* self, const std::string& plant, const std::string& block, std::uint64_t count,
                             TimeUs t) {
  Logged& l = static_cast<PlantWiring*>(self)->logged_[plant + "/" + block];
  if (l.at >= 0 && t - l.at < kNonFiniteLogPeriod) return;
  spdlog::warn("plant {}: block {} produced a NaN or an infinity ({} time(s) so far): it keeps its last finite value",
               plant, block, count);
  l.at = t;
  l.count = count;
}

namespace {
double output_value(const void* context, TimeUs t) {
  const auto& f = *static_cast<const PlantWiring::Feed*>(context);
  const config::PlantInputBinding& b = *f.binding;
  return physics::from_unit(f.outputs->position(b.output - 1, t) * b.scale + b.offset, b.unit);
}
void advance_plant(void* plant, TimeUs t) { static_cast<physics::Plant*>(plant)->advance_to(t); }
}  // namespace

void PlantWiring::attach(const std::function<io::NodeRef(const std::string&)>& node,
                         const std::function<bool(const std::string&, io::BusId&)>& bus, TimeUs now) {
  detach(now);
  if (!plants_) return;
  std::map<io::BusId, std::vector<std::uint32_t>> ids;
  for (const config::PlantInputBinding& b : config_.bindings) {
    auto f = std::make_unique<Feed>();
    f->binding = &b;
    f->plant = plants_->find(b.plant);
    f->input = b.input_index;
    if (!f->plant) continue;
    switch (b.kind) {
      case config::PlantInputBinding::Kind::kFrame: {
        io::BusId id = 0;
        if (!bus(b.interface, id)) continue;
        by_frame_[frame_key(id, b.signal.can_id, b.signal.extended)].push_back(f.get());
        ids[id].push_back(b.signal.can_id | (b.signal.extended ? cob::kRxIdExtended : 0u));
        break;
      }
      case config::PlantInputBinding::Kind::kObject: {
        const io::NodeRef ref = node(b.node_key);
        if (ref == io::kNoNode) continue;
        by_object_[object_key(ref, b.index, b.sub)].push_back(f.get());
        break;
      }
      case config::PlantInputBinding::Kind::kOutput: {
        const io::NodeRef ref = node(b.node_key);
        if (ref == io::kNoNode) continue;
        f->outputs = dynamic_cast<personalities::analog_output::AnalogOutputApplication*>(core_.app(ref));
        if (!f->outputs) continue;
        f->outputs->add_listener(advance_plant, f->plant);
        f->plant->bind_external(f->input, physics::ExternalSource{output_value, f.get()}, now);
        break;
      }
    }
    feeds_.push_back(std::move(f));
  }
  for (auto& [id, list] : ids) {
    core_.tap_ids(id, list);
    tapped_buses_.push_back(id);
  }
  if (!by_frame_.empty()) core_.set_frame_tap(this);
}

void PlantWiring::detach(TimeUs now) {
  for (const auto& f : feeds_)
    if (f->outputs) {
      f->outputs->clear_listeners();
      f->plant->bind_external(f->input, {}, now);
    }
  for (io::BusId id : tapped_buses_) core_.tap_ids(id, {});
  tapped_buses_.clear();
  core_.set_frame_tap(nullptr);
  by_frame_.clear();
  by_object_.clear();
  feeds_.clear();
}

void PlantWiring::push(const Feed& f, double raw_in_unit, TimeUs now) {
  f.plant->set_input(f.input, physics::from_unit(raw_in_unit, f.binding->unit), now);
}

void PlantWiring::on_frame(io::BusId bus, const CanFrame& frame, TimeUs now) {
  auto it = by_frame_.find(frame_key(bus, frame.id, frame.extended()));
  if (it == by_frame_.end()) return;
  for (const Feed* f : it->second)
    if (const std::optional<double> v = f->binding->signal.value(frame)) push(*f, *v, now);
}

void PlantWiring::on_remote_write(io::NodeRef ref, const OdEntry& e, WriteVia via, TimeUs t) {
  if (!by_object_.empty()) {
    auto it = by_object_.find(object_key(ref, e.index, e.sub));
    if (it != by_object_.end()) {
      const double raw = core_.node(ref).values().get_f(e);
      for (const Feed* f : it->second) push(*f, raw * f->binding->scale + f->binding->offset, t);
    }
  }
  if (next_) next_->on_remote_write(ref, e, via, t);
}

void PlantWiring::on_nmt_state(io::NodeRef ref, NmtState old, NmtState now, TimeUs t) {
  if (next_) next_->on_nmt_state(ref, old, now, t);
}
void PlantWiring::on_boot_up(io::NodeRef ref, TimeUs t) {
  if (next_) next_->on_boot_up(ref, t);
}
void PlantWiring::on_emcy(io::NodeRef ref, std::uint16_t code, std::uint8_t reg, const std::uint8_t vendor[5],
                          TimeUs t) {
  if (next_) next_->on_emcy(ref, code, reg, vendor, t);
}
void PlantWiring::on_power(io::NodeRef ref, bool powered, TimeUs t) {
  if (next_) next_->on_power(ref, powered, t);
}
void PlantWiring::on_pdo_config(io::NodeRef ref, TimeUs t) {
  if (next_) next_->on_pdo_config(ref, t);
}

}  // namespace cansim::daemon
