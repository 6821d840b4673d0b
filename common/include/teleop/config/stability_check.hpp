#pragma once

#include <optional>
#include <span>
#include <string>
#include <vector>

#include "teleop/analysis/fixture_check.hpp"
#include "teleop/analysis/teleoperator_model.hpp"
#include "teleop/config/process_config.hpp"
#include "teleop/device/device_registry.hpp"

namespace teleop::config {

/// The stability check of a process config: what teleop-master and teleop-slave run at start-up, and what
/// `teleop-analyze check --config` prints. One function builds the model from a config, so both agree.
/// docs/stability.md ("In the processes") and docs/configuration.md (`stability`).

/// The analysed fixture side of a process: its own (the master checks the master fixture, the slave the slave's).
analysis::FixtureSide FixtureSideOf(Role role) noexcept;

/// Why the check cannot apply to this process's device: the backend's model says "not applicable" (a passive
/// device, a cobot) and stability.device does not give both mass_kg and damping_Ns_per_m. Empty when it applies.
std::string StabilityNotApplicable(const ProcessConfig& config);

/// The data age a triggered slave is assumed to see when `stability.peer_delay_fraction` is absent (s): the
/// master's sample is used this long after the master's cycle started (send, network, wake-up). The bench
/// (docs/performance.md, "Round trip and data age") measures it; set stability.peer_delay_fraction from a measured p99
/// instead.
inline constexpr double kTriggeredDataAge_s = 100e-6;

/// The data age a triggered slave of this config is assumed to see when `stability.peer_delay_fraction` is absent
/// (s): kTriggeredDataAge_s over UDP; over CAN (`can`, `emulated-can`) the master's sample is whole only when its
/// last frame has been sent, so it adds the master's frames of one cycle on the wire at the configured bit rates
/// (worst-case stuffing, proto::can::ComputeBusLoad) and one frame of the slave's that may hold the bus when the
/// master's first frame is queued (arbitration is non-preemptive): docs/can.md, "Phase-locked cycles over CAN".
double TriggeredDataAge_s(const ProcessConfig& config);

/// The sampled teleoperator seen along DOF `axis` of this process: its law gains for that DOF, its fixture
/// stiffness (0 when no plane's normal has a component on `axis`), rate, velocity filter, its device (stability.device,
/// else the backend's registered model, device::DeviceModel), and the peer of `config.stability.peer` (defaults:
/// the paper's device of the other role, the same gains, no fixture), with `stability.peer_delay_samples` and
/// `stability.unilateral`; with sync.mode triggered, the slave's peer delay is `stability.peer_delay_fraction` (absent:
/// TriggeredDataAge_s(config) · rate_hz, at most 1). Throws teleop::Error when `axis` is outside 0..dof-1, the model is
/// invalid, or the check does not apply (StabilityNotApplicable).
analysis::SampledTeleoperator StabilityModel(const ProcessConfig& config, int axis);

/// The link's one-way delay the check assumes on top of the pair's one sample: link.expected_delay_ms, else the
/// emulated link's delay + jitter when link.emulate is on, else 0 (s). StabilityModel adds it to both directions.
double AssumedLinkDelay_s(const ProcessConfig& config) noexcept;
/// Where that delay came from, in words ("link.expected_delay_ms 40 ms"), for the check's messages.
std::string DescribeAssumedLinkDelay(const ProcessConfig& config);

/// The operator set of `config.stability`: the `human_bounds` CSV (a relative path is relative to the config file's
/// directory) or the built-in finger table, with `human_grid_steps`. Throws teleop::Error on a bad file.
std::vector<analysis::HumanModel> StabilityOperators(const ProcessConfig& config);

/// The fixture over the configurations where its plane can be reached, for a device whose model depends on its
/// configuration (an arm: device::DeviceBackend::sweep; docs/arms.md, "Stability"): the smallest limit found.
struct ConfigurationSweep {
  int plane = 0;                        ///< The fixture plane of the worst configuration (index in law.fixture.planes).
  int axis = 0;                         ///< The DOF whose gains were used (the largest component of the normal).
  std::string summary;                  ///< What the device sampled (device::AnalysisSweep::summary), per plane.
  int analysed = 0;                     ///< Configurations analysed (one per bucket), over every plane.
  device::AnalysisConfiguration worst;  ///< The configuration with the smallest limit.
  analysis::FixtureCheck check;         ///< The configured fixture at `worst`.
  double elapsed_ms = 0.0;
};

/// The check of every DOF of a process.
struct StabilityReport {
  std::vector<analysis::FixtureCheck> axes;  ///< One per DOF (axes with identical models share one analysis).
  /// Empty when the check applied; else why not (axes is empty, stable() is true: nothing was found to refuse).
  std::string not_applicable;
  int operators = 0;        ///< Size of the operator set.
  double elapsed_ms = 0.0;  ///< Wall time of the analysis.
  /// Present when the device sweeps its configurations near the fixture's planes (a fixture with a stiffness and
  /// planes, a device with a sweep, and stability.device not giving both mass and damping).
  std::optional<ConfigurationSweep> sweep;

  bool stable() const noexcept;
  bool applicable() const noexcept { return not_applicable.empty(); }
  /// The axis that fails, or the one with the smallest limit / stiffness margin when all pass.
  int worst_axis() const noexcept;
  const analysis::FixtureCheck& worst() const noexcept { return axes[static_cast<std::size_t>(worst_axis())]; }
};

/// Analyses this process's own fixture on every DOF against the predicted limit (analysis::CheckFixture with the
/// model of StabilityModel), and, for a device whose model depends on its configuration, at every configuration the
/// device's sweep reports near each fixture plane (StabilityReport::sweep; its own device's mass and damping replaced
/// by the configuration's, the gains of the normal's largest axis). `humans` empty: StabilityOperators(config). Runs
/// whether or not `config.stability.check` is set (the caller decides what to do with it). Throws teleop::Error on
/// invalid input.
StabilityReport CheckProcessStability(const ProcessConfig& config, std::span<const analysis::HumanModel> humans = {});

/// One line for the log when the check passed: stiffness, limit, margin, worst damping ratio, assumptions; or, when
/// it did not apply, the backend's reason and how to check anyway.
std::string DescribePass(const ProcessConfig& config, const StabilityReport& report);
/// Why it did not pass: the config file, the configured stiffness, the predicted limit (N/m), the assumptions and what
/// to change. Names the "unstable even without a fixture" case separately. The caller adds its override hint.
std::string DescribeFailure(const ProcessConfig& config, const StabilityReport& report);

/// The `teleop-analyze max-stiffness` command line that reproduces the check's limit for DOF `axis` of `config`
/// with its values as they are (the live ones at run time, not the file's): every model input spelled out.
std::string AnalyzeCommandLine(const ProcessConfig& config, int axis);

}  // namespace teleop::config
