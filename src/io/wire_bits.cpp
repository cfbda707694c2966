#include "io/wire_bits.hpp"

#include <array>

namespace cansim::io {

namespace {

constexpr std::uint16_t kCrc15Generator = 0x4599;  // x^15 + x^14 + x^10 + x^8 + x^7 + x^4 + x^3 + 1

// The CRC is linear in the message: the CRC of a message is the XOR, over
// its bytes, of the CRC of that byte followed by as many zero bytes as follow
// it. kCrcSlices[k][b] is that for byte b with k bytes after it (a 13-byte
// message at most: a 29-bit header padded to 5 bytes and 8 data bytes), so
// the reads are independent of each other (no chain through the register).
constexpr int kMaxCrcBytes = 13;
constexpr std::array<std::array<std::uint16_t, 256>, kMaxCrcBytes> make_crc_slices() {
  std::array<std::array<std::uint16_t, 256>, kMaxCrcBytes> t{};
  for (unsigned i = 0; i < 256; ++i) {
    unsigned r = i << 7;  // the byte through the register, MSB first
    for (int b = 0; b < 8; ++b) r = (r & 0x4000) ? ((r << 1) ^ kCrc15Generator) : (r << 1);
    t[0][i] = std::uint16_t(r & 0x7FFF);
  }
  for (int k = 1; k < kMaxCrcBytes; ++k)
    for (unsigned i = 0; i < 256; ++i) {
      const unsigned c = t[k - 1][i];  // then a zero byte
      t[k][i] = std::uint16_t(((c << 8) & 0x7FFF) ^ t[0][(c >> 7) & 0xFF]);
    }
  return t;
}
constexpr auto kCrcSlices = make_crc_slices();

// Stuffing as a state machine over bytes. State: the last bit sent (stuff
// bits included) and the length of its run, 1..4 (a run reaching 5 inserts a
// stuff bit at once, which starts a run of 1 of the other value):
// s = bit * 4 + run - 1. For each value of `width` input bits (MSB first),
// byte s of `next` is the next state of state s, times 8, and byte s of
// `inserted` the stuff bits inserted. A state times 8 is the shift that
// picks its byte: the chain from one input byte to the next is a shift and
// a mask (the words are read off the chain, by the data), not a table read.
struct StuffTable {
  std::array<std::uint64_t, 256> next{};
  std::array<std::uint64_t, 256> inserted{};
};
constexpr StuffTable make_stuff_table(int width) {
  StuffTable t;
  for (unsigned in = 0; in < (1u << width); ++in)
    for (unsigned s = 0; s < 8; ++s) {
      unsigned last = s >> 2, run = (s & 3) + 1, inserted = 0;
      for (int i = width - 1; i >= 0; --i) {
        const unsigned bit = (in >> i) & 1;
        if (bit != last) {
          last = bit;
          run = 1;
        } else if (++run == 5) {
          ++inserted;
          last ^= 1;
          run = 1;
        }
      }
      t.next[in] |= std::uint64_t((last * 4 + run - 1) * 8) << (8 * s);
      t.inserted[in] |= std::uint64_t(inserted) << (8 * s);
    }
  return t;
}
constexpr auto kStuff8 = make_stuff_table(8);
constexpr auto kStuff7 = make_stuff_table(7);  // the last 7 bits of the CRC

int data_bytes(const CanFrame& f) { return f.rtr() ? 0 : (f.dlc > 8 ? 8 : f.dlc); }
unsigned dlc_field(const CanFrame& f) { return f.dlc > 15 ? 15 : f.dlc; }

// SOF to the end of the control field, behind a pad that makes it whole
// bytes, as an integer. 11-bit: pad 10101, SOF ID RTR IDE=0 r0=0 DLC (5 + 19
// = 24 bits); 29-bit: pad 1, SOF base-ID SRR=1 IDE=1 extension RTR r1=0 r0=0
// DLC (1 + 39 = 40 bits). The pad alternates and ends in 1: it inserts no
// stuff bit, and SOF (0) starts a fresh run as after the recessive idle bus.
// For the CRC the pad bits are zeros (leading zeros do not change a CRC that
// starts at 0).
struct Header {
  std::uint64_t crc_bits;    // zero pad
  std::uint64_t stuff_bits;  // alternating pad
  int bytes;
};
Header header(const CanFrame& f) {
  const std::uint64_t rtr = f.rtr() ? 1 : 0;
  if (!f.extended()) {
    const std::uint64_t h = (std::uint64_t(f.id & 0x7FF) << 7) | (rtr << 6) | dlc_field(f);
    return {h, (std::uint64_t(0b10101) << 19) | h, 3};
  }
  const std::uint64_t base = (f.id >> 18) & 0x7FF, extension = f.id & 0x3FFFF;
  const std::uint64_t h = (base << 27) | (std::uint64_t(3) << 25) | (extension << 7) | (rtr << 6) | dlc_field(f);
  return {h, (std::uint64_t(1) << 39) | h, 5};
}

// `shift`: the state times 8.
unsigned stuff_step(const StuffTable& t, unsigned shift, unsigned bits, int& inserted) {
  inserted += int((t.inserted[bits] >> shift) & 0xFF);
  return unsigned((t.next[bits] >> shift) & 0xFF);
}

// CRC and stuff bits: the stuffing is a chain of table reads, byte after
// byte; the CRC's reads run beside it and are ready for its last two bytes.
struct Coded {
  unsigned crc;
  int stuff;
};
Coded code(const CanFrame& f) {
  const Header h = header(f);
  const int n = data_bytes(f), length = h.bytes + n;
  unsigned crc = 0, shift = 0;  // state 0, as after a single dominant bit: the pad starts with 1
  int inserted = 0;
  for (int i = 0; i < h.bytes; ++i) {
    crc ^= kCrcSlices[length - 1 - i][(h.crc_bits >> (8 * (h.bytes - 1 - i))) & 0xFF];
    shift = stuff_step(kStuff8, shift, unsigned(h.stuff_bits >> (8 * (h.bytes - 1 - i))) & 0xFF, inserted);
  }
  for (int i = 0; i < n; ++i) {
    crc ^= kCrcSlices[n - 1 - i][f.data[i]];
    shift = stuff_step(kStuff8, shift, f.data[i], inserted);
  }
  shift = stuff_step(kStuff8, shift, crc >> 7, inserted);
  stuff_step(kStuff7, shift, crc & 0x7F, inserted);
  return {crc, inserted};
}

}  // namespace

std::uint16_t crc15(const CanFrame& frame) { return std::uint16_t(code(frame).crc); }

int stuff_bits(const CanFrame& frame) { return code(frame).stuff; }

int wire_bits(const CanFrame& frame) {
  return stuffable_bits(frame) + stuff_bits(frame) + kFrameTailBits + kIntermissionBits;
}

}  // namespace cansim::io
