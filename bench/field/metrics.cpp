// SPDX-License-Identifier: MIT
// bench/field/metrics.cpp: the field bench's metrics (metrics.hpp).
#include "metrics.hpp"

#include <algorithm>
#include <cmath>

namespace imucal::field_bench {
namespace {

constexpr double kRadToMdeg = 180.0e3 / 3.14159265358979323846;

// The q-quantile (0..1) by the nearest rank; 0 for none.
double quantile(std::vector<float> v, double q) {
  if (v.empty()) return 0.0;
  const auto k = static_cast<std::size_t>(
      std::min(static_cast<double>(v.size() - 1), std::floor(q * static_cast<double>(v.size()))));
  std::nth_element(v.begin(), v.begin() + static_cast<std::ptrdiff_t>(k), v.end());
  return static_cast<double>(v[k]);
}

}  // namespace

double display_unit(Param p, double gravity) {
  switch (p) {
    case Param::kGyro:
      return kRadToMdeg;
    case Param::kAccel:
      return 1e3 / gravity;
    case Param::kMag:
      return 1.0;
  }
  return 1.0;
}

const char* display_unit_name(Param p) {
  return p == Param::kGyro ? "mdeg/s" : p == Param::kAccel ? "mg" : "uT";
}

ParamTrack::ParamTrack(Param p, double gravity, const FalseUpdateRule& rule)
    : param_(p),
      unit_(display_unit(p, gravity)),
      threshold_(p == Param::kGyro    ? rule.gyro_mdps
                 : p == Param::kAccel ? rule.accel_mg
                                      : rule.mag_ut),
      sigmas_(rule.sigmas) {}

void ParamTrack::second(const Estimate3& e, const Eigen::Vector3d& truth, double t_s, bool motion,
                        bool away) {
  ++seconds_;
  const bool updated = e.updates > seen_updates_;
  if (updated) {
    updates_ += e.updates - seen_updates_;
    seen_updates_ = e.updates;
  }
  if (!e.valid) return;
  if (first_s_ < 0.0) first_s_ = t_s;
  ++seconds_after_first_;
  const Eigen::Vector3d d = e.value - truth;
  const auto err = static_cast<float>(d.norm() * unit_);
  err_.push_back(err);
  if (motion) err_motion_.push_back(err);
  if (away) err_away_.push_back(err);
  const bool sigma = e.has_sigma && (e.sigma.array() > 0.0).all();
  if (sigma) {
    has_sigma_ = true;
    z2_ += (d.array() / e.sigma.array()).square().sum();
    zn_ += 3;
  }
  if (updated) {
    const bool wrong = sigma ? (d.array().abs() > sigmas_ * e.sigma.array()).any()
                             : static_cast<double>(err) > threshold_;
    false_updates_ += wrong;
    if (trace_ != nullptr) {
      const Eigen::Vector3d shown = d * unit_;
      std::fprintf(trace_, "trace %s %s update %.0f s: error %.3g %.3g %.3g", who_.c_str(),
                   param_name(param_), t_s, shown(0), shown(1), shown(2));
      if (sigma)
        std::fprintf(trace_, ", sigma %.3g %.3g %.3g", e.sigma(0) * unit_, e.sigma(1) * unit_,
                     e.sigma(2) * unit_);
      std::fprintf(trace_, " %s%s\n", display_unit_name(param_), wrong ? " FALSE" : "");
    }
  }
}

void ParamTrack::trace(std::FILE* out, const std::string& who) {
  trace_ = out;
  who_ = who;
}

ParamSummary ParamTrack::summary() const {
  ParamSummary s;
  s.any = first_s_ >= 0.0;
  s.first_s = first_s_;
  s.coverage =
      seconds_ > 0 ? static_cast<double>(err_.size()) / static_cast<double>(seconds_) : 0.0;
  s.n = err_.size();
  s.n_motion = err_motion_.size();
  s.n_away = err_away_.size();
  s.median = quantile(err_, 0.5);
  s.p95 = quantile(err_, 0.95);
  s.median_motion = quantile(err_motion_, 0.5);
  s.p95_motion = quantile(err_motion_, 0.95);
  s.median_away = quantile(err_away_, 0.5);
  s.p95_away = quantile(err_away_, 0.95);
  s.away_share = seconds_after_first_ > 0 ? static_cast<double>(err_away_.size()) /
                                                static_cast<double>(seconds_after_first_)
                                          : 0.0;
  s.updates = updates_;
  s.false_updates = false_updates_;
  s.has_sigma = has_sigma_;
  s.honesty = zn_ > 0 ? std::sqrt(z2_ / static_cast<double>(zn_)) : 0.0;
  return s;
}

void RestTemperatures::mark(double temperature_c) {
  const double i = std::floor((temperature_c - kMin) / kBin);
  if (i >= 0.0 && i < static_cast<double>(seen_.size())) seen_[static_cast<std::size_t>(i)] = true;
  any_ = true;
}

bool RestTemperatures::away(double temperature_c, double margin_c) const {
  if (!any_) return false;
  const double lo = std::floor((temperature_c - margin_c - kMin) / kBin);
  const double hi = std::floor((temperature_c + margin_c - kMin) / kBin);
  for (double i = std::max(lo, 0.0); i <= hi && i < static_cast<double>(seen_.size()); i += 1.0)
    if (seen_[static_cast<std::size_t>(i)]) return false;
  return true;
}

}  // namespace imucal::field_bench
