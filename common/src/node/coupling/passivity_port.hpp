#pragma once

// The passivity stage of the coupling: the time-domain passivity controller on the command actually applied
// (docs/stability.md). Private to the node.

#include <array>
#include <cstdint>

#include "teleop/control/passivity_controller.hpp"
#include "teleop/proto/sample_message.hpp"

namespace teleop::node {

/// The port's energies after a step, per DOF (J): a copy for the wire's energy block and the record.
struct PortEnergies {
  std::array<double, kMaxDof> input_energy_J{};
  std::array<double, kMaxDof> output_energy_J{};
  std::array<double, kMaxDof> observed_J{};
};

/// The port integrates the command the device gets (after the limiter, the reaction and the safe state); where that
/// command must stay what it is, the controller only observes. Allocation-free and noexcept in Step.
class PassivityPort {
 public:
  using Config = control::PassivityController::Config;
  struct State {
    control::PassivityController::Input input;  ///< The peer's E_in as last received crosses cycles.
    std::uint64_t peer_without_energy = 0;      ///< energy_exchange: peer samples without the block.
  };
  struct Input {
    const DofVector* force_N = nullptr;           ///< The shaped command.
    const DofVector* velocity_m_per_s = nullptr;  ///< The law's velocity.
    bool may_act = false;
    const proto::SampleMessage* peer = nullptr;  ///< The newest peer sample held (null: none).
  };
  struct Output {
    DofVector force_N;           ///< The command for the device.
    DofVector damping_Ns_per_m;  ///< α this step.
    PortEnergies energies;
  };

  explicit PassivityPort(const Config& config);

  Output Step(const Input& in, double period_s) noexcept;
  /// A run-time mode change (Changes::has_passivity): PassivityController::SwitchMode.
  void SwitchMode(control::PassivityMode mode) noexcept { controller_.SwitchMode(mode); }

  const control::PassivityController& controller() const noexcept { return controller_; }
  const State& state() const noexcept { return state_; }

 private:
  control::PassivityController controller_;  ///< Off = observe only.
  State state_;
};

}  // namespace teleop::node
