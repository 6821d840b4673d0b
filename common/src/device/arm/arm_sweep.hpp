#pragma once

// The arm along a fixture plane's normal (docs/arms.md, "Stability"): its apparent mass and damping at one
// configuration, and over the configurations where the plane can be reached (the start-up check's sweep). Set-up
// and off-thread code: the sweep allocates its result.

#include <Eigen/Core>
#include <cstdint>
#include <vector>

#include "arm_model.hpp"

namespace teleop::device::arm {

/// The arm as one mass and one damper along a unit direction n at the model's last Update.
struct NormalModel {
  double mass_kg = 0.0;  ///< m_n(q) = 1 / (nᵀ·J_v·M(q)⁻¹·J_vᵀ·n); +inf when the arm cannot move along n.
  double damping_Ns_per_m = 0.0;  ///< b / |J_vᵀ·n|² from joint viscous damping b (0 when b = 0).
};

/// m_n and b_n of `model` (updated at the configuration of interest) along the unit vector `n_B`, with the joints'
/// viscous damping `joint_damping_Nms_per_rad`.
NormalModel ModelAlong(const ArmModel& model, const Eigen::Vector3d& n_B, double joint_damping_Nms_per_rad) noexcept;

/// How the start-up check samples the joint space (device.arm.fixture_sweep, docs/configuration.md).
struct FixtureSweepConfig {
  int samples = 4000;              ///< Configurations drawn uniformly within the joint limits; 0: no sweep.
  double plane_distance_m = 0.02;  ///< Kept when the tool point is within this distance of the plane (either side).
  std::uint64_t seed = 1;          ///< The draw is a function of the seed alone (same on every machine).
  double bucket = 0.05;            ///< Relative width of a mass/damping bucket; 0: every configuration analysed.
};

/// One analysed configuration: the kept configuration of its bucket with the least damping (ties: the most mass).
struct SweptConfiguration {
  JointVector q;                                   ///< rad (m for prismatic joints).
  Eigen::Vector3d p_BT = Eigen::Vector3d::Zero();  ///< The tool point in the base frame (m).
  NormalModel along_normal;
  int bucket_size = 1;  ///< How many kept configurations the bucket holds.
};

struct FixtureSweep {
  int sampled = 0;     ///< Configurations drawn.
  int near_plane = 0;  ///< Of those, within plane_distance_m of the plane.
  int skipped = 0;     ///< Of those, singular (manipulability below the bound) or immobile along n: not analysed.
  std::vector<SweptConfiguration> buckets;  ///< One per (mass, damping) bucket, in the order first reached.
};

/// The joint configuration number `index` of the sweep with `seed`: joint i uniform in [lower, upper] ([-π, π] for
/// a continuous joint), from SplitMix64 (the same numbers on every platform).
JointVector SweepConfiguration(const ArmChain& arm, std::uint64_t seed, int index);

/// Draws `config.samples` configurations, keeps those whose tool point p_BT satisfies |n·p_BT − offset_B| ≤
/// plane_distance_m (n = unit `normal_B`), skips those below `min_manipulability` or immobile along n, and groups the
/// rest by log-buckets of relative width `config.bucket` in mass and damping. `model` is updated along the way.
FixtureSweep SweepNearPlane(ArmModel& model, const FixtureSweepConfig& config, double joint_damping_Nms_per_rad,
                            const Eigen::Vector3d& normal_B, double offset_B_m, double min_manipulability);

}  // namespace teleop::device::arm
