#pragma once

// The parsed `device.arm` section (arm_backend.cpp reads it; docs/configuration.md, `device.arm`). Joint-space lists
// stay plain vectors here: their length is checked against the chain when the device is built.

#include <string>
#include <vector>

#include "arm_chain.hpp"
#include "arm_device.hpp"
#include "arm_sweep.hpp"
#include "cia402_joint_bus.hpp"
#include "mit_joint_bus.hpp"
#include "simulated_arm.hpp"
#include "teleop/device/device_configuration.hpp"

namespace teleop::device::arm {

struct ArmSection {
  ArmChainSpec chain;  ///< urdf (resolved beside the config), base_link, tool_link, tool offset, limits.
  Eigen::Vector3d workspace_origin_m = Eigen::Vector3d::Zero();  ///< Reported position = p_BT − this (m, B).
  double gravity_m_per_s2 = 9.81;                                ///< Along -z of the base frame.
  ArmDeviceConfig device;                                        ///< The torque law and the singularity bound.
  std::vector<double> posture_q_rad;                             ///< Empty: the middle of each joint's range.
  SimulatedArmConfig simulation;  ///< actuators: simulated (and the plant of actuators: mit with mit.bus simulated).
  bool mit_actuators = false;     ///< actuators: mit.
  MitJointBusConfig mit;          ///< actuators: mit.
  bool cia402_actuators = false;  ///< actuators: cia402.
  Cia402JointBusConfig cia402;    ///< actuators: cia402.
  std::vector<double> initial_q_rad;        ///< The simulated arm's start; empty: the middle of each joint's range.
  FixtureSweepConfig fixture_sweep;         ///< The start-up check's configurations near a fixture plane.
  ConfigurationLimitOptions runtime_limit;  ///< The run-time limit at the current configuration (off by default).

  Eigen::Vector3d gravity_B() const { return {0.0, 0.0, -gravity_m_per_s2}; }
};

/// Builds the arm device of a parsed section (the chain, its model, the actuators). Throws teleop::Error naming the
/// URDF file and the joint or link; a list whose length is not the chain's joint count names the key.
std::unique_ptr<ArmDevice> MakeArmDevice(const ArmSection& section);

/// The simulated arm of a section on its own (tests, scenarios).
std::unique_ptr<SimulatedArm> MakeSimulatedArm(const ArmSection& section);

/// The joint bus of a section with actuators: mit: on its CAN port, or (mit.simulated) on the simulated MIT arm of
/// the section's simulation.
std::unique_ptr<MitJointBus> MakeMitJointBus(const ArmSection& section);

/// The joint bus of a section with actuators: cia402: on its CAN buses, or (cia402.simulated) on the simulated
/// CiA 402 arm of the section's simulation.
std::unique_ptr<Cia402JointBus> MakeCia402JointBus(const ArmSection& section);

}  // namespace teleop::device::arm
