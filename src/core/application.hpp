// What a node's application (vendor personality + measurement source) plugs
// into the core. The core calls it around OD accesses flagged with kHookRead /
// kHookWrite and on NMT events; the application drives the core through the
// Node API (values(), emcy(), pdo().raise_event(), ...).
#pragma once

#include <memory>
#include <span>

#include "core/can_frame.hpp"
#include "core/od.hpp"

namespace cansim {

class Node;
enum class NmtState : std::uint8_t;

enum class ResetKind : std::uint8_t {
  kPowerOn,        // fresh start: all values from defaults + storage
  kNode,           // NMT reset node (0x81)
  kCommunication,  // NMT reset communication (0x82)
};

class Application {
 public:
  virtual ~Application() = default;
  // After the OD was (re)loaded for a reset, before the boot-up frame.
  virtual void on_reset(Node&, ResetKind, TimeUs) {}
  virtual void on_nmt_state(Node&, NmtState, TimeUs) {}
  // Before a remote read (SDO upload, TPDO sampling) of a kHookRead entry:
  // bring the stored value up to date.
  virtual void refresh(Node&, const OdEntry&, TimeUs) {}
  // Before a remote write of a kHookWrite entry is stored: accept or abort.
  virtual SdoAbort check_write(Node&, const OdEntry&, std::span<const std::uint8_t>, TimeUs) { return SdoAbort::kNone; }
  // After a remote write of a kHookWrite entry was stored.
  virtual void after_write(Node&, const OdEntry&, TimeUs) {}
  // A SYNC frame was consumed (counter 0 when the SYNC has no counter byte).
  virtual void on_sync(Node&, std::uint8_t, TimeUs) {}
  // A PDO's communication or mapping parameters changed, or the PDOs were
  // reloaded (reset, restore); node.pdo().tpdos() has the new configuration.
  virtual void on_pdo_config(Node&, TimeUs) {}
  // Periodic application work (event checks, vendor timers). Returns the
  // next time it wants to run, or kNever.
  virtual TimeUs process(Node&, TimeUs) { return kNever; }
  // The node's surroundings (injected power, bus and timing faults): applied
  // at power-on before the boot-up and, when due, before any service runs at
  // that instant. Returns when it next needs to run, or kNever. May switch
  // the node off (Node::power_cycle).
  virtual TimeUs environment(Node&, TimeUs) { return kNever; }

  // Snapshots, alongside Node::snapshot(): a copy of this application's state
  // (never run, only restored from), or null when the application cannot
  // take one (the default).
  virtual std::unique_ptr<Application> snapshot() const { return nullptr; }
  // Brings back the state of a snapshot() of this application.
  virtual void restore(const Application&) {}
};

// Where a node keeps what 0x1010 and LSS "store configuration" saved. The
// daemon implements it with an atomically written file per node; tests keep
// it in memory. load() must be cheap (the daemon caches the blob).
class NodeStorage {
 public:
  virtual ~NodeStorage() = default;
  virtual bool load(std::vector<std::uint8_t>& blob) = 0;
  virtual bool save(std::span<const std::uint8_t> blob) = 0;
  // The node dropped what load() gave (a bad inner CRC, an impossible
  // node-ID, ...): `why` says what, for the owner's log.
  virtual void rejected(const char* /*why*/) {}
};

}  // namespace cansim
