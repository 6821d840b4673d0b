#pragma once

// Private to the cobot backend (common/src/device/cobot): what its reader, devices and registration share.

#include <string>

#include "device/cobot/cobot_backend.hpp"
#include "teleop/types.hpp"

namespace teleop::config {
class Field;
}  // namespace teleop::config

namespace teleop::device::cobot {

/// The backend's name, `device.backend: cobot`.
const std::string& CobotName() noexcept;

/// Reads and validates `device.cobot` (section may be null: the defaults) for a process of `dof` and `role`; the
/// errors name the file, line and key (config::Field::Fail) or, without a section, "device.cobot: ...".
CobotBackendConfig ReadCobot(const config::Field* section, int dof, Role role);

/// The scripted operator's push (N, world) for a cart moving at `velocity` (m/s, world); `integral_N` is its PI
/// state. Real-time safe.
Vec2 OperatorPush(const CobotOperatorScript& op, double time_s, const Vec2& velocity, double period_s,
                  double& integral_N) noexcept;

}  // namespace teleop::device::cobot
