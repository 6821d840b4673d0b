#pragma once

#include <array>
#include <cstdint>

#include "teleop/types.hpp"

namespace teleop::control {

/// How the time-domain passivity controller works (docs/stability.md, "Time-domain passivity").
enum class PassivityMode : std::uint8_t {
  kOff = 0,         ///< Observe only (energies, observed-energy minimum); the command is never changed.
  kObserver,        ///< Hannaford & Ryu (2002): the port may give back only what it absorbed (local, any link).
  kEnergyExchange,  ///< Ryu, Artigas & Preusche (2007/2010): the port may give out what the peer's port put in.
};

/// "off" / "observer" / "energy_exchange".
const char* ToString(PassivityMode mode) noexcept;

/// The time-domain passivity observer (PO) and controller (PC) on one device port, per DOF, in the local device's
/// base frame. The port is the actuator: the network (this process's law, the link, the peer's law) applies the
/// force u to the device, which moves at v; the power it delivers to the device is P = u·v. The devices, the
/// operator and the environment are assumed passive; what can make the teleoperator active is the network (a
/// delayed link, a sampled spring). Energies accumulate per DOF over the run, in J (N·m; N·m·rad for a rotational
/// DOF). The force u'(n-1) is held over the interval [n-1, n]; with v(n) the backward difference (x(n)-x(n-1))/T
/// its work u'(n-1)·v(n)·T is exact, and step n settles it (a measured or low-pass-filtered velocity makes it an
/// approximation):
///
///   E_in(n)  = Σ max(0, -u(k-1)·v(k))·T          energy the law absorbed from the device at this port
///   E_out(n) = Σ max(0,  u(k-1)·v(k))·T          energy the law delivered to the device (before the PC)
///   E_pc(n)  = Σ α(k-1)·v(k-1)·v(k)·T            energy the controller's damper dissipated
///
/// The observed energy W(n) (the PO) is what the port may still deliver without the network being active:
///
///   observer:         W(n) = E_in(n)      + E_pc(n) - E_out(n)    (Hannaford & Ryu 2002, one port)
///   energy_exchange:  W(n) = E_in,peer(n) + E_pc(n) - E_out(n)    E_in,peer as last received over the link
///
/// The PC (a variable damper in parallel with the device, impedance causality) predicts the coming interval's
/// delivery u(n)·v(n)·T (energy_exchange: only its positive part) and, when W(n) minus it would be negative,
/// applies u' = u - α·v with α = -(W - u·v·T)/(v²·T): exactly the deficit, so W(n+1) = 0 when v is steady. α is
/// bounded by max_damping_Ns_per_m (a deficit the bound leaves is carried to the next step) and by max_force_N.
/// α ≥ 0 always: the damper only ever takes energy out. In energy_exchange each side sends its E_in with every
/// sample; a side outputs only what the other side has supplied, and E_in(n-D) ≤ E_in(n) for any delay D, so the
/// two ports together never deliver more than they absorbed (Ryu, Artigas & Preusche 2010): passive for any
/// delay, jitter or loss.
///
/// In energy_exchange the credit is the increase of the peer's E_in between two received values; a decrease (peer
/// restarted) takes the new value as the base without credit. Non-finite u or v: passed through unchanged and
/// counted (the law already zeroes its command on non-finite input), and the next step starts a new interval.
class PassivityController {
 public:
  struct Config {
    PassivityMode mode = PassivityMode::kOff;
    int dof = 1;
    DofVector max_damping_Ns_per_m;  ///< α ≤ this, per DOF (N·s/m; N·m·s/rad for a rotational DOF).
    double max_force_N = 0.0;        ///< |u'| ≤ this when > 0 (the law's saturation); α is reduced to respect it.
  };

  struct Input {
    DofVector force_N;               ///< u: the law's command on the device (N), before the controller.
    DofVector velocity_m_per_s;      ///< v: the device's velocity at the port (the law's measured or estimated one).
    DofVector peer_input_energy_J;   ///< energy_exchange: the peer's cumulative E_in as last received; else unused.
    bool peer_energy_valid = false;  ///< energy_exchange: a peer value has been received (false: no credit).
    /// False: observe only this step (α = 0, the force passes unchanged), for a command that must stay what it is
    /// (a safe state, a zero-force reaction); the observer still settles the interval with it.
    bool may_act = true;
  };

  struct Output {
    DofVector force_N;           ///< u' = u - α·v, the command for the device.
    DofVector damping_Ns_per_m;  ///< α this step (0 when the controller did not act).
    bool acted = false;          ///< α > 0 on some DOF.
  };

  /// Per-DOF arrays hold `dof` valid entries.
  struct State {
    std::array<double, kMaxDof> input_energy_J{};         ///< E_in (sent to the peer in energy_exchange).
    std::array<double, kMaxDof> output_energy_J{};        ///< E_out.
    std::array<double, kMaxDof> dissipated_J{};           ///< E_pc.
    std::array<double, kMaxDof> observed_J{};             ///< W after this step.
    std::array<double, kMaxDof> peer_base_J{};            ///< The peer E_in already credited.
    std::array<double, kMaxDof> last_law_force_N{};       ///< u(n-1), held over the last interval.
    std::array<double, kMaxDof> last_damping_Ns_per_m{};  ///< α(n-1).
    std::array<double, kMaxDof> last_velocity_m_per_s{};  ///< v(n-1), the velocity α(n-1) acted on.
    bool has_last = false;
    bool rebase_pending = false;  ///< SwitchMode: the next step starts W at 0 after settling the last interval.
    double min_observed_J = 0.0;  ///< min over steps and DOF of W before the controller acted (the PO's deficit).
    std::uint64_t steps = 0;
    std::uint64_t acting_steps = 0;      ///< Steps in which α > 0 on some DOF.
    std::uint64_t saturated_steps = 0;   ///< Steps in which a bound left part of the deficit for later.
    std::uint64_t nonfinite_inputs = 0;  ///< Steps passed through because u or v was not finite.
  };

  /// Off, 1 DOF, no damping bound.
  PassivityController();
  /// Validates: dof in 1..kMaxDof, max_damping of size dof, finite and ≥ 0 (0 disables the controller on that
  /// DOF), max_force_N finite and ≥ 0. Throws teleop::Error otherwise.
  explicit PassivityController(const Config& config);

  /// One cycle. Allocation-free, never throws. Input vectors must have `dof` entries (else passed through, counted
  /// as non-finite).
  [[nodiscard]] Output Step(const Input& input, double period_s) noexcept;
  /// Zeroes the energies and counters.
  void Reset() noexcept;
  /// Changes the mode at run time (the delay re-check's `on_unstable: passivity`, docs/stability.md). The observed
  /// energy W starts again from 0 on every DOF: what the port generated before the switch is not paid back by a
  /// damper at once (that would be a jolt of up to max_damping), the port is passive from the switch on. The
  /// cumulative energies, the peer's credited base and the counters are kept. Allocation-free.
  void SwitchMode(PassivityMode mode) noexcept;

  /// Sum over DOF of E_pc (J).
  double total_dissipated_J() const noexcept;
  const Config& config() const noexcept { return config_; }
  const State& state() const noexcept { return state_; }

 private:
  Config config_{};
  State state_{};
};

}  // namespace teleop::control
