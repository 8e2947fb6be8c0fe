// SPDX-License-Identifier: MIT
// bench/field/oracle_estimator.cpp: field.md section 7's lower reference. Told exactly when the
// board is still (the truth), it averages the nominally scaled gyro over the true rest and holds
// the last value until the next rest. The average is over the rest's last 10 s (or the whole
// rest while shorter), so that an hours-long rest through a temperature swing follows the bias
// instead of averaging its history; it is published once the rest has lasted a second. It knows
// nothing of temperature. Gyro only: the accelerometer's bias needs the orientation, which it is
// not told.
#include <algorithm>
#include <array>

#include "estimator.hpp"

namespace imucal::field_bench {
namespace {

class OracleEstimator final : public Estimator {
 public:
  explicit OracleEstimator(const sim::DeviceSheet& sheet)
      : scale_(sheet.gyro_rad_s_per_count), per_block_(static_cast<std::uint64_t>(sheet.rate_hz)) {}

  bool reads_truth() const override { return true; }

  void feed(const sim::LifeSample& s, const sim::LifeTruth* truth) override {
    if (truth == nullptr || !truth->still) {
      blocks_ = next_ = 0;
      current_.setZero();
      current_n_ = 0;
      published_ = false;
      return;
    }
    current_ += s.imu.gyro.cast<double>() * scale_;
    ++current_n_;
    if (current_n_ == per_block_) {  // a second complete: into the window
      block_[next_] = current_;
      next_ = (next_ + 1) % block_.size();
      blocks_ = std::min(blocks_ + 1, block_.size());
      current_.setZero();
      current_n_ = 0;
    }
    if (blocks_ == 0) return;
    Eigen::Vector3d sum = current_;
    for (std::size_t i = 0; i < blocks_; ++i) sum += block_[i];
    value_ = sum / static_cast<double>(blocks_ * per_block_ + current_n_);
    valid_ = true;
    if (!published_) ++updates_;  // one update per rest
    published_ = true;
  }

  Estimate estimate() override {
    Estimate e;
    e.gyro_bias.valid = valid_;
    e.gyro_bias.value = value_;
    e.gyro_bias.updates = updates_;
    return e;
  }

 private:
  double scale_;
  std::uint64_t per_block_;
  std::array<Eigen::Vector3d, 10> block_{};  // the window's complete seconds, sums
  std::size_t blocks_ = 0, next_ = 0;
  Eigen::Vector3d current_ = Eigen::Vector3d::Zero(), value_ = Eigen::Vector3d::Zero();
  std::uint64_t current_n_ = 0, updates_ = 0;
  bool valid_ = false, published_ = false;
};

}  // namespace

std::unique_ptr<Estimator> make_oracle_estimator(const sim::DeviceSheet& sheet) {
  return std::make_unique<OracleEstimator>(sheet);
}

}  // namespace imucal::field_bench
