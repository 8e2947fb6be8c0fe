// SPDX-License-Identifier: MIT
// examples/firmware/simulated_imu.hpp: stands in for the IMU driver of the example firmware. A
// device with a known distortion is held still, then turned between poses (one axis at a time,
// a smooth rate profile) and held still again, sampled at 100 Hz with a little noise. Fixed
// memory only; the distortion and the noise are the example's, not a real sensor's.
#pragma once

#include <Eigen/Geometry>
#include <cmath>
#include <cstdint>

#include "imucal/calibrator/calibrator.hpp"

class SimulatedImu {
 public:
  // The next raw sample; false once the script of moves is over.
  bool read(imucal::ImuSample<float>& s) {
    const float dt = 0.01f;
    if (!advance(dt)) return false;
    t_us_ += 10000u;
    const Eigen::Vector3f up = attitude_.transpose() * Eigen::Vector3f(0.0f, 0.0f, kGravity);
    Eigen::Matrix3f accel_distortion;  // raw = D f + offset: scale, misalignment, offset
    accel_distortion << 0.98f, 0.01f, -0.005f, 0.0f, 1.02f, 0.008f, 0.0f, 0.0f, 1.01f;
    Eigen::Matrix3f gyro_distortion;
    gyro_distortion << 1.03f, 0.004f, -0.006f, 0.002f, 0.97f, 0.005f, -0.003f, 0.001f, 1.01f;
    s.t_us = t_us_;
    s.acc = accel_distortion * up + Eigen::Vector3f(0.15f, -0.2f, 0.1f) + noise(0.01f);
    s.gyro = gyro_distortion * rate_ + Eigen::Vector3f(0.02f, -0.01f, 0.015f) + noise(0.002f);
    return true;
  }

  // The true specific force and rate of the last sample (m/s^2, rad/s), to check the result.
  Eigen::Vector3f true_acc() const {
    return attitude_.transpose() * Eigen::Vector3f(0.0f, 0.0f, kGravity);
  }
  const Eigen::Vector3f& true_rate() const { return rate_; }

 private:
  static constexpr float kGravity = 9.81f;
  static constexpr float kPi = 3.14159265f;
  static constexpr int kMoves = 60;
  static constexpr float kRestSeconds = 2.0f, kMoveSeconds = 1.0f, kFirstRestSeconds = 11.0f;

  // Time passes; the device rests, then turns about the next axis. False at the end.
  bool advance(float dt) {
    phase_time_ += dt;
    const float rest = move_ == 0 ? kFirstRestSeconds : kRestSeconds;
    if (phase_time_ < rest) {
      rate_.setZero();
      return true;
    }
    if (move_ == kMoves) return false;
    const float t = phase_time_ - rest;
    if (t >= kMoveSeconds) {  // the move is over: the next rest starts
      phase_time_ = 0.0f;
      ++move_;
      rate_.setZero();
      return true;
    }
    // Axes x, y, z in turn; angles between 60 and 140 degrees, alternating in sign.
    const int axis = move_ % 3;
    const float angle = (60.0f + 20.0f * static_cast<float>((move_ * 7) % 5)) * kPi / 180.0f *
                        ((move_ / 3) % 2 == 0 ? 1.0f : -1.0f);
    // A smooth start and stop: the rate is (1 - cos) shaped and integrates to `angle`.
    const float speed = angle / kMoveSeconds * (1.0f - std::cos(2.0f * kPi * t / kMoveSeconds));
    rate_ = Eigen::Vector3f::Unit(axis) * speed;
    attitude_ = attitude_ * Eigen::AngleAxisf(speed * dt, Eigen::Vector3f::Unit(axis));
    return true;
  }

  // Roughly Gaussian noise of the given standard deviation (sum of uniforms, xorshift32).
  Eigen::Vector3f noise(float sigma) {
    Eigen::Vector3f n;
    for (int i = 0; i < 3; ++i) {
      float sum = 0.0f;
      for (int k = 0; k < 4; ++k) {
        state_ ^= state_ << 13;
        state_ ^= state_ >> 17;
        state_ ^= state_ << 5;
        sum += static_cast<float>(state_ >> 8) * (1.0f / 16777216.0f) - 0.5f;
      }
      n(i) = sum * sigma * 1.7320508f;  // 4 uniforms: variance 1/3
    }
    return n;
  }

  Eigen::Matrix3f attitude_ = Eigen::Matrix3f::Identity();  // body to world
  Eigen::Vector3f rate_ = Eigen::Vector3f::Zero();
  float phase_time_ = 0.0f;
  int move_ = 0;
  std::uint32_t t_us_ = 0;
  std::uint32_t state_ = 2463534242u;
};
