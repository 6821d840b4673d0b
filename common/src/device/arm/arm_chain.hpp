#pragma once

// An arm's kinematic chain from its URDF: urdfdom parses the file, BuildArmChain walks from the tool link up to the
// base link and builds the KDL chain (no kdl_parser: Debian's pulls in ROS 1). Set-up only; throws teleop::Error
// naming the URDF file and the link or joint at fault.

#include <Eigen/Core>
#include <kdl/chain.hpp>
#include <optional>
#include <string>
#include <vector>

namespace teleop::device::arm {

/// One movable joint of the chain, as the URDF (or the config's override) limits it.
struct JointSpec {
  std::string name;
  bool prismatic = false;  ///< Else revolute or continuous (rad).
  bool bounded = true;     ///< False for a `continuous` joint: no position limits.
  double lower = 0.0;      ///< Position limits (rad, or m for a prismatic joint); used when bounded.
  double upper = 0.0;
  double max_velocity = 0.0;  ///< rad/s (m/s); 0: the URDF gives none.
  double max_effort = 0.0;    ///< N·m (N): the actuator's limit the arm clamps to; > 0 once the chain is built.
};

/// A joint's limits given in config, overriding the URDF's (an absent value keeps the URDF's).
struct JointLimitOverride {
  std::string joint;
  std::optional<double> lower;
  std::optional<double> upper;
  std::optional<double> max_velocity;
  std::optional<double> max_effort;
};

/// What to build: the file, the chain's two ends, the tool point and limit overrides.
struct ArmChainSpec {
  std::string urdf_file;
  std::string base_link;
  std::string tool_link;
  /// The tool point T in the tool link's frame (m): p_LT. The chain ends at T.
  Eigen::Vector3d p_LT = Eigen::Vector3d::Zero();
  std::vector<JointLimitOverride> limit_overrides;
};

/// The chain from the base link's frame B to the tool point T, and its movable joints in order.
struct ArmChain {
  ArmChainSpec spec;
  KDL::Chain chain;
  std::vector<JointSpec> joints;  ///< One per movable joint (KDL's getNrOfJoints()), base to tool.
  int joint_count() const noexcept { return static_cast<int>(joints.size()); }
};

/// Parses `spec.urdf_file` and builds the chain from `spec.base_link` to `spec.tool_link` plus the tool offset.
///
/// Each URDF joint on the path becomes a KDL segment whose root is the parent link's frame: its `origin`
/// (fixed-axis roll-pitch-yaw, then xyz, in the parent's frame) is the segment's tip frame, and the KDL joint turns
/// (or slides) about the URDF axis expressed in the parent's frame through the origin's point, so the segment's tip
/// is the child link's frame at any q. The child link's inertial (mass at `inertial/origin`, inertia about the
/// centre of mass in the inertial frame) becomes the segment's inertia, rotated into the link frame. revolute,
/// continuous, prismatic and fixed joints are taken; floating and planar joints are refused (a serial KDL chain has
/// one DOF per joint). A last fixed segment carries p_LT.
///
/// Throws teleop::Error: the file is unreadable or not a URDF; a link is not in it; the tool link is not downstream
/// of the base link; a joint KDL cannot take; a joint without position limits (lower ≥ upper) or without an effort
/// limit (effort 0) that the config does not override; an override naming a joint not in the chain; more than
/// kMaxJoints movable joints.
ArmChain BuildArmChain(const ArmChainSpec& spec);

}  // namespace teleop::device::arm
