#pragma once

#include <Eigen/Core>

namespace teleop::device::hybrid {

/// Time-domain passivity observer/controller at the handle port, impedance causality (velocity in, force out), the
/// scheme Kwon & Song compare against (§4, Figs. 8(b)/9(b), their ref. [4]: Hannaford & Ryu, "Time-domain passivity
/// control of haptic interfaces", IEEE Trans. Robot. Autom. 18(1), 2002).
///
/// Hannaford & Ryu's observer and series controller (impedance form), sign chosen so that E ≥ 0 means the
/// environment has absorbed energy (f: force the environment puts on the handle, v: handle velocity, T: period):
///   W(n)  = W(n−1) − f(n)·v(n)·T + α(n−1)·|v(n−1)|²·T          (observed energy, the PC's past dissipation added once)
///   α(n)  = −W(n) / (T·|v(n)|²)  if W(n) < 0,  else 0            (capped at max_damping_Ns_per_m)
///   F(n)  = f(n) − α(n)·v(n)
/// Here the observed energy is that of the force actually applied at the port, F_app: the controller's output after
/// saturation at max_force_N and through the actuator model (the motor's current-loop lag: the exact mean of a
/// first-order lag over the period under the held command), booked when the period is over with the displacement
/// over it, v(n)·T (exact for a velocity differenced from the encoders, as the rig's):
///   E(n) = E(n−1) − F_app(n−1)·v(n)·T
/// F_app already contains the PC's damping, so its dissipation is counted exactly once (crediting α·v²·T when the
/// damping is commanded *and* observing the damped force counts it twice and releases the controller early). The
/// controller decides on H&R's W(n), the observed energy plus this step's term: W(n) = E(n) − f(n)·v(n)·T.
/// A saturated or lagging actuator cannot always render α·v, so E can dip below zero by at most one step's energy
/// (tested); the next step's α removes it.
struct PassivityObserverConfig {
  /// First-order lag of the force the motors deliver behind their command: the current (torque) loop. 0 = ideal.
  double actuator_time_constant_s = 0.0005;
  /// Largest force the actuators render (N; the command is saturated to it before it is observed).
  double max_force_N = 100.0;
  /// Cap on α (N·s/m): damping the sampled loop can render without itself going unstable (about m/T).
  double max_damping_Ns_per_m = 1000.0;
  void Validate() const;
};

class PassivityObserver {
 public:
  explicit PassivityObserver(const PassivityObserverConfig& config);
  /// One period: books the energy of the last period's applied force with v(n), then, given the environment's force
  /// f(n) (before the controller), returns the force to command (f − α·v, saturated to max_force_N). Real-time safe;
  /// non-finite input gives zero force and books nothing.
  [[nodiscard]] Eigen::Vector2d Step(const Eigen::Vector2d& environment_force_N,
                                     const Eigen::Vector2d& velocity_m_per_s, double period_s) noexcept;
  /// The same with the measured displacement over the last period (x(n) − x(n−1), from the encoders) for the
  /// observer's work, the velocity (an estimate, possibly filtered) for the controller's damping.
  [[nodiscard]] Eigen::Vector2d Step(const Eigen::Vector2d& environment_force_N, const Eigen::Vector2d& displacement_m,
                                     const Eigen::Vector2d& velocity_m_per_s, double period_s) noexcept;
  /// E(n): energy the environment (with the controller) has absorbed through the port, J.
  double energy_J() const noexcept { return energy_J_; }
  /// Σ α|v|²T: what the controller has dissipated (as commanded), J.
  double dissipated_J() const noexcept { return dissipated_J_; }
  double damping_Ns_per_m() const noexcept { return alpha_Ns_per_m_; }
  /// F_app(n): the force applied over the coming period (after saturation and the actuator model), booked next step.
  const Eigen::Vector2d& applied_force_N() const noexcept { return applied_N_; }
  void Reset() noexcept;

 private:
  PassivityObserverConfig config_;
  Eigen::Vector2d delivered_N_{0.0, 0.0};  ///< The actuator model's output at the end of the last period.
  Eigen::Vector2d applied_N_{0.0, 0.0};
  double energy_J_ = 0.0;
  double dissipated_J_ = 0.0;
  double alpha_Ns_per_m_ = 0.0;
};

}  // namespace teleop::device::hybrid
