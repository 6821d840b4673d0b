#pragma once

#include <cstdint>
#include <memory>

#include "device/cobot/bicycle_caster.hpp"
#include "device/cobot/bicycle_plant.hpp"
#include "device/cobot/bicycle_sensing.hpp"
#include "device/cobot/cobot_fieldbus_config.hpp"
#include "device/cobot/master_walls.hpp"
#include "device/cobot/unicycle_cobot.hpp"
#include "teleop/device/device.hpp"
#include "teleop/device/device_config.hpp"
#include "teleop/device/device_registry.hpp"

namespace teleop::device::cobot {

/// A scripted operator on the simulated cobot (a master without a human): pushes towards `direction_deg` (world,
/// from +x) holding `speed_m_per_s`; from `then_at_s` on (if > 0) towards `then_direction_deg` instead.
struct CobotOperatorScript {
  bool enabled = false;
  double speed_m_per_s = 0.2;
  double direction_deg = 0.0;
  double then_at_s = 0.0;
  double then_direction_deg = 0.0;
  double max_force_N = 60.0;
};

/// The parsed `device.cobot` section (docs/cobot.md lists every key).
struct CobotBackendConfig {
  enum class Kind : std::uint8_t { kUnicycle, kBicycle };
  Kind kind = Kind::kUnicycle;
  UnicycleCobotConfig unicycle = UnicycleCobotConfig::Prototype();
  UnicyclePlantState initial{};
  /// A coupling force (the law's force without the fixture's share) above this means the slave is blocked: the
  /// cobot renders a wall through the current position, across the force. Released below half of it, once the
  /// operator has pulled off that wall.
  double contact_force_threshold_N = 2.0;
  CobotOperatorScript op{};
  BicyclePlantConfig bicycle{};
  BicycleCasterConfig bicycle_caster{};
  /// simulated: the models above are the device; fieldbus: the real unicycle cobot on CAN
  /// (UnicycleCobotFieldbusDevice).
  enum class Rig : std::uint8_t { kSimulated, kFieldbus };
  Rig rig = Rig::kSimulated;
  CobotFieldbusConfig fieldbus{};
};

/// What a cobot reports it can do (dof 2 or 3; a brake when brake_N > 0).
Capabilities CobotCapabilities(int dof, double brake_N);
/// A Command the cobot can use: sizes match dof, everything finite, constraints in range.
bool CobotCommandUsable(const Command& command, int dof) noexcept;

/// The `cobot` backend (registered from cobot_backend.cpp): a passive device that renders constraints by steering.
DeviceBackend CobotBackend();

/// A DeviceConfig selecting the cobot backend (dof 2 for a unicycle, 3 for a bicycle).
DeviceConfig CobotDeviceConfig(const CobotBackendConfig& config);

/// The simulated unicycle cobot behind the Device interface. As a master it renders
///  - each fixture plane of the Command as a steered virtual wall (the most penetrated plane at a time), and
///  - a blocked slave (coupling force above its free-motion level by more than contact_force_threshold_N) as a
///    wall through the position where the contact began, normal to that excess force;
/// it never pushes: force_N of the Command is not rendered. Reading::rendered_force_N is the in-plane force the
/// floor exerts through the wheel (the constraint force the operator feels), zero in ideal caster motion.
class UnicycleCobotDevice final : public Device {
 public:
  explicit UnicycleCobotDevice(const CobotBackendConfig& config);
  const Capabilities& capabilities() const noexcept override { return capabilities_; }
  const std::string& name() const noexcept override;
  void Read(Reading& out) noexcept override;
  void Write(const Command& command) noexcept override;
  void Update(double period_s) noexcept override;
  void SetSafe() noexcept override;

  const UnicycleCobot& rig() const noexcept { return rig_; }
  /// Which wall is rendered: -1 none, 0..kMaxConstraints-1 a fixture plane, kContactWall the contact wall.
  int rendered_wall() const noexcept { return walls_.source(); }
  /// SetSafe() or a bad Command, until a good Command.
  bool safe() const noexcept { return safe_; }
  WallMode controller_mode() const noexcept { return rig_.controller().mode(); }
  static constexpr int kContactWall = MasterWalls::kContactWall;
  const MasterWalls& walls() const noexcept { return walls_; }
  const CobotSample& last_sample() const noexcept { return last_; }

 private:
  CobotBackendConfig config_;
  Capabilities capabilities_;
  UnicycleCobot rig_;
  CobotSample last_{};
  Vec2 operator_force_N_ = Vec2::Zero();
  double operator_integral_N_ = 0.0;
  double time_s_ = 0.0;
  MasterWalls walls_;
  std::uint32_t pending_faults_ = kFaultNone;
  bool safe_ = false;
};

/// The simulated bicycle cobot (x, y, θ) behind the Device interface. In free space the bicycle caster (eq 1 per
/// wheel). As a master it renders the fixture planes and a blocked slave as virtual walls on the plate's reference
/// point (its origin, midway between the wheels), with the same switching as the unicycle (caster → overlay →
/// tracking → caster when the operator pulls away; MasterWalls, VirtualWallController): while a wall is engaged both
/// wheels are steered parallel (modulo π) to one virtual heading ψ_v, which the unicycle's tracker turns. With
/// parallel wheels the reference point, which lies on the line through the wheels, moves along ψ_v even at the
/// singular configuration, so it is a unicycle there. The θ components of a plane's normal are ignored (walls act
/// on x, y).
class BicycleCobotDevice final : public Device {
 public:
  explicit BicycleCobotDevice(const CobotBackendConfig& config);
  const Capabilities& capabilities() const noexcept override { return capabilities_; }
  const std::string& name() const noexcept override;
  void Read(Reading& out) noexcept override;
  void Write(const Command& command) noexcept override;
  void Update(double period_s) noexcept override;
  void SetSafe() noexcept override;
  const BicyclePlantState& state() const noexcept { return state_; }
  const VirtualWallController& controller() const noexcept { return controller_; }
  const MasterWalls& walls() const noexcept { return walls_; }
  int rendered_wall() const noexcept { return walls_.source(); }
  bool safe() const noexcept { return safe_; }
  WallMode controller_mode() const noexcept { return controller_.mode(); }
  /// The virtual heading the wheels are steered to while a wall is engaged (world, rad).
  double virtual_heading_rad() const noexcept;
  /// The scripted operator's push in the last Update (N, world).
  const Vec2& operator_force_N() const noexcept { return operator_force_N_; }
  const WallControllerOutput& last_control() const noexcept { return last_control_; }

 private:
  CobotBackendConfig config_;
  Capabilities capabilities_;
  BicyclePlantState state_{};
  VirtualWallController controller_;
  MasterWalls walls_;
  BicycleSensing sensing_;  ///< The encoders and the rate estimates the controllers see.
  WallControllerOutput last_control_{};
  Vec2 MeasuredForce() const noexcept;

  Vec2 operator_force_N_ = Vec2::Zero();
  bool safe_ = false;
  bool locked_ = false;  ///< Safe with no wall set: both wheels hold their steering.
  std::uint32_t pending_faults_ = kFaultNone;
  double time_s_ = 0.0;
  double operator_integral_N_ = 0.0;
};

}  // namespace teleop::device::cobot
