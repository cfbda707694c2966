// Where cansimctl monitor and capture read a bus's frames, whatever carries
// it: a CAN_RAW socket on a kernel interface (with the kernel's receive
// time), or a socketcand client on a bus cansimd serves over TCP
// (docs/socketcand.md; the frames' times are cansimd's). The decoder and the
// capture file see RawFrames either way.
#pragma once

#include <cstdint>
#include <map>
#include <memory>
#include <string>
#include <utility>

#include "ctl/connection.hpp"
#include "ctl/frame_decoder.hpp"

namespace cansim::ctl {

class FrameSource {
 public:
  virtual ~FrameSource() = default;
  virtual int fd() const = 0;  // readable when frames wait
  virtual const std::string& interface() const = 0;
  // The next frame waiting; false when none. Throws Failure when the source failed.
  virtual bool receive(RawFrame& out) = 0;
  // Frames lost before cansimctl read them, since the source opened: the
  // kernel's count of a CAN socket's receive-queue overflows (SO_RXQ_OVFL),
  // as of the last frame received; 0 where nobody counts.
  virtual std::uint64_t dropped() const { return 0; }
};

// The socketcand buses of the fleet (Fleet1.SocketcandBuses): name -> (host, port).
using SocketcandAddresses = std::map<std::string, std::pair<std::string, std::uint16_t>>;
SocketcandAddresses socketcand_addresses(Connection& connection);

// Bus `name`: its socketcand address when cansimd serves it so, else the
// kernel interface of that name. Throws Failure naming what failed.
std::unique_ptr<FrameSource> open_frame_source(const std::string& name, const SocketcandAddresses& served,
                                               double timeout_s);

}  // namespace cansim::ctl
