#pragma once

#include <string>
#include <vector>

#include "teleop/config/process_config.hpp"
#include "teleop/device/device.hpp"

namespace teleop::config {

/// Whether a device can render what a process config asks of it (the node checks this at start-up, after
/// Device::Configure). Each problem names the config key and says what to change:
///  - the device's DOF differs from `dof`;
///  - a device that cannot push (Rendering::kDissipativeOnly, kSteeredConstraints) with active coupling gains:
///    `law.kp_N_per_m`, `law.kd_Ns_per_m` or `law.kf` not zero (they drive the handle towards the peer, which
///    needs an active actuator);
///  - a steered-constraint device (cobot) with `law.kv_Ns_per_m` not zero (it renders no force at all; its
///    constraints come from the fixture);
///  - a device with its own force limit on an axis, and `law.max_force_N` unset (0) or above that limit: the
///    device would clip what the law and the stability check assume is rendered.
/// Empty when the device can render the config.
std::vector<std::string> RenderProblems(const ProcessConfig& config, const device::Capabilities& capabilities,
                                        const std::string& device_name);

/// Throws teleop::Error listing every RenderProblems entry, with the config file's name. Does nothing when empty.
void RequireRenderable(const ProcessConfig& config, const device::Capabilities& capabilities,
                       const std::string& device_name);

}  // namespace teleop::config
