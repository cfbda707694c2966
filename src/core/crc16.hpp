// CRC-16-CCITT as SDO block transfer uses it (CiA 301 §7.2.4.3.16):
// polynomial x^16 + x^12 + x^5 + 1 (0x1021), initial value 0, no reflection,
// no final XOR. Test vector: CRC("123456789") = 0x31C3.
#pragma once

#include <cstdint>
#include <span>

namespace cansim {

// Continues a running CRC over `data` (start with crc = 0).
std::uint16_t crc16_ccitt(std::span<const std::uint8_t> data, std::uint16_t crc = 0);

}  // namespace cansim
