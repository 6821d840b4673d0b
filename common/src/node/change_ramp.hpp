#pragma once

// The shortest ramp of a run-time stiffness or gain change (docs/clutch.md, "Run-time commands"): a change asked
// with a shorter ramp (0 included) is stretched to it, so that the change alone moves the force on any axis by at
// most engagement.max_force_rate_N_per_s on a still device, as the clutch and the plane moves are bounded. Private
// to the node; pure functions of the values the cycle holds when it takes the change.

#include "teleop/control/three_channel_law.hpp"
#include "teleop/types.hpp"

namespace teleop::node {

/// What the law's gains multiply (three_channel_law.hpp: command = -K_p·e - K_d·ė - K_v·Ẋ_l - K_f·F_r - F_VF), per
/// DOF, local frame. Zero entries where a term is off (no peer: e, ė and F_r are 0).
struct GainSignals {
  DofVector position_error_m;        ///< e = X_l - X_r
  DofVector velocity_error_m_per_s;  ///< ė = Ẋ_l - Ẋ_r
  DofVector velocity_m_per_s;        ///< Ẋ_l
  DofVector peer_force_N;            ///< F_r
};

/// |K_target - K_now| · max_i |F_VF,i(position_m)| per N/m of stiffness / max_force_rate (s): the fixture's force
/// at `position_m` (the law's position, local frame) is K·d along the normals, so a linear ramp of K over this time
/// changes it at most at the bound while the device stands still. 0 outside the region.
double StiffnessRampFloor_s(const control::ForbiddenRegionFixture& fixture, const DofVector& position_m,
                            double target_N_per_m, double max_force_rate_N_per_s) noexcept;

/// max_i |ΔK_p,i·e_i + ΔK_d,i·ė_i + ΔK_v,i·Ẋ_i + ΔK_f,i·F_r,i| / max_force_rate (s), Δ = target - `now`'s gains;
/// `target` holds kp, kd, kv, kf in that order.
double GainRampFloor_s(const control::ThreeChannelLaw::Config& now, const DofVector (&target)[4],
                       const GainSignals& signals, double max_force_rate_N_per_s) noexcept;

}  // namespace teleop::node
