// A signal in a CAN frame (core/can_signal.hpp) for the control API's
// clients: cansimctl monitor decodes the plant inputs' frames with the same
// decoder the daemon uses (Fleet1.ListPlantSignals says where they are).
#pragma once

#include "core/can_signal.hpp"
