// The length of a classic CAN frame on the wire (ISO 11898-1:2015 §10.4), bit
// for bit: what the timed bus model (io/timed_bus.hpp) charges a frame.
//
//   SOF | arbitration | control | data | CRC-15 | CRC del | ACK slot, del | EOF | intermission
//    1    11 (+1 RTR)   IDE r0 DLC  8*n     15        1           2         7        3
//         29-bit: 11 SRR IDE 18 RTR, control r1 r0 DLC
//
// Bit stuffing (§10.5): from SOF to the end of the CRC sequence, after five
// equal bits the transmitter inserts one of the opposite value, which itself
// counts for the next run. The stuff bits therefore depend on the frame's own
// identifier, data and CRC: a standard data frame of n bytes takes 47 + 8n
// bits plus 0 to (34 + 8n - 1) / 4 stuff bits (8 bytes: 111 to 135 bits incl.
// the 3-bit intermission); a 29-bit one 67 + 8n plus up to (54 + 8n - 1) / 4.
// A remote frame sends its DLC but no data. The CRC is CRC-15/CAN (generator
// 0x4599, initial value 0) over the unstuffed bits SOF to the end of the data.
//
// Both are computed a byte at a time from tables (no loop per bit): about a
// dozen table reads per frame.
#pragma once

#include <cstdint>

#include "core/can_frame.hpp"

namespace cansim::io {

constexpr int kIntermissionBits = 3;
// An error frame (§10.4.4): a 6-bit error flag superposed by the other
// nodes' (up to 12 bits, taken as 9), the 8-bit delimiter, intermission.
constexpr int kErrorFrameBits = 9 + 8 + kIntermissionBits;
// CRC delimiter, ACK slot, ACK delimiter and EOF: fixed form, never stuffed.
constexpr int kFrameTailBits = 1 + 2 + 7;

// CRC-15/CAN of the frame's bits from SOF to the end of its data field.
std::uint16_t crc15(const CanFrame& frame);
// Stuff bits the transmitter inserts between SOF and the end of the CRC.
int stuff_bits(const CanFrame& frame);
// Bits before stuffing from SOF to the end of the CRC (the stuffed region).
inline int stuffable_bits(const CanFrame& frame) {
  const int data = frame.rtr() ? 0 : (frame.dlc > 8 ? 8 : frame.dlc);
  return (frame.extended() ? 39 : 19) + 8 * data + 15;
}
// The whole frame on the wire: stuffed region with its stuff bits, CRC
// delimiter, ACK, EOF and the 3-bit intermission before the next frame.
int wire_bits(const CanFrame& frame);
// The same without stuff bits: the least the frame can take (47 + 8n bits
// for 11-bit identifiers, 67 + 8n for 29-bit), at no cost.
inline int unstuffed_wire_bits(const CanFrame& frame) {
  return stuffable_bits(frame) + kFrameTailBits + kIntermissionBits;
}

}  // namespace cansim::io
