#pragma once

// The run-time commands of one cycle as one value (docs/architecture.md, "The cycle"): drained by the node at one
// named point of the cycle (before the coupling), applied by the setpoint stage at its bounded rates.

#include <cstdint>

#include "teleop/control/passivity_controller.hpp"
#include "teleop/types.hpp"

namespace teleop::node {

/// What the command side asked for since the last cycle. A later command of the same kind replaces an earlier one
/// (as a later ramp or move replaces the one in progress). Fixed size, no allocation.
struct Changes {
  struct StiffnessRamp {
    double target_N_per_m = 0.0;
    double ramp_s = 0.0;  ///< 0: at once.
  };
  struct GainRamp {
    DofVector kp_N_per_m;  ///< The targets.
    DofVector kd_Ns_per_m;
    DofVector kv_Ns_per_m;
    DofVector kf;
    double ramp_s = 0.0;  ///< 0: at once.
  };
  struct PlaneMove {
    int index = 0;
    DofVector normal;  ///< The target (unit).
    double offset_m = 0.0;
    double offset_rate_m_per_s = 0.0;
    double normal_rate_rad_per_s = 0.0;
  };

  bool command_clutch = false;  ///< The command channel's clutch (TeleopNode::SetClutch), read every cycle.
  bool has_stiffness = false;
  StiffnessRamp stiffness;
  bool has_gains = false;
  GainRamp gains;
  bool has_plane = false;
  PlaneMove plane;
  bool has_passivity =
      false;  ///< The passivity controller's mode changes (the delay re-check, on_unstable: passivity).
  control::PassivityMode passivity_mode = control::PassivityMode::kOff;
};

}  // namespace teleop::node
