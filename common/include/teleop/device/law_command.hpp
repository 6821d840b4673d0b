#pragma once

#include "teleop/control/three_channel_law.hpp"
#include "teleop/device/device.hpp"

namespace teleop::device {

static_assert(kMaxConstraints == control::ForbiddenRegionFixture::kMaxPlanes,
              "a Command must be able to carry every plane of the fixture");

/// The Command of one law step: the law's force and fixture share, and every plane of the law's fixture (when it
/// is enabled, stiffness > 0) with its penetration at `position_m`, the position the law used. No allocation.
void FillCommand(const control::ThreeChannelLaw::Output& out, const control::ForbiddenRegionFixture& fixture,
                 const DofVector& position_m, Command& command) noexcept;

}  // namespace teleop::device
