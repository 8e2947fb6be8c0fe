// SPDX-License-Identifier: MIT
// imucal/stream/fifo.hpp: a batch of raw frames as a sensor's FIFO delivers them: where each
// frame's readings are in the bytes, and when each frame was taken. Every calibrator's add_fifo()
// reads its frames with fifo_frame() and gives each the status add_raw() would. Integer work
// only. Never allocates, throws or blocks. Header-only.
#pragma once

#include <cstddef>
#include <cstdint>
#include <limits>

#include "imucal/status.hpp"
#include "imucal/types.hpp"

namespace imucal {

// The bytes of one FIFO frame: two 16-bit readings per sensor axis, at these offsets.
struct FifoLayout {
  std::uint16_t stride = 12;      // bytes from one frame to the next (at least the readings')
  std::uint16_t acc_offset = 0;   // byte offset of the accelerometer's first reading
  std::uint16_t gyro_offset = 6;  // byte offset of the gyro's first reading
  // axis_order[i]: which reading (0, 1, 2: first, second, third in the frame) is body axis i;
  // the same for both sensors.
  std::uint8_t axis_order[3] = {0, 1, 2};
  bool big_endian = false;  // most IMUs are little-endian

  bool valid() const {
    const unsigned a = axis_order[0], b = axis_order[1], c = axis_order[2];
    return a < 3 && b < 3 && c < 3 && a != b && b != c && a != c && acc_offset + 6u <= stride &&
           gyro_offset + 6u <= stride;
  }
};

// When the frames were taken: per-frame timestamps, or the first one and the period.
struct FifoTiming {
  std::uint32_t first_us = 0;  // the first frame's timestamp (wrapping microseconds)
  // The sensor's output period in 1/256 microseconds (e.g. 104 Hz: 9615.38 us -> 2461538): the
  // frames' timestamps keep the fraction, so a long stream does not drift.
  std::uint32_t period_q8 = 0;
  const std::uint32_t* t_us = nullptr;  // per-frame timestamps instead (count of them), if set
};

// What a batch came to: each frame counted by what add_raw() would have returned.
struct FifoResult {
  std::uint32_t taken = 0;             // kOk or a note
  std::uint32_t refused = 0;           // every other status
  Status first_status = Status::kOk;   // the first status other than kOk (kOk: none)
  Status first_refusal = Status::kOk;  // the first refusal (kOk: none)
};

namespace detail {
inline std::int16_t read16(const std::uint8_t* p, bool big_endian) {
  const unsigned v = big_endian ? (static_cast<unsigned>(p[0]) << 8) | p[1]
                                : (static_cast<unsigned>(p[1]) << 8) | p[0];
  return static_cast<std::int16_t>(static_cast<std::uint16_t>(v));
}
}  // namespace detail

// Frame k of a FIFO buffer, with its timestamp.
inline RawFrame fifo_frame(const std::uint8_t* data, std::uint32_t k, const FifoLayout& l,
                           const FifoTiming& timing) {
  const std::uint8_t* f = data + static_cast<std::size_t>(l.stride) * k;
  RawFrame r;
  for (int i = 0; i < 3; ++i) {
    const unsigned j = 2u * l.axis_order[i];
    r.acc[i] = detail::read16(f + l.acc_offset + j, l.big_endian);
    r.gyro[i] = detail::read16(f + l.gyro_offset + j, l.big_endian);
  }
  r.t_us = timing.t_us != nullptr
               ? timing.t_us[k]
               : timing.first_us + static_cast<std::uint32_t>(
                                       (static_cast<std::uint64_t>(timing.period_q8) * k) >> 8);
  return r;
}

// Counts one frame's status into the batch's result.
inline void count_fifo_status(FifoResult& r, Status s, bool taken) {
  if (taken) {
    ++r.taken;
  } else {
    ++r.refused;
    if (r.first_refusal == Status::kOk) r.first_refusal = s;
  }
  if (s != Status::kOk && r.first_status == Status::kOk) r.first_status = s;
}

// A batch fed frame by frame: add(frame, temperature) gives each frame its status (the batch's
// temperature goes with each frame until one reads it: read() counts the temperatures the front
// end has read, usable or not, without side effects, and is asked only while the temperature
// goes along; none goes with the frames after), taken(status) says whether the
// frame was taken, and refuse() refuses each frame of a batch whose layout is invalid or whose
// buffer is null. Each status is counted in the result and written to statuses[k] if given
// (count entries). What every calibrator's add_fifo() runs.
template <typename Scalar, class Add, class Taken, class Refuse, class Read>
FifoResult feed_fifo(const std::uint8_t* data, std::uint32_t count, const FifoLayout& layout,
                     const FifoTiming& timing, Scalar temperature, Status* statuses, Add&& add,
                     Taken&& taken, Refuse&& refuse, Read&& read) {
  FifoResult r;
  const bool ok = data != nullptr && layout.valid();
  Scalar t = temperature;
  bool carried = !detail::is_nan(t);  // asked of read() only while the temperature goes along
  for (std::uint32_t k = 0; k < count; ++k) {
    const std::uint32_t before = carried ? read() : 0u;
    const Status s = ok ? add(fifo_frame(data, k, layout, timing), t) : refuse();
    if (carried && read() != before) {
      t = std::numeric_limits<Scalar>::quiet_NaN();
      carried = false;
    }
    const bool took = taken(s);
    count_fifo_status(r, s, took);
    if (statuses != nullptr) statuses[k] = s;
  }
  return r;
}

}  // namespace imucal
