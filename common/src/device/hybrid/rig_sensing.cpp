#include "device/hybrid/rig_sensing.hpp"

#include <cmath>

#include "teleop/error.hpp"

namespace teleop::device::hybrid {

void EncoderConfig::Validate() const {
  if (!(std::isfinite(counts_per_joint_rev) && counts_per_joint_rev >= 0.0) ||
      !(std::isfinite(velocity_filter_hz) && velocity_filter_hz >= 0.0)) {
    throw Error("hybrid encoder: counts_per_joint_rev and velocity_filter_hz must be finite and >= 0");
  }
}

JointEncoders::JointEncoders(const EncoderConfig& config) : config_(config) { config_.Validate(); }

void JointEncoders::Reset(const Eigen::Vector2d& joint_rad) noexcept {
  origin_ = joint_rad;  // incremental encoders count from where they start
  primed_ = false;
  qd_.setZero();
  Sample(joint_rad, Eigen::Vector2d::Zero(), 1.0);
}

void JointEncoders::Sample(const Eigen::Vector2d& joint_rad, const Eigen::Vector2d& true_velocity_rad_per_s,
                           double period_s) noexcept {
  Eigen::Vector2d q = joint_rad;
  if (config_.counts_per_joint_rev > 0.0) {
    const double step = 2.0 * M_PI / config_.counts_per_joint_rev;
    for (int i = 0; i < 2; ++i) q(i) = origin_(i) + step * std::floor((q(i) - origin_(i)) / step + 0.5);
  }
  if (config_.exact_velocity) {
    qd_ = true_velocity_rad_per_s;
  } else if (primed_ && period_s > 0.0) {
    const Eigen::Vector2d raw = (q - q_) / period_s;
    const double a =
        config_.velocity_filter_hz > 0.0 ? 1.0 - std::exp(-2.0 * M_PI * config_.velocity_filter_hz * period_s) : 1.0;
    qd_ += a * (raw - qd_);
  }
  q_ = q;
  primed_ = true;
}

void ForceSensorDynamicsConfig::Validate() const {
  if (!(std::isfinite(noise_std_N) && noise_std_N >= 0.0) || !(std::isfinite(bandwidth_hz) && bandwidth_hz >= 0.0)) {
    throw Error("hybrid force sensor: noise_std_N and bandwidth_hz must be finite and >= 0");
  }
}

ForceSensorDynamics::ForceSensorDynamics(const ForceSensorDynamicsConfig& config)
    : config_(config), state_(config.seed ^ 0x9E3779B97F4A7C15ULL) {
  config_.Validate();
}

double ForceSensorDynamics::Gaussian() noexcept {
  // splitmix64 → two uniforms → Box–Muller (portable: the same numbers on every standard library).
  const auto next = [this] {
    std::uint64_t z = (state_ += 0x9E3779B97F4A7C15ULL);
    z = (z ^ (z >> 30U)) * 0xBF58476D1CE4E5B9ULL;
    z = (z ^ (z >> 27U)) * 0x94D049BB133111EBULL;
    return static_cast<double>((z ^ (z >> 31U)) >> 11U) * 0x1.0p-53;
  };
  const double u1 = 1.0 - next();
  const double u2 = next();
  return std::sqrt(-2.0 * std::log(u1)) * std::cos(2.0 * M_PI * u2);
}

Eigen::Vector2d ForceSensorDynamics::Filter(const Eigen::Vector2d& force_N, double period_s) noexcept {
  if (!force_N.allFinite()) return force_N;  // a broken reading stays broken (the device reports it)
  if (!primed_ || config_.bandwidth_hz <= 0.0 || !(period_s > 0.0)) {
    filtered_ = force_N;
    primed_ = true;
  } else {
    filtered_ += (1.0 - std::exp(-2.0 * M_PI * config_.bandwidth_hz * period_s)) * (force_N - filtered_);
  }
  Eigen::Vector2d out = filtered_;
  if (config_.noise_std_N > 0.0) {
    out.x() += config_.noise_std_N * Gaussian();
    out.y() += config_.noise_std_N * Gaussian();
  }
  return out;
}

}  // namespace teleop::device::hybrid
