#pragma once

// The table of MIT-mode motor models (deploy/motors/mit-models.yaml, docs/mit-motors.md): per model the
// ranges of its fixed-point fields and its peak torque. Set-up only; errors are teleop::Error located in the file.

#include <map>
#include <string>

#include "teleop/proto/can/mit_motor.hpp"

namespace teleop::fieldbus {

struct MitMotorModel {
  proto::can::mit::MotorRanges ranges{};
  double peak_torque_Nm = 0;  ///< What the motor can give (the hard limit a host clamps to), <= T_MAX.
};

/// Reads a models file: `models: {NAME: {p_max_rad, v_max_rad_per_s, t_max_Nm, peak_torque_Nm}}`.
std::map<std::string, MitMotorModel> ReadMitMotorModels(const std::string& path);

/// The model `name` of `models`; an unknown name is an error listing the known ones (and the closest).
const MitMotorModel& FindMitMotorModel(const std::map<std::string, MitMotorModel>& models, const std::string& name,
                                       const std::string& path);

/// The shipped models file: beside the installed configs, else in the source tree.
std::string DefaultMitMotorModelsPath();

}  // namespace teleop::fieldbus
