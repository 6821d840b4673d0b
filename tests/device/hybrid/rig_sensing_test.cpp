// The simulated rig's sensors (rig_sensing.hpp): encoder quantization and the velocity estimate from it, the handle
// sensor's noise and bandwidth; seeded and deterministic.
#include "device/hybrid/rig_sensing.hpp"

#include <gtest/gtest.h>

#include <cmath>

#include "teleop/error.hpp"

namespace teleop::device::hybrid {
namespace {

// Counted from the start pose: 1.4 counts away reads 1 count, −0.6 reads −1 (nearest count).
TEST(JointEncoders, QuantizeFromTheStartPose) {
  EncoderConfig c;
  c.counts_per_joint_rev = 1000.0;
  JointEncoders enc{c};
  const double step = 2.0 * M_PI / 1000.0;
  const Eigen::Vector2d q0{0.3, 1.7};
  enc.Reset(q0);
  EXPECT_EQ(enc.joint_rad(), q0);
  enc.Sample(q0 + Eigen::Vector2d{1.4 * step, -0.6 * step}, Eigen::Vector2d::Zero(), 1e-3);
  EXPECT_NEAR(enc.joint_rad()(0) - q0(0), step, 1e-12);
  EXPECT_NEAR(enc.joint_rad()(1) - q0(1), -step, 1e-12);
}

// A constant 0.05 rad/s (about 10 mm/s at the handle: 0.32 counts per 1 ms period at 40 000 counts): the filtered
// estimate averages to the true speed (within 2 %) and its ripple stays within one count per period.
TEST(JointEncoders, VelocityEstimateAveragesToTheTrueSpeed) {
  JointEncoders enc{EncoderConfig{}};
  enc.Reset(Eigen::Vector2d::Zero());
  const double w = 0.05;
  double sum = 0.0;
  double worst = 0.0;
  const double count_per_period = 2.0 * M_PI / 40000.0 / 1e-3;
  for (int k = 1; k <= 4000; ++k) {
    enc.Sample(Eigen::Vector2d{w * k * 1e-3, 0.0}, Eigen::Vector2d::Zero(), 1e-3);
    if (k > 1000) {
      sum += enc.joint_velocity_rad_per_s()(0);
      worst = std::max(worst, std::abs(enc.joint_velocity_rad_per_s()(0) - w));
    }
  }
  EXPECT_NEAR(sum / 3000.0, w, 0.02 * w);
  EXPECT_LT(worst, count_per_period);
  EXPECT_GT(worst, 0.0);  // quantization is there
  EncoderConfig bad;
  bad.counts_per_joint_rev = -1.0;
  EXPECT_THROW(JointEncoders{bad}, Error);
}

// Noise: the same seed gives the same readings, another seed others; the standard deviation is the configured one
// (20 000 samples: within 3 %, about 4 standard errors). Bandwidth: a step reaches 1 − e⁻¹ after 1/(2π·500 Hz).
TEST(ForceSensorDynamics, SeededNoiseAndFirstOrderBandwidth) {
  ForceSensorDynamicsConfig c;
  c.bandwidth_hz = 0.0;
  ForceSensorDynamics a{c};
  ForceSensorDynamics b{c};
  c.seed = 2;
  ForceSensorDynamics other{c};
  double sum2 = 0.0;
  bool differs = false;
  for (int k = 0; k < 20000; ++k) {
    const Eigen::Vector2d x = a.Filter(Eigen::Vector2d::Zero(), 1e-3);
    ASSERT_EQ(x, b.Filter(Eigen::Vector2d::Zero(), 1e-3));
    differs = differs || x != other.Filter(Eigen::Vector2d::Zero(), 1e-3);
    sum2 += x.squaredNorm();
  }
  EXPECT_TRUE(differs);
  EXPECT_NEAR(std::sqrt(sum2 / 40000.0), 0.05, 0.0015);

  ForceSensorDynamicsConfig quiet;
  quiet.noise_std_N = 0.0;
  ForceSensorDynamics s{quiet};
  (void)s.Filter(Eigen::Vector2d::Zero(), 1e-3);
  const double tau = 1.0 / (2.0 * M_PI * 500.0);
  const Eigen::Vector2d y = s.Filter({10.0, 0.0}, tau);
  EXPECT_NEAR(y.x(), 10.0 * (1.0 - std::exp(-1.0)), 1e-9);
  EXPECT_FALSE(s.Filter({std::nan(""), 0.0}, 1e-3).allFinite());  // a broken reading stays broken
}

}  // namespace
}  // namespace teleop::device::hybrid
