// What the error frames of a real CAN interface said (CanInterface), as the
// loop core passes it to the nodes (LoopCore::controller_event).
#pragma once

#include "core/can_frame.hpp"

namespace cansim::io {

struct ControllerEvent {
  CanState state = CanState::kErrorActive;  // the controller's state now
  bool state_changed = false;
  bool frames_lost = false;  // rx or tx overflow
};

}  // namespace cansim::io
