// Every bound on what a client (or a file a client names) can make the
// daemon do, declared once (docs/limits.md lists them with the measured cost
// at each). The loop serves every node of every bench: a call must never hold
// it for long, and no client may pin memory without bound. Sizes are checked
// before anything is parsed; a call over a bound is refused with
// io.cansim.Error.TooLarge (control/names.hpp) and changes nothing.
#pragma once

#include <cstddef>
#include <cstdint>

namespace cansim::limits {

// ---- text a client sends as YAML: AddNodes, SetModel, each ArmFault value
inline constexpr std::size_t kYamlTextBytes = 16 * 1024;
// Nesting, counted by a pre-scan as block indentation levels (plus compact
// "- " entries) and open [ / { brackets. Profiles and fleets nest about 6 deep.
inline constexpr int kYamlDepth = 32;
// Aliases (*name): each stands for its anchored node, which the parsers then
// read again (2,253 aliases of a 300-point table in 16 KiB: 865 ms).
inline constexpr std::size_t kYamlAliases = 16;

// ---- AddNodes
inline constexpr std::size_t kAddNodesEntries = 4;  // node entries in one call (each may load a profile)
inline constexpr std::size_t kAddNodesNodes = 128;  // nodes in one call (`count:` included)
inline constexpr std::size_t kFleetNodes = 4096;    // AddNodes refuses to grow the fleet beyond

// ---- ArmFault's a{ss}
inline constexpr std::size_t kFaultParams = 32;       // entries (a fault has 16 keys)
inline constexpr std::size_t kFaultValueBytes = 256;  // each key and value

// ---- one D-Bus message from a peer of the private socket, all of it: a
// larger one is read and dropped in 64 KiB slices, never handed to sd-bus
// (which checks a message whole: 100 MiB held the loop 0.4-1.2 s), and is
// answered TooLarge (control/message_gate.hpp). The bus daemons have their own
// bound (dbus-daemon: 128 MiB by default).
inline constexpr std::size_t kMessageBytes = 1024 * 1024;

// ---- any other argument: only the message bound above (on a bus, the bus's);
// such strings are compared, never parsed or kept, and an error message
// (which may quote them) is cut to this length.
inline constexpr std::size_t kErrorMessageBytes = 4096;

// ---- files the daemon reads (regular files only, opened without blocking):
// profiles, EDS/DCF and fleet files (the shipped profiles are 10-24 KiB);
// a process model's `csv:` table (about 90,000 points).
inline constexpr std::size_t kProfileFileBytes = 1024 * 1024;
inline constexpr std::size_t kTableFileBytes = 1024 * 1024;
// Stored parameters (<state dir>/*.params); a node's blob is a few KiB.
inline constexpr std::size_t kParameterFileBytes = 1024 * 1024;

// ---- times in YAML quantities (`at:`, `duration:`, `sdo_delay:` ...):
// at most this many seconds (about 31 years), so µs never overflow.
inline constexpr double kMaxSeconds = 1e9;

// ---- connections to the private socket
inline constexpr std::size_t kDefaultMaxClients = 64;  // --max-clients
inline constexpr std::size_t kMaxClientsCeiling = 4096;
inline constexpr std::int64_t kAuthTimeoutUs = 3'000'000;  // D-Bus handshake done within
// A connection that has made no method call this long after it was accepted
// is closed (it holds a slot and does nothing: 64 of them locked everyone out).
inline constexpr std::int64_t kFirstCallTimeoutUs = 10'000'000;
// A share of the slots (--max-clients / kOtherUsersShare) is kept for callers
// of another uid: one uid (other than root) holds at most the rest, so idle
// or reconnecting connections of one user cannot lock out the others or root.
inline constexpr std::size_t kOtherUsersShare = 4;
// What one connection's unread answers and signals may hold: its kernel
// send buffer (the kernel doubles this figure for its bookkeeping), then
// messages queued in the daemon: a client that falls this far behind is
// dropped (and gets no more signals meanwhile).
inline constexpr std::size_t kSocketBufferBytes = 256 * 1024;
inline constexpr std::uint64_t kQueuedMessages = 4096;
// Refused clients still get their answer (why) for this long, this many at once.
inline constexpr std::int64_t kRefusalLingerUs = 1'000'000;
inline constexpr std::size_t kRefusing = 16;
// Connection warnings: at most one line per kind in this period (the rest counted).
inline constexpr std::int64_t kWarningPeriodUs = 10'000'000;

// ---- socketcand buses (`transport: socketcand`, docs/socketcand.md): per bus
inline constexpr std::size_t kSocketcandClients = 64;             // connected at once; one more is told why and closed
inline constexpr std::size_t kSocketcandSendBuffer = 256 * 1024;  // SO_SNDBUF of a client socket
inline constexpr std::size_t kSocketcandUnread = 64 * 1024;       // frames waiting in cansimd beyond it: then dropped
inline constexpr std::size_t kSocketcandReadPerPass = 16 * 1024;  // bytes read from one client per loop pass
// A client's frames queued on a timed bus: beyond, its socket is not read
// until some are on the wire (TCP holds the client back).
inline constexpr std::size_t kSocketcandInFlight = 64;
// After `< ok >` to `< rawmode >`: frames wait until the client sends again, or this long.
inline constexpr std::int64_t kSocketcandRawmodeHoldUs = 200'000;

// ---- Fleet1.QueueFrames (cansimctl replay): frames handed ahead of their time
inline constexpr std::size_t kQueueFramesPerCall = 1024;   // more in one call: TooLarge
inline constexpr std::size_t kQueuedFramesPerBus = 4096;   // waiting per bus; a call takes what fits
inline constexpr std::int64_t kQueueAheadUs = 10'000'000;  // a frame's time at most this far ahead: else OutOfRange

}  // namespace cansim::limits
