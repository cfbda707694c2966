// A signal in a CAN frame, as a DBC file describes one: where its bits are,
// their byte order and type, and the linear scaling to a value. Plant inputs
// read the controller's commands this way (docs/plants.md); cansimctl
// monitor decodes the same frames by name. Header-only and pure, so the
// client (ctl/, through control/can_signal.hpp) shares the decoder.
//
// Bit numbering is DBC's: bit b of byte B is start bit 8 B + b (b = 0 the
// least significant). Little-endian (Intel): `start` is the signal's least
// significant bit and the signal runs up through the following bytes.
// Big-endian (Motorola): `start` is its most significant bit; the signal runs
// down within the byte, then on at bit 7 of the next byte.
#pragma once

#include <cstdint>
#include <cstring>
#include <optional>

#include "core/can_frame.hpp"

namespace cansim {

struct CanSignal {
  enum class Type : std::uint8_t { kUnsigned, kSigned, kReal32 };
  std::uint32_t can_id = 0;
  bool extended = false;  // 29-bit CAN-ID
  std::uint16_t start = 0;
  std::uint8_t length = 8;  // bits, 1..64 (REAL32: 32)
  Type type = Type::kUnsigned;
  bool little_endian = true;
  double scale = 1.0;  // value = raw x scale + offset
  double offset = 0.0;

  bool matches(const CanFrame& f) const { return f.id == can_id && f.extended() == extended && !f.rtr(); }

  // The frame's bytes this signal needs, counted from byte 0 (a shorter
  // frame does not carry it).
  std::uint8_t bytes_needed() const {
    if (little_endian) return std::uint8_t((start + length + 7) / 8);
    // Motorola: from the start bit's byte on, length bits counting down.
    const int msb_in_byte = start % 8;
    const int rest = length - (msb_in_byte + 1);
    return std::uint8_t(start / 8 + 1 + (rest > 0 ? (rest + 7) / 8 : 0));
  }

  // Layout checks (the loader's): a message or null.
  const char* invalid() const {
    if (length < 1 || length > 64) return "expected a length of 1..64 bits";
    if (type == Type::kReal32 && length != 32) return "a REAL32 signal is 32 bits long";
    if (start > 63) return "expected a start bit 0..63";
    if (bytes_needed() > 8) return "the signal does not fit in 8 bytes";
    if (extended ? can_id > 0x1FFFFFFFu : can_id > 0x7FFu) return "expected an 11-bit CAN-ID (29-bit with extended)";
    return nullptr;
  }

  // The raw bits of the signal (right-aligned), nullopt when the frame is too short.
  std::optional<std::uint64_t> raw(const CanFrame& f) const {
    if (f.dlc < bytes_needed()) return std::nullopt;
    std::uint64_t v = 0;
    if (little_endian) {
      for (int i = 0; i < length; ++i) {
        const int bit = start + i;
        v |= std::uint64_t((f.data[bit / 8] >> (bit % 8)) & 1u) << i;
      }
      return v;
    }
    int bit = start;  // the most significant bit first
    for (int i = 0; i < length; ++i) {
      v = (v << 1) | ((f.data[bit / 8] >> (bit % 8)) & 1u);
      bit = bit % 8 == 0 ? bit + 15 : bit - 1;  // down within a byte, then bit 7 of the next
    }
    return v;
  }

  // raw x scale + offset, nullopt when the frame does not carry the signal.
  std::optional<double> value(const CanFrame& f) const {
    const std::optional<std::uint64_t> r = raw(f);
    if (!r) return std::nullopt;
    double x;
    switch (type) {
      case Type::kUnsigned: x = double(*r); break;
      case Type::kSigned: {
        std::uint64_t u = *r;
        if (length < 64 && (u >> (length - 1)) & 1u) u |= ~std::uint64_t(0) << length;  // sign-extend
        x = double(std::int64_t(u));
        break;
      }
      case Type::kReal32: {
        const std::uint32_t bits = std::uint32_t(*r);
        float fv;
        std::memcpy(&fv, &bits, sizeof fv);
        x = fv;
        break;
      }
      default: x = 0; break;
    }
    return x * scale + offset;
  }
};

}  // namespace cansim
