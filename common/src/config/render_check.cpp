#include "teleop/config/render_check.hpp"

#include <cmath>
#include <sstream>

#include "teleop/error.hpp"

namespace teleop::config {
namespace {

bool AnyNonZero(const DofVector& v) noexcept {
  for (int i = 0; i < v.size(); ++i) {
    if (v[i] != 0.0) return true;
  }
  return false;
}

std::string Plain(double value) {
  std::ostringstream out;
  out << value;
  return out.str();
}

}  // namespace

std::vector<std::string> RenderProblems(const ProcessConfig& config, const device::Capabilities& caps,
                                        const std::string& device_name) {
  std::vector<std::string> problems;
  const std::string device = "device '" + device_name + "' (" + device::ToString(caps.rendering) + ")";
  if (caps.dof != config.dof) {
    problems.push_back("key 'dof': " + std::to_string(config.dof) + ", but " + device + " has " +
                       std::to_string(caps.dof) + " DOF");
    return problems;  // the per-axis checks below would index the wrong axes
  }
  const control::ThreeChannelLaw::Config& law = config.law;
  if (!caps.can_push()) {
    const auto active = [&](const DofVector& gain, const char* key, const char* what) {
      if (AnyNonZero(gain)) {
        problems.push_back(std::string("key '") + key + "': " + what + " needs a device that can push; " + device +
                           " cannot; set it to 0");
      }
    };
    // A steered-constraint device (cobot) takes the coupling force as information, not as a force to render: a
    // coupling force that stays high means a blocked slave, rendered as a constraint across it (docs/cobot.md).
    // A device that only dissipates has no such use for it.
    if (caps.rendering != device::Rendering::kSteeredConstraints) {
      active(law.kp_N_per_m, "law.kp_N_per_m", "active position coupling");
      active(law.kd_Ns_per_m, "law.kd_Ns_per_m", "active velocity coupling");
    }
    active(law.kf, "law.kf", "force feed-forward");
  }
  if (caps.rendering == device::Rendering::kSteeredConstraints && AnyNonZero(law.kv_Ns_per_m)) {
    problems.push_back("key 'law.kv_Ns_per_m': damping is a force, and " + device +
                       " renders no force; set it to 0 (its constraints come from the fixture)");
  }
  if (caps.can_push()) {
    for (int axis = 0; axis < caps.dof; ++axis) {
      const double limit_N = caps.max_force_on(axis);
      if (!std::isfinite(limit_N)) continue;
      if (law.max_force_N == 0.0 || law.max_force_N > limit_N) {
        problems.push_back("key 'law.max_force_N': " +
                           (law.max_force_N == 0.0 ? std::string("unset (no limit)") : Plain(law.max_force_N) + " N") +
                           ", but " + device + " renders at most " + Plain(limit_N) + " N on axis " +
                           std::to_string(axis) + "; set law.max_force_N <= " + Plain(limit_N));
        break;  // one message for the smallest-index axis is enough to act on
      }
    }
  }
  return problems;
}

void RequireRenderable(const ProcessConfig& config, const device::Capabilities& capabilities,
                       const std::string& device_name) {
  const std::vector<std::string> problems = RenderProblems(config, capabilities, device_name);
  if (problems.empty()) return;
  std::string message = config.source_path + ": the device cannot render this config: ";
  for (std::size_t i = 0; i < problems.size(); ++i) message += (i == 0 ? "" : "; ") + problems[i];
  throw Error(message);
}

}  // namespace teleop::config
