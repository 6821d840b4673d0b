#include "teleop/node/reading_check.hpp"

#include <cmath>

namespace teleop::node {

ReadingCheck::ReadingCheck(const SafetyConfig& safety, const device::Capabilities& capabilities, int dof)
    : safety_(safety),
      measures_velocity_(capabilities.measures_velocity),
      measures_force_(capabilities.measures_force),
      previous_m_(DofVector::Zero(dof)) {}

std::uint32_t ReadingCheck::Check(const device::Reading& reading, double period_s) noexcept {
  std::uint32_t faults = device::kFaultNone;
  const DofVector& x = reading.position_m;
  const bool finite = x.size() == previous_m_.size() && AllFinite(x) &&
                      (!measures_velocity_ || AllFinite(reading.velocity_m_per_s)) &&
                      (!measures_force_ || AllFinite(reading.force_N));
  if (!finite) {
    ++nonfinite_;
    have_previous_ = false;  // the next finite reading starts a new jump check
    return device::kFaultNonFiniteSensor;
  }
  bool out = false;
  if (safety_.max_abs_position_m > 0.0 && x.cwiseAbs().maxCoeff() > safety_.max_abs_position_m) out = true;
  if (measures_force_ && safety_.max_abs_force_sensor_N > 0.0 && reading.force_N.size() > 0 &&
      reading.force_N.cwiseAbs().maxCoeff() > safety_.max_abs_force_sensor_N) {
    out = true;
  }
  if (out) {
    ++out_of_range_;
    faults |= device::kFaultOutOfRange;
  }
  if (safety_.max_speed_m_per_s > 0.0 && have_previous_ && std::isfinite(period_s) && period_s > 0.0) {
    const double bound = safety_.max_speed_m_per_s * period_s + safety_.encoder_slack_m;
    if ((x - previous_m_).cwiseAbs().maxCoeff() > bound) {
      ++encoder_jumps_;
      faults |= device::kFaultImplausible;
    }
  }
  previous_m_ = x;
  have_previous_ = true;
  return faults;
}

}  // namespace teleop::node
