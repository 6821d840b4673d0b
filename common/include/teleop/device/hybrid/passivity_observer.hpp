#pragma once

#include <Eigen/Core>

namespace teleop::device::hybrid {

/// Time-domain passivity observer/controller (Hannaford & Ryu 2002), impedance form, at the handle port, the scheme
/// Kwon & Song compare against (§4, Fig. 8(b)/9(b)). The observer integrates the energy the virtual environment
/// has absorbed, E = Σ −F·v·T (F: force the environment puts on the handle, v: handle velocity); when E < 0 the
/// environment has produced energy and the controller adds a damping force −α·v with α = −E/(T·|v|²) (capped at
/// max_damping_Ns_per_m) that dissipates the surplus. F is the force the motors are estimated to deliver (the
/// command through a first-order lag of the motor's time constant), so the motor lag's energy leak is observed.
struct PassivityObserverConfig {
  double actuator_time_constant_s = 0.007;
  double max_damping_Ns_per_m = 5000.0;
  void Validate() const;
};

class PassivityObserver {
 public:
  explicit PassivityObserver(const PassivityObserverConfig& config);
  /// Given the environment's force for this cycle (before the controller), the handle velocity and the period,
  /// returns the force to command (environment force + controller damping). Real-time safe.
  [[nodiscard]] Eigen::Vector2d Step(const Eigen::Vector2d& environment_force_N,
                                     const Eigen::Vector2d& velocity_m_per_s, double period_s) noexcept;
  double energy_J() const noexcept { return energy_J_; }
  double damping_Ns_per_m() const noexcept { return alpha_Ns_per_m_; }
  void Reset() noexcept;

 private:
  PassivityObserverConfig config_;
  Eigen::Vector2d delivered_N_{0.0, 0.0};
  double energy_J_ = 0.0;
  double alpha_Ns_per_m_ = 0.0;
};

}  // namespace teleop::device::hybrid
