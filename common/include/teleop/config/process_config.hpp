#pragma once

#include <optional>
#include <string>

#include "teleop/config/engagement_config.hpp"
#include "teleop/control/passivity_controller.hpp"
#include "teleop/control/three_channel_law.hpp"
#include "teleop/dds/bridge_config.hpp"
#include "teleop/device/device_config.hpp"
#include "teleop/link/link_config.hpp"
#include "teleop/runtime/periodic_loop.hpp"
#include "teleop/types.hpp"

namespace teleop::config {

/// Where per-cycle telemetry goes. Written by a non-real-time thread fed through a lock-free ring.
struct TelemetryConfig {
  std::string csv_path;       ///< Empty: no CSV.
  int decimation = 1;         ///< Record every n-th cycle (the caller decimates before TelemetryWriter::Push).
  int ring_capacity = 16384;  ///< Records buffered between the loop and the writer (16..2^24; ~480 B each).
};

/// The start-up stability check of this process's own fixture (docs/stability.md, "In the processes"). An absent
/// value means "the documented default": the peer is the paper's §4.1 device of the other role running the same
/// gains as this process, without a fixture; this device is the backend's registered model (device::DeviceModel;
/// when the backend says the check does not apply, the check reports why and is skipped).
struct StabilityConfig {
  /// What this process assumes of the other side (the analysis needs both halves of the teleoperator).
  struct Peer {
    std::optional<double> mass_kg;
    std::optional<double> damping_Ns_per_m;
    std::optional<DofVector> kp_N_per_m;  ///< Per DOF; absent: this process's law.kp_N_per_m.
    std::optional<DofVector> kd_Ns_per_m;
    std::optional<DofVector> kv_Ns_per_m;
    std::optional<DofVector> kf;  ///< Dimensionless; drops out of the analysis (free space), kept for symmetry.
    double fixture_stiffness_N_per_m = 0.0;  ///< The peer's own fixture, held fixed in the search.
  };
  /// This device along the fixture normal; overrides the backend's model (both given: also for a backend whose model
  /// is "not applicable").
  struct Device {
    std::optional<double> mass_kg;
    std::optional<double> damping_Ns_per_m;
  };
  bool check = true;           ///< false: skip the check (logged as a warning).
  int peer_delay_samples = 1;  ///< 1: peer data one sample old, as over a link; 0: the paper's model.
  /// With peer_delay_samples 1 and sync.mode triggered: the slave's law sees the master's sample this fraction of
  /// a period late (the master still sees the slave's one sample late). Absent: derived from the mode
  /// (StabilityModel: min(1, TriggeredDataAge_s(config) · rate_hz) when triggered, the CAN frames included; unused
  /// when free).
  std::optional<double> peer_delay_fraction;
  bool unilateral = false;   ///< Analyse with the master actuator rendering nothing of the slave.
  std::string human_bounds;  ///< Operator bounds CSV; empty: the built-in finger table. Relative: to the config.
  int human_grid_steps = 4;  ///< Grid points per parameter per force level (4: 512 operators).
  Peer peer{};
  Device device{};
};

/// Everything one process (teleop-master or teleop-slave) needs, read from one YAML file.
/// See docs/configuration.md for every key, its unit and range.
struct ProcessConfig {
  Role role = Role::kMaster;
  int dof = 1;
  runtime::PeriodicLoopConfig loop{};
  link::LinkConfig link{};
  device::DeviceConfig device{};
  control::ThreeChannelLaw::Config law{};
  TelemetryConfig telemetry{};
  StabilityConfig stability{};
  dds::BridgeConfig dds{};  ///< The DDS bridge (docs/dds.md); off unless dds.enabled.
  /// Time-domain passivity on this device's port (docs/stability.md); off (observe only) unless passivity.mode.
  /// dof and max_damping_Ns_per_m are sized by the reader; max_force_N is the law's.
  control::PassivityController::Config passivity{};
  EngagementConfig engagement{};  ///< How coupling starts and restarts (teleop/node/engagement.hpp).
  SafetyConfig safety{};          ///< Safe states, fault records, reading checks.
  std::string source_path;        ///< The file it was read from (for messages).
};

}  // namespace teleop::config
