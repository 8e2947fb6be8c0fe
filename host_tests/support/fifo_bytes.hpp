// SPDX-License-Identifier: MIT
// Test support: a frame written into a FIFO buffer as a sensor would, in a given layout (the
// inverse of fifo_frame(), stream/fifo.hpp), said once for the tests and the instruction
// benchmarks that feed add_fifo().
#pragma once

#include <cstdint>

#include "imucal/stream/fifo.hpp"
#include "imucal/types.hpp"

namespace imucal::test {

// Frame k of the buffer at data: its readings where layout puts them, in its byte order (the
// timestamp is not in the bytes: FifoTiming carries it).
inline void put_fifo_frame(std::uint8_t* data, std::uint32_t k, const FifoLayout& layout,
                           const RawFrame& f) {
  std::uint8_t* frame = data + static_cast<std::uint32_t>(layout.stride) * k;
  const auto put16 = [&layout](std::uint8_t* at, std::int16_t v) {
    const auto u = static_cast<std::uint16_t>(v);
    const auto hi = static_cast<std::uint8_t>(u >> 8), lo = static_cast<std::uint8_t>(u & 0xFFu);
    at[0] = layout.big_endian ? hi : lo;
    at[1] = layout.big_endian ? lo : hi;
  };
  for (int i = 0; i < 3; ++i) {
    const unsigned j = 2u * layout.axis_order[i];
    put16(frame + layout.acc_offset + j, f.acc[i]);
    put16(frame + layout.gyro_offset + j, f.gyro[i]);
  }
}

}  // namespace imucal::test
