#pragma once

#include <cstdint>
#include <functional>
#include <random>
#include <vector>

#include "teleop/control/passivity_controller.hpp"
#include "teleop/control/three_channel_law.hpp"
#include "teleop/control/velocity_estimator.hpp"
#include "teleop/device/law_command.hpp"
#include "teleop/device/loopback.hpp"
#include "teleop/types.hpp"

namespace teleop::test {

/// An in-process bilateral teleoperator: master plant (+ simulated operator) and slave plant (+ environment), one
/// ThreeChannelLaw per side, both stepped at the same rate, each side's sample reaching the other `delay_cycles`
/// cycles after it was taken (1 = what a real link gives: the peer data used at cycle k were sent at cycle k-1;
/// 0 = the paper's single-computer model, both laws see the other's cycle-k sample).
///
/// One cycle k (t_k = k·T), for both sides, mirroring the processes:
///   Read() → outgoing sample {position read, velocity by eq. 20 (+ the law's low-pass), force sensor} into the
///   link → law Step() with the peer sample that arrives at k (peer_valid = false until the first one arrives) →
///   Write() → Update(T).
/// Deterministic: simulated time only.
struct ClosedLoopConfig {
  double rate_hz = 1000.0;
  int delay_cycles = 1;  ///< Per direction, 0..1000.
  /// A WAN on top of the fixed delay (docs/link-emulation.md): each sample's delay is delay_cycles plus a uniform
  /// 0..jitter_cycles, each sample is lost with probability `loss`, and a side uses the newest sample that has
  /// arrived (an older one arriving after it is dropped, as the processes do; nothing new: the last one again).
  /// Seeded per direction from `seed`: deterministic. 0 and 0: the lock-step fixed delay.
  int jitter_cycles = 0;  ///< 0..1000.
  double loss = 0.0;      ///< 0..1 (exclusive).
  std::uint32_t seed = 1;
  control::ThreeChannelLaw::Config master_law = control::ThreeChannelLaw::ZeroGains(Role::kMaster, 1);
  control::ThreeChannelLaw::Config slave_law = control::ThreeChannelLaw::ZeroGains(Role::kSlave, 1);
  device::LoopbackPlantConfig master_plant = device::LoopbackPlantConfig::PaperMaster();
  device::LoopbackPlantConfig slave_plant = device::LoopbackPlantConfig::PaperSlave();
  /// Time-domain passivity on each port (off by default: observe only). In energy_exchange each side's E_in
  /// travels with its sample through the same delay line.
  control::PassivityController::Config master_passivity = PassivityOff(1);
  control::PassivityController::Config slave_passivity = PassivityOff(1);
  static control::PassivityController::Config PassivityOff(int dof);
};

/// 1-DOF set-up in the paper's terms (eqs. 7-9), for tests and the stability cross-checks. Unset gains are 0.
/// Fixtures are eq. 7 at X = 0 (forbidden X > 0) on the side(s) with a non-zero stiffness.
/// The operator is enabled with (m_h, b_h, k_h) and pushes F_h* = operator_force_N, ramped from 0 over
/// operator_ramp_s (0 = a step at t = 0), then held.
struct OneDofSetup {
  double rate_hz = 1000.0;
  int delay_cycles = 1;
  int jitter_cycles = 0;  ///< ClosedLoopConfig::jitter_cycles.
  double loss = 0.0;      ///< ClosedLoopConfig::loss.
  std::uint32_t seed = 1;
  double kpm_N_per_m = 0.0;
  double kps_N_per_m = 0.0;
  double kdm_Ns_per_m = 0.0;
  double kds_Ns_per_m = 0.0;
  double kvm_Ns_per_m = 0.0;
  double kvs_Ns_per_m = 0.0;
  double kfm = 0.0;
  double master_fixture_N_per_m = 0.0;
  double slave_fixture_N_per_m = 0.0;
  double velocity_filter_hz = 0.0;  ///< Both laws.
  double max_force_N = 0.0;         ///< Both laws; 0 = no saturation.
  double master_mass_kg = 0.040;
  double master_damping_Ns_per_m = 0.41;
  double slave_mass_kg = 0.036;
  double slave_damping_Ns_per_m = 0.49;
  double human_mass_kg = 0.0;
  double human_damping_Ns_per_m = 0.0;
  double human_stiffness_N_per_m = 0.0;
  double operator_force_N = 0.0;
  double operator_ramp_s = 0.0;
  double encoder_resolution_m = 0.0;  ///< Both plants.
};

/// Builds the ClosedLoopConfig of a OneDofSetup (throws teleop::Error via the laws/plants on bad values later).
ClosedLoopConfig MakeOneDofConfig(const OneDofSetup& setup);

/// What both sides saw and did in one cycle. Positions/velocities are the plants' TRUE states at t_k (before the
/// cycle's Update); forces are the sensors' readings at t_k; commands are the laws' outputs at t_k.
struct ClosedLoopSample {
  std::uint64_t cycle = 0;
  double time_s = 0.0;
  DofVector master_position_m;
  DofVector slave_position_m;
  DofVector master_velocity_m_per_s;
  DofVector slave_velocity_m_per_s;
  DofVector master_command_N;
  DofVector slave_command_N;
  DofVector operator_target_force_N;  ///< F_h*(t_k).
  DofVector operator_force_N;         ///< F_h, the master's force sensor.
  DofVector environment_force_N;      ///< F_e, the slave's force sensor.
  double master_penetration_m = 0.0;  ///< Master fixture penetration.
  double slave_penetration_m = 0.0;   ///< Slave fixture penetration.
  control::ThreeChannelLaw::StepStatus master_status = control::ThreeChannelLaw::StepStatus::kOk;
  control::ThreeChannelLaw::StepStatus slave_status = control::ThreeChannelLaw::StepStatus::kOk;
  std::uint32_t master_faults = 0;
  std::uint32_t slave_faults = 0;
  double master_observed_J = 0.0;  ///< The passivity observer's W on each port, DOF 0, after this cycle.
  double slave_observed_J = 0.0;
  /// Energy the two ports' network (laws + delayed link + passivity controllers) has absorbed from both devices
  /// up to this cycle: Σ -(u'_m(k-1)·Δx_m(k) + u'_s(k-1)·Δx_s(k)) over all DOF, the exact work of the held commands
  /// on the true positions (J). Negative: the network has generated energy.
  double network_energy_J = 0.0;
  bool master_pc_acted = false;
  bool slave_pc_acted = false;
};

/// What one direction of the loop's link did (ClosedLoopConfig's jitter and loss).
struct LinkStats {
  std::uint64_t sent = 0;
  std::uint64_t lost = 0;
  std::uint64_t fresh = 0;  ///< Cycles in which a newer sample arrived.
  std::uint64_t held = 0;   ///< Cycles that used the last sample again (nothing newer arrived).
  std::uint64_t min_age_cycles = ~std::uint64_t{0};  ///< The age of a fresh sample when used: now - its send cycle.
  std::uint64_t max_age_cycles = 0;
};

class ClosedLoop {
 public:
  /// Validates through the law and plant constructors (teleop::Error); rate_hz must be > 0, delay 0..1000.
  explicit ClosedLoop(const ClosedLoopConfig& config);

  /// Runs one cycle and returns its record.
  const ClosedLoopSample& Step();
  /// Runs round(duration_s · rate_hz) cycles and returns every record.
  std::vector<ClosedLoopSample> Run(double duration_s);
  /// Runs round(duration_s · rate_hz) cycles, handing each record to `observer` (no trace kept).
  void Run(double duration_s, const std::function<void(const ClosedLoopSample&)>& observer);

  double period_s() const noexcept { return period_s_; }
  double time_s() const noexcept { return master_plant_.time_s(); }
  const ClosedLoopConfig& config() const noexcept { return config_; }
  const ClosedLoopSample& last() const noexcept { return last_; }
  /// Direct access, e.g. to SetDisturbance() on a plant between cycles.
  device::LoopbackPlant& master_plant() noexcept { return master_plant_; }
  device::LoopbackPlant& slave_plant() noexcept { return slave_plant_; }
  const control::ThreeChannelLaw& master_law() const noexcept { return master_law_; }
  const control::ThreeChannelLaw& slave_law() const noexcept { return slave_law_; }
  const control::PassivityController& master_passivity() const noexcept { return master_pc_; }
  const control::PassivityController& slave_passivity() const noexcept { return slave_pc_; }
  const LinkStats& master_to_slave_stats() const noexcept { return master_to_slave_.stats; }
  const LinkStats& slave_to_master_stats() const noexcept { return slave_to_master_.stats; }

 private:
  struct WireSample {
    DofVector position_m;
    DofVector velocity_m_per_s;
    DofVector force_N;
    DofVector input_energy_J;  ///< The sender's passivity E_in (energy_exchange).
  };
  /// Fixed ring of delay+jitter+1 samples, one per direction, each with its arrival cycle.
  struct DelayLine {
    struct Slot {
      WireSample sample;
      std::uint64_t index = 0;
      std::uint64_t sent_cycle = 0;
      std::uint64_t arrival = 0;
      bool lost = false;
      bool filled = false;
    };
    std::vector<Slot> ring;
    std::uint64_t pushed = 0;
    WireSample held;  ///< The newest sample received so far.
    std::uint64_t held_index = 0;
    bool has_held = false;
    std::mt19937 random;
    LinkStats stats;
    /// Pushes the sample sent at `cycle` with its delay and fate drawn from the config.
    void Push(const WireSample& sample, std::uint64_t cycle, const ClosedLoopConfig& config);
    /// The newest sample arrived by `cycle` (held when none newer arrived), or nullptr if none yet.
    const WireSample* Received(std::uint64_t cycle);
  };

  ClosedLoopConfig config_;
  double period_s_;
  control::ThreeChannelLaw master_law_;
  control::ThreeChannelLaw slave_law_;
  control::PassivityController master_pc_;
  control::PassivityController slave_pc_;
  double network_energy_J_ = 0.0;
  DofVector last_master_command_N_;
  DofVector last_slave_command_N_;
  DofVector last_master_position_m_;
  DofVector last_slave_position_m_;
  device::LoopbackPlant master_plant_;
  device::LoopbackPlant slave_plant_;
  device::Command master_command_;
  device::Command slave_command_;
  control::VelocityEstimator master_sender_velocity_;
  control::VelocityEstimator slave_sender_velocity_;
  DelayLine master_to_slave_;
  DelayLine slave_to_master_;
  ClosedLoopSample last_;
  std::uint64_t cycle_ = 0;
};

/// Which scalar of a record to analyse.
enum class Signal : std::uint8_t {
  kMasterPosition,
  kSlavePosition,
  kTrackingError,  ///< slave - master position (m).
  kMasterCommand,
  kSlaveCommand,
  kOperatorForce,
  kEnvironmentForce,
  kSlavePenetration,
  kMasterPenetration,
};
double Value(const ClosedLoopSample& sample, Signal signal, int axis = 0);

/// Statistics of one signal over the records with from_s ≤ time_s < to_s.
struct WindowStats {
  int count = 0;
  double mean = 0.0;
  double rms = 0.0;      ///< Root mean square of the value itself.
  double std_dev = 0.0;  ///< RMS about the mean (oscillation size).
  double min = 0.0;
  double max = 0.0;
  double peak_to_peak = 0.0;  ///< max - min.
  double max_abs = 0.0;
};
WindowStats Stats(const std::vector<ClosedLoopSample>& trace, Signal signal, double from_s, double to_s, int axis = 0);

}  // namespace teleop::test
