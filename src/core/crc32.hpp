// CRC-32 as IEEE 802.3 (and zlib, PNG) define it: polynomial 0x04C11DB7
// reflected (0xEDB88320), initial value and final XOR 0xFFFFFFFF. Guards the
// stored parameters, in the node's blob (core/store.cpp) and in the
// daemon's file around it (daemon/file_storage.cpp). Test vector:
// CRC("123456789") = 0xCBF43926.
#pragma once

#include <cstdint>
#include <span>

namespace cansim {

std::uint32_t crc32(std::span<const std::uint8_t> data);

}  // namespace cansim
