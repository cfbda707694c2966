#include "personalities/network_faults.hpp"

#include "physics/random.hpp"

namespace cansim::personalities {

using physics::FaultKind;
using physics::FaultSpec;

namespace {

std::uint64_t seed_of(const physics::FaultSet& faults, physics::FaultHandle h) {
  return physics::derive_seed(faults.seed(), 0x4E37FA17ull ^ h);
}

FrameSelector selector(const physics::NetFaultParams& p) {
  using physics::FrameService;
  FrameSelector s;
  switch (p.service) {
    case FrameService::Tpdo:
      s.service = TxService::kTpdo;
      s.tpdo = p.tpdo;
      break;
    case FrameService::Heartbeat: s.service = TxService::kHeartbeat; break;
    case FrameService::Emcy: s.service = TxService::kEmcy; break;
    case FrameService::Sdo: s.service = TxService::kSdo; break;
    case FrameService::BootUp: s.service = TxService::kBootUp; break;
    case FrameService::Lss: s.service = TxService::kLss; break;
    default:
      s.service = TxService::kOther;
      s.cob_id = p.cob_id;
      s.extended = p.cob_id > 0x7FF;
  }
  return s;
}

FrameFaultRule frame_rule(const physics::FaultSet& faults, physics::FaultHandle h, const FaultSpec& spec) {
  static constexpr FrameFaultKind kKinds[] = {FrameFaultKind::kDrop,   FrameFaultKind::kDelay,
                                              FrameFaultKind::kFreeze, FrameFaultKind::kCorrupt,
                                              FrameFaultKind::kDlc,    FrameFaultKind::kDuplicate};
  const physics::NetFaultParams& p = spec.net;
  FrameFaultRule r;
  r.id = h;
  r.kind = kKinds[std::size_t(spec.kind) - std::size_t(FaultKind::FrameDrop)];
  r.select = selector(p);
  r.probability = p.probability;
  r.delay = p.delay_us;
  r.jitter = p.jitter_us;
  r.bytes = p.bytes;
  r.value = p.value;
  r.dlc = p.dlc;
  r.seed = seed_of(faults, h);
  return r;
}

BusError bus_error(physics::ErrorClass c) {
  using physics::ErrorClass;
  switch (c) {
    case ErrorClass::Warning: return BusError::kWarning;
    case ErrorClass::Passive: return BusError::kPassive;
    case ErrorClass::BusOff: return BusError::kBusOff;
    case ErrorClass::Restarted: return BusError::kRestarted;
    case ErrorClass::Stuff: return BusError::kStuff;
    case ErrorClass::Form: return BusError::kForm;
    case ErrorClass::Ack: return BusError::kAck;
  }
  return BusError::kStuff;
}

// 8 data bytes on the fault's COB-ID, as often as `rate` or `duty` of the
// node's bit rate says (duty against the frame without stuff bits: duty 1
// offers more than the bus carries).
void babble(Node& node, physics::FaultHandle h, const physics::NetFaultParams& p, TimeUs now) {
  CanFrame f;
  f.id = p.cob_id;
  f.flags = p.cob_id > 0x7FF ? CanFrame::kExtended : 0;
  f.dlc = 8;
  double rate = p.rate_hz;
  if (p.duty > 0) {
    const std::int64_t bit_ns = bit_time_ns(node.bit_rate_index());
    const int bits = (f.extended() ? 67 : 47) + 8 * 8;
    rate = bit_ns > 0 ? p.duty * 1e9 / double(bit_ns) / bits : 0;
  }
  node.disturbance().babble(h, f, rate, now);
}

void sdo_fault(SdoServer::Faults& out, const physics::FaultSet& faults, physics::FaultHandle h, const FaultSpec& spec) {
  const SdoServer::ObjectMatch object{spec.net.index, spec.net.sub};
  switch (spec.kind) {
    case FaultKind::SdoAbort:
      if (out.abort_n < out.aborts.size()) out.aborts[out.abort_n++] = {object, spec.net.code};
      break;
    case FaultKind::SdoSilent:
      if (out.silent_n < out.silent.size()) out.silent[out.silent_n++] = object;
      break;
    default:  // SdoToggleError: the first one in force sets the generator
      if (out.toggle_probability == 0) {
        out.toggle_probability = spec.net.probability;
        out.toggle_seed = seed_of(faults, h);
      }
  }
}

}  // namespace

void apply_network_faults(Node& node, const physics::FaultSet& faults, TimeUs now) {
  bool twin = false;
  double drift_ppm = 0;
  SdoServer::Faults sdo;
  for (physics::FaultHandle h = 0; h < faults.size(); ++h) {
    const FaultSpec& spec = *faults.spec(h);
    const bool on = faults.active(h, now);
    if (physics::is_frame_fault(spec.kind)) {
      if (on && !node.frame_faults().has(h)) node.frame_faults().set(frame_rule(faults, h, spec));
      if (!on) node.frame_faults().clear(h);
      continue;
    }
    switch (spec.kind) {
      case FaultKind::NodeIdCollision: twin |= on; break;
      case FaultKind::ClockDrift: drift_ppm += on ? spec.net.ppm : 0; break;
      case FaultKind::SdoAbort:
      case FaultKind::SdoSilent:
      case FaultKind::SdoToggleError:
        if (on) sdo_fault(sdo, faults, h, spec);
        break;
      case FaultKind::Babbling:
      case FaultKind::ErrorFrames:
        if (!on) {
          node.disturbance().stop(h, [&](BusError e) { node.report_bus_error(e); });
        } else if (spec.kind == FaultKind::Babbling) {
          babble(node, h, spec.net, now);
        } else {
          node.disturbance().error_frames(h, bus_error(spec.net.error_class), spec.net.error_period_us, now);
        }
        break;
      default: break;
    }
  }
  node.set_twin(twin, now);
  node.set_clock_drift(drift_ppm);
  node.sdo().set_faults(sdo);
}

}  // namespace cansim::personalities
