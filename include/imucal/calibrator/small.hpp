// SPDX-License-Identifier: MIT
// imucal/calibrator/small.hpp: the protocol calibrator sized for a part with 32 KB of RAM
// (SAMD21, STM32G0/C0, nRF52810): at most 12 KiB, the other 20 KiB left to the application, its
// stack and the record store (docs/small_parts.md).
//
//   SmallCalibrator = Calibrator<float, 24, 128, 4>: 11,744 bytes on the Cortex-M0+ (the default
//   Calibrator<float, 48, 630, 8>: 33,616; test_small_calibrator prints both).
//
// It keeps every check, the solve, the integer path (add_raw(), add_fifo()) and the default
// settings (target_poses is 24: ready at a full store). What it gives up:
//   - poses: 24 instead of 48. A longer protocol's later rests are not stored (kCapacityExceeded
//     once, phase ready), so the sigmas are those of 24 poses (the xsens recording's first 24 of
//     41: the accelerometer's about 1.5 times, the gyro's 1.3 times the default's);
//   - the moves' resolution: 128 gyro segments for the 23 moves instead of 630 for 47. The move
//     store coarsens (move_store.hpp: exact merges, the bounds doubling each time; 5 times on the
//     xsens recording, against none for the default);
//   - the rest trimming: a delay line of 4 blocks, so trim_seconds at most 3 blocks (0.75 s at
//     the default block_seconds of 0.25 s; the default trim_seconds, 0.25 s, fits). Settings
//     asking more are refused (kInvalidArgument).
// No rate limit: the stores hold blocks, poses and segments, not samples, so the memory does not
// depend on the sample rate.
// test_small_calibrator holds it to 12 KiB on every target and to the default's parameters within
// their sigma on the xsens recording.
#pragma once

#include "imucal/calibrator/calibrator.hpp"

namespace imucal {

// The stores' sizes in the calibrator's terms: poses, gyro segments, delay-line blocks.
constexpr int kSmallMaxPoses = 24;
constexpr int kSmallMaxSegments = 128;
constexpr int kSmallDelayBlocks = 4;
// The RAM the small configuration is held to on every target (docs/small_parts.md).
constexpr unsigned kSmallCalibratorBytes = 12u * 1024u;

using SmallCalibrator = Calibrator<float, kSmallMaxPoses, kSmallMaxSegments, kSmallDelayBlocks>;

}  // namespace imucal
