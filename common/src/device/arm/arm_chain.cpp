// URDF (urdfdom) to KDL chain: see arm_chain.hpp for the conventions.

#include "arm_chain.hpp"

#include <urdf_model/model.h>
#include <urdf_parser/urdf_parser.h>

#include <Eigen/Geometry>
#include <algorithm>
#include <fstream>
#include <kdl/frames.hpp>
#include <kdl/joint.hpp>
#include <kdl/rigidbodyinertia.hpp>
#include <kdl/segment.hpp>
#include <sstream>

#include "joint_space.hpp"
#include "teleop/error.hpp"

namespace teleop::device::arm {
namespace {

std::string ReadWholeFile(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) throw Error("arm: cannot read the URDF file '" + path + "'");
  std::ostringstream text;
  text << in.rdbuf();
  return text.str();
}

KDL::Vector ToKdl(const urdf::Vector3& v) { return {v.x, v.y, v.z}; }

KDL::Frame ToKdl(const urdf::Pose& pose) {
  return {KDL::Rotation::Quaternion(pose.rotation.x, pose.rotation.y, pose.rotation.z, pose.rotation.w),
          ToKdl(pose.position)};
}

/// The child link's inertia in its own frame: mass at inertial/origin, the inertia tensor (given about the centre of
/// mass in the inertial frame) rotated into the link frame, R·I·Rᵀ.
KDL::RigidBodyInertia LinkInertia(const urdf::Link& link) {
  if (!link.inertial) return KDL::RigidBodyInertia::Zero();
  const urdf::Inertial& in = *link.inertial;
  const KDL::Frame X_LC = ToKdl(in.origin);
  Eigen::Matrix3d I_C;
  I_C << in.ixx, in.ixy, in.ixz, in.ixy, in.iyy, in.iyz, in.ixz, in.iyz, in.izz;
  Eigen::Matrix3d R;
  for (int r = 0; r < 3; ++r) {
    for (int c = 0; c < 3; ++c) R(r, c) = X_LC.M(r, c);
  }
  const Eigen::Matrix3d I_L = R * I_C * R.transpose();
  return KDL::RigidBodyInertia(
      in.mass, X_LC.p, KDL::RotationalInertia(I_L(0, 0), I_L(1, 1), I_L(2, 2), I_L(0, 1), I_L(0, 2), I_L(1, 2)));
}

std::string Where(const ArmChainSpec& spec) { return "arm: URDF '" + spec.urdf_file + "': "; }

KDL::Joint ToKdlJoint(const ArmChainSpec& spec, const urdf::Joint& joint) {
  const KDL::Frame X_PJ = ToKdl(joint.parent_to_joint_origin_transform);
  const KDL::Vector axis = X_PJ.M * ToKdl(joint.axis);
  switch (joint.type) {
    case urdf::Joint::REVOLUTE:
    case urdf::Joint::CONTINUOUS:
      return {joint.name, X_PJ.p, axis, KDL::Joint::RotAxis};
    case urdf::Joint::PRISMATIC:
      return {joint.name, X_PJ.p, axis, KDL::Joint::TransAxis};
    case urdf::Joint::FIXED:
      return KDL::Joint(joint.name, KDL::Joint::None);
    default:
      break;
  }
  const char* type = joint.type == urdf::Joint::FLOATING ? "floating"
                     : joint.type == urdf::Joint::PLANAR ? "planar"
                                                         : "unknown";
  throw Error(Where(spec) + "joint '" + joint.name + "' is " + type +
              "; an arm's chain takes revolute, continuous, prismatic and fixed joints (one DOF each)");
}

JointSpec LimitsOf(const ArmChainSpec& spec, const urdf::Joint& joint) {
  JointSpec j;
  j.name = joint.name;
  j.prismatic = joint.type == urdf::Joint::PRISMATIC;
  j.bounded = joint.type != urdf::Joint::CONTINUOUS;
  if (joint.limits) {
    j.lower = joint.limits->lower;
    j.upper = joint.limits->upper;
    j.max_velocity = joint.limits->velocity;
    j.max_effort = joint.limits->effort;
  }
  for (const JointLimitOverride& o : spec.limit_overrides) {
    if (o.joint != joint.name) continue;
    if (o.lower) j.lower = *o.lower;
    if (o.upper) j.upper = *o.upper;
    if (o.max_velocity) j.max_velocity = *o.max_velocity;
    if (o.max_effort) j.max_effort = *o.max_effort;
  }
  if (j.bounded && !(j.lower < j.upper)) {
    throw Error(Where(spec) + "joint '" + joint.name + "' has no position range (lower " + std::to_string(j.lower) +
                " >= upper " + std::to_string(j.upper) +
                "): give <limit lower=.. upper=..> in the URDF or joint_limits in the config");
  }
  if (!(j.max_effort > 0.0)) {
    throw Error(Where(spec) + "joint '" + joint.name +
                "' has no effort limit: give <limit effort=..> in the URDF or joint_limits[].max_effort_Nm in the "
                "config (the arm clamps every torque to it)");
  }
  return j;
}

}  // namespace

ArmChain BuildArmChain(const ArmChainSpec& spec) {
  const std::string text = ReadWholeFile(spec.urdf_file);
  const urdf::ModelInterfaceSharedPtr model = urdf::parseURDF(text);
  if (!model) {
    throw Error(Where(spec) +
                "not a valid URDF (urdfdom could not parse it; its message is printed above: a missing <limit> on a "
                "revolute or prismatic joint, a link without a name, a joint naming an unknown link, ...)");
  }
  const urdf::LinkConstSharedPtr base = model->getLink(spec.base_link);
  if (!base) throw Error(Where(spec) + "no link named '" + spec.base_link + "' (the base link)");
  const urdf::LinkConstSharedPtr tool = model->getLink(spec.tool_link);
  if (!tool) throw Error(Where(spec) + "no link named '" + spec.tool_link + "' (the tool link)");

  // Walk from the tool up to the base: the joints on the way, tool first.
  std::vector<urdf::JointConstSharedPtr> path;
  for (urdf::LinkConstSharedPtr link = tool; link->name != spec.base_link;) {
    const urdf::JointConstSharedPtr joint = link->parent_joint;
    if (!joint) {
      throw Error(Where(spec) + "the tool link '" + spec.tool_link + "' is not downstream of the base link '" +
                  spec.base_link + "' (walking up from the tool reached the root '" + link->name + "')");
    }
    path.push_back(joint);
    link = model->getLink(joint->parent_link_name);
  }
  std::reverse(path.begin(), path.end());
  for (const JointLimitOverride& o : spec.limit_overrides) {
    const bool found = std::any_of(path.begin(), path.end(), [&](const urdf::JointConstSharedPtr& j) {
      return j->name == o.joint && j->type != urdf::Joint::FIXED;
    });
    if (!found) {
      throw Error(Where(spec) + "joint_limits names joint '" + o.joint + "', which is not a movable joint between '" +
                  spec.base_link + "' and '" + spec.tool_link + "'");
    }
  }

  ArmChain arm;
  arm.spec = spec;
  for (const urdf::JointConstSharedPtr& joint : path) {
    const KDL::Joint kdl_joint = ToKdlJoint(spec, *joint);
    const urdf::LinkConstSharedPtr child = model->getLink(joint->child_link_name);
    arm.chain.addSegment(
        KDL::Segment(child->name, kdl_joint, ToKdl(joint->parent_to_joint_origin_transform), LinkInertia(*child)));
    if (kdl_joint.getType() != KDL::Joint::None) arm.joints.push_back(LimitsOf(spec, *joint));
  }
  arm.chain.addSegment(KDL::Segment("tool_point", KDL::Joint("tool_point", KDL::Joint::None),
                                    KDL::Frame(KDL::Vector(spec.p_LT.x(), spec.p_LT.y(), spec.p_LT.z()))));
  if (arm.joint_count() == 0) {
    throw Error(Where(spec) + "no movable joint between '" + spec.base_link + "' and '" + spec.tool_link + "'");
  }
  if (arm.joint_count() > kMaxJoints) {
    throw Error(Where(spec) + std::to_string(arm.joint_count()) + " movable joints between '" + spec.base_link +
                "' and '" + spec.tool_link + "'; an arm has at most " + std::to_string(kMaxJoints));
  }
  return arm;
}

}  // namespace teleop::device::arm
