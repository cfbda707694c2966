#include "core/crc16.hpp"

#include <array>

namespace cansim {

namespace {

constexpr std::array<std::uint16_t, 256> make_table() {
  std::array<std::uint16_t, 256> table{};
  for (unsigned byte = 0; byte < 256; ++byte) {
    std::uint16_t crc = std::uint16_t(byte << 8);
    for (int bit = 0; bit < 8; ++bit)
      crc = (crc & 0x8000) ? std::uint16_t((crc << 1) ^ 0x1021) : std::uint16_t(crc << 1);
    table[byte] = crc;
  }
  return table;
}

constexpr auto kTable = make_table();

}  // namespace

std::uint16_t crc16_ccitt(std::span<const std::uint8_t> data, std::uint16_t crc) {
  for (std::uint8_t b : data) crc = std::uint16_t((crc << 8) ^ kTable[((crc >> 8) ^ b) & 0xFF]);
  return crc;
}

}  // namespace cansim
