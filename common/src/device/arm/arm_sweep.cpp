// The arm along a fixture plane's normal and the start-up check's sweep (arm_sweep.hpp).

#include "arm_sweep.hpp"

#include <climits>
#include <cmath>
#include <kdl/chainfksolverpos_recursive.hpp>
#include <kdl/frames.hpp>
#include <limits>
#include <map>
#include <numbers>
#include <utility>

namespace teleop::device::arm {

NormalModel ModelAlong(const ArmModel& model, const Eigen::Vector3d& n_B, double joint_damping_Nms_per_rad) noexcept {
  NormalModel m;
  m.mass_kg = model.ApparentMass(n_B);
  double sq = 0.0;  // |J_vᵀ·n|², column by column
  for (int j = 0; j < model.joint_count(); ++j) {
    const double d = model.J_BT().col(j).head<3>().dot(n_B);
    sq += d * d;
  }
  m.damping_Ns_per_m = joint_damping_Nms_per_rad > 0.0 && sq > 0.0 ? joint_damping_Nms_per_rad / sq : 0.0;
  return m;
}

namespace {

/// SplitMix64 (Steele, Lea & Flood 2014): one 64-bit value per (seed, counter), portable.
std::uint64_t SplitMix64(std::uint64_t x) noexcept {
  x += 0x9E3779B97F4A7C15ULL;
  x = (x ^ (x >> 30U)) * 0xBF58476D1CE4E5B9ULL;
  x = (x ^ (x >> 27U)) * 0x94D049BB133111EBULL;
  return x ^ (x >> 31U);
}

/// A uniform number in [0, 1) from 53 bits.
double Unit(std::uint64_t bits) noexcept { return static_cast<double>(bits >> 11U) * 0x1.0p-53; }

int BucketIndex(double value, double log_width) noexcept {
  if (!(value > 0.0)) return INT_MIN;
  return static_cast<int>(std::floor(std::log(value) / log_width));
}

}  // namespace

JointVector SweepConfiguration(const ArmChain& arm, std::uint64_t seed, int index) {
  const int n = arm.joint_count();
  JointVector q(n);
  for (int i = 0; i < n; ++i) {
    const JointSpec& j = arm.joints[static_cast<std::size_t>(i)];
    const std::uint64_t counter =
        static_cast<std::uint64_t>(index) * static_cast<std::uint64_t>(kMaxJoints) + static_cast<std::uint64_t>(i);
    const double u = Unit(SplitMix64(SplitMix64(seed) ^ counter));
    const double lower = j.bounded ? j.lower : -std::numbers::pi;
    const double upper = j.bounded ? j.upper : std::numbers::pi;
    q[i] = lower + u * (upper - lower);
  }
  return q;
}

FixtureSweep SweepNearPlane(ArmModel& model, const FixtureSweepConfig& config, double joint_damping_Nms_per_rad,
                            const Eigen::Vector3d& normal_B, double offset_B_m, double min_manipulability) {
  FixtureSweep sweep;
  const double norm = normal_B.norm();
  if (!(norm > 0.0)) return sweep;
  const Eigen::Vector3d n = normal_B / norm;
  const double offset = offset_B_m / norm;
  const int joints = model.joint_count();
  KDL::ChainFkSolverPos_recursive fk(model.arm().chain);
  KDL::JntArray q_kdl(static_cast<unsigned>(joints));
  KDL::Frame x;
  const JointVector zero(joints);
  // A bucket: (mass index, damping index) -> the index in sweep.buckets. std::map keeps the order deterministic.
  std::map<std::pair<int, int>, std::size_t> index;
  const double log_width = std::log1p(config.bucket);
  for (int s = 0; s < config.samples; ++s) {
    const JointVector q = SweepConfiguration(model.arm(), config.seed, s);
    ++sweep.sampled;
    for (int i = 0; i < joints; ++i) q_kdl(static_cast<unsigned>(i)) = q[i];
    if (fk.JntToCart(q_kdl, x) < 0) continue;
    const Eigen::Vector3d p(x.p.x(), x.p.y(), x.p.z());
    if (std::abs(n.dot(p) - offset) > config.plane_distance_m) continue;
    ++sweep.near_plane;
    if (!model.Update(q, zero) || model.TranslationalManipulability() < min_manipulability) {
      ++sweep.skipped;
      continue;
    }
    const NormalModel along = ModelAlong(model, n, joint_damping_Nms_per_rad);
    if (!std::isfinite(along.mass_kg) || !(along.mass_kg > 0.0)) {
      ++sweep.skipped;
      continue;
    }
    const std::pair<int, int> key =
        config.bucket > 0.0
            ? std::pair<int, int>{BucketIndex(along.mass_kg, log_width), BucketIndex(along.damping_Ns_per_m, log_width)}
            : std::pair<int, int>{s, 0};
    const auto [it, inserted] = index.emplace(key, sweep.buckets.size());
    if (inserted) {
      sweep.buckets.push_back({q, model.p_BT(), along, 1});
      continue;
    }
    SweptConfiguration& b = sweep.buckets[it->second];
    ++b.bucket_size;
    const NormalModel& kept = b.along_normal;
    if (along.damping_Ns_per_m < kept.damping_Ns_per_m ||
        (along.damping_Ns_per_m == kept.damping_Ns_per_m && along.mass_kg > kept.mass_kg)) {
      b.q = q;
      b.p_BT = model.p_BT();
      b.along_normal = along;
    }
  }
  return sweep;
}

}  // namespace teleop::device::arm
