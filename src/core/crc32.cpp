#include "core/crc32.hpp"

#include <array>

namespace cansim {

namespace {
// The CRC of every byte value: a byte (not a bit) at a time, as the blob is
// checked at every power-on.
constexpr std::array<std::uint32_t, 256> kCrcTable = [] {
  std::array<std::uint32_t, 256> table{};
  for (std::uint32_t byte = 0; byte < 256; ++byte) {
    std::uint32_t crc = byte;
    for (int bit = 0; bit < 8; ++bit) crc = (crc >> 1) ^ (0xEDB88320u & (0u - (crc & 1u)));
    table[byte] = crc;
  }
  return table;
}();
}  // namespace

std::uint32_t crc32(std::span<const std::uint8_t> data) {
  std::uint32_t crc = 0xFFFFFFFFu;
  for (std::uint8_t byte : data) crc = (crc >> 8) ^ kCrcTable[(crc ^ byte) & 0xFFu];
  return ~crc;
}

}  // namespace cansim
