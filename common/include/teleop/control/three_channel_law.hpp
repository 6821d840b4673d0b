#pragma once

#include <cstdint>

#include "teleop/control/velocity_estimator.hpp"
#include "teleop/control/virtual_fixture.hpp"
#include "teleop/types.hpp"

namespace teleop::control {

/// One side of the three-channel telemanipulation law of Abbott & Okamura (eqs. 8 and 9), in the local device's
/// base frame. Both sides reduce to one form, with l = local and r = peer (peer quantities already scaled into the
/// local frame):
///
///   master (eq. 8):  F_am = K_pm(X_m - X_s) + K_dm(Ẋ_m - Ẋ_s) + K_vm·Ẋ_m + K_fm·F_e + F_mVF,  command = -F_am
///   slave  (eq. 9):  F_as = K_ps(X_m - X_s) + K_ds(Ẋ_m - Ẋ_s) - K_vs·Ẋ_s - F_sVF,              command = +F_as
///
///   command = -K_p(X_l - X_r) - K_d(Ẋ_l - Ẋ_r) - K_v·Ẋ_l - K_f·F_r - F_VF(X_l)
///
/// The sign convention is the paper's (eqs. 3-4): the actuator force on the master opposes the operator, the force
/// on the slave drives it. The command is the force the local actuator should apply to its device (N, base frame).
/// K_f is the master's force feed-forward of the environment force the slave measures (eq. 8; F_e > 0 when the
/// slave pushes on its environment along +x, eq. 4); eq. 9 has no force term, so a slave law with K_f ≠ 0 is
/// rejected at construction. Gains are per DOF. F_VF(X_l) is the fixture of eq. 7 (ForbiddenRegionFixture, whose
/// force_N = -F_VF is what the command contains).
///
/// Degraded modes (never an exception in Step):
///  - peer_valid == false: the coupling terms (K_p, K_d, K_f) are off; K_v damping and the fixture still act.
///  - NaN/inf in a used input, an input vector of the wrong size, or a period that is not finite and > 0: the
///    command is zero (safe state) and the status is kNonFiniteInput. A bad local position also resets the
///    velocity estimator, so the next good sample does not produce a velocity spike.
///  - |command| > max_force_N on a DOF: that DOF is clamped, status kSaturated.
///  Status precedence: kNonFiniteInput > kPeerMissing > kSaturated > kOk (the counters in State count each).
class ThreeChannelLaw {
 public:
  struct Config {
    Role role = Role::kMaster;
    int dof = 1;
    DofVector kp_N_per_m;              ///< K_p, position gain per DOF.
    DofVector kd_Ns_per_m;             ///< K_d, gain on the velocity difference.
    DofVector kv_Ns_per_m;             ///< K_v, local velocity feedback (damping).
    DofVector kf;                      ///< K_f, force feed-forward of the peer's measured force (dimensionless).
    double peer_position_scale = 1.0;  ///< Peer position (and velocity) in the local frame = scale · received.
    double peer_force_scale = 1.0;     ///< Peer force in the local frame = scale · received.
    double max_force_N = 0.0;          ///< Actuator saturation per DOF, |command| ≤ max; 0 = no limit.
    ForbiddenRegionFixture::Config fixture{};
    double velocity_filter_hz = 0.0;  ///< Low-pass on the backward-difference velocity; 0 = none.
  };

  struct Input {
    DofVector position_m;        ///< Local measured position.
    DofVector velocity_m_per_s;  ///< Local velocity; used only when `has_velocity`, else estimated (eq. 20).
    bool has_velocity = false;
    DofVector peer_position_m;        ///< Peer position as received (peer frame, before scaling).
    DofVector peer_velocity_m_per_s;  ///< Peer velocity as received.
    DofVector peer_force_N;           ///< Peer's measured force as received (the slave's F_e for the master).
    bool peer_valid = false;          ///< False before the first sample or after the link watchdog tripped.
  };

  /// Why a step produced the command it did. Not an error: a status for telemetry and the fault logic.
  enum class StepStatus : std::uint8_t {
    kOk = 0,
    kSaturated,       ///< At least one DOF hit max_force_N.
    kPeerMissing,     ///< No valid peer sample: coupling terms off, only local damping and fixture act.
    kNonFiniteInput,  ///< NaN/inf in the input: command forced to zero (safe state).
  };

  struct Output {
    DofVector command_N;         ///< Force for the local actuator, after saturation.
    DofVector fixture_force_N;   ///< The fixture's share (already included in command_N), before saturation.
    DofVector velocity_m_per_s;  ///< Local velocity used this step (measured or estimated).
    double fixture_penetration_m = 0.0;
    StepStatus status = StepStatus::kOk;
  };

  struct State {
    VelocityEstimator velocity;  // declared in velocity_estimator.hpp
    std::uint64_t steps = 0;
    std::uint64_t saturated_steps = 0;
    std::uint64_t nonfinite_inputs = 0;
    std::uint64_t peer_missing_steps = 0;
  };

  /// A 1-DOF master law with all gains zero and no fixture (commands zero force).
  ThreeChannelLaw();
  /// Validates the config; throws teleop::Error otherwise: dof in 1..kMaxDof; kp, kd, kv, kf of size dof; kp, kd,
  /// kv finite and ≥ 0; kf finite (and all zero on the slave); scales finite and the position scale ≠ 0;
  /// max_force_N finite and ≥ 0; velocity_filter_hz finite and ≥ 0; a fixture with planes or stiffness must have
  /// the law's dof (a disabled default fixture is resized to it).
  explicit ThreeChannelLaw(const Config& config);

  /// One control cycle. Allocation-free, lock-free, never throws.
  [[nodiscard]] Output Step(const Input& input, double period_s) noexcept;
  /// Forgets the velocity history and zeroes the counters.
  void Reset() noexcept;
  /// The local position's frame moved by `offset_m` (clutch re-index): the velocity estimate sees no jump.
  void ShiftPosition(const DofVector& offset_m) noexcept { state_.velocity.Shift(offset_m); }
  /// The fixture's stiffness at run time (ForbiddenRegionFixture::SetStiffness). Allocation-free.
  void SetFixtureStiffness(double stiffness_N_per_m) noexcept { fixture_.SetStiffness(stiffness_N_per_m); }
  /// A fixture plane at run time (ForbiddenRegionFixture::SetPlane). Allocation-free.
  void SetFixturePlane(int index, const DofVector& normal, double offset_m) noexcept {
    fixture_.SetPlane(index, normal, offset_m);
  }
  /// The gains at run time (a ramp step of a checked change). Ignored, all four, unless each has dof entries, all
  /// finite, K_p, K_d, K_v >= 0, and K_f zero on the slave (the constructor's rules). Allocation-free.
  void SetGains(const DofVector& kp_N_per_m, const DofVector& kd_Ns_per_m, const DofVector& kv_Ns_per_m,
                const DofVector& kf) noexcept;

  const Config& config() const noexcept { return config_; }
  const State& state() const noexcept { return state_; }
  const ForbiddenRegionFixture& fixture() const noexcept { return fixture_; }

  /// A config with every gain zero (vectors sized to `dof`), no fixture, for `role`. Set-up helper.
  static Config ZeroGains(Role role, int dof);

 private:
  Config config_{};
  ForbiddenRegionFixture fixture_{};
  State state_{};
};

const char* ToString(ThreeChannelLaw::StepStatus status) noexcept;

}  // namespace teleop::control
