#pragma once

#include <atomic>
#include <cstdint>
#include <cstdio>
#include <limits>
#include <string>
#include <thread>
#include <type_traits>

#include "teleop/runtime/spsc_ring.hpp"
#include "teleop/types.hpp"

namespace teleop::runtime {

/// One cycle of one process, as it leaves the loop for the CSV file. Plain data (copied through the ring); arrays
/// hold `dof` valid entries, the rest are 0. Local quantities are in the local device's base frame, peer quantities
/// as received (peer frame, before scaling).
struct TelemetryRecord {
  std::uint64_t cycle = 0;
  double time_s = 0.0;  ///< Since the first cycle, loop clock.
  int dof = 0;
  double position_m[kMaxDof] = {};        ///< Measured local position.
  double velocity_m_per_s[kMaxDof] = {};  ///< Local velocity the law used (measured or estimated).
  double force_sensor_N[kMaxDof] = {};    ///< Local force sensor (operator force F_h or environment F_e).
  double command_N[kMaxDof] = {};         ///< Actuator command sent to the device (0 in the safe state).
  double rendered_force_N[kMaxDof] = {};  ///< What the device reports it rendered (device::Reading::rendered_force_N).
  double fixture_force_N[kMaxDof] = {};   ///< The virtual fixture's share of the command.
  /// The peer's sample the node holds, as received (engaged: what the law used; aligning or in the safe state: what
  /// the peer sent, not the virtual peer the law saw). 0 while the node holds none: before the first sample of a
  /// link session (at start, and after a new session made it forget the old peer).
  double peer_position_m[kMaxDof] = {};
  double peer_velocity_m_per_s[kMaxDof] = {};
  double peer_force_N[kMaxDof] = {};
  double fixture_penetration_m = 0.0;
  int law_status = 0;                                       ///< control::ThreeChannelLaw::StepStatus as an integer.
  std::uint32_t flags = 0;                                  ///< proto::StateFlags bits of the sample sent this cycle.
  double rtt_s = std::numeric_limits<double>::quiet_NaN();  ///< Round trip to the peer; NaN when unknown.
  double compute_s = 0.0;                                   ///< Cycle body time so far.
  double passivity_observed_J[kMaxDof] = {};        ///< Time-domain passivity: the observer's W (docs/stability.md).
  double passivity_damping_Ns_per_m[kMaxDof] = {};  ///< The controller's damping α this cycle (0: did not act).
  int engagement = 0;  ///< node::EngagementState as an integer (0 disengaged .. 3 engaged; teleop/node/engagement.hpp).
  /// Age of the peer sample the law used this cycle: cycle start - its (kernel) receive time; NaN when none.
  double data_age_s = std::numeric_limits<double>::quiet_NaN();
  std::uint32_t device_warnings = 0;  ///< device::WarningBits the backend reported this cycle (0: none).
  int clutch = 0;  ///< Clutch sources held this cycle (node::ClutchSource bits: 1 device, 2 peer, 4 command; 0: none).
  /// The fixture stiffness the law used this cycle (N/m; a ramped change shows its ramp; 0 without a fixture).
  double fixture_stiffness_N_per_m = 0.0;
  /// The fixture's predicted stability limit at the device's current configuration (N/m; the run-time limit of an
  /// arm, config::ConfigurationLimit, its newest evaluation); NaN when none is computed.
  double fixture_limit_N_per_m = std::numeric_limits<double>::quiet_NaN();
  /// A device made of joints (device::Capabilities::joints; 0 on a Cartesian device): `joints` valid entries of each
  /// joint's position (rad; m for a prismatic joint) and the torque its actuator reports (N·m; N). The CSV's last
  /// columns, written only when the writer was given joints.
  int joints = 0;
  double joint_position_rad[kMaxDof] = {};
  double joint_torque_Nm[kMaxDof] = {};
};
static_assert(std::is_trivially_copyable_v<TelemetryRecord>);

/// The CSV column names for `dof` entries per vector, in the order WriteCsvRow writes them, comma-separated, no
/// newline. Units are in the names (`position_m_0`, `command_N_1`, ...). With `joints` > 0 (a device made of
/// joints) the last columns are joint_position_rad_0..joints-1 then joint_torque_Nm_0..joints-1; with 0 there are
/// none, so a Cartesian device's file is what it always was.
std::string TelemetryCsvHeader(int dof, int joints = 0);
/// One CSV row (no newline) for `record`, `dof` entries per vector and `joints` joint entries. Doubles are written
/// in the shortest form that reads back exactly; NaN as `nan`.
std::string TelemetryCsvRow(const TelemetryRecord& record, int dof, int joints = 0);

/// Carries telemetry out of the real-time loop: Push() copies a record into a lock-free ring (never blocks,
/// never allocates), a writer thread drains the ring into a CSV file every few milliseconds.
///
/// Decimation is the caller's job: push only the cycles you want recorded (config `telemetry.decimation`).
/// A full ring drops the record and counts it (dropped()): never silent. Stop() drains, flushes and joins; the
/// destructor calls it. Call Stop() after the producer has pushed its last record.
class TelemetryWriter {
 public:
  /// Opens (truncates) `csv_path` and starts the writer thread; throws teleop::Error when the file cannot be opened
  /// or ring_capacity is 0. `dof` (1..kMaxDof) fixes the columns per vector; 0 takes it (and the joints) from the
  /// first record (kMaxDof when no record arrives). `joints` (0..kMaxDof): the joint columns (0: none).
  TelemetryWriter(const std::string& csv_path, std::size_t ring_capacity, int dof = 0, int joints = 0);
  ~TelemetryWriter();
  TelemetryWriter(const TelemetryWriter&) = delete;
  TelemetryWriter& operator=(const TelemetryWriter&) = delete;

  /// From the real-time thread (single producer). False when the ring was full and the record was dropped.
  [[nodiscard]] bool Push(const TelemetryRecord& record) noexcept {
    if (ring_.TryPush(record)) {
      pushed_.fetch_add(1, std::memory_order_relaxed);
      return true;
    }
    dropped_.fetch_add(1, std::memory_order_relaxed);
    return false;
  }

  /// Drains what is left, flushes, closes the file, joins the thread. Idempotent. Logs (spdlog) a warning when
  /// records were dropped or could not be written.
  void Stop();

  std::uint64_t pushed() const noexcept { return pushed_.load(std::memory_order_relaxed); }
  std::uint64_t dropped() const noexcept { return dropped_.load(std::memory_order_relaxed); }
  /// Rows written to the file so far.
  std::uint64_t written() const noexcept { return written_.load(std::memory_order_relaxed); }
  /// Rows lost to a file write error (disk full, ...).
  std::uint64_t write_errors() const noexcept { return write_errors_.load(std::memory_order_relaxed); }
  const std::string& path() const noexcept { return path_; }
  std::size_t capacity() const noexcept { return ring_.capacity(); }

 private:
  void Drain();
  void WriteLine(const std::string& line);

  std::string path_;
  std::FILE* file_ = nullptr;
  int dof_;
  int joints_;
  bool header_written_ = false;
  SpscRing<TelemetryRecord> ring_;
  std::atomic<bool> stop_{false};
  std::atomic<std::uint64_t> pushed_{0};
  std::atomic<std::uint64_t> dropped_{0};
  std::atomic<std::uint64_t> written_{0};
  std::atomic<std::uint64_t> write_errors_{0};
  std::thread thread_;
};

}  // namespace teleop::runtime
